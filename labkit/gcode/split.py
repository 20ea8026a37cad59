"""The G-code splitter of [MicroCAM] §6.2.1: a long program as sub-programs a controller accepts.

[MicroCAM]'s control environment uploaded a program larger than the controller's
program buffer as sub-programs, each uploaded "after completing the previous one".
For that to machine the same part, every sub-program has to run as if the whole
program had run up to its first line. :func:`split_program` therefore

1. parses the program (strictly: a bad line is a :class:`~labkit.errors.GcodeError`
   with file, line and column), and takes the modal state after every line from the
   interpreter's trace (:func:`labkit.gcode.state.line_states`), with what each line
   did (axis words, a motion word, an offset change);
2. cuts between whole lines, as late as the size limit allows, at a *safe point*:
   a line boundary where the beam is not cutting across the cut (the move before or
   the move after is not burning) — a part ends with the head stopped while the next
   part uploads, and a stop in the middle of a cut would mark the work. Only if a
   single cut is longer than a part is it split inside (counted in
   :attr:`SplitResult.inside_cuts`);
3. starts each part after the first with a *preamble* that restates the state on a
   fresh controller (:func:`labkit.gcode.state.restate`): offsets cleared, beam off
   (M5), a rapid to the position the previous part ended at, the motion mode (a
   zero-length G1 when it is G1), plane, feed mode, arc-centre mode, feed, coordinate
   system, work offset (G92), coolant, S and M3/M4/M5, units and distance mode — and
   ends each part but the last with M5, so the beam is off while the next part uploads.

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
from dataclasses import dataclass, field

import numpy as np

from labkit.errors import InputError
from labkit.gcode.dialects import get_dialect
from labkit.gcode.reader import parse
from labkit.gcode.state import ModalState, line_states, restate
from labkit.toolpath.moves import Moves

__all__ = ["Part", "SplitResult", "split_program", "verify_parts"]

#: Position tolerance of the verification, mm (restated coordinates round-trip a double).
POSITION_ATOL_MM = 1e-9


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
    d = get_dialect(dialect)
    if max_lines is None and max_bytes is None:
        raise InputError("give max_lines or max_bytes (the controller's program buffer)")
    for name, v in (("max_lines", max_lines), ("max_bytes", max_bytes)):
        if v is not None and (isinstance(v, bool) or int(v) != v or v < 1):
            raise InputError(f"{name} must be a whole number >= 1, got {v!r}")
    lim_lines = math.inf if max_lines is None else int(max_lines)
    lim_bytes = math.inf if max_bytes is None else int(max_bytes)
    moves = parse(text, dialect=d, filename=filename)
    trace, lines = line_states(text, dialect=d)
    n = len(lines)
    sizes = np.array([len(s.encode("utf-8")) + 1 for s in lines], np.int64)
    cum_bytes = np.concatenate([[0], np.cumsum(sizes)])

    # per boundary b (part starts at 0-based line b, 1 <= b <= n-1): can it be restated?
    motion = trace["motion"]
    states_motion = trace["motion_word"]
    axis_or_motion = trace["axis_words"] | states_motion
    next_am = np.full(n + 1, n, np.int64)      # first line >= i with axis or motion words
    for i in range(n - 1, -1, -1):
        next_am[i] = i if axis_or_motion[i] else next_am[i + 1]
    offset_line = trace["sets_offsets"]
    n_off_before = np.concatenate([[0], np.cumsum(offset_line)])     # offset lines in [0, i)
    move_line0 = moves.line.astype(np.int64) - 1                      # 0-based source line per move
    burning = moves.laser_on & moves.is_motion
    motion_rows = np.flatnonzero(moves.is_motion)

    def boundary_info(b):
        """(restatable, safe) for a part starting at 0-based line b. Restatable: not inside a
        modal arc the next lines rely on, and no offset change between the boundary and the
        nearest move (G10 L2 origins or G28.1 positions a later part uses cannot be restated
        on a fresh controller; a move on the far side shows what the offset was)."""
        m = int(motion[b - 1])
        nxt = next_am[b]
        if m in (2, 3) and nxt < n and not states_motion[nxt]:
            return False, False
        k = np.searchsorted(move_line0[motion_rows], b)         # first motion row at line >= b
        before = motion_rows[k - 1] if k > 0 else -1
        after = motion_rows[k] if k < len(motion_rows) else -1
        known = ((after >= 0 and n_off_before[move_line0[after]] == n_off_before[b])
                 or (before >= 0 and n_off_before[b] == n_off_before[move_line0[before] + 1])
                 or n_off_before[b] == 0)
        if not known:
            return False, False
        safe = (before < 0 or not burning[before]) or (after < 0 or not burning[after])
        return True, bool(safe)

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
            ok, safe = boundary_info(b)
            if not ok:
                continue
            if fallback is None:
                fallback = b
            if safe:
                chosen = (b, True)
                break
        if chosen is None and fallback is not None:
            chosen = (fallback, False)
            result.inside_cuts += 1
        if chosen is None:
            need_l = head + pre_lines + 2
            raise InputError(
                f"{filename or '<string>'}: lines {start + 1}-{min(n, start + 2)} cannot start a part "
                f"within the limit (max_lines={max_lines}, max_bytes={max_bytes}): the preamble takes "
                f"{pre_lines} lines / {pre_bytes} bytes, and no line boundary after line {start + 1} can "
                f"be restated within it; raise the limit (at least {need_l} lines, or "
                f"{pre_bytes + 60 + int(sizes[start]) + len(off_word) + 1} bytes)")
        b, safe = chosen
        pieces.append((start, b, preamble, safe))
        preamble = restate(ModalState.at(trace, b - 1), d)
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
