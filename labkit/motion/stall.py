"""Stalls: where a controller's planner runs dry because the serial link cannot keep up.

A GRBL-family controller moves only what is in its planner buffer. When short
blocks finish faster than the link (115200 baud 8N1 is 11,520 bytes/s) and the
controller's parser can deliver new ones, the buffer empties while the job still
has lines left: the machine stops and restarts (a *starvation*, seen on a raster
job as stutter and burned dots). This module holds the record every simulated
machine reports a starvation with — the firmware's paced host simulator, the
virtual machine and the stall predictor report the same thing, so they can be
compared one to one — and the predictor itself.

The predictor (:func:`predict_stalls`) follows each line through the link as a
character-counting sender streams it (GRBL's rule: a line goes out while the
characters in flight, itself included, stay below the receive buffer less one),
over the wire at the machine's bytes per second, through the parser
(``block_parse_s`` a line, one line after the other; on GRBL a parsed line waits
for a free planner slot, as its main loop does, on the labkit firmware a line is
parsed once a slot is free) into the planner; the motion of each block takes the time the
motion reference (:func:`labkit.motion.plan`) gives it. A block starts when the
one before has ended and it is ready: on GRBL when it is in the planner; on the
labkit firmware (``waits_for_lookahead``) when its whole look-ahead window has
arrived, or the input has gone quiet for 30 ms (``FLUSH_QUIET_MS`` in
``firmware/src/protocol.c``). The sender answers at once (no USB latency). A
starvation is a stop between two blocks while the job has lines left — before the
last line has been parsed, whether its bytes are still on the wire or already
wait in the receive buffer for a parser that cannot keep up. On the labkit
firmware a block's speed profile does not depend on when it arrives (the window
is always complete), so the prediction is exact up to the step timer's ticks: the
firmware runs each block as its ticks (``labkit steps``), never faster than the
plan's continuous time and, with few steps a block, a few per cent slower (8 steps
a 0.1 mm pixel on ``labkit-diode``: about 2 %), so the prediction errs towards
stalls. On GRBL a shallow buffer also slows the motion down, which the prediction
leaves out (it sees only where the buffer empties; :func:`short_queues` says where).

A controller that waits for its planner to empty at a change of M3/M4/M5
(``laser_change_syncs``: GRBL's ``spindle_sync``; :func:`labkit.gcode.grbl_sync_lines`) stops
there: the plan ends the motion before such a line at rest, the line is answered once
that motion has ended, and the next line is read after it. That stop is the program's:
it counts as a starvation only when the line after it had not arrived by then.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import numpy as np

from labkit.errors import MotionError
from labkit.motion._stall import stream_lines

__all__ = ["Starvation", "LinkPrediction", "StallFreeFeed", "predict_stalls", "stall_free_feed",
           "sent_line_bytes", "with_feed", "program_feeds", "read_starvation_log", "may_starve",
           "block_time_bounds", "motion_line_numbers", "short_queues", "controller_sync_lines", "controller_syncs",
           "FLUSH_QUIET_S"]

#: Quiet input after which the labkit firmware runs what its look-ahead holds back, s
#: (``FLUSH_QUIET_MS`` in ``firmware/src/protocol.c``).
FLUSH_QUIET_S = 0.030

#: Stops shorter than this are timer granularity, not starvations, s.
_MIN_STALL_S = 1e-6


@dataclass(frozen=True)
class Starvation:
    """The motors stood still while the job had lines left.

    Parameters
    ----------
    time_s : float
        When the motors stopped, in seconds of machine time from the job's
        first byte.
    line : int
        The source line (1-based, as ``labkit check`` numbers them) of the
        block the machine resumed with (on GRBL: the block it was waiting for;
        on the labkit firmware, which waits for its look-ahead window, the
        block that then runs).
    duration_s : float
        How long the machine stood without a block, s (> 0).
    """

    time_s: float
    line: int
    duration_s: float


def read_starvation_log(path) -> list[Starvation]:
    """The starvations the firmware's host simulator logged (``--starvation-log``).

    Parameters
    ----------
    path : str or Path
        The CSV (``time_s,line,duration_s``).

    Returns
    -------
    list of Starvation

    Raises
    ------
    MotionError
        The file does not start with that header, or a row is not three numbers.
    """
    from pathlib import Path

    rows = Path(path).read_text("ascii").splitlines()
    if not rows or rows[0].strip() != "time_s,line,duration_s":
        raise MotionError(f"{path}: line 1: expected the header 'time_s,line,duration_s', "
                          f"got {rows[0]!r}" if rows else f"{path}: empty; expected a header")
    out = []
    for n, row in enumerate(rows[1:], start=2):
        try:
            t, line, d = row.split(",")
            out.append(Starvation(float(t), int(line), float(d)))
        except ValueError:
            raise MotionError(f"{path}: line {n}: expected time_s,line,duration_s, got {row!r}") from None
    return out


def sent_line_bytes(text: str) -> np.ndarray:
    """Bytes each source line puts on the link as ``labkit stream`` sends it.

    Comments, spaces and tabs removed, upper case, and a newline; a line with
    nothing left is not sent (0).

    Parameters
    ----------
    text : str
        The program.

    Returns
    -------
    ndarray of int
        One count per source line.

    Examples
    --------
    >>> sent_line_bytes("G1 X10 (cut)\\n\\n; note\\nX.1S5\\n").tolist()
    [6, 0, 0, 6]
    """
    from labkit.gcode.reader import strip_comments

    fast = _plain_line_bytes(text)
    if fast is not None:
        return fast
    cut = _whole_text_code(text)
    if cut is not None:
        # lines end in \n or \r\n only: the whole text at once, the same cuts per line
        parts = cut[1].split("\n")
        if text.endswith("\n") or not text:
            parts.pop()
        n = np.fromiter(map(len, parts), dtype=np.int64, count=len(parts))
        return np.where(n > 0, n + 1, 0)
    out = []
    for raw in text.splitlines():
        body = re.sub(r"\s", "", strip_comments(raw))
        out.append(len(body) + 1 if body else 0)
    return np.asarray(out, dtype=np.int64)


def _plain_line_bytes(text: str):
    """:func:`sent_line_bytes` of a text as programs are written (printable ASCII, tabs, \\n
    line ends, comments only as whole lines starting with ``;``) with numpy over its bytes,
    else None. A program writer's output, as long as a photo's, takes a few ms."""
    lines = _plain_lines(text.encode("latin-1", "replace"))
    return None if lines is None else lines[0]


def _plain_lines(encoded: bytes, axes: bool = False):
    """(bytes each line sends, and with ``axes`` whether it holds an X, Y or Z) of a program
    ``encoded`` as bytes and written plainly (see :func:`_plain_line_bytes`), else None.

    A line sends its length less its spaces and tabs, plus its newline; what is rare in a
    written program (spaces in compact text, comments) is counted before it is looked for.
    Read a block of about :data:`_COUNT_BLOCK_BYTES` bytes (whole lines) at a time: the
    temporaries stay a few MB whatever the length of the program; only the per-line results
    are as long as it.
    """
    if not encoded:
        return None
    raw = np.frombuffer(encoded, dtype=np.uint8)
    n_lines = encoded.count(b"\n") + (raw[-1] != 10)
    nbytes = np.empty(n_lines, dtype=np.int64)
    has_axis = np.empty(n_lines, dtype=bool) if axes else None
    first_line = 0
    lo = 0
    while lo < len(raw):
        hi = encoded.find(b"\n", min(lo + _COUNT_BLOCK_BYTES, len(raw)) - 1)
        hi = len(raw) if hi < 0 else hi + 1                 # past the block's last newline
        part = raw[lo:hi]
        newline = part == 10
        tabs = np.count_nonzero(part == 9)
        if part.max() > 126 or np.count_nonzero(part < 32) != np.count_nonzero(newline) + tabs:
            return None                                     # a control character
        ends = np.flatnonzero(newline)
        del newline
        if part[-1] != 10:                                  # the last line has no newline
            ends = np.append(ends, len(part))
        starts = np.concatenate([[0], ends[:-1] + 1])
        comment = part[np.minimum(starts, len(part) - 1)] == 59
        comment &= starts < ends                            # an empty line is no comment
        if np.count_nonzero(part == 40) or np.count_nonzero(part == 59):
            special = np.flatnonzero((part == 40) | (part == 59))     # ( and ;
            if not comment[np.searchsorted(ends, special)].all():
                return None
        n = ends - starts
        spaces = np.count_nonzero(part == 32) + tabs
        if spaces:
            blank = (part == 32) | (part == 9)
            if spaces < len(part) // 64:                    # a few: counted where they are
                n -= np.bincount(np.searchsorted(ends, np.flatnonzero(blank)), minlength=len(n))
            else:
                count = np.zeros(len(part) + 1, dtype=np.int64)
                np.cumsum(blank, out=count[1:])
                n -= count[ends] - count[starts]
            del blank
        n[comment] = 0
        nbytes[first_line:first_line + len(n)] = np.where(n > 0, n + 1, 0)
        if axes:
            # X, Y or Z (88-90) in each line's bytes with its newline: never an empty stretch
            has_axis[first_line:first_line + len(n)] = np.logical_or.reduceat(part - np.uint8(88) < 3, starts)
        first_line += len(n)
        lo = hi
    return nbytes, has_axis


def motion_line_numbers(text: str, n_moves: int):
    """The source line (1-based) of each move of a program written one move a line, and the
    bytes each line sends (:func:`sent_line_bytes`).

    The motion lines are the sent lines with an X, Y or Z word, in order; when there are
    not ``n_moves`` of them (a move without an axis word, two on a line) the first is None.

    Returns
    -------
    (ndarray of int or None, ndarray of int)
        Line numbers (one a move), bytes sent per line (one a line).

    Examples
    --------
    >>> motion_line_numbers("G21\\nG0X1\\n;X\\nG1Y2F600\\nM5\\n", 2)[0].tolist()
    [2, 4]
    """
    lines = _plain_lines(text.encode("ascii", "replace"), axes=True)
    if lines is not None:
        nbytes, has_axis = lines
        has_axis &= nbytes > 0
        rows = np.flatnonzero(has_axis)
        del has_axis
    else:
        nbytes = sent_line_bytes(text)
        raw = np.frombuffer(text.encode("ascii", "replace"), dtype=np.uint8)
        axis = np.flatnonzero((raw == ord("X")) | (raw == ord("Y")) | (raw == ord("Z")))
        rows = np.searchsorted(np.flatnonzero(raw == ord("\n")), axis)     # 0-based, in order
        rows = rows[np.concatenate([[True], rows[1:] != rows[:-1]])] if len(rows) else rows
        rows = rows[nbytes[rows] > 0]
    return (rows + 1 if len(rows) == n_moves else None), nbytes


#: Bytes of a program read at a time by :func:`_plain_lines` (bounds its memory, not its result).
_COUNT_BLOCK_BYTES = 1 << 20


#: What str.splitlines breaks a line at besides \n and \r\n (and a lone \r).
_OTHER_LINE_BREAKS = "\x0b\x0c\x1c\x1d\x1e\x85\u2028\u2029"
#: The whitespace ``\s`` matches in ASCII, but \n: deleted by str.translate.
_ASCII_SPACE = str.maketrans("", "", " \t\r\x0b\x0c\x1c\x1d\x1e\x1f")
_last_code: list = [None, None]          # the last text and its _whole_text_code (texts are immutable)


def _whole_text_code(text: str):
    """(text without comments, that without whitespace but line ends, its F words' values)
    when the lines of ``text`` end in \n or \r\n only (as str.splitlines cuts them), else None."""
    if _last_code[0] is text:
        return _last_code[1]
    if text.count("\r") != text.count("\r\n") or any(c in text for c in _OTHER_LINE_BREAKS):
        out = None
    else:
        code = _COMMENT_IN_LINE.sub("", text)
        out = (code, code.translate(_ASCII_SPACE) if code.isascii() else _SPACE_IN_LINE.sub("", code),
               tuple(float(v) for _, v in _F_WORD.findall(code)))
    _last_code[0], _last_code[1] = text, out
    return out
#: labkit.gcode.reader's comments (``(`` to ``)`` or the line's end; ``;`` to the line's end)
#: within one line of a whole text, and the whitespace sent_line_bytes drops.
_COMMENT_IN_LINE = re.compile(r"\([^)\n]*\)?|;[^\n]*")
_SPACE_IN_LINE = re.compile(r"[^\S\n]")


_F_WORD = re.compile(r"(F)([-+]?(?:\d+\.?\d*|\.\d+))", re.IGNORECASE)


def program_feeds(text: str) -> list[float]:
    """Every F word's value in a program, in order (comments left out), mm/min.

    >>> program_feeds("G1 X1 F1000 (F2)\\nG1 Y1 F500\\n")
    [1000.0, 500.0]
    """
    from labkit.gcode.reader import strip_comments

    cut = _whole_text_code(text)
    if cut is not None:                                  # lines end in \n or \r\n: all at once
        return list(cut[2])
    return [float(m.group(2)) for raw in text.splitlines() for m in _F_WORD.finditer(strip_comments(raw))]


def _f_words(lines: list[str]):
    """The F words :func:`with_feed` scales: those in the code of a line (before its first
    ``;`` or ``(``). ``lines`` keep their ends; returns (line index, start, end) of each F
    word's number and the number's text."""
    where, numbers = [], []
    for i, ln in enumerate(lines):
        if "F" not in ln and "f" not in ln:
            continue
        raw = ln.rstrip("\r\n")
        ends = [k for k in (raw.find(";"), raw.find("(")) if k >= 0]
        for m in _F_WORD.finditer(raw, 0, min(ends) if ends else len(raw)):
            where.append((i, m.start(2), m.end(2)))
            numbers.append(m.group(2))
    return where, numbers


def _with_numbers(lines: list[str], where, numbers) -> str:
    """The program with the F numbers at ``where`` (from :func:`_f_words`) replaced by ``numbers``."""
    out = list(lines)
    by_line: dict[int, list] = {}
    for (i, a, b), new in zip(where, numbers):
        by_line.setdefault(i, []).append((a, b, new))
    for i, words in by_line.items():
        ln, parts, cursor = lines[i], [], 0
        for a, b, new in words:
            parts += [ln[cursor:a], new]
            cursor = b
        parts.append(ln[cursor:])
        out[i] = "".join(parts)
    return "".join(out)


def _scaled_numbers(values: np.ndarray, k: float) -> list[str]:
    """F numbers scaled by ``k`` as :func:`with_feed` writes them (6 significant digits)."""
    return [f"{v:.6g}" for v in (values * k).tolist()]


def with_feed(text: str, feed_mm_min: float) -> str:
    """The program with its feeds scaled so that the highest F word is ``feed_mm_min``.

    Parameters
    ----------
    text : str
        The program (every F word read as mm/min; comments are left alone).
    feed_mm_min : float
        The new highest feed, mm/min (> 0).

    Returns
    -------
    str

    Raises
    ------
    MotionError
        The program has no F word, or the feed is not > 0.

    Examples
    --------
    >>> with_feed("G1 X1 F1000\\nX2\\nG1 Y1 F500 (slow)\\n", 1500)
    'G1 X1 F1500\\nX2\\nG1 Y1 F750 (slow)\\n'
    """
    if not (feed_mm_min > 0 and math.isfinite(feed_mm_min)):
        raise MotionError(f"the feed must be > 0 mm/min, got {feed_mm_min!r}")
    feeds = program_feeds(text)
    if not feeds or max(feeds) <= 0:
        raise MotionError("the program has no F word > 0: there is no feed to scale")
    k = feed_mm_min / max(feeds)
    lines = text.splitlines(True)
    where, numbers = _f_words(lines)
    return _with_numbers(lines, where, _scaled_numbers(np.array([float(v) for v in numbers]), k))


@dataclass(frozen=True)
class LinkPrediction:
    """A job streamed over the machine's link, line by line and block by block.

    Attributes
    ----------
    machine : MachineSpec
    line : ndarray of int
        Source line of each line sent (1-based).
    bytes : ndarray of int
        Bytes of each line sent, its newline included.
    sent_s, arrived_s, parsed_s : ndarray of float
        When the sender wrote each line, when its newline arrived, when its
        block(s) entered the planner (the line answered ``ok``), s.
    fill : ndarray of int
        Blocks in the planner right after each line was parsed (its fill level).
    block_line : ndarray of int
        Source line of each planner block.
    block_start_s, block_end_s : ndarray of float
        When each block's motion started and ended, s.
    stalls : list of Starvation
        Every time the motors stood while the job had lines left.
    job_time_s : float
        End of the last block, s from the first byte.
    motion_time_s : float
        The job's time with a link that never holds it back (the plan's), s.
    block_exit_mm_s, block_brake_mm2_s2, block_floor_mm_s : ndarray of float or None
        From the plan, per block: its exit speed, the square of the speed its length lets it
        shed (2 a L) and its floor, the speed of its driver at the step timer's slowest rate
        (``start_rate_hz``; GRBL's planner rests at 0 but its steps never tick slower); what
        :func:`short_queues` needs.
    sync_lines : ndarray of int
        Lines at which the controller emptied its planner before it went on (GRBL's
        M3/M4/M5 changes and the other lines of :func:`labkit.gcode.grbl_sync_lines`).
    """

    machine: object
    line: np.ndarray
    bytes: np.ndarray
    sent_s: np.ndarray
    arrived_s: np.ndarray
    parsed_s: np.ndarray
    fill: np.ndarray
    block_line: np.ndarray
    block_start_s: np.ndarray
    block_end_s: np.ndarray
    stalls: list = field(default_factory=list)
    job_time_s: float = 0.0
    motion_time_s: float = 0.0
    block_exit_mm_s: np.ndarray | None = None
    block_brake_mm2_s2: np.ndarray | None = None
    block_floor_mm_s: np.ndarray | None = None
    sync_lines: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))

    @property
    def stall_time_s(self) -> float:
        """Time the motors stood in starvations, s."""
        return float(sum(s.duration_s for s in self.stalls))


def _plan_text(text: str, machine, dialect: str, sync_lines=None):
    from labkit.gcode import parse
    from labkit.motion.pipeline import plan

    return plan(parse(text, dialect=dialect), machine, planner="junction", sync_lines=sync_lines)


def controller_sync_lines(text, machine, dialect: str = "grbl", trace=None) -> np.ndarray:
    """The lines at which ``machine``'s controller empties its planner before it goes on, so
    that the motion stops there (``plan``'s ``sync_lines``): when the description says it
    waits (``laser_change_syncs``), every line GRBL syncs on in the grbl dialect
    (:func:`labkit.gcode.grbl_sync_lines`: laser and coolant switches, a new S alone with the
    beam on, offsets, probes; the M3/M4/M5 changes are the most frequent); none otherwise.

    Parameters
    ----------
    text : str or bytes
        The program.
    machine : MachineSpec or str
    dialect : str
        The program's dialect; other dialects than grbl keep power in the step stream.
    trace : ndarray, optional
        The program's strict :func:`~labkit.gcode.parse_with_states` trace, when the caller
        has read it (see :func:`~labkit.gcode.grbl_sync_lines`).

    Returns
    -------
    ndarray of int
        1-based source lines, rising.

    Examples
    --------
    >>> controller_sync_lines("M3S100\\nG1X10F600\\nM5\\nG1X20\\n", "grbl-diode").tolist()
    [1, 3]
    """
    from labkit.gcode import grbl_sync_lines

    if not controller_syncs(machine, dialect):
        return np.zeros(0, np.int64)
    return np.asarray(grbl_sync_lines(text, dialect=dialect, trace=trace), np.int64)


def controller_syncs(machine, dialect: str = "grbl") -> bool:
    """Whether ``machine``'s controller empties its planner at some lines of a program in
    ``dialect`` (:func:`controller_sync_lines` finds them): its description says it waits
    (``laser_change_syncs``) and the program is GRBL's; other dialects keep power in the step
    stream. A caller that reads the program only for those lines asks this first.

    Parameters
    ----------
    machine : MachineSpec or str
    dialect : str

    Returns
    -------
    bool

    Examples
    --------
    >>> controller_syncs("grbl-diode"), controller_syncs("grbl-diode", "labkit-fw")
    (True, False)
    """
    from labkit.gcode import get_dialect
    from labkit.motion.spec import load_machine

    return bool(load_machine(machine).laser_change_syncs) and get_dialect(dialect).name == "grbl"


def _synced(p, machine, sync: np.ndarray):
    """The plan ``p`` with the motion stopped at the lines ``sync`` (made again from its
    blocks when it was made without them)."""
    from labkit.motion.pipeline import plan

    if np.array_equal(p.sync_lines, sync):
        return p
    return plan(p.blocks, machine, planner=p.planner, law=p.law, sync_lines=sync)


def predict_stalls(text: str, machine=None, *, line_bytes=None, dialect: str = "grbl",
                   plan=None) -> LinkPrediction:
    """Follow a program through the link, the parser and the planner; find where it starves.

    Parameters
    ----------
    text : str
        The program.
    machine : MachineSpec, str or None
        As :func:`labkit.motion.load_machine` takes it; its link fields (``link_baud``,
        ``link_bits_per_byte``, ``rx_buffer_bytes``, ``planner_blocks``, ``block_parse_s``,
        ``waits_for_lookahead``, ``laser_change_syncs``) and ``buffer_blocks`` decide.
    line_bytes : sequence of int, optional
        Bytes the sender puts on the link for each source line, newline included (0: not
        sent). Default :func:`sent_line_bytes` (as ``labkit stream`` sends).
    dialect : str
        How the program is read.
    plan : Plan, optional
        The program's plan on this machine, when already made.

    Returns
    -------
    LinkPrediction

    Raises
    ------
    MotionError
        ``line_bytes`` does not give one count per line, or a line that makes a block is
        not sent, or a line is longer than the receive buffer takes.

    Examples
    --------
    Three 0.1 mm cuts at 1200 mm/min on the CBR-40, each about 27 ms with its ramps; at
    1200 baud (120 bytes/s) the 11-byte first line arrives at 91.7 ms and each 6-byte line
    50 ms later. With a look-ahead of one block the first cut starts when the second has
    arrived (141.7 ms) and ends at 168.1 ms; the second waits for the third (191.7 ms): a
    starvation of 23.6 ms. The third waits for the quiet-input flush, with no line left
    to come: not a starvation.

    >>> from labkit.motion.spec import CBR40
    >>> m = CBR40.replace(link_baud=1200, buffer_blocks=1)
    >>> p = predict_stalls("G1X.1F1200\\nG1X.2\\nG1X.3\\n", m)
    >>> [(s.line, round(s.duration_s, 3)) for s in p.stalls]
    [(2, 0.024)]
    """
    from labkit.motion.spec import load_machine

    m = load_machine(machine)
    nbytes = sent_line_bytes(text) if line_bytes is None else np.asarray(line_bytes, dtype=np.int64)
    if line_bytes is None:
        n_lines = len(nbytes)
    elif _whole_text_code(text) is not None:             # lines end in \n or \r\n
        n_lines = text.count("\n") + (not text.endswith("\n") and text != "")
    else:
        n_lines = len(text.splitlines())
    if len(nbytes) != n_lines:
        raise MotionError(f"line_bytes gives {len(nbytes)} counts for {n_lines} lines")
    limit = m.rx_buffer_bytes - 1
    too_long = np.flatnonzero(nbytes >= limit)
    if len(too_long):
        k = int(too_long[0])
        raise MotionError(f"line {k + 1}: {int(nbytes[k])} bytes with its newline; a counting sender "
                          f"sends only lines shorter than {limit} (the {m.rx_buffer_bytes}-byte buffer "
                          f"less one)")
    sync = controller_sync_lines(text, m, dialect)
    p = _plan_text(text, m, dialect, sync) if plan is None else _synced(plan, m, sync)
    block_line = np.asarray(p.blocks.line, dtype=np.int64)
    dur = np.asarray(p.block_time_s, dtype=float)
    sent_idx = np.flatnonzero(nbytes > 0)
    unsent = block_line[(block_line >= 1) & (block_line <= len(nbytes))]
    unsent = unsent[nbytes[unsent - 1] == 0]
    if len(unsent):
        raise MotionError(f"line {int(unsent[0])} makes a block but sends nothing")

    if np.any(np.diff(block_line) < 0):
        raise MotionError("the plan's blocks are not in source-line order")
    W = m.buffer_blocks if m.waits_for_lookahead else 0
    src_line = sent_idx + 1
    n_sent = len(sent_idx)
    nb = len(block_line)
    first_block = np.searchsorted(block_line, src_line, side="left")   # blocks b0 … b1-1 of each line
    last_block = np.searchsorted(block_line, src_line, side="right")
    tau = m.link_bits_per_byte / m.link_baud
    sent_bytes = np.ascontiguousarray(nbytes[sent_idx])
    sent, arrived, parsed, start, end = stream_lines(
        sent_bytes, first_block.astype(np.int64), last_block.astype(np.int64),
        np.ascontiguousarray(dur), tau, float(m.block_parse_s), int(W), int(m.planner_blocks),
        int(limit), FLUSH_QUIET_S if W else 0.0, not m.waits_for_lookahead, np.isin(src_line, sync))

    # a starvation: a stop while the job has lines left, i.e. before the last line has been
    # parsed (on the wire, in the receive buffer or in the parser), not the final flush's
    # wait. The parser's time counts: a controller that parses more slowly than its blocks
    # run starves with its buffer full of text.
    stalls = []
    gaps = np.flatnonzero(start[1:] - end[:-1] > _MIN_STALL_S) + 1
    if len(gaps) and n_sent:
        t0, t1 = end[gaps - 1], start[gaps]
        hit = t0 < parsed[-1]
        if len(sync):
            # the stop at a sync the controller makes anyway: a starvation only where the
            # line of the block after it had not arrived when the motion before it ended
            at_sync = np.searchsorted(sync, block_line[gaps - 1], side="right") < \
                np.searchsorted(sync, block_line[gaps], side="right")
            late = arrived[np.searchsorted(src_line, block_line[gaps])] > t0
            hit &= ~at_sync | late
        stalls = [Starvation(float(a), int(block_line[j]), float(b - a))
                  for a, b, j in zip(t0[hit], t1[hit], gaps[hit])]
    # fill level: blocks entered by each line minus blocks that had ended by then
    entered = last_block
    ended = np.searchsorted(np.sort(end), parsed, side="right") if nb else np.zeros(n_sent, int)
    fill = np.maximum(entered - ended, 0)
    return LinkPrediction(machine=m, line=src_line, bytes=sent_bytes, sent_s=sent, arrived_s=arrived,
                          parsed_s=parsed, fill=fill, block_line=block_line, block_start_s=start,
                          block_end_s=end, stalls=stalls, job_time_s=float(end.max()) if nb else 0.0,
                          motion_time_s=float(dur.sum()),
                          block_exit_mm_s=np.asarray(p.lookahead.speed_mm_s[1:nb + 1], dtype=float),
                          block_brake_mm2_s2=2.0 * np.asarray(p.blocks.accel_mm_s2, dtype=float)
                          * np.asarray(p.blocks.length_mm, dtype=float),
                          block_floor_mm_s=p.blocks.speed_at_rate(m.start_rate_hz), sync_lines=sync)


def short_queues(prediction: LinkPrediction) -> list[Starvation]:
    """Where a GRBL-family planner runs short: a block starts with too few queued behind it.

    GRBL (``waits_for_lookahead`` false) runs whatever its planner holds and plans every
    queue to stop at its end, so a block that starts with too little queued behind it to
    shed its planned exit speed by the queue's end leaves at a lower speed: the link costs
    speed (a dip a raster job shows as a darker dot) before it costs a stop. Block j is
    short when its exit speed in the plan (the whole program ahead) is above what the
    blocks parsed by its start (at most ``planner_blocks`` - 1) let it keep: the square
    root of the last one's floor squared plus 2 a L summed over them (no speed cap
    between can raise it, and one that binds binds the plan too). The floor is the speed
    of the step timer's slowest rate (``start_rate_hz``): a dip below it cannot show, the
    steps run at it anyway (GRBL's planner stops at 0, its stepper at 30.5 Hz). This is the event a
    GRBL-family machine (the virtual machine's ``short_queues``) is compared on; a
    starvation (:attr:`LinkPrediction.stalls`) is the worse case of it.

    Parameters
    ----------
    prediction : LinkPrediction
        From :func:`predict_stalls`.

    Returns
    -------
    list of Starvation
        One per short block: ``time_s`` its start, ``line`` the source line of the first
        block not yet parsed then, ``duration_s`` how long after the start that line was
        parsed (s). A block whose queue holds the rest of the job is never short, nor is the
        job's first or the first after a sync (nothing could be behind it, at any feed). A
        block after a starvation is counted: GRBL, which slows down instead, would have had
        it queued behind a slow block.

    Examples
    --------
    The docstring case of :func:`predict_stalls`, on GRBL (no look-ahead wait): each 0.1 mm
    cut takes about 27 ms and each 6-byte line 50 ms on the wire. At 6000 baud (10 ms a
    line) the first cut (19 ms) runs while the second arrives; the second (9 ms at cruise)
    starts 0.9 ms before the third has come, with nothing behind it: short, not a starvation.

    >>> from labkit.motion.spec import CBR40
    >>> m = CBR40.replace(link_baud=6000, waits_for_lookahead=False, block_parse_s=0.0)
    >>> job = "G1X.1F1200\\nG1X.2\\nG1X.3\\n"
    >>> p = predict_stalls(job, m)
    >>> [(s.line, round(s.duration_s, 4)) for s in short_queues(p)], p.stalls
    ([(3, 0.0009)], [])
    """
    p = prediction
    nb = len(p.block_line)
    if nb < 2 or p.block_exit_mm_s is None:
        return []
    # when each block's line was parsed (the blocks of a line enter the planner together)
    parsed = p.parsed_s[np.searchsorted(p.line, p.block_line)]
    j = np.arange(nb - 1)
    # blocks queued behind block j at its start (parse times rise with the block index)
    q = np.searchsorted(parsed, p.block_start_s[:-1], side="right") - j - 1
    q = np.clip(q, 0, p.machine.planner_blocks - 1)
    last = j + q
    brake = np.concatenate([[0.0], np.cumsum(p.block_brake_mm2_s2)])
    keep = np.sqrt(p.block_floor_mm_s[last] ** 2 + brake[last + 1] - brake[j + 1])
    short = (p.block_exit_mm_s[:-1] > keep * (1 + 1e-9)) & (j > 0) & (last + 1 < nb)
    # the first block after a sync enters a planner the program emptied, as a job's first
    restart = np.searchsorted(p.block_line, p.sync_lines, side="left")
    short[restart[restart < nb - 1]] = False
    short &= q < p.machine.planner_blocks - 1           # a full planner: its depth, not the link
    hit = np.flatnonzero(short)
    waited = last[hit] + 1
    return [Starvation(float(p.block_start_s[k]), int(p.block_line[w]), float(parsed[w] - p.block_start_s[k]))
            for k, w in zip(hit.tolist(), waited.tolist())]


def block_time_bounds(moves, machine=None):
    """The blocks straight moves make, and a lower bound of each one's motion time.

    A move makes a block when it moves by a step (as :func:`labkit.motion.build_blocks`
    drops the others); the block runs its step-rounded length no faster than its feed
    (rapids: no faster than all axes at their top rates at once).

    Parameters
    ----------
    moves : Moves
        Rapids and lines only.
    machine : MachineSpec, str or None

    Returns
    -------
    (ndarray of int, ndarray of float) or None
        The rows of ``moves`` that make a block and their times' lower bounds, s; None
        when ``moves`` has an arc or a dwell (their blocks are not one a row).

    Examples
    --------
    >>> from labkit.toolpath.moves import Moves
    >>> from labkit.motion.spec import CBR40
    >>> m = Moves.from_cuts([(1, 0)], [(7, 0)], feed_mm_min=600, s_word=500)  # a rapid, a cut
    >>> rows, t = block_time_bounds(m, CBR40)
    >>> rows.tolist(), float(t[1].round(3))                # 6 mm at 600 mm/min: 0.6 s
    ([0, 1], 0.6)
    """
    from labkit.motion.blocks import to_steps
    from labkit.motion.spec import load_machine
    from labkit.toolpath.moves import MoveKind

    m = load_machine(machine)
    kind = np.asarray(moves.kind)
    if np.any((kind != MoveKind.RAPID) & (kind != MoveKind.LINE)):
        return None
    spm = np.asarray(m.steps_per_mm, dtype=float)
    top = float(np.linalg.norm(np.asarray(m.max_rate_mm_min, dtype=float)))
    rows_out = np.empty(len(kind), dtype=np.int64)        # filled in order, then cut to length
    times_out = np.empty(len(kind))
    made = 0
    start, end = moves.start, moves.end
    before = None                                          # steps of the end of the row before a
    for a in range(0, len(kind), _BOUND_BLOCK_ROWS):      # a block of rows at a time: bounded memory
        b = min(a + _BOUND_BLOCK_ROWS, len(kind))
        end_steps = to_steps(end[a:b], spm)
        # a program's rows mostly start where the row before ended: their steps are known
        if b - a > 1 and np.array_equal(start[a + 1:b], end[a:b - 1]) and before is not None \
                and np.array_equal(start[a], end[a - 1]):
            start_steps = np.concatenate([before[None], end_steps[:-1]])
        else:
            start_steps = to_steps(start[a:b], spm)
        before = end_steps[-1]
        delta = end_steps - start_steps
        del end_steps, start_steps
        moved = delta[:, 0] != 0
        moved |= delta[:, 1] != 0
        moved |= delta[:, 2] != 0
        rows = np.flatnonzero(moved)
        every = len(rows) == b - a                          # (most programs: no row left out)
        d = (delta if every else delta[rows]) / spm
        # np.linalg.norm(d, axis=1), term for term: the squares added in axis order
        length = np.sqrt(d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] + d[:, 2] * d[:, 2])
        del d, delta
        feed = np.asarray(moves.feed_mm_min[a:b], dtype=float)
        line = kind[a:b] == MoveKind.LINE
        if not every:
            feed, line = feed[rows], line[rows]
        fast = np.where(line & (feed > 0), np.minimum(feed, top), top)
        np.add(rows, a, out=rows_out[made:made + len(rows)])
        np.divide(length, fast / 60.0, out=times_out[made:made + len(rows)])
        made += len(rows)
    return rows_out[:made], times_out[:made]


#: Moves bounded at a time by :func:`block_time_bounds` (its memory, not its result).
_BOUND_BLOCK_ROWS = 1 << 16


def may_starve(line_bytes, block_line, block_min_s, machine=None) -> bool:
    """Whether a job *can* starve on the link: a necessary condition for a stall, O(n) numpy.

    False proves :func:`predict_stalls` finds no starvation; True says only that it may.
    A stop before block j needs block j ready (its line parsed; on a controller that waits
    for its look-ahead, the line of block j + ``buffer_blocks``) after block j - 1 has
    ended; at the job's end, where the last blocks wait for the quiet-input flush, it is a
    starvation only while lines still arrive: the last line after block j - 1 has ended. From the job's start, or from the last
    moment a line had to wait for a planner slot (the planner then held ``planner_blocks``
    - 1 blocks not yet run, those just before it), the lines after arrive no later than the
    sum over them of the slower of wire and parse (two parses more: the first line crosses
    the wire before its parse; a character-counting sender that may put two lines in flight
    waits for an answer only while the parser has work), while the blocks run no faster
    than their lower bounds and the first starts no sooner than its window (or a quiet
    input) lets it.
    The condition is that sum exceeding the motion it must keep ahead of, for some block.

    Parameters
    ----------
    line_bytes : array of int
        Bytes each source line puts on the link (0: not sent), as :func:`sent_line_bytes`.
    block_line : array of int
        Source line (1-based) of each planner block, in order.
    block_min_s : array of float
        A lower bound of each block's motion time, s (its length over the fastest it may
        run, less a step's rounding).
    machine : MachineSpec, str or None
        The machine and its link.

    Returns
    -------
    bool

    Examples
    --------
    Sixty 0.1 mm cuts at 600 mm/min (10 ms each) in 7-byte lines: 7.3 ms a line at 9600
    baud keeps ahead of them; at 4800 baud (14.6 ms a line) the link may fall behind.

    >>> from labkit.motion.spec import CBR40
    >>> cuts = (np.full(60, 7), np.arange(1, 61), np.full(60, 0.010))
    >>> may_starve(*cuts, CBR40.replace(link_baud=9600)), may_starve(*cuts, CBR40.replace(link_baud=4800))
    (False, True)
    """
    from labkit.motion.spec import load_machine

    m = load_machine(machine)
    nbytes = np.asarray(line_bytes, dtype=np.int64)
    block_line = np.asarray(block_line, dtype=np.int64)
    nb = len(block_line)
    if nb < 2 or not np.any(nbytes > 0):
        return False
    tau = m.link_bits_per_byte / m.link_baud
    p = float(m.block_parse_s)
    # upper bound of each line's parse, from a reset, less 2 p: the wire and the parser work
    # side by side, a line costing the slower of the two, as long as the sender may put two
    # lines in flight (it then waits for an answer only while the parser has a line to
    # parse); else the wire, then the parse
    side_by_side = _pairs_fit(nbytes, m.rx_buffer_bytes - 1)
    # Two arrays as long as the program (millions of rows for a photo): the lines' cumulated
    # link times and the blocks' cumulated motion; the rest is made a chunk of
    # _STARVE_CHUNK rows at a time, and the check stops at the first block that may starve.
    link = nbytes * tau                                                  # wire time of each line
    if side_by_side:
        np.maximum(link, p, out=link)
    else:
        link += p
    link[nbytes <= 0] = 0.0
    np.cumsum(link, out=link)
    motion = np.empty(nb + 1)                                            # blocks 0…k-1
    motion[0] = 0.0
    np.cumsum(np.asarray(block_min_s, dtype=float), out=motion[1:])
    W = m.buffer_blocks if m.waits_for_lookahead else 0
    Q = m.planner_blocks - 1
    # from the start: block 0 runs once its window has arrived (no sooner than the wire
    # brings it), or after a quiet input of FLUSH_QUIET_S, possible only where the next
    # line may arrive that much after the one before (only the lines up to block W's count)
    k0 = block_line[0] - 1
    kw = block_line[min(W, nb - 1)] - 1
    head = nbytes[:kw + 1]
    arrived_lb = tau * np.cumsum(head).astype(float)
    parsed_lb = np.maximum(arrived_lb + p, np.cumsum(head > 0) * p)     # one parser, in order
    start0 = parsed_lb[kw]
    if W:
        gap = link[k0 + 1:kw + 1] + 2 * p - arrived_lb[k0:kw] >= FLUSH_QUIET_S
        if np.any(gap):
            start0 = max(parsed_lb[k0], min(start0, float(arrived_lb[k0:kw][gap][0]) + FLUSH_QUIET_S))
    del head, arrived_lb, parsed_lb
    # the last blocks wait for the flush after the last line, but a wait is a starvation
    # only while a line still arrives: the last one after block j - 1 has ended
    last = max(nb - 1 - W, 0) if W else nb
    best = _BestSoFar(block_line, motion, link, Q)
    for i0 in range(0, nb - 1, _STARVE_CHUNK):                           # block j = i + 1
        i1 = min(i0 + _STARVE_CHUNK, nb - 1)
        # the line each block j >= 1 waits for (its window's last), 0-based
        wait_line = block_line[np.minimum(np.arange(i0 + 1 + W, i1 + 1 + W), nb - 1)] - 1
        ready = link[wait_line] + 2 * p
        if i1 > last:
            tail = max(last - i0, 0)
            ready[tail:] = link[-1] + 2 * p
            wait_line[tail:] = len(nbytes) - 1
        ahead = best.at(wait_line)
        np.maximum(ahead, -start0, out=ahead)
        ready -= motion[i0 + 1:i1 + 1]
        ready += ahead
        if np.any(ready > 0):
            return True
    return False


#: Rows of a program :func:`may_starve` works on at a time (bounds its memory, not its result).
_STARVE_CHUNK = 1 << 16


def _pairs_fit(nbytes: np.ndarray, room: int) -> bool:
    """Whether every two lines sent one after the other (lines of 0 bytes are not sent) hold
    fewer than ``room`` bytes together, or fewer than two lines are sent."""
    before = 0
    sent_any = 0
    for a in range(0, len(nbytes), _STARVE_CHUNK):
        sent = nbytes[a:a + _STARVE_CHUNK]
        sent = sent[sent > 0]
        if not len(sent):
            continue
        if sent_any and int(sent[0]) + before >= room:
            return False
        if len(sent) > 1 and int((sent[1:] + sent[:-1]).max()) >= room:
            return False
        sent_any += len(sent)
        before = int(sent[-1])
    return True


class _BestSoFar:
    """For :func:`may_starve`: at line r, the most the lines after a reset may run ahead,
    max over lines r' <= r of motion[first_block(r') - Q] - link[r'] (-inf where fewer than
    Q blocks come before line r': it never waits for a slot), read at non-decreasing lines
    and worked out only as far as asked, a chunk of lines at a time."""

    def __init__(self, block_line, motion, link, Q):
        self.block_line, self.motion, self.link, self.Q = block_line, motion, link, Q
        self.done = 0                    # lines folded into self.carry
        self.carry = -np.inf

    def at(self, lines: np.ndarray) -> np.ndarray:
        """The values at ``lines`` (0-based, non-decreasing, none before the last line asked)."""
        out = np.full(len(lines), self.carry)
        top = int(lines[-1]) + 1 if len(lines) else 0
        while self.done < top:
            l0 = self.done
            l1 = min(top, l0 + _STARVE_CHUNK)
            # blocks before line r + 1 (1-based): those of the lines before l0, then a count
            b0 = int(np.searchsorted(self.block_line, l0 + 1, side="left"))
            b1 = int(np.searchsorted(self.block_line, l1 + 1, side="left"))
            per_line = np.bincount(self.block_line[b0:b1] - (l0 + 1), minlength=l1 - l0)
            first_block = np.empty(l1 - l0, dtype=np.int64)
            first_block[0] = b0
            np.cumsum(per_line[:-1], out=first_block[1:])
            first_block[1:] += b0
            seg = self.motion[np.maximum(first_block - self.Q, 0)]
            seg -= self.link[l0:l1]
            seg[first_block < self.Q] = -np.inf
            np.maximum.accumulate(seg, out=seg)
            np.maximum(seg, self.carry, out=seg)
            inside = (lines >= l0) & (lines < l1)
            out[inside] = seg[lines[inside] - l0]
            self.carry = float(seg[-1])
            self.done = l1
        return out


def _plainly_modal(text: str, scaled_words: int) -> bool:
    """Whether every F the reader sees in ``text`` is one of the ``scaled_words`` F words
    :func:`with_feed` scales (none after a comment, none with a space before its number),
    with no jog ($J) and no inverse time (G93): each move then runs at the last of them."""
    cut = _whole_text_code(text)
    if cut is None:
        return False
    code = cut[1]
    return (code.count("F") + code.count("f") == scaled_words
            and "$J" not in code.upper()
            and ("93" not in code or re.search(r"G0*93", code, re.IGNORECASE) is None))


class _FeedScaled:
    """A program at other feeds, as :func:`with_feed` writes it, without rewriting its text.

    Scaling the F words changes nothing but each move's feed and each line's bytes. The
    program is parsed once more with its scaled F words tagged (word j as j + 2): a move
    whose feed is the last scaled word before it times a reader's factor (G20's 25.4, an F
    in mm/s), both in the program and tagged, runs at that word times that factor. When a
    move is not so (G93's length, a jog, an F word with_feed leaves alone), a second tagged
    parse (every word 1) gives each move's factor itself. A move then runs at the new
    number times its factor, as the reader computes it; a line's bytes change by the new
    numbers' lengths; the plan at a feed is the same moves with the new feeds. Where this
    cannot hold (a scaled number written with an exponent), :meth:`at` returns None and
    the caller rewrites the text.
    """

    def __init__(self, text: str, machine, dialect: str, moves=None, plan=None):
        from labkit.gcode import parse

        self.text, self.machine, self.dialect = text, machine, dialect
        lines = text.splitlines(True)
        where, numbers = _f_words(lines)
        self.numbers = numbers
        self.values = np.array([float(v) for v in numbers])
        self.old_len = np.array([len(v) for v in numbers], dtype=np.int64)
        self.word_line = np.array([w[0] for w in where], dtype=np.int64)
        self.bytes = sent_line_bytes(text)
        self.sync = controller_sync_lines(text, machine, dialect)
        self.programmed = max(program_feeds(text))
        self.moves = parse(text, dialect=dialect) if moves is None else moves
        self.base_plan = plan       # the plan of the text as it is, when given
        self.plan = plan            # the last plan made (its blocks' geometry is the program's)
        feed0 = self.moves.feed_mm_min
        n = len(feed0)
        word = np.searchsorted(self.word_line, np.asarray(self.moves.line) - 1, side="right") - 1
        w = np.maximum(word, 0)
        self.ok = True
        if _plainly_modal(text, len(where)):
            # every F the reader sees is a scaled word and stays in effect until the next:
            # a move runs at the last one before it, or has no feed (none yet, or F0)
            tag = None
            feed_tag = np.where(word >= 0, w + 2.0, np.nan)
            still = np.isnan(feed0) & ((word < 0) | (self.values[w] == 0))
        else:
            tag = parse(_with_numbers(lines, where, [str(j + 2) for j in range(len(where))]),
                        dialect=dialect)
            self.ok = self._same_lines(tag)
            if not self.ok:
                return
            feed_tag = tag.feed_mm_min
            still = (feed0 == feed_tag) | (np.isnan(feed0) & np.isnan(feed_tag))
        scale, per_s = np.ones(n), np.ones(n)
        found = np.zeros(n, bool)
        for sc, ps in ((1.0, 1.0), (25.4, 1.0), (1.0, 60.0), (25.4, 60.0)):   # as the reader multiplies
            hit = ~found & (word >= 0) & (self.values[w] * sc * ps == feed0) & ((w + 2.0) * sc * ps == feed_tag)
            scale[hit], per_s[hit], found[hit] = sc, ps, True
        if tag is None and not np.all(found ^ still):
            self.ok = False                     # not as the text says: rewrite the text instead
            return
        if np.all(found ^ still):
            self.word = np.where(found, word, -1)
        else:                                   # G93, jogs, words left alone: each move's factor
            one = parse(_with_numbers(lines, where, ["1"] * len(where)), dialect=dialect)
            self.ok = self._same_lines(one)
            if not self.ok:
                return
            scale, per_s = one.feed_mm_min, np.ones(n)
            with np.errstate(invalid="ignore", divide="ignore"):
                ratio = feed_tag / scale
            tag = np.where(np.isfinite(ratio), np.rint(ratio), 1.0)
            self.ok = bool(np.all(np.abs(np.where(np.isfinite(ratio), ratio, 1.0) - tag) < 1e-6))
            self.word = (tag - 2).astype(np.int64)      # -1: no scaled F word sets its feed
        self.scale, self.per_s = scale, per_s

    def _same_lines(self, other) -> bool:
        return len(other) == len(self.moves) and np.array_equal(other.line, self.moves.line)

    def at(self, feed_mm_min: float):
        """(bytes per source line, moves, the numbers written) of the program at
        ``feed_mm_min``, or None."""
        from labkit.toolpath.moves import Moves

        if not self.ok:
            return None
        numbers = _scaled_numbers(self.values, feed_mm_min / self.programmed)
        if any(("e" in x or "n" in x) for x in set(numbers)):   # an exponent, inf, nan
            return None
        value = np.array([float(x) for x in numbers])
        length = np.array([len(x) for x in numbers], dtype=np.int64)
        nbytes = self.bytes + np.bincount(self.word_line, weights=length - self.old_len,
                                          minlength=len(self.bytes)).astype(np.int64)
        feed = self.moves.feed_mm_min.copy()
        scaled = self.word >= 0
        f = value[self.word[scaled]] * self.scale[scaled] * self.per_s[scaled]
        feed[scaled] = np.where(f > 0, f, np.nan)
        cols = self.moves.columns()
        cols["feed_mm_min"] = feed
        return nbytes, Moves(source=self.moves.source, s_max=self.moves.s_max, **cols), numbers

    def stalls_at(self, feed_mm_min: float, events=None) -> list:
        """The starvations at ``feed_mm_min`` (:func:`predict_stalls` of :func:`with_feed`'s text),
        or ``events(prediction)``."""
        from labkit.motion.pipeline import plan

        pick = events or (lambda p: p.stalls)
        got = self.at(feed_mm_min)
        if got is None:
            return pick(predict_stalls(with_feed(self.text, feed_mm_min), self.machine,
                                       dialect=self.dialect))
        nbytes, moves, numbers = got
        if self.base_plan is not None and numbers == self.numbers:      # the text as it is
            self.plan = self.base_plan
        else:
            self.plan = plan(moves, self.machine, planner="junction", sync_lines=self.sync)
        return pick(predict_stalls(self.text, self.machine, line_bytes=nbytes, plan=self.plan))


@dataclass(frozen=True)
class StallFreeFeed:
    """The highest feed at which a job streams without a starvation.

    Attributes
    ----------
    feed_mm_min : float
        The highest F (the program's feeds scaled together) without a starvation, mm/min.
    limited_by : str
        ``"link"``; ``"machine"`` when even the machine's top speed does not starve;
        ``"travel"`` (``feed_mm_min`` 0) when the job starves at any feed, because moves
        whose speed F does not set (rapids) outrun the link.
    programmed_mm_min : float
        The program's highest F, mm/min.
    stalls : list of Starvation
        The starvations at the programmed feed.
    rows : list of dict
        For a raster job (most blocks along X), per image row (consecutive blocks ending at
        one Y): ``y_mm``, ``first_line``, ``last_line``, ``bytes`` sent, ``stalls`` at the
        programmed feed, and ``feed_mm_min``: the highest feed, on a grid 3 % apart from the
        job's stall-free feed up to the machine's top speed, up to which the row never starves
        (the rows before it streamed as well). Empty for other jobs.
    """

    feed_mm_min: float
    limited_by: str
    programmed_mm_min: float
    stalls: list
    rows: list

    def as_dict(self) -> dict:
        """Plain values for JSON: ``stall_free_feed_mm_min``, ``limited_by``, ``stalls``, ``rows``."""
        return {"stall_free_feed_mm_min": self.feed_mm_min, "limited_by": self.limited_by,
                "programmed_feed_mm_min": self.programmed_mm_min,
                "stalls": [{"time_s": s.time_s, "line": s.line, "duration_s": s.duration_s}
                           for s in self.stalls],
                "rows": self.rows}


#: Step of the per-row feed grid (3 %).
_ROW_STEP = 1.03


def stall_free_feed(text: str, machine=None, *, line_bytes=None, dialect: str = "grbl",
                    rel_tol: float = 0.002, rows: bool = True, moves=None, plan=None,
                    criterion: str = "stall") -> StallFreeFeed:
    """The highest feed at which the link never leaves the machine without a block.

    The program's feeds are scaled together (:func:`with_feed`) and the highest
    F without a starvation (:func:`predict_stalls`) is found by bisection, up to
    the machine's top speed (the slower of X and Y). The text is not rewritten for
    each feed: the parsed moves get the feeds and the lines the byte counts that
    :func:`with_feed`'s text would give, and only the plan's speeds are made again
    (the same predictions, to the bit; a ``line_bytes`` sender still rewrites the text).

    Parameters
    ----------
    text : str
        The program.
    machine : MachineSpec, str or None
        The machine and its link.
    line_bytes : callable, optional
        ``text -> bytes per source line`` for a sender other than ``labkit stream``.
    dialect : str
        How the program is read.
    rel_tol : float
        Relative width of the final bracket.
    rows : bool
        Find each image row's stall-free feed too (a raster job; a few more predictions).
    moves, plan : Moves and Plan, optional
        The program as read in ``dialect`` and its plan as :func:`predict_stalls` makes it
        (GRBL's junction planner on ``machine``), when already made.
    criterion : {"stall", "short_queue"}
        What the feed must avoid: a starvation (the motors stop), or on a GRBL-family machine
        a block started with nothing queued behind it (:func:`short_queues`: GRBL slows down
        there). The result's ``stalls`` are these events.

    Returns
    -------
    StallFreeFeed

    Raises
    ------
    MotionError
        The program has no F word.
    """
    from labkit.motion.spec import load_machine

    m = load_machine(machine)
    feeds = program_feeds(text)
    if not feeds or max(feeds) <= 0:
        raise MotionError("the program has no F word > 0: there is no feed to find")
    events = {"stall": lambda p: p.stalls, "short_queue": short_queues}.get(criterion)
    if events is None:
        raise MotionError(f"criterion: expected 'stall' or 'short_queue', got {criterion!r}")
    programmed = max(feeds)
    top = float(min(m.max_rate_mm_min[:2]))

    scaled = None
    if line_bytes is None:
        scaled = _FeedScaled(text, m, dialect, moves, plan)

        def stalls_at(feed):
            return scaled.stalls_at(feed, events)
    else:
        def stalls_at(feed):
            t = with_feed(text, feed)
            return events(predict_stalls(t, m, dialect=dialect, line_bytes=line_bytes(t)))

    at_programmed = stalls_at(programmed)
    if not stalls_at(top):
        best, limited = top, "machine"
    elif stalls_at(top * 1e-3):
        # starving at a thousandth of the top speed: moves F does not set (rapids) outrun the link
        best, limited = 0.0, "travel"
    else:
        lo, hi = top * 1e-3, top
        if not at_programmed and programmed < top:
            lo = programmed
        elif at_programmed:
            hi = programmed
        while hi - lo > rel_tol * hi:
            mid = 0.5 * (lo + hi)
            if stalls_at(mid):
                hi = mid
            else:
                lo = mid
        best, limited = lo, "link"
    if rows:
        geometry = scaled.plan if scaled is not None and scaled.plan is not None else _plan_text(text, m, dialect)
        row_list = _row_feeds(text, m, geometry, line_bytes, best, top, stalls_at, at_programmed)
    else:
        row_list = []
    return StallFreeFeed(feed_mm_min=best, limited_by=limited, programmed_mm_min=programmed,
                         stalls=at_programmed, rows=row_list)


def _rows(p, m):
    """Image rows of a raster job planned as ``p``: (y_mm, first line, last line), or [] for
    another job."""
    b = p.blocks[p.motion]
    if not len(b):
        return []
    start = np.asarray(b.start_steps, dtype=float)
    end = np.asarray(b.end_steps, dtype=float)
    along_x = (start[:, 1] == end[:, 1]) & (start[:, 0] != end[:, 0])
    if along_x.mean() < 0.9:
        return []
    y = end[:, 1] / m.steps_per_mm[1]
    cuts = np.flatnonzero(np.diff(end[:, 1]) != 0) + 1
    lines = np.asarray(b.line)
    return [(float(y[g[0]]), int(lines[g[0]]), int(lines[g[-1]]))
            for g in np.split(np.arange(len(b)), cuts)]


def _row_feeds(text, m, p, line_bytes, best, top, stalls_at, at_programmed) -> list[dict]:
    rows = _rows(p, m)
    if not rows:
        return []
    nbytes = sent_line_bytes(text) if line_bytes is None else np.asarray(line_bytes(text))
    firsts = np.array([r[1] for r in rows])

    def row_of(stalls):
        lines = np.array([s.line for s in stalls], dtype=np.int64)
        return set((np.searchsorted(firsts, lines, side="right") - 1).tolist())

    feed = np.full(len(rows), top)
    open_rows = set(range(len(rows)))
    prev = best
    f = best * _ROW_STEP
    while open_rows and 0 < prev < top:
        f = min(f, top)
        for r in row_of(stalls_at(f)) & open_rows:
            feed[r] = prev
            open_rows.discard(r)
        prev, f = f, f * _ROW_STEP
    stall_lines = np.sort(np.array([s.line for s in at_programmed], dtype=np.int64))
    first = np.array([a for _, a, _ in rows])
    last = np.array([z for _, _, z in rows])
    stalls = np.searchsorted(stall_lines, last, side="right") - np.searchsorted(stall_lines, first, side="left")
    upto = np.concatenate([[0], np.cumsum(nbytes)])
    row_bytes = upto[last] - upto[first - 1]
    return [{"y_mm": y, "first_line": a, "last_line": z, "bytes": int(row_bytes[i]),
             "stalls": int(stalls[i]), "feed_mm_min": float(feed[i])}
            for i, (y, a, z) in enumerate(rows)]
