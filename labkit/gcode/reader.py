"""G-code text → :class:`~labkit.toolpath.Moves`.

What is read
------------
- One block per line: an optional ``N`` number, words ``LETTER number``
  (letters in either case, numbers signed and fractional, spaces allowed
  between letter and number), comments ``( … )`` and ``; …``, an optional
  ``*checksum`` last (the RepRap rule: XOR of every byte before ``*``).
- Lines end at LF, CRLF or a lone CR (GRBL ends a line at either byte, so a
  CR inside an LF file separates two blocks, as on the controller).
- A ``%`` alone on its line (program delimiter) and blank lines are skipped;
  a ``%`` with anything else on its line is error 1, as GRBL reads it. GRBL
  ``$`` system lines are kept as :class:`~labkit.toolpath.Record` of kind
  ``"system"``; ``$J=`` jog lines are the jogs they are (GRBL 1.1): a LINE
  move at the jog's F, with the laser state in effect, recorded as ``"jog"``;
  only X Y Z F N, G20/G21, G90/G91 (for that line) and G53 are allowed, and
  the modal state is left as it was.
- Numbers at or above 2**53 in magnitude (``X`` followed by 400 digits), and
  positions that would get there, are rejected (bad number, error 2;
  out of range, error 103): no infinite or NaN position reaches the Moves.
- Motion G0 G1 G2 G3, dwell G4 P, planes G17 G18 G19, units G20 G21,
  distance G90 G91, arc centres G91.1 (and G90.1 outside grbl), feed F,
  laser M3 M4 M5 with S (M106/M107 in the marlin dialect), stops M0 M1 M2
  M30, coolant/air assist (recorded; grbl: M8 M9 as GRBL's default build),
  look-ahead G5 P (labkit-fw dialect, recorded). Which G words a dialect
  runs is its ``g_codes`` list; the grbl dialect runs GRBL 1.1's:
- Offsets as GRBL runs them: G54-G59 (origins set by G10 L2/L20, all 0 at
  the start: GRBL keeps them in EEPROM, a file cannot rely on them), G92 /
  G92.1, G43.1 Z / G49, G53 (machine coordinates for one block), G28 / G30
  (rapid through the named intermediate point to the position stored by
  G28.1 / G30.1). Moves hold machine coordinates; ``work_offset`` holds the
  work origin of each move (``moves.work_end`` = what the words said).
- G80 cancels motion; G93 inverse time (F = 1/min per move, each move's
  feed in mm/min is F × its length); G38.2-G38.5 probes are LINE moves with
  the beam off and a ``"probe"`` record; the position after a probe is taken
  as its target (as if no contact): a program that relies on the probed
  position cannot be predicted from its text. T is accepted (up to the
  dialect's maximum, GRBL 255), M6 and M7 are error 20 in grbl as in GRBL's
  default build. The marlin dialect homes with G28 (to machine 0), reads E
  (extrusion: accepted, never motion, not kept), and keeps M82 M83 M84 M104
  M109 M140 M190 as ``"printer"`` records (their S is not laser power).
- Inch input is converted to mm; feeds become mm/min; dwells seconds.

Errors
------
Each rejected line raises (strict) or reports (lenient) a
:class:`~labkit.errors.GcodeError` with file, line, column, the offending
text and what was expected, numbered like GRBL's errors. A rejected line
changes nothing, as on a controller; lenient parsing goes on with the next
line and returns every diagnostic in ``moves.diagnostics``.

The work happens in the compiled interpreter :mod:`labkit.gcode._kernel`.
"""

from __future__ import annotations

import os
import re
from typing import NamedTuple

import numpy as np

from labkit.errors import GcodeError
from labkit.gcode import _kernel as K
from labkit.gcode.dialects import Dialect, get_dialect
from labkit.toolpath.moves import LaserMode, MoveKind, Moves, Record

__all__ = ["parse", "parse_file", "parse_with_states", "check", "modal_trace", "ParseOptions",
           "grbl_system_verdict", "grbl_sync_lines", "Interpreter", "strip_comments"]

_COMMON_LETTERS = "FGIJKMNPRSXYZ"


