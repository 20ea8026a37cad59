"""The G-code splitter of [MicroCAM] §6.2.1: a long program as sub-programs a controller accepts.

[MicroCAM]'s control environment uploaded a program larger than the controller's
program buffer as sub-programs, each uploaded "after completing the previous one".
For that to machine the same part, every sub-program has to run as if the whole
program had run up to its first line. :func:`split_program` therefore

1. parses the program once (strictly: a bad line is a :class:`~labkit.errors.GcodeError`
   with file, line and column), and takes the modal state after every line from
   :func:`labkit.gcode.modal_trace` (motion mode, plane, units, distance mode, arc
   centre mode, feed, S, laser) plus a few words the trace does not carry (feed
   mode G93/G94, coordinate system G54–G59, coolant), read from the words of each line;
2. cuts between whole lines, as late as the size limit allows, at a *safe point*:
   a line boundary where the beam is not cutting across the cut (the move before or
   the move after is not burning) — a part ends with the head stopped while the next
   part uploads, and a stop in the middle of a cut would mark the work. Only if a
   single cut is longer than a part is it split inside (counted in
   :attr:`SplitResult.inside_cuts`);
3. starts each part after the first with a *preamble* that restates the state from a
   fresh controller: offsets cleared, beam off (M5), a rapid to the position the
   previous part ended at, the motion mode (a zero-length G1 when it is G1), plane,
   feed mode, arc-centre mode, feed, coordinate system, work offset (G92),
   coolant, S and M3/M4/M5, units and distance mode — and ends each part but the
   last with M5, so the beam is off while the next part uploads.

A boundary is refused where the state cannot be restated: inside modal G2/G3 when
the next line with axis words relies on it (an arc mode cannot be set without an
arc), or next to a line that changes the work offsets (G10, G92, G43.1, G28/G30, M2…)
with no motion between to read the offset from.

The result is checked by :func:`verify_parts`: each part parsed alone, with its
preamble's and trailer's moves removed, gives exactly the original's moves for its
lines (every column; positions to 1e-9 mm, since restated coordinates are the
shortest decimal of a double), and the original's records (pauses, coolant, ``$``
lines). :func:`split_program` runs it before returning.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import numpy as np

from labkit.errors import InputError
from labkit.toolpath.moves import Moves

__all__ = ["Part", "SplitResult", "split_program", "verify_parts", "restated_state"]

#: Position tolerance of the verification, mm (restated coordinates round-trip a double).
POSITION_ATOL_MM = 1e-9

_COMMENT = re.compile(r"\([^)]*\)|;.*$")
_WORD = re.compile(r"([A-Za-z])\s*([-+]?(?:\d+\.?\d*|\.\d+))")
_OFFSET_G = {10.0, 28.0, 30.0, 43.1, 49.0, 92.0, 92.1}
_OFFSET_M = {2.0, 30.0}
_MOTION_G = {0.0, 1.0, 2.0, 3.0, 38.2, 38.3, 38.4, 38.5, 80.0}


@dataclass(frozen=True)
class Part:
    """One sub-program.

    Attributes
    ----------
    text : str
        The sub-program, lines ending in ``\\n``.
    first_line, last_line : int
        1-based lines of the original it carries (inclusive).
    preamble_lines, trailer_lines : int
        Lines added before (state restated) and after (M5) the original lines.
    safe : bool
        The part ends at a safe point (the beam is not cutting across it); the last
        part is always safe.
    """

    text: str
    first_line: int
    last_line: int
    preamble_lines: int
    trailer_lines: int
    safe: bool = True

    @property
    def n_lines(self) -> int:
        """Lines of the sub-program, added ones included."""
        return self.text.count("\n")

    @property
    def n_bytes(self) -> int:
        """Size of the sub-program in bytes (UTF-8, newlines included)."""
        return len(self.text.encode("utf-8"))


@dataclass
class SplitResult:
    """The parts and what the split cost.

    Attributes
    ----------
    parts : list of Part
    inside_cuts : int
        Boundaries that had to fall inside a cut (no safe point within the limit).
    added_lines : int
        Preamble and trailer lines over all parts.
    source_lines : int
        Lines of the original program.
    """

    parts: list[Part] = field(default_factory=list)
    inside_cuts: int = 0
    added_lines: int = 0
    source_lines: int = 0


def _num(value: float) -> str:
    """Shortest decimal that reads back as the same double, never in exponent form."""
    if value == 0:
        return "0"
    return np.format_float_positional(float(value), unique=True, trim="-")


def _line_words(lines: list[str]):
    """Per line: (G numbers, M numbers, has axis words), comments removed."""
    out = []
    for text in lines:
        if text.lstrip().startswith("$"):
            out.append(((), (), False))
            continue
        words = _WORD.findall(_COMMENT.sub("", text))
        gs = tuple(round(float(v), 1) for k, v in words if k in "Gg")
        ms = tuple(round(float(v), 1) for k, v in words if k in "Mm")
        axes = any(k in "XYZxyz" for k, _ in words)
        out.append((gs, ms, axes))
    return out


def restated_state(state: dict, dialect) -> list[str]:
    """The preamble lines that bring a fresh controller to ``state``.

    Parameters
    ----------
    state : dict
        ``motion`` (0, 1, 2, 3, 80), ``plane`` (17–19), ``inches`` (bool),
        ``absolute`` (bool), ``arc_absolute`` (bool), ``feed_mm_min`` (NaN if unset),
        ``s`` (S word), ``laser`` (0, 3, 4), ``position`` (machine X Y Z, mm),
        ``offset`` (work offset: machine − work, mm), ``coord`` (54–59),
        ``inverse_time`` (bool), ``coolant`` (M numbers on, e.g. ``(8,)``).
    dialect : Dialect

    Returns
    -------
    list of str
        G-code lines (no newlines).

    Examples
    --------
    >>> from labkit.gcode import get_dialect
    >>> st = dict(motion=1, plane=17, inches=False, absolute=True, arc_absolute=False,
    ...           feed_mm_min=600.0, s=800.0, laser=3, position=(10.0, 2.5, 0.0),
    ...           offset=(0.0, 0.0, 0.0), coord=54, inverse_time=False, coolant=())
    >>> restated_state(st, get_dialect("grbl"))
    ['G92.1 G49 G54', 'G21 G90 M5', 'G0 X10 Y2.5 Z0', 'F600', 'G1 X10 Y2.5 Z0', 'G17', 'S800 M3']
    """
    g_ok = set(round(g, 1) for g in dialect.g_codes)
    out = []
    reset = [w for w, g in (("G92.1", 92.1), ("G49", 49.0), ("G54", 54.0)) if g in g_ok]
    if reset:
        out.append(" ".join(reset))
    out.append("G21 G90 " + f"M{dialect.laser_off_codes[0]}")
    p = [float(v) for v in state["position"]]
    xyz = f"X{_num(p[0])} Y{_num(p[1])} Z{_num(p[2])}"
    out.append(f"G0 {xyz}")
    feed = state["feed_mm_min"]
    if feed == feed:                                           # not NaN
        out.append(f"F{_num(dialect.feed_from_mm_min(feed))}")
    motion = int(state["motion"])
    if motion == 1:
        out.append(f"G1 {xyz}")                                # zero length, beam off: sets G1
    elif motion == 80:
        out.append("G80")
    out.append(f"G{int(state['plane'])}")
    if state["inverse_time"]:
        out.append("G93")
    if state["arc_absolute"]:
        out.append("G90.1")
    coord = int(state["coord"])
    if coord != 54:
        out.append(f"G{coord}")
    w = [float(v) for v in state["offset"]]
    if any(w):
        if 92.0 not in g_ok:
            raise InputError(f"a work offset ({', '.join(_num(v) for v in w)}) mm is in effect and "
                             f"the {dialect.name} dialect has no G92 to restate it")
        out.append("G92 " + " ".join(f"{a}{_num(pa - wa)}" for a, pa, wa in zip("XYZ", p, w)))
    for m in state["coolant"]:
        out.append(f"M{int(m)}")
    laser = int(state["laser"])
    word = f"M{laser}" if laser else f"M{dialect.laser_off_codes[0]}"
    out.append(f"S{_num(state['s'])} {word}")
    if state["inches"]:
        out.append("G20")
    if not state["absolute"]:
        out.append("G91")
    return out


def _states(text, dialect, filename):
    """Moves, line texts and the state after every line (arrays), parsed strictly."""
    from labkit.gcode import modal_trace, parse

    moves = parse(text, dialect=dialect, filename=filename)
    trace = modal_trace(text, dialect=dialect, filename=filename)
    lines = trace["text"].tolist()
    words = _line_words(lines)
    n = len(lines)
    coolant_codes = set(float(c) for c in dialect.coolant_codes)
    inverse = np.zeros(n, bool)
    coord = np.full(n, 54, np.int16)
    coolant = []
    inv, cs, cool = False, 54, ()
    for i, (gs, ms, _) in enumerate(words):
        for g in gs:
            if g in (93.0, 94.0):
                inv = g == 93.0
            elif 54.0 <= g <= 59.0:
                cs = int(g)
        for m in ms:
            if m in coolant_codes:
                cool = () if m == 9.0 else tuple(sorted(set(cool) | {int(m)}))
            elif m in _OFFSET_M:             # program end: GRBL resets these
                inv, cs, cool = False, 54, ()
        inverse[i], coord[i] = inv, cs
        coolant.append(cool)
    return moves, trace, lines, words, inverse, coord, coolant


def split_program(text, *, max_lines: int | None = None, max_bytes: int | None = None,
                  dialect="grbl", filename: str | None = None, verify: bool = True) -> SplitResult:
    """Split a G-code program into sub-programs of at most ``max_lines`` lines / ``max_bytes`` bytes.

    Parameters
    ----------
    text : str
        The program.
    max_lines : int, optional
        Largest number of lines per part (added lines included), ≥ 2 + the preamble.
    max_bytes : int, optional
        Largest size of a part in bytes (newlines included). At least one of the
        two limits is required; with both, both hold.
    dialect : str or Dialect
        G-code dialect (``"grbl"`` default, ``"labkit-fw"``, ``"marlin"``).
    filename : str, optional
        Name for messages.
    verify : bool
        Run :func:`verify_parts` before returning (default True).

    Returns
    -------
    SplitResult

    Raises
    ------
    GcodeError
        A line of the program is rejected by the parser.
    InputError
        A limit is too small for a part (the message names the lines that do not
        fit and the smallest workable limit), or a state cannot be restated.

    Examples
    --------
    >>> prog = "G21 G90\\nM3 S800\\nG1 X1 F600\\nX2\\nX3\\nM5\\nG0 X0\\nM3\\nG1 Y1\\nY2\\n"
    >>> res = split_program(prog, max_lines=10)
    >>> [(p.first_line, p.last_line, p.n_lines, p.safe) for p in res.parts]
    [(1, 8, 10, True), (9, 10, 9, True)]
    >>> print(res.parts[1].text, end="")
    (labkit split: part 2 of 2, lines 9-10)
    G92.1 G49 G54
    G21 G90 M5
    G0 X0 Y0 Z0
    F600
    G17
    S800 M3
    G1 Y1
    Y2
    """
    from labkit.gcode import get_dialect

    d = get_dialect(dialect)
    if max_lines is None and max_bytes is None:
        raise InputError("give max_lines or max_bytes (the controller's program buffer)")
    for name, v in (("max_lines", max_lines), ("max_bytes", max_bytes)):
        if v is not None and (isinstance(v, bool) or int(v) != v or v < 1):
            raise InputError(f"{name} must be a whole number >= 1, got {v!r}")
    lim_lines = math.inf if max_lines is None else int(max_lines)
    lim_bytes = math.inf if max_bytes is None else int(max_bytes)
    moves, trace, lines, words, inverse, coord, coolant = _states(text, d, filename)
    n = len(lines)
    sizes = np.array([len(s.encode("utf-8")) + 1 for s in lines], np.int64)
    cum_bytes = np.concatenate([[0], np.cumsum(sizes)])

    # per boundary b (part starts at 0-based line b, 1 <= b <= n-1): can it be restated?
    motion = trace["motion"].str[1:].astype(float).to_numpy()
    axis_or_motion = np.array([bool(ax) or any(g in _MOTION_G for g in gs) for gs, _, ax in words])
    states_motion = np.array([any(g in _MOTION_G for g in gs) for gs, _, _ in words])
    next_am = np.full(n + 1, n, np.int64)      # first line >= i with axis or motion words
    for i in range(n - 1, -1, -1):
        next_am[i] = i if axis_or_motion[i] else next_am[i + 1]
    offset_line = np.array([any(g in _OFFSET_G for g in gs) or any(m in _OFFSET_M for m in ms)
                            for gs, ms, _ in words])
    n_off_before = np.concatenate([[0], np.cumsum(offset_line)])     # offset lines in [0, i)
    move_line0 = moves.line.astype(np.int64) - 1                      # 0-based source line per move
    burning = moves.laser_on & moves.is_motion
    motion_rows = np.flatnonzero(moves.is_motion)

    def boundary_info(b):
        """(restatable, safe, offset) for a part starting at 0-based line b."""
        m = int(motion[b - 1])
        nxt = next_am[b]
        if m in (2, 3) and nxt < n and not states_motion[nxt]:
            return False, False, None
        k = np.searchsorted(move_line0[motion_rows], b)         # first motion row at line >= b
        before = motion_rows[k - 1] if k > 0 else -1
        after = motion_rows[k] if k < len(motion_rows) else -1
        offset = None
        if after >= 0 and n_off_before[move_line0[after]] == n_off_before[b]:
            offset = moves.work_offset[after]
        elif before >= 0 and n_off_before[b] == n_off_before[move_line0[before] + 1]:
            offset = moves.work_offset[before]
        elif n_off_before[b] == 0:
            offset = np.zeros(3)
        if offset is None:
            return False, False, None
        safe = (before < 0 or not burning[before]) or (after < 0 or not burning[after])
        return True, bool(safe), offset

    def state_at(b, offset):
        row = trace.iloc[b - 1]
        return dict(motion=int(motion[b - 1]), plane=int(row["plane"][1:]), inches=row["units"] == "G20",
                    absolute=row["distance"] == "G90", arc_absolute=row["arc_centres"] == "G90.1",
                    feed_mm_min=float(row["feed_mm_min"]), s=float(row["S"]),
                    laser={"M5": 0, "M3": 3, "M4": 4}[row["laser"]],
                    position=(float(row["x"]), float(row["y"]), float(row["z"])), offset=offset,
                    coord=int(coord[b - 1]), inverse_time=bool(inverse[b - 1]), coolant=coolant[b - 1])

    off_word = f"M{d.laser_off_codes[0]}"
    result = SplitResult(source_lines=n)
    start, preamble, safe_start = 0, [], True
    pieces = []            # (start, end, preamble lines, safe)
    while start < n:
        pre_lines = len(preamble)
        pre_bytes = sum(len(s) + 1 for s in preamble)
        head = 1                                            # the part's comment line (≤ 60 bytes)
        # the longest body that fits with a trailer (and without one, if it is the end)
        room_lines = lim_lines - head - pre_lines
        room_bytes = lim_bytes - 60 - pre_bytes
        end_last = min(n, start + room_lines) if room_lines < math.inf else n
        if (end_last == n and cum_bytes[n] - cum_bytes[start] <= room_bytes):
            pieces.append((start, n, preamble, True))
            break
        # with a trailer line (M5)
        end_max = min(n, start + room_lines - 1) if room_lines < math.inf else n
        end_max = min(end_max, int(np.searchsorted(cum_bytes, cum_bytes[start] + room_bytes
                                                   - len(off_word) - 1, side="right")) - 1)
        chosen = None
        fallback = None
        for b in range(min(end_max, n - 1), start, -1):
            ok, safe, offset = boundary_info(b)
            if not ok:
                continue
            if fallback is None:
                fallback = (b, offset)
            if safe:
                chosen = (b, offset, True)
                break
        if chosen is None and fallback is not None:
            chosen = (*fallback, False)
            result.inside_cuts += 1
        if chosen is None:
            need_l = head + pre_lines + 2
            raise InputError(
                f"{filename or '<string>'}: lines {start + 1}-{min(n, start + 2)} cannot start a part "
                f"within the limit (max_lines={max_lines}, max_bytes={max_bytes}): the preamble takes "
                f"{pre_lines} lines / {pre_bytes} bytes, and no line boundary after line {start + 1} can "
                f"be restated within it; raise the limit (at least {need_l} lines, or "
                f"{pre_bytes + 60 + int(sizes[start]) + len(off_word) + 1} bytes)")
        b, offset, safe = chosen
        pieces.append((start, b, preamble, safe))
        preamble = restated_state(state_at(b, offset), d)
        start = b

    total = len(pieces)
    for k, (s0, s1, pre, safe) in enumerate(pieces, 1):
        trailer = [off_word] if k < total else []
        headline = f"(labkit split: part {k} of {total}, lines {s0 + 1}-{s1})"
        body = lines[s0:s1]
        part_text = "\n".join([headline] + pre + body + trailer) + "\n"
        result.parts.append(Part(part_text, s0 + 1, s1, 1 + len(pre), len(trailer), safe))
        result.added_lines += 1 + len(pre) + len(trailer)
    for p in result.parts:
        if p.n_lines > lim_lines or p.n_bytes > lim_bytes:
            raise InputError(f"part with lines {p.first_line}-{p.last_line} has {p.n_lines} lines, "
                             f"{p.n_bytes} bytes: over the limit; raise max_lines/max_bytes")
    if verify:
        verify_parts(text, result.parts, dialect=d, filename=filename, moves=moves)
    return result


def _compare(a: Moves, b: Moves) -> str | None:
    if len(a) != len(b):
        return f"{len(b)} moves instead of {len(a)}"
    for name in Moves.column_names():
        x, y = getattr(a, name), getattr(b, name)
        if name in ("start", "end", "centre", "work_offset"):
            same = np.allclose(x, y, rtol=0, atol=POSITION_ATOL_MM, equal_nan=True)
        else:
            same = np.array_equal(x, y, equal_nan=True)
        if not same:
            bad = np.flatnonzero(~np.isclose(x, y, rtol=0, atol=POSITION_ATOL_MM, equal_nan=True)
                                 .reshape(len(x), -1).all(axis=1))
            row = int(bad[0]) if len(bad) else 0
            return f"column {name!r} differs first at move {row} (line {int(a.line[row])})"
    return None


def verify_parts(text, parts, *, dialect="grbl", filename=None, moves: Moves | None = None) -> Moves:
    """Check that the parts, each parsed alone, give the original program's moves.

    Each part is parsed from a fresh state; the moves of its preamble and trailer
    lines are removed, its line numbers mapped back to the original's, and the parts
    concatenated. That must equal the original's moves in every column (positions
    within :data:`POSITION_ATOL_MM`) and its records (pauses, coolant, ``$`` lines).

    Returns
    -------
    Moves
        The concatenated moves of the parts (line numbers of the original).

    Raises
    ------
    InputError
        Naming the first part and column that differ.

    Examples
    --------
    >>> prog = "G1 X1 F100\\nG91\\n" + "X1\\n" * 10          # incremental: the state matters
    >>> res = split_program(prog, max_lines=12, verify=False)
    >>> [(p.first_line, p.last_line) for p in res.parts], len(verify_parts(prog, res.parts))
    ([(1, 10), (11, 12)], 11)
    """
    from labkit.gcode import parse

    if moves is None:
        moves = parse(text, dialect=dialect, filename=filename)
    got, records = [], []
    for k, p in enumerate(parts, 1):
        m = parse(p.text, dialect=dialect, filename=f"{filename or '<string>'} part {k}")
        first = p.preamble_lines + 1
        last = p.preamble_lines + (p.last_line - p.first_line + 1)
        keep = (m.line >= first) & (m.line <= last)
        sub = m[keep]
        sub.line[:] = sub.line - p.preamble_lines + p.first_line - 1
        got.append(sub)
        base = sum(len(g) for g in got[:-1])
        idx = np.flatnonzero(keep)
        for r in m.records:
            if first <= r.line <= last:
                index = base + int(np.searchsorted(idx, r.index))
                records.append((r.line - p.preamble_lines + p.first_line - 1, index, r.kind, r.text))
    joined = Moves.concat(got) if got else Moves.empty()
    problem = _compare(moves, joined)
    if problem is None:
        want = [(r.line, r.index, r.kind, r.text) for r in moves.records]
        if want != records:
            problem = "the records (pauses, coolant, $ lines) differ"
    if problem:
        raise InputError(f"{filename or '<string>'}: the parts do not reproduce the program: {problem}; "
                         "the program changes state the splitter cannot restate (e.g. G10/G28.1 "
                         "stored positions used in a later part)")
    return joined
