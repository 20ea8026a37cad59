"""Compiled G-code writer: Moves columns → bytes.

Numbers are handled as integers scaled by 10^decimals, so that modal
suppression compares exactly what is written (no float noise) and a number
is printed by integer arithmetic, without trailing zeros.
"""

from __future__ import annotations

import math
from collections import namedtuple

from labkit._jit import jit
import numpy as np

from labkit.toolpath.moves import LaserMode, MoveKind

RAPID, LINE, ARC_CW, ARC_CCW, DWELL = (int(MoveKind.RAPID), int(MoveKind.LINE), int(MoveKind.ARC_CW),
                                       int(MoveKind.ARC_CCW), int(MoveKind.DWELL))
LASER_OFF = int(LaserMode.OFF)
#: The G word of each move kind and the M word of each laser mode, as ASCII digits.
_G_DIGIT = np.zeros(max(MoveKind) + 1, np.uint8)
for _kind, _g in ((MoveKind.RAPID, "0"), (MoveKind.LINE, "1"), (MoveKind.ARC_CW, "2"),
                  (MoveKind.ARC_CCW, "3"), (MoveKind.DWELL, "4")):
    _G_DIGIT[_kind] = ord(_g)
_M_DIGIT = np.zeros(max(LaserMode) + 1, np.uint8)
for _mode, _m in ((LaserMode.OFF, "5"), (LaserMode.CONSTANT, "3"), (LaserMode.DYNAMIC, "4")):
    _M_DIGIT[_mode] = ord(_m)
del _kind, _g, _mode, _m

#: The program's rows as :func:`write_moves` takes them. Integers scaled by 10**decimals:
#: ``end`` (n×3 positions); by 10**value_decimals in the dialect's units: ``feed``,
#: ``power``, ``dwell``. ``centre`` stays float mm (offsets are computed from the *written*
#: previous point). ``kind``, ``plane`` (17/18/19) and ``laser`` as in Moves; ``r_mode`` per
#: row: 0 write I J K, +1 / −1 write R (negative R for sweeps over 180°).
EmitRows = namedtuple("EmitRows", ["kind", "end", "centre", "plane", "feed", "power", "laser",
                                   "dwell", "r_mode"])

#: How numbers and lines are written: coordinate ``decimals``, ``value_decimals`` (F S P),
#: ``inline_power`` (S on the motion line), ``rapid_laser_off`` (the controller switches the
#: beam off on G0 itself), ``numbered`` (N words), ``checksums`` (``*`` checksums),
#: ``modal_motion`` (False: the G0-G3 word on every motion line, as stock Marlin needs) and
#: ``compact`` (words without spaces, no ``0`` before a decimal point, and each line move
#: written absolute (G90) or relative (G91), whichever makes the program shorter).
EmitFormat = namedtuple("EmitFormat", ["decimals", "value_decimals", "inline_power",
                                       "rapid_laser_off", "numbered", "checksums", "modal_motion",
                                       "compact"])

#: Lines kept from the source (system lines, pauses, program ends): ``row[j]`` the row before
#: which line j goes (n = after the last), its text ``text[span[j, 0]:span[j, 1]]``,
#: ``reset[j]`` a program end (the controller is back in its default modes after it).
EmitRecords = namedtuple("EmitRecords", ["row", "text", "span", "reset"])

#: The writer's modal state between blocks of rows, as :func:`write_moves` reads and leaves it
#: (int64): the written position (3, scaled like ``end``), motion word, plane, F, S, laser
#: mode, beam parked for a rapid (0/1), the next record to write, and the distance mode
#: (0 G90, 1 G91).
STATE_SIZE = 11
_PLANE_AXES = np.array([[0, 1, 2], [2, 0, 1], [1, 2, 0]], dtype=np.int64)
_AXIS_LETTER = np.array([88, 89, 90], dtype=np.uint8)      # X Y Z
_OFFSET_LETTER = np.array([73, 74, 75], dtype=np.uint8)    # I J K


@jit
def _ensure(out, used, extra):
    if used + extra <= out.shape[0]:
        return out
    bigger = np.empty(max(2 * out.shape[0], used + extra + 64), np.uint8)
    bigger[:used] = out[:used]
    return bigger


@jit
def _put(out, used, c):
    out[used] = c
    return used + 1


@jit
def _parts(value, decimals):
    """Whole and fractional parts of value / 10**decimals (value >= 0), as integers."""
    scale = 1
    for _ in range(decimals):
        scale *= 10
    whole = value // scale
    return whole, value - whole * scale