class ParseOptions(NamedTuple):
    """Settings of the interpreter derived from a dialect (see :class:`~labkit.gcode.dialects.Dialect`),
    and the modal state it starts from (``start``, a one-row
    :data:`~labkit.gcode._kernel.TRACE_ROW` array; GRBL's power-on state by default).

    A named tuple: the compiled :func:`labkit.gcode._kernel.interpret` takes it whole and
    reads the fields by name, so a new setting is one field here and its use there.
    """

    letters_ok: np.ndarray
    g_codes_ok: np.ndarray
    laser_on_codes: np.ndarray
    laser_off_codes: np.ndarray
    coolant_codes: np.ndarray
    record_m_codes: np.ndarray
    feed_scale: float
    dwell_scale: float
    arc_r_tol: float
    arc_tol_abs: float
    arc_tol_rel: float
    full_circle_ok: bool
    require_axis_words: bool
    home_is_origin: bool
    max_tool: int
    line_limit: int = 0
    grbl_verdicts: bool = False
    grbl_streamed: bool = False
    start: np.ndarray = K.initial_state()

    @classmethod
    def from_dialect(cls, dialect: Dialect, *, streaming: bool = False) -> "ParseOptions":
        ok = np.zeros(26, np.bool_)
        for ch in _COMMON_LETTERS + dialect.extra_letters:
            ok[ord(ch) - 65] = True
        ok[ord("G") - 65] = ok[ord("M") - 65] = False   # commands are handled apart
        return cls(
            letters_ok=ok,
            g_codes_ok=np.array(sorted(round(10 * g) for g in dialect.g_codes), np.int64),
            laser_on_codes=np.array(dialect.laser_on_codes, np.int64),
            laser_off_codes=np.array(dialect.laser_off_codes, np.int64),
            coolant_codes=np.array(dialect.coolant_codes, np.int64),
            record_m_codes=np.array(dialect.record_m_codes, np.int64),
            feed_scale=60.0 if dialect.feed_per_second else 1.0,
            dwell_scale=0.001 if dialect.dwell_in_ms else 1.0,
            arc_r_tol=dialect.arc_r_tol_mm,
            arc_tol_abs=dialect.arc_radius_tol_mm,
            arc_tol_rel=dialect.arc_radius_tol_rel,
            full_circle_ok=dialect.full_circle_without_axes,
            require_axis_words=dialect.require_axis_words,
            home_is_origin=dialect.home_is_origin,
            max_tool=int(dialect.max_tool),
            line_limit=dialect.line_buffer_chars if streaming else 0,
            grbl_verdicts=dialect.grbl_verdicts,
            grbl_streamed=dialect.grbl_verdicts and streaming,
        )


def _as_bytes(text) -> bytes:
    if isinstance(text, str):
        data = text.encode("utf-8", "surrogateescape")
    elif isinstance(text, (bytes, bytearray, memoryview)):
        data = bytes(text)
    else:
        raise TypeError(f"G-code must be str or bytes, got {type(text).__name__}")
    if data.startswith(b"\xef\xbb\xbf"):
        data = b"   " + data[3:]           # a UTF-8 BOM: blank it, keep the columns
    if b"\r" in data:
        data = _LONE_CR.sub(b"\n", data)  # a lone CR ends a line (GRBL); same length, same columns
    return data


_LONE_CR = re.compile(rb"\r(?!\n)")


def _line_count(data: bytes) -> int:
    """How many lines :func:`_text_lines` gives, without decoding them."""
    n = data.count(b"\n") + 1
    return n - 1 if n > 1 and data.endswith(b"\n") else n


def _text_lines(data: bytes) -> list[str]:
    """The lines of :func:`_as_bytes` output as the interpreter numbers them (ends removed)."""
    lines = data.decode("utf-8", "replace").split("\n")
    if lines and lines[-1] == "" and len(lines) > 1:
        lines = lines[:-1]
    return [s.rstrip("\r") for s in lines]


def _run(data: bytes, dialect: Dialect, lenient: bool, trace: bool,
         streaming: bool = False, start=None) -> K.Interpretation:
    """Run the compiled interpreter on ``data`` with the dialect's settings, from the modal
    state ``start`` (a one-row :data:`~labkit.gcode._kernel.TRACE_ROW` array; None: power-on)."""
    from labkit.budget import budget

    o = ParseOptions.from_dialect(dialect, streaming=streaming)
    if start is not None:
        o = o._replace(start=start)
    buf = np.frombuffer(data, dtype=np.uint8)
    max_errors = int(budget("diagnostics")) if lenient else 1
    return K.interpret(buf, o, lenient, max_errors, trace)


def parse(text, *, dialect: str | Dialect = "grbl", filename: str | None = None,
          lenient: bool = False, streaming: bool = False) -> Moves:
    """Interpret G-code text as a machine program.

    Parameters
    ----------
    text : str or bytes
        The program.
    dialect : str or Dialect
        ``"grbl"`` (default), ``"labkit-fw"`` or ``"marlin"``: how F, G4 P and
        S are read and which words exist (see :mod:`labkit.gcode.dialects`).
    filename : str, optional
        Name used in messages and kept as ``moves.source``.
    lenient : bool
        False (default): raise at the first rejected line. True: skip
        rejected lines, as a controller would, and return their errors in
        ``moves.diagnostics`` (at most the ``diagnostics`` budget of
        :mod:`labkit.budget`; ``moves.dropped_diagnostics`` counts the rest).
    streaming : bool
        Also reject what the controller rejects when the text is streamed to
        it line by line: a line with more significant characters than its
        line buffer holds (GRBL: 79, error 11; comments and spaces do not count), and
        for GRBL a ``%`` line (error 1: GRBL has no program delimiter, though senders often
        strip it) and ``$`` lines its system commands refuse
        (:func:`grbl_system_verdict`).

    Returns
    -------
    Moves
        Positions in mm (machine coordinates), feeds in mm/min, dwells in s,
        S as written; ``moves.records`` holds ``$`` lines, stops, coolant and
        look-ahead settings.

    Raises
    ------
    GcodeError
        In strict mode, for the first line that cannot be accepted.

    Examples
    --------
    >>> m = parse("G21 G90\\nM3 S500\\nG1 X10 F600\\nG2 X20 Y0 I5 J0\\nM5")
    >>> [MoveKind(k).name for k in m.kind]
    ['LINE', 'ARC_CW']
    >>> m.end[-1].tolist(), m.centre[-1].tolist()
    ([20.0, 0.0, 0.0], [15.0, 0.0, 0.0])
    >>> parse("G1 X1 X2 F100")
    Traceback (most recent call last):
    ...
    labkit.errors.GcodeError: <string>:1:7: error 25: a word is repeated in one line (got 'X2'; expected each letter at most once per line)
    """
    return _interpreted(text, dialect, filename, lenient, streaming, trace=False)[0]


def parse_with_states(text, *, dialect: str | Dialect = "grbl", filename: str | None = None,
                      lenient: bool = False, streaming: bool = False):
    """:func:`parse` and :func:`labkit.gcode.state.line_states` from one reading of the text.

    For a caller that needs the moves and what every line states (``labkit stream``'s job:
    its plan, and which lines GRBL answers late): the interpreter runs once, writing its
    trace as it goes.

    Parameters
    ----------
    text, dialect, filename, lenient, streaming
        As for :func:`parse`, which raises the same :class:`~labkit.errors.GcodeError` in
        strict mode.

    Returns
    -------
    moves : Moves
        What :func:`parse` returns.
    trace : ndarray of :data:`~labkit.gcode._kernel.TRACE_ROW`
        What :func:`~labkit.gcode.state.line_states` returns: the modal state after every
        line, one row per line (a rejected line keeps the state before it);
        :meth:`~labkit.gcode.state.ModalState.at` reads a row.

    Examples
    --------
    >>> moves, trace = parse_with_states("G1 X10 F600\\nG91\\nX5\\n")
    >>> moves.end[:, 0].tolist(), trace["distance"].tolist()
    ([10.0, 15.0], [90.0, 91.0, 91.0])
    """
    moves, data, out = _interpreted(text, dialect, filename, lenient, streaming, trace=True)
    return moves, out.trace[:_line_count(data)]


def grbl_sync_lines(text, *, dialect: str | Dialect = "grbl", trace=None) -> list[int]:
    """The lines GRBL runs only once the moves before them have ended, so that the machine
    stops before their moves: every accepted line with a
    :func:`~labkit.gcode.state.grbl_sync_reasons` (a laser or coolant switch, an offset or
    stored position, a probe). For :func:`labkit.motion.plan`'s ``sync_lines`` (the
    firmware's grbl dialect waits at the same lines). Other dialects keep power and coolant
    changes in the step stream ([CBR40]): none.

    Parameters
    ----------
    text : str or bytes
        The program.
    dialect : str or Dialect
    trace : ndarray, optional
        What :func:`parse_with_states` returned for ``text`` in strict mode (no line
        refused), when the caller has it: the lines are read from it instead of running
        the interpreter again.

    Returns
    -------
    list of int
        1-based line numbers, ascending.

    Examples
    --------
    >>> grbl_sync_lines("M3 S100\\nG1 X5 F600\\nG1 X10 S300\\nS500\\nM5\\nG0 X0\\n")
    [1, 4, 5]
    >>> grbl_sync_lines("M3 S100\\nG1 X5 F600\\nM5\\n", dialect="labkit-fw")
    []
    """
    d = get_dialect(dialect)
    if d.name != "grbl":
        return []
    data = _as_bytes(text)
    # one command asks several times for the same program's lines (the plan, the link's
    # prediction, the stall-free feed): the answer is kept for the last few programs, by
    # digest, not by holding their text (hashlib here: importing it loads OpenSSL, which
    # a command that never asks should not pay)
    import hashlib

    key = (hashlib.blake2b(data, digest_size=16).digest(), len(data), d)
    lines = _SYNC_LINES_SEEN.get(key)
    if lines is None:
        lines = _SYNC_LINES_SEEN[key] = tuple(_grbl_sync_lines(data, d, trace))
        while len(_SYNC_LINES_SEEN) > 4:
            del _SYNC_LINES_SEEN[next(iter(_SYNC_LINES_SEEN))]
    return list(lines)


_SYNC_LINES_SEEN: dict[tuple, tuple[int, ...]] = {}


def _grbl_sync_lines(data: bytes, d: Dialect, trace=None) -> list[int]:
    from labkit.gcode.state import ModalState, grbl_sync_reasons

    texts = _text_lines(data)
    if trace is None:
        out = _run(data, d, lenient=True, trace=True)
        refused = set(out.errors["line"].tolist())
        trace = out.trace[:len(texts)]
    else:
        refused = set()
        if len(trace) != len(texts):
            raise ValueError(f"grbl_sync_lines: the trace has {len(trace)} rows for {len(texts)} lines")
    # only a line that changes the state the rule reads, or writes an offset or stored position
    # or probes whatever it changes, can wait: the rule runs on those lines only
    before = np.concatenate([K.initial_state(), trace[:-1]]) if len(trace) else trace
    changed = np.zeros(len(trace), bool)
    for name in ("laser", "coolant", "s_word", "motion", "coord_system", "tool_offset"):
        changed |= trace[name] != before[name]
    lines = []
    for k, raw in enumerate(texts, start=1):
        if k in refused:
            continue
        if not changed[k - 1] and not _OFFSET_WORDS.search(raw):
            continue
        line = "".join(c for c in strip_comments(raw) if c > " " and c != "/").upper()
        if not line.startswith("$") and grbl_sync_reasons(line, ModalState.at(trace, k - 2)):
            lines.append(k)
    return lines