def _put_scaled_python(out, used, value, decimals):
    """:func:`_put_scaled` as Python: the same integer parts written by ``str`` in one slice
    (digit by digit into a fresh numpy array it took 2.5 µs a number, a third of writing
    a program as Python)."""
    whole, frac = divmod(-value if value < 0 else value, 10 ** decimals)
    text = f"-{whole}" if value < 0 else str(whole)
    if frac > 0:                       # the fraction's digits, its trailing zeros dropped
        text += "." + str(frac).rjust(decimals, "0").rstrip("0")
    end = used + len(text)
    out[used:end] = memoryview(text.encode())
    return end


@jit(python_below=4096, python=_put_scaled_python)  # format_number: one number at a time, as Python
def _put_scaled(out, used, value, decimals):
    """Write value / 10**decimals without trailing zeros (``-0`` written as ``0``)."""
    if value < 0:
        out[used] = 45
        used += 1
        value = -value
    whole, frac = _parts(value, decimals)
    # Integer part.
    digits = np.empty(20, np.uint8)
    nd = 0
    if whole == 0:
        digits[0] = 48
        nd = 1
    while whole > 0:
        digits[nd] = 48 + whole % 10
        whole //= 10
        nd += 1
    for k in range(nd - 1, -1, -1):
        out[used] = digits[k]
        used += 1
    if frac > 0:
        nf = decimals
        while frac % 10 == 0:
            frac //= 10
            nf -= 1
        out[used] = 46
        used += 1
        for k in range(nf - 1, -1, -1):
            d = frac
            for _ in range(k):
                d //= 10
            out[used] = 48 + d % 10
            used += 1
    return used


@jit
def _put_word(out, used, letter, value, decimals, compact=False):
    """`` X12.5``; compact: ``X12.5`` and ``X.5`` (GRBL reads a number from its point on)."""
    if not compact:
        out[used] = 32
        used += 1
    out[used] = letter
    first = used + 1
    used = _put_scaled(out, first, value, decimals)
    if compact:
        lead = first + 1 if out[first] == 45 else first    # after a minus sign
        if used - lead > 1 and out[lead] == 48 and out[lead + 1] == 46:
            for k in range(lead, used - 1):
                out[k] = out[k + 1]
            used -= 1
    return used


@jit
def _number_chars(value, decimals, compact):
    """Characters :func:`_put_word` writes for ``value`` after the letter."""
    n = 1 if value < 0 else 0
    whole, frac = _parts(abs(value), decimals)
    if whole == 0:
        n += 0 if (compact and frac > 0) else 1
    while whole > 0:
        n += 1
        whole //= 10
    if frac > 0:
        nf = decimals
        while frac % 10 == 0:
            frac //= 10
            nf -= 1
        n += 1 + nf
    return n


def _number_chars_numpy(values, decimals):
    """:func:`_number_chars` (compact) of every element of the int64 array ``values``."""
    scale = 10 ** decimals
    magnitude = np.abs(values)
    whole, frac = np.divmod(magnitude, scale)
    n = (values < 0).astype(np.int64)
    digits = np.ones_like(whole)                  # whole's digits; a lone 0 before a point is dropped
    power = 10
    while power <= int(whole.max(initial=0)):
        digits += whole >= power
        power *= 10
    n += np.where((whole == 0) & (frac > 0), 0, digits)
    fraction = np.where(frac > 0, 1 + decimals, 0)  # the point and the digits before trailing zeros
    for place in range(1, decimals):            # a trailing zero at this place is not written
        fraction -= (frac > 0) & (frac % 10 ** place == 0)
    return n + fraction