#: G10, G28.1, G30.1, G38.x, G92(.1): GRBL waits for them even when nothing changes (a
#: superset: the rule itself decides; comments may match, which only costs time).
_OFFSET_WORDS = re.compile(r"[gG]\s*0*(10|28\s*\.|30\s*\.|38|92)")


def _interpreted(text, dialect, filename, lenient, streaming, trace):
    """(Moves, the text's bytes, the interpreter's :class:`~labkit.gcode._kernel.Interpretation`)
    of :func:`parse`; strict mode raises the first error."""
    d = get_dialect(dialect)
    data = _as_bytes(text)
    out = _run(data, d, lenient, trace=trace, streaming=streaming)
    errors = [_make_error(data, filename, e) for e in out.errors]
    kept = out.records
    if d.grbl_verdicts and streaming and len(kept):     # $ lines as GRBL's system commands
        refused = [_system_line_error(data, filename, r, d) for r in kept]
        kept = [r for r, e in zip(kept, refused) if e is None]
        errors = sorted(errors + [e for e in refused if e is not None], key=lambda e: e.line)
    if errors and not lenient:
        raise errors[0]
    moves = Moves.from_rows(out.moves, source=filename, s_max=d.s_max, records=_records(data, kept),
                            diagnostics=errors, dropped_diagnostics=out.error_total - len(out.errors))
    return moves, data, out


def _records(data: bytes, kept) -> list[Record]:
    """The :class:`Record` of each kernel record row."""
    return [Record(int(r["line"]), int(r["index"]), K.RECORD_NAMES[int(r["kind"])],
                   _clip(data[r["span"][0]:r["span"][1]].decode("utf-8", "replace").strip()),
                   float(r["value"]))
            for r in kept]


class Interpreter:
    """G-code interpreted line by line, the modal state kept between lines: for a
    controller's view of a stream (the virtual machine, a step-through in a notebook).

    Parameters
    ----------
    dialect : str or Dialect
    state : ModalState, optional
        Where the interpreter starts (default GRBL's power-on state).
    streaming : bool
        Also refuse what the controller refuses of a streamed line (its line buffer; see
        :func:`parse`).

    Attributes
    ----------
    state : ModalState
        The state after the last accepted line; assign one to move the interpreter (a
        reset, a cancelled jog, homing).

    Examples
    --------
    >>> it = Interpreter()
    >>> moves, error = it.feed("G91 G1 X5 F600")
    >>> moves.end.tolist(), error
    ([[5.0, 0.0, 0.0]], None)
    >>> moves, error = it.feed("X5 X6")
    >>> len(moves), error.code, it.state.position
    (0, 25, (5.0, 0.0, 0.0))
    >>> it.feed("X5")[0].end.tolist(), it.state.distance
    ([[10.0, 0.0, 0.0]], 91)
    """

    def __init__(self, dialect: str | Dialect = "grbl", state=None, *, streaming: bool = False):
        from labkit.gcode.state import ModalState

        self.dialect = get_dialect(dialect)
        self._options = ParseOptions.from_dialect(self.dialect, streaming=streaming)
        self.state = ModalState() if state is None else state

    @property
    def state(self):
        return self._state

    @state.setter
    def state(self, value) -> None:
        self._state = value
        self._options = self._options._replace(start=value.record())

    def feed(self, line) -> tuple[Moves, GcodeError | None]:
        """Interpret one line (str or bytes, without a line end).

        Returns
        -------
        moves : Moves
            What the line does (empty when it is rejected or does not move); its
            ``records`` hold a pause, coolant, a ``$`` line … as :func:`parse` keeps them.
        error : GcodeError or None
            Why the line was rejected (``error.code``: the status number); a rejected line
            changes nothing, as on a controller.
        """
        from labkit.gcode.state import ModalState

        data = _as_bytes(line)
        if b"\n" in data.rstrip(b"\n"):
            raise ValueError("Interpreter.feed takes one line; got a line end inside it")
        out = K.interpret(np.frombuffer(data.rstrip(b"\n"), np.uint8), self._options, False, 1, False)
        if out.error_total:
            return Moves.empty(), _make_error(data, None, out.errors[0])
        self._state = ModalState.at(out.final, 0)
        self._options = self._options._replace(start=out.final)
        return Moves.from_rows(out.moves, s_max=self.dialect.s_max,
                               records=_records(data, out.records)), None


#: GRBL 1.1's settings ($n=value) below the per-axis ones ($100…$132, three axes).
_GRBL_SETTINGS = frozenset((0, 1, 2, 3, 4, 5, 6, 10, 11, 12, 13, 20, 21, 22, 23, 24, 25, 26, 27,
                            30, 31, 32))
_GRBL_FLOAT = re.compile(r"[-+]?(\d+\.?\d*|\.\d+)")     # read_float: no exponent
_COMMENT = re.compile(r"\([^)]*\)?|;.*")


def strip_comments(line: str) -> str:
    """One line without its comments, as GRBL's serial reader drops them: from ``(`` to the
    next ``)`` or, when none closes it, to the line's end; from ``;`` to the line's end.

    Parameters
    ----------
    line : str
        One line of G-code or a ``$`` command, without its line end.

    Returns
    -------
    str
        The line with the comments cut out; spaces and case as they were.

    Examples
    --------
    >>> strip_comments("G1 X10 (cut) Y5 ; to the corner"), strip_comments("$$ (unclosed")
    ('G1 X10  Y5 ', '$$ ')
    """
    return _COMMENT.sub("", line)


def grbl_system_verdict(line: str, dialect: str | Dialect = "grbl") -> tuple[str, str] | None:
    """What GRBL 1.1h answers to a ``$`` line, from its grammar alone: None for ``ok``, else
    the status name and why.

    The line is taken as GRBL's serial reader hands it over: spaces, comments and the
    real-time characters ``? ~ !`` dropped, letters upper case. Answered as with GRBL's
    default build and settings ($22 = 0: ``$H`` is error 5; ``$20=1`` is error 10), and
    regardless of the machine's state (``$C``, ``$X`` and settings need an idle or alarmed
    machine; the checker has none). ``$J=`` jog lines are the interpreter's.

    >>> grbl_system_verdict("$rst=gcode")
    ('invalid_statement', '$RST= takes $, # or *')
    >>> grbl_system_verdict("$110 = 500"), grbl_system_verdict("$HTTP/1.1 200")[0]
    (None, 'setting_disabled')
    """
    d = get_dialect(dialect)
    s = strip_comments(line)
    s = "".join(ch for ch in s if ch > " " and not (d.grbl_verdicts and ch in "?~!")).upper()
    cmd = s[1:2]
    if cmd == "" or s in ("$$", "$G", "$C", "$X", "$#", "$I", "$N", "$SLP"):
        return None
    if cmd in "$GCX#":
        return "invalid_statement", f"{s[:2]} takes nothing after it"
    if cmd == "J":
        return None if s[2:3] == "=" else ("invalid_statement", "a jog is $J= followed by G-code")
    if cmd == "H":
        return "setting_disabled", "homing is disabled ($22=0), so $H is refused"
    if cmd == "S":
        return "invalid_statement", "the only $S command is $SLP"
    if cmd == "I":
        return None if s[2:3] == "=" else ("invalid_statement", "$I or $I=<build info>")
    if cmd == "R":
        ok = s[2:5] == "ST=" and len(s) == 6 and s[5] in "$#*"
        return None if ok else ("invalid_statement", "$RST= takes $, # or *")
    startup = cmd == "N"
    rest = s[2:] if startup else s[1:]
    m = _GRBL_FLOAT.match(rest)
    if m is None:
        return "bad_number", "a setting number or a $N line number after '$'"
    number, rest = float(m.group(0)), rest[m.end():]
    if rest[:1] != "=":
        return "invalid_statement", "'=' after the setting number"
    rest = rest[1:]
    if startup:                                  # $Nx=<G-code>: the line is checked as G-code
        if rest.startswith("$"):
            # GRBL reads a start-up line that begins with '$' as a jog from its fourth
            # character on ($XYG91X1F100 jogs); a shorter one has no letter where one must be
            if len(rest) < 3:
                return "expected_letter", "a start-up line of G-code or a jog ($J=...)"
            rest = "$J=" + rest[3:]
        errors = check(rest, dialect=d)
        return None if not errors else (errors[0].status.name, f"a valid startup line: {errors[0].message}")
    m = _GRBL_FLOAT.match(rest)
    if m is None:
        return "bad_number", "a number after '='"
    value = float(m.group(0))
    if rest[m.end():] or number > 255:
        return "invalid_statement", "$<setting>=<value> and nothing after it"
    if value < 0:
        return "negative_value", "a setting's value is not negative"
    key = int(number)
    if key >= 100:
        axis_set, axis = divmod(key - 100, 10)
        ok = axis_set <= 3 and axis < 3
    else:
        ok = key in _GRBL_SETTINGS
    if not ok:
        return "invalid_statement", f"${key} is not a GRBL 1.1 setting"
    if key == 0 and int(value) < 3:
        return "setting_step_pulse_min", "a step pulse of at least 3 µs ($0)"
    if key == 20 and int(value):
        return "soft_limit_error", "soft limits ($20=1) need homing enabled ($22=1) first"
    return None


def _system_line_error(data: bytes, filename, rec, dialect) -> GcodeError | None:
    """The :class:`GcodeError` GRBL's answer to a ``$`` record is, or None (ok)."""
    if K.RECORD_NAMES[int(rec["kind"])] != "system":
        return None
    ls = data.rfind(b"\n", 0, int(rec["span"][0])) + 1
    le = data.find(b"\n", ls)
    le = len(data) if le < 0 else le
    source = data[ls:le].decode("utf-8", "replace").rstrip("\r")
    text = data[rec["span"][0]:rec["span"][1]].decode("utf-8", "replace")
    verdict = grbl_system_verdict(text, dialect)
    if verdict is None:
        return None
    name, expected = verdict
    column = len(data[ls:int(rec["span"][0])].decode("utf-8", "replace")) + 1
    return GcodeError("GRBL refuses this $ line", filename=filename, line=int(rec["line"]),
                      column=column, text=_clip(text.strip()), expected=expected, code=name,
                      source_line=_clip(source))