def _choose_relative_numpy(kind, end_i, cur0, relative0, decimals, last):
    """:func:`choose_relative` as Python: each row's cost in either mode for all rows at once
    (numpy), then the two-state programme over plain ints, tie for tie as the kernel takes it
    (a Python loop over numpy scalars is several times slower)."""
    n = kind.shape[0]
    big = 1 << 40
    moves = kind != DWELL                          # every row but a dwell moves the position
    before = np.maximum.accumulate(np.where(moves, np.arange(n), -1))
    previous = np.concatenate(([-1], before))[:n]   # the last moving row before each row
    cur = np.where(previous[:, None] >= 0, end_i[np.maximum(previous, 0)], np.asarray(cur0)[None, :3])
    changed = end_i != cur
    line_abs = np.where(changed, 1 + _number_chars_numpy(end_i, decimals), 0).sum(axis=1)
    line_rel = np.where(changed, 1 + _number_chars_numpy(end_i - cur, decimals), 0).sum(axis=1)
    still = ~changed.any(axis=1)
    line_abs[still] = 1 + _number_chars_numpy(end_i[still, 0], decimals)
    line_rel[still] = 2
    straight = (kind == RAPID) | (kind == LINE)
    line_abs[~straight] = 0
    line_rel[~straight] = np.where(kind[~straight] == DWELL, 0, big)
    switch_cost = np.where(moves, 3, big).tolist()
    c0 = 0 if relative0 == 0 else 3
    c1 = 0 if relative0 == 1 else 3
    from0 = bytearray(n)                           # the mode of the row before, for each mode
    from1 = bytearray(n)
    for i, (a, r, s) in enumerate(zip(line_abs.tolist(), line_rel.tolist(), switch_cost)):
        if c0 <= c1 + s:
            n0 = c0 + a
        else:
            n0 = c1 + s + a
            from0[i] = 1
        if c1 <= c0 + s:
            n1 = c1 + r
        else:
            n1 = c0 + s + r
            from1[i] = 1
        c0, c1 = n0, n1
    rel = np.zeros(n, np.int8)
    m = 0 if c0 <= c1 + (4 if last else 0) else 1
    for i in range(n - 1, -1, -1):
        rel[i] = m
        if (from1 if m else from0)[i]:
            m = 1 - m
    return rel


@jit(python_below=6_000_000, python=_choose_relative_numpy)  # 4 elements a row: 0.4-0.7 µs a row as Python
def choose_relative(kind, end_i, cur0, relative0, decimals, last):
    """Per row, 1 where the move is best written relative (G91), 0 absolute (G90).

    The shortest text over the whole block: a two-state dynamic programme over the
    motion lines, each line costing the characters of its axis words in either mode and
    a change of mode the three of its ``G90``/``G91`` word. Arcs stay absolute; rows that
    do not move keep the mode they find. ``cur0`` is the written position before the
    block (scaled like ``end_i``), ``relative0`` the mode in effect.
    """
    n = kind.shape[0]
    big = 1 << 40
    cost = np.zeros((n + 1, 2), np.int64)
    came = np.zeros((n + 1, 2), np.int8)       # the mode of the row before, for each mode
    cost[0, 0] = 0 if relative0 == 0 else 3
    cost[0, 1] = 0 if relative0 == 1 else 3
    # cost[i + 1, m]: the cheapest text of rows 0..i ending in mode m
    cur = np.empty(3, np.int64)
    for a in range(3):
        cur[a] = cur0[a]
    for i in range(n):
        k = kind[i]
        if k != RAPID and k != LINE:
            line_abs = 0
            line_rel = 0 if k == DWELL else big
        else:
            line_abs = 0
            line_rel = 0
            wrote = False
            for a in range(3):
                v = end_i[i, a]
                if v != cur[a]:
                    line_abs += 1 + _number_chars(v, decimals, True)
                    line_rel += 1 + _number_chars(v - cur[a], decimals, True)
                    wrote = True
            if not wrote:
                line_abs += 1 + _number_chars(end_i[i, 0], decimals, True)
                line_rel += 2
        if k != DWELL:
            for a in range(3):
                cur[a] = end_i[i, a]
        for m in range(2):
            stay = cost[i, m]
            switch = cost[i, 1 - m] + (3 if k != DWELL else big)
            if stay <= switch:
                cost[i + 1, m] = stay
                came[i + 1, m] = m
            else:
                cost[i + 1, m] = switch
                came[i + 1, m] = 1 - m
            cost[i + 1, m] += line_rel if m == 1 else line_abs
    rel = np.zeros(n, np.int8)
    m = 0 if cost[n, 0] <= cost[n, 1] + (4 if last else 0) else 1
    for i in range(n, 0, -1):
        rel[i - 1] = m
        m = came[i, m]
    return rel


def _end_line_python(out, used, line_start, numbered, checksums, number):
    """:func:`_end_line` as Python: the line moved by slices, not byte by byte."""
    if used > line_start and out[line_start] == 32:
        out[line_start:used - 1] = out[line_start + 1:used]
        used -= 1
    if numbered:
        prefix = memoryview(f"N{number} ".encode())
        line = bytes(out[line_start:used])
        out[line_start:line_start + len(prefix)] = prefix
        used += len(prefix)
        out[used - len(line):used] = memoryview(line)
    if checksums:
        x = 0
        for c in bytes(out[line_start:used]):
            x ^= c
        out[used] = 42
        used = _put_scaled(out, used + 1, x, 0)
    out[used] = 10
    return used + 1