def parse_file(path, *, dialect: str | Dialect = "grbl", lenient: bool = False) -> Moves:
    """Read and :func:`parse` a G-code file (``moves.source`` is its path, used in messages)."""
    path = os.fspath(path)
    from labkit._files import check_input_file

    check_input_file(path, what="G-code file")
    with open(path, "rb") as fh:
        data = fh.read()
    return parse(data, dialect=dialect, filename=path, lenient=lenient)


def check(text, *, dialect: str | Dialect = "grbl", filename: str | None = None) -> list[GcodeError]:
    """Every diagnostic of a program as it would be streamed (empty list when it is valid).

    Includes the line-buffer limit of the dialect's controller (GRBL error 11,
    see ``parse(..., streaming=True)``); at most the ``diagnostics`` budget is
    returned.

    >>> [e.code for e in check("G1 X1 F100\\nG5 P3\\nG1 Y2 Y3")]
    [20, 25]
    >>> [e.code for e in check("G1 F100 X1." + "0" * 80 + " ; comments may be long" * 9)]
    [11]
    >>> check("G1 F100 X1 ; comments may be long" * 9)
    []
    """
    return list(parse(text, dialect=dialect, filename=filename, lenient=True,
                      streaming=True).diagnostics)


def modal_trace(text, *, dialect: str | Dialect = "grbl", filename: str | None = None,
                offsets: bool = False):
    """The modal state after every line, as a pandas DataFrame (for teaching).

    Columns: ``line``, ``text``, ``motion`` (G0…G3), ``plane``, ``units``,
    ``distance``, ``arc_centres``, ``feed_mm_min``, ``S``, ``laser`` (M3/M4/M5)
    and the position ``x``, ``y``, ``z`` in mm (machine coordinates, the
    controller's own offsets taken as zero at the start). Rejected lines keep
    the previous state and are marked in ``error``.

    With ``offsets=True`` also the work offsets the program set: ``coords``
    (G54…G59 in use), ``origin_x/y/z`` (its origin), ``g92_x/y/z``,
    ``tool_offset`` (G43.1 Z) and the work position ``wx``, ``wy``, ``wz`` —
    what the program's own X Y Z words mean there (mm).

    >>> t = modal_trace("G0 X10 Y5\\nG92 X0 Y0\\nG0 X1\\n", offsets=True)
    >>> t[["x", "wx", "g92_x", "coords"]].values.tolist()
    [[10.0, 10.0, 0.0, 'G54'], [10.0, 0.0, 10.0, 'G54'], [11.0, 1.0, 10.0, 'G54']]
    """
    import pandas as pd

    d = get_dialect(dialect)
    data = _as_bytes(text)
    out = _run(data, d, lenient=True, trace=True)
    state = out.trace
    lines = _text_lines(data)
    n = len(lines)
    errs = dict(zip(out.errors["line"].tolist(), out.errors["code"].tolist()))
    laser_names = {int(LaserMode.OFF): "M5", int(LaserMode.CONSTANT): "M3",
                   int(LaserMode.DYNAMIC): "M4"}
    table = pd.DataFrame({
        "line": np.arange(1, n + 1),
        "text": lines,
        "motion": [f"G{int(v)}" for v in state["motion"][:n]],
        "plane": [f"G{int(v)}" for v in state["plane"][:n]],
        "units": [f"G{int(v)}" for v in state["units"][:n]],
        "distance": [f"G{int(v)}" for v in state["distance"][:n]],
        "arc_centres": ["G90.1" if v == 90.1 else "G91.1" for v in state["arc_distance"][:n]],
        "feed_mm_min": state["feed_mm_min"][:n],
        "S": state["s_word"][:n],
        "laser": [laser_names[int(v)] for v in state["laser"][:n]],
        "x": state["position"][:n, 0], "y": state["position"][:n, 1],
        "z": state["position"][:n, 2],
        "error": [errs.get(i, 0) for i in range(1, n + 1)],
    })
    if offsets:
        system = state["coord_system"][:n].astype(int)
        origin = state["coord_origins"][:n][np.arange(n), system - 54]
        shift = origin + state["g92"][:n]
        shift[:, 2] += state["tool_offset"][:n]
        work = state["position"][:n] - shift
        table = table.assign(coords=[f"G{v}" for v in system],
                             origin_x=origin[:, 0], origin_y=origin[:, 1], origin_z=origin[:, 2],
                             g92_x=state["g92"][:n, 0], g92_y=state["g92"][:n, 1], g92_z=state["g92"][:n, 2],
                             tool_offset=state["tool_offset"][:n],
                             wx=work[:, 0], wy=work[:, 1], wz=work[:, 2])
    return table


# ---- messages -------------------------------------------------------------------------