@jit(python=_end_line_python)
def _end_line(out, used, line_start, numbered, checksums, number):
    """Finish a line: drop the leading space, prefix ``N`` and add ``*checksum`` when asked."""
    if used > line_start and out[line_start] == 32:
        for k in range(line_start, used - 1):
            out[k] = out[k + 1]
        used -= 1
    if numbered:
        # Write "N<number> " in front of the line already written.
        tmp = np.empty(24, np.uint8)
        t = 0
        tmp[t] = 78
        t += 1
        t = _put_scaled(tmp, t, number, 0)
        tmp[t] = 32
        t += 1
        for k in range(used - 1, line_start - 1, -1):
            out[k + t] = out[k]
        for k in range(t):
            out[line_start + k] = tmp[k]
        used += t
    if checksums:
        x = 0
        for k in range(line_start, used):
            x ^= out[k]
        out[used] = 42
        used = _put_scaled(out, used + 1, x, 0)
    out[used] = 10
    return used + 1


# column elements (14 a move): 8-9.5 µs a move as Python (the 4096² zig-zag, a gray and a dithered
# photo), so 100,000 moves take about LOAD_COST_S, what loading numba and this module costs
@jit(python_below=1_400_000, views=True)
def write_moves(rows, state, fmt, first_number, records, row0, relative):
    """Write a block of the program body: ``rows`` an :data:`EmitRows` (program rows ``row0``
    on), ``state`` the writer's modal state before them (see :data:`STATE_SIZE`; updated in
    place to the state after them, so the next block goes on from it), ``fmt`` an
    :data:`EmitFormat`, ``records`` the whole program's :data:`EmitRecords`, ``relative``
    per row 1 to write it relative (G91), 0 absolute (:func:`choose_relative`; all 0 unless
    ``fmt.compact``). Returns (bytes, next line number).
    """
    kind, end_i, centre, plane = rows.kind, rows.end, rows.centre, rows.plane
    feed_i, power_i, laser, dwell_i, r_mode_rows = (rows.feed, rows.power, rows.laser,
                                                    rows.dwell, rows.r_mode)
    decimals, value_decimals = fmt.decimals, fmt.value_decimals
    numbered, checksums = fmt.numbered, fmt.checksums
    rec_row, rec_text, rec_span, rec_reset = (records.row, records.text, records.span,
                                              records.reset)
    n = kind.shape[0]
    out = np.empty(64 + 48 * n, np.uint8)
    used = 0
    number = first_number
    scale = 1.0
    for _ in range(decimals):
        scale *= 10.0
    cur = np.empty(3, np.int64)
    for a in range(3):
        cur[a] = state[a]
    cur_motion = state[3]
    cur_plane = state[4]
    cur_feed = state[5]
    cur_power = state[6]
    cur_laser = state[7]
    beam_parked = state[8] != 0     # laser switched off for a rapid on a dialect that needs it
    j = state[9]
    cur_rel = state[10]
    compact = fmt.compact
    nrec = rec_row.shape[0]
    for i in range(n + 1):
        # Records (system lines, pauses, program ends …) that stand before this row (at
        # i == n: before the next block's first row, the same place in the text).
        while j < nrec and rec_row[j] <= i + row0:
            s0 = rec_span[j, 0]
            s1 = rec_span[j, 1]
            out = _ensure(out, used, s1 - s0 + 64)
            ls = used
            for q in range(s0, s1):
                out[used] = rec_text[q]
                used += 1
            used = _end_line(out, used, ls, numbered, checksums, number)
            number += 1
            if rec_reset[j]:
                cur_motion = -1
                cur_plane = 17
                cur_laser = LASER_OFF
                beam_parked = False
                cur_rel = 0
            j += 1
        if i == n:
            break
        out = _ensure(out, used, 256)
        k = kind[i]
        feed_row = k == LINE or k == ARC_CW or k == ARC_CCW
        want_laser = laser[i]
        # Laser mode first (GRBL order: spindle words before motion).
        if k == RAPID and not fmt.rapid_laser_off and cur_laser != LASER_OFF:
            ls = used
            used = _put(out, used, 77)
            used = _put(out, used, _M_DIGIT[LASER_OFF])
            used = _end_line(out, used, ls, numbered, checksums, number)
            number += 1
            cur_laser = LASER_OFF
            beam_parked = True
        elif k != RAPID or fmt.rapid_laser_off:
            if want_laser != cur_laser or (beam_parked and want_laser != LASER_OFF):
                ls = used
                used = _put(out, used, 77)
                used = _put(out, used, _M_DIGIT[want_laser])
                if want_laser != LASER_OFF:
                    used = _put_word(out, used, 83, power_i[i], value_decimals, compact)
                    cur_power = power_i[i]
                used = _end_line(out, used, ls, numbered, checksums, number)
                number += 1
                cur_laser = want_laser
                beam_parked = False
            elif (feed_row and not fmt.inline_power and want_laser != LASER_OFF
                  and power_i[i] != cur_power):
                ls = used
                used = _put(out, used, 77)
                used = _put(out, used, _M_DIGIT[want_laser])
                used = _put_word(out, used, 83, power_i[i], value_decimals, compact)
                cur_power = power_i[i]
                used = _end_line(out, used, ls, numbered, checksums, number)
                number += 1
        if k == DWELL:
            ls = used
            used = _put(out, used, 71)
            used = _put(out, used, _G_DIGIT[DWELL])
            used = _put_word(out, used, 80, dwell_i[i], value_decimals, compact)
            used = _end_line(out, used, ls, numbered, checksums, number)
            number += 1
            continue
        arc = k == ARC_CW or k == ARC_CCW
        pl = plane[i]
        if arc and pl != cur_plane:
            ls = used
            used = _put(out, used, 71)
            used = _put(out, used, 49)
            used = _put(out, used, 48 + (pl - 10))      # the 7, 8 or 9 of G17/G18/G19
            used = _end_line(out, used, ls, numbered, checksums, number)
            number += 1
            cur_plane = pl
        ls = used
        rel = relative[i] != 0
        if rel != (cur_rel != 0):
            used = _put(out, used, 71)
            used = _put(out, used, 57)
            used = _put(out, used, 49 if rel else 48)       # G91 / G90
            cur_rel = 1 if rel else 0
        if k != cur_motion or not fmt.modal_motion:
            used = _put(out, used, 71)
            used = _put(out, used, _G_DIGIT[k])
            cur_motion = k
        wrote_axis = False
        a0 = _PLANE_AXES[pl - 17, 0]
        a1 = _PLANE_AXES[pl - 17, 1]
        for a in range(3):
            v = end_i[i, a]
            must = arc and (a == a0 or a == a1)
            if must or v != cur[a]:
                used = _put_word(out, used, _AXIS_LETTER[a], v - cur[a] if rel else v, decimals, compact)
                wrote_axis = True
        if not wrote_axis:
            # A zero-length move still states an axis, so it stays a move when read back.
            used = _put_word(out, used, _AXIS_LETTER[0], 0 if rel else end_i[i, 0], decimals, compact)
        if arc:
            if r_mode_rows[i] != 0:
                # Signed radius from the written start: negative for sweeps over 180°.
                r = math.hypot(cur[a0] / scale - centre[i, a0], cur[a1] / scale - centre[i, a1])
                ri = np.int64(round(r * scale))
                used = _put_word(out, used, 82, ri * r_mode_rows[i], decimals, compact)
            else:
                for a in (a0, a1):
                    off = np.int64(round((centre[i, a] - cur[a] / scale) * scale))
                    used = _put_word(out, used, _OFFSET_LETTER[a], off, decimals, compact)
        for a in range(3):
            cur[a] = end_i[i, a]
        if feed_row and feed_i[i] != cur_feed:
            used = _put_word(out, used, 70, feed_i[i], value_decimals, compact)
            cur_feed = feed_i[i]
        if feed_row and fmt.inline_power and power_i[i] != cur_power:
            used = _put_word(out, used, 83, power_i[i], value_decimals, compact)
            cur_power = power_i[i]
        used = _end_line(out, used, ls, numbered, checksums, number)
        number += 1
    for a in range(3):
        state[a] = cur[a]
    state[3] = cur_motion
    state[4] = cur_plane
    state[5] = cur_feed
    state[6] = cur_power
    state[7] = cur_laser
    state[8] = 1 if beam_parked else 0
    state[9] = j
    state[10] = cur_rel
    return out[:used], number