# (code, detail) → (status name, message, expected). A detail of 0 is the default for its code.
_MESSAGES = {
    (K.E_EXPECTED_LETTER, 0): ("expected_letter", "a word must start with a letter",
                               "a letter A-Z followed by a number, a comment or a line end"),
    (K.E_BAD_NUMBER, K.D_NUMBER_NO_DIGITS): ("bad_number", "the word has no number",
                                             "a number like 12, -0.5 or +3.25 after the letter"),
    (K.E_BAD_NUMBER, K.D_NUMBER_TRAILING): ("bad_number", "malformed number",
                                            "a number like 12, -0.5 or +3.25 (one sign, one point, no exponent)"),
    (K.E_BAD_NUMBER, K.D_NUMBER_TOO_LARGE): ("bad_number", "number too large",
                                             f"a magnitude below {K.MAX_ABS_VALUE:.0f} "
                                             "(2**53; a machine coordinate in mm)"),
    (K.E_EXPECTED_LETTER, K.D_PERCENT): ("expected_letter", "'%' inside a line",
                                         "'%' alone on its line (the program delimiter) or a "
                                         "word letter A-Z"),
    (K.E_EXPECTED_LETTER, K.D_PERCENT_LINE): ("expected_letter", "a '%' line, which GRBL refuses",
                                              "no '%' line: GRBL 1.1 has no program delimiter "
                                              "and answers error 1 (leave it out for GRBL)"),
    (K.E_OVERFLOW, 0): ("line_overflow", "line too long for the controller's line buffer",
                        "at most the buffer's characters, not counting spaces and comments "
                        "(GRBL 1.1: 79 of its 80-byte buffer); split the block"),
    (K.E_INVALID_JOG, K.D_JOG_COMMAND): ("invalid_jog", "a jog cannot take this command",
                                         "only G20/G21, G90/G91 and G53 on a $J= line"),
    (K.E_UNUSED, K.D_JOG_WORD): ("unused_words", "a jog cannot take this word",
                                 "only X Y Z F (and N) on a $J= line"),
    (K.E_OUT_OF_RANGE, 0): ("value_out_of_range", "position out of range",
                            f"positions and arc centres below {K.MAX_ABS_VALUE:.0f} mm in "
                            "magnitude (finite)"),
    (K.E_BAD_NUMBER, K.D_CHECKSUM_DIGITS): ("bad_number", "malformed checksum",
                                            "'*' followed by 1 to 3 digits (0-255)"),
    (K.E_NEGATIVE, 0): ("negative_value", "value must not be negative", "a value >= 0"),
    (K.E_UNSUPPORTED, K.D_UNKNOWN_LETTER): ("unsupported_command", "unknown word for this dialect",
                                            "one of the letters F G I J K M N P R S X Y Z (and the dialect's extras)"),
    (K.E_UNSUPPORTED, K.D_UNKNOWN_G): ("unsupported_command", "unsupported G command",
                                       "a G command of the dialect (Dialect.g_codes; GRBL 1.1's "
                                       "list for grbl)"),
    (K.E_UNSUPPORTED, K.D_G10_L): ("unsupported_command", "G10 with an L other than 2 or 20",
                                   "G10 L2 (set a system's origin) or G10 L20 (make the current "
                                   "position the given work coordinates)"),
    (K.E_UNSUPPORTED, K.D_G10_R): ("unsupported_command", "G10 L2 with R (rotation)",
                                   "G10 L2 P… with axis words only"),
    (K.E_MISSING_VALUE, K.D_G10_LP): ("missing_value_word", "G10 without its L and P words",
                                      "G10 L2 P<0-6> or G10 L20 P<0-6> with axis words"),
    (K.E_AXIS_CONFLICT, 0): ("axis_command_conflict",
                             "two commands in one line both use the axis words",
                             "one command per line that uses the axis words: G0-G3, G38, "
                             "G10, G28, G30, G92, G43.1 or G49"),
    (K.E_COORD_SYS, 0): ("unsupported_coord_sys", "coordinate system number out of range",
                         "P0 (the active system) or P1-P6 (G54-G59)"),
    (K.E_G53_MOTION, 0): ("g53_invalid_motion_mode", "G53 needs G0 or G1",
                          "G53 with G0 or G1 in effect"),
    (K.E_AXIS_EXIST, 0): ("axis_words_exist", "axis words with motion cancelled (G80)",
                          "a motion command (G0-G3, G38) before axis words"),
    (K.E_G43_AXIS, 0): ("g43_dynamic_axis_error", "G43.1 takes a Z word only",
                        "G43.1 Z<offset>"),
    (K.E_MAX_VALUE, 0): ("max_value_exceeded", "value above its maximum",
                         "a tool number T up to the dialect's maximum (GRBL: 255)"),
    (K.E_INVALID_ARC, K.D_PROBE_TARGET): ("invalid_arc", "probe target is the current position",
                                          "a G38 target away from the current position"),
    (K.E_UNSUPPORTED, K.D_UNKNOWN_M): ("unsupported_command", "unsupported M command",
                                       "M0 M1 M2 M30, the dialect's laser words (M3 M4 M5) or coolant words "
                                       "(grbl: M8 M9; M7 and M6 are not in GRBL 1.1's default build)"),
    (K.E_MODAL_GROUP, 0): ("modal_group_violation", "two commands of one modal group in one line",
                           "at most one command per group (e.g. one of G0/G1/G2/G3)"),
    (K.E_MODAL_GROUP, K.D_TOO_MANY): ("modal_group_violation", "too many commands in one line",
                                      f"at most {K.MAX_COMMANDS} G and {K.MAX_COMMANDS} M words"),
    (K.E_UNDEFINED_FEED, 0): ("undefined_feed", "feed motion without a feed rate",
                              "an F word on this line or an earlier one"),
    (K.E_NON_INTEGER, 0): ("non_integer_command", "command number must be an integer",
                           "a whole number like G1 or M3"),
    (K.E_REPEATED, 0): ("repeated_word", "a word is repeated in one line",
                        "each letter at most once per line"),
    (K.E_NO_AXIS_WORDS, 0): ("missing_axis_words", "motion command without axis words",
                             "at least one of X Y Z"),
    (K.E_LINE_NUMBER, 0): ("bad_line_number", "line number out of range",
                           f"a whole N from 0 to {K.MAX_LINE_NUMBER}"),
    (K.E_MISSING_VALUE, K.D_DWELL_P): ("missing_value_word", "dwell without its time",
                                       "G4 P<time>"),
    (K.E_MISSING_VALUE, K.D_LOOKAHEAD_P): ("missing_value_word", "look-ahead without its depth",
                                           "G5 P<blocks>"),
    (K.E_NO_PLANE_AXIS, 0): ("missing_plane_axis", "arc without an end point in its plane",
                             "an end point word of the arc plane (X or Y for G17)"),
    (K.E_INVALID_ARC, K.D_R_FULL_CIRCLE): ("invalid_arc", "a full circle cannot be given by R",
                                           "an end point different from the start, or I J K offsets"),
    (K.E_INVALID_ARC, K.D_R_TOO_SMALL): ("invalid_arc", "arc radius is smaller than half the chord",
                                         "|R| >= half the distance from start to end"),
    (K.E_ARC_RADIUS, K.D_R_TOO_SMALL): ("arc_radius_error", "arc radius is smaller than half the chord",
                                        "|R| >= half the distance from start to end"),
    (K.E_INVALID_ARC, K.D_RADIUS_MISMATCH): ("invalid_arc", "arc radius at start and end differ",
                                             "an end point on the circle through the start around the "
                                             "centre (within the dialect's tolerance)"),
    (K.E_INVALID_ARC, K.D_ZERO_RADIUS): ("invalid_arc", "arc centre is the start point",
                                         "I J K offsets that put the centre away from the start"),
    (K.E_NO_OFFSET, 0): ("missing_offset_words", "arc without a centre offset in its plane",
                         "R, or an I J K word of the arc plane (I or J for G17)"),
    (K.E_NO_OFFSET, K.D_ABS_CENTRE): ("missing_offset_words",
                                      "absolute arc centre (G90.1) needs both in-plane words",
                                      "both in-plane centre words (I and J for G17)"),
    (K.E_UNUSED, 0): ("unused_words", "value word that no command in the line uses",
                      "I J K or R only with G2/G3, P only with G4 (G5) or G10, L only with G10"),
    (K.E_CHECKSUM, 0): ("bad_checksum", "checksum does not match the line",
                        "'*' followed by the XOR of every byte before it"),
    (K.E_DELIMITER, K.D_UNCLOSED_COMMENT): ("bad_delimiter", "comment is not closed",
                                            "')' before the end of the line"),
    (K.E_DELIMITER, K.D_AFTER_CHECKSUM): ("bad_delimiter", "text after the checksum",
                                          "the checksum last on the line"),
}


#: Longest text quoted in a message (a multi-megabyte line is quoted by its start).
_QUOTE_CHARS = 120


def _clip(text: str) -> str:
    return text if len(text) <= _QUOTE_CHARS else text[:_QUOTE_CHARS] + "…"


def _make_error(data: bytes, filename, row) -> GcodeError:
    """The :class:`GcodeError` for one :data:`labkit.gcode._kernel.ERROR_ROW` of ``data``."""
    line, pos, end = int(row["line"]), int(row["pos"]), int(row["end"])
    code, detail, aux = int(row["code"]), int(row["detail"]), row["aux"]
    ls = data.rfind(b"\n", 0, pos) + 1
    le = data.find(b"\n", pos)
    le = len(data) if le < 0 else le
    source_line = _clip(data[ls:le].decode("utf-8", "replace").rstrip("\r"))
    text = _clip(data[pos:end].decode("utf-8", "replace").strip())
    column = len(data[ls:pos].decode("utf-8", "replace")) + 1
    name, message, expected = _MESSAGES.get((code, detail)) or _MESSAGES[(code, 0)]
    a0, a1 = float(aux[0]), float(aux[1])
    if code == K.E_CHECKSUM:
        message = f"checksum does not match the line (computed {a0:.0f}, written {a1:.0f})"
    elif code in (K.E_INVALID_ARC, K.E_ARC_RADIUS) and detail == K.D_R_TOO_SMALL:
        message = f"arc radius {a0:.6g} mm is smaller than half the chord {a1:.6g} mm"
    elif code == K.E_INVALID_ARC and detail == K.D_RADIUS_MISMATCH:
        message = (f"arc radius at start {a0:.6g} mm and at end {a1:.6g} mm differ by "
                   f"{abs(a1 - a0):.3g} mm")
    return GcodeError(message, filename=filename, line=line, column=column, text=text,
                      expected=expected, code=name, source_line=source_line)
