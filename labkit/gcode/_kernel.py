"""The compiled G-code interpreter: bytes in, Moves columns and diagnostics out.

One pass over the text, one line at a time, in three phases per line (each a kernel
inlined into :func:`interpret`: :func:`_scan`, :func:`_check`, :func:`_commit`):

1. *scan* — split the line into words (letter + number), skipping comments
   ``( … )`` and ``; …``, verifying a ``*`` checksum, and recognising ``$``
   system lines and ``%`` delimiters;
2. *check and compute* — classify G and M words into modal groups, convert
   units, work out the target, the arc centre and the dwell, and find every
   reason to reject the line — without touching the modal state;
3. *commit* — only an accepted line changes the state and appends rows.

A rejected line therefore changes nothing, exactly as a controller that
answers ``error:N`` (GRBL) or ``er`` (labkit firmware). In lenient mode the
scan continues with the next line and every rejection is reported; in strict
mode it stops at the first.

The order of execution inside a line follows GRBL (and RS274/NGC): feed, S,
laser M words, coolant, dwell, plane, units, distance modes, motion, then
program stop/end. Numbers are read exactly: the digits form an integer
mantissa that is divided once by a power of ten, so any number with at most
15 significant digits equals Python's ``float()`` of the same text.

This module is the only compiled part of the parser; :mod:`labkit.gcode.reader`
wraps it. Run with ``NUMBA_DISABLE_JIT=1`` to step through it as Python.
"""

from __future__ import annotations

import functools
import math
from collections import namedtuple

from labkit._jit import jit
import numpy as np

from labkit.errors import status_code
from labkit.toolpath.moves import BLANK_ROW, MOVE_ROW, LaserMode, MoveKind, Moves


def _code(name: str) -> int:
    return status_code(name).code


# Move kinds (labkit.toolpath.MoveKind), as plain ints for the compiled code.
RAPID, LINE, ARC_CW, ARC_CCW, DWELL = (int(MoveKind.RAPID), int(MoveKind.LINE), int(MoveKind.ARC_CW),
                                       int(MoveKind.ARC_CCW), int(MoveKind.DWELL))

# Laser modes (labkit.toolpath.LaserMode, whose values are the M numbers M5→0, M3, M4).
LASER_OFF, LASER_CONSTANT, LASER_DYNAMIC = (int(LaserMode.OFF), int(LaserMode.CONSTANT),
                                            int(LaserMode.DYNAMIC))

#: The Moves columns, in the one order of :mod:`labkit.toolpath.moves`; the kernel writes
#: rows of :data:`labkit.toolpath.moves.MOVE_ROW`, the record type derived from them.
MOVES_COLUMNS = Moves.column_names()

# Record kinds.
RECORD_NAMES = ("", "system", "pause", "optional_pause", "end", "lookahead", "coolant", "jog",
                "probe", "printer")
REC_SYSTEM, REC_PAUSE, REC_OPTIONAL_PAUSE, REC_END, REC_LOOKAHEAD, REC_COOLANT, REC_JOG, \
    REC_PROBE, REC_PRINTER = range(1, len(RECORD_NAMES))

# Status codes: numbers from the one table, labkit/status_codes.csv (names are its rows).
OK = _code("ok")
E_EXPECTED_LETTER = _code("expected_letter")
E_BAD_NUMBER = _code("bad_number")
E_NEGATIVE = _code("negative_value")
E_OVERFLOW = _code("line_overflow")
E_INVALID_JOG = _code("invalid_jog")
E_UNSUPPORTED = _code("unsupported_command")
E_MODAL_GROUP = _code("modal_group_violation")
E_UNDEFINED_FEED = _code("undefined_feed")
E_NON_INTEGER = _code("non_integer_command")
E_REPEATED = _code("repeated_word")
E_NO_AXIS_WORDS = _code("missing_axis_words")
E_LINE_NUMBER = _code("bad_line_number")
E_MISSING_VALUE = _code("missing_value_word")
E_NO_PLANE_AXIS = _code("missing_plane_axis")
E_INVALID_ARC = _code("invalid_arc")
E_NO_OFFSET = _code("missing_offset_words")
E_UNUSED = _code("unused_words")
E_CHECKSUM = _code("bad_checksum")
E_DELIMITER = _code("bad_delimiter")
E_OUT_OF_RANGE = _code("value_out_of_range")
E_AXIS_CONFLICT = _code("axis_command_conflict")
E_COORD_SYS = _code("unsupported_coord_sys")
E_G53_MOTION = _code("g53_invalid_motion_mode")
E_AXIS_EXIST = _code("axis_words_exist")
E_G43_AXIS = _code("g43_dynamic_axis_error")
E_MAX_VALUE = _code("max_value_exceeded")
E_ARC_RADIUS = _code("arc_radius_error")

# Details that select the message for a status code (see reader._MESSAGES).
D_NONE = 0
D_UNCLOSED_COMMENT = 1
D_AFTER_CHECKSUM = 2
D_UNKNOWN_LETTER = 3
D_UNKNOWN_G = 4
D_UNKNOWN_M = 5
D_R_FULL_CIRCLE = 6
D_R_TOO_SMALL = 7
D_RADIUS_MISMATCH = 8
D_ZERO_RADIUS = 9
D_DWELL_P = 10
D_LOOKAHEAD_P = 11
D_TOO_MANY = 12
D_CHECKSUM_DIGITS = 13
D_NUMBER_NO_DIGITS = 14
D_NUMBER_TRAILING = 15
D_ABS_CENTRE = 16
D_NUMBER_TOO_LARGE = 17
D_PERCENT = 18
D_JOG_COMMAND = 19
D_JOG_WORD = 20
D_G10_LP = 21
D_G10_L = 22
D_G10_R = 23
D_PROBE_TARGET = 24
D_PERCENT_LINE = 25

# Letters (index = letter − 'A').
L_E, L_F, L_G, L_I, L_J, L_K, L_L, L_M, L_N, L_P, L_R, L_S, L_T, L_X, L_Y, L_Z = (
    4, 5, 6, 8, 9, 10, 11, 12, 13, 15, 17, 18, 19, 23, 24, 25)

# Modal groups (bit numbers).
G_MOTION, G_NONMODAL, G_PLANE, G_UNITS, G_DISTANCE, G_ARCDIST, G_FEEDMODE, G_CUTTER, \
    G_TOOLLEN, G_COORD, G_PATH, M_STOP, M_LASER, M_COOLANT, M_RECORD = range(15)

MAX_COMMANDS = 16   # G or M words per line; more cannot be valid (fewer groups exist)
MAX_LINE_NUMBER = 9_999_999  # labkit's limit for N
MAX_LINE_NUMBER_GRBL = 10_000_000  # GRBL 1.1's MAX_LINE_NUMBER (N10000000 is accepted)
#: Largest magnitude of a number or coordinate, mm (2**53: above it a float64 no longer
#: holds every integer, so neither the position nor the digits written back are exact).
MAX_ABS_VALUE = 9007199254740992.0

# Exact powers of ten up to 1e22; beyond that the division is done in two steps.
_POW10 = np.array([10.0 ** k for k in range(23)])

# Plane → (first axis, second axis, linear axis), as in labkit.toolpath.PLANE_AXES.
_PLANE_AXES = np.array([[0, 1, 2], [2, 0, 1], [1, 2, 0]], dtype=np.int64)


@jit
def _grow(a, cap):
    b = np.empty(cap, a.dtype)
    b[: a.shape[0]] = a
    return b


@jit
def _is_space(c):
    return c == 32 or c == 9 or c == 13 or c == 11 or c == 12


@jit
def _read_number(buf, i, end):
    """Read ``[+-]digits[.digits]`` at ``buf[i]``.

    Returns (value, next index, status) with status 0 ok, 1 no digits,
    2 followed by something that cannot end a number (``1.2.3``, ``5x``…; the value is the
    number read up to it, which is where GRBL's reader ends the word),
    3 magnitude at or above :data:`MAX_ABS_VALUE` (``X`` followed by 400 digits).
    """
    neg = False
    if i < end and (buf[i] == 45 or buf[i] == 43):   # '-' '+'
        neg = buf[i] == 45
        i += 1
    mant = 0
    frac = 0
    extra_exp = 0
    ndigits = 0
    nsig = 0
    dot = False
    while i < end:
        c = buf[i]
        if 48 <= c <= 57:
            ndigits += 1
            if mant == 0 and c == 48:
                if dot:
                    frac += 1
            elif nsig < 18:
                mant = mant * 10 + (c - 48)
                nsig += 1
                if dot:
                    frac += 1
            elif not dot:
                extra_exp += 1   # digits past 18 significant ones only scale the integer part
        elif c == 46 and not dot:   # '.'
            dot = True
        else:
            break
        i += 1
    if ndigits == 0:
        return 0.0, i, 1
    trailing = 0
    if i < end:
        c = buf[i]
        if not (_is_space(c) or c == 10 or c == 40 or c == 59 or c == 42
                or (65 <= c <= 90) or (97 <= c <= 122)):
            trailing = 2
    if extra_exp > 0:
        return 0.0, i, trailing or 3   # 19 or more integer digits: beyond MAX_ABS_VALUE
    value = float(mant)
    while frac > 22:
        value = value / 1e22
        frac -= 22
    if frac > 0:
        value = value / _POW10[frac]
    if value >= MAX_ABS_VALUE:
        return 0.0, i, trailing or 3
    return (-value if neg else value), i, trailing


@jit
def _is_realtime(c, grbl_verdicts):
    """GRBL's real-time characters (status ?, cycle start ~, feed hold !): its serial
    interrupt takes them out of the stream, so they never reach a line."""
    return grbl_verdicts and (c == 63 or c == 126 or c == 33)


@jit
def _contains(arr, v):
    for k in range(arr.shape[0]):
        if arr[k] == v:
            return True
    return False


@jit
def _in_range(v):
    return abs(v) < MAX_ABS_VALUE      # False for inf and NaN too


_ROW_BLANK = BLANK_ROW[0].item()
_ROW_AT = {name: i for i, name in enumerate(MOVE_ROW.names)}


def _put_row_python(rows, i, k, p0, p1, c, plane, feed, power, laser, dwell, line, offs):
    """:func:`_put_row` for the Python path: one tuple assignment instead of nineteen record
    field writes (each a slow numpy attribute lookup in Python)."""
    row = list(_ROW_BLANK)
    row[_ROW_AT["kind"]] = k
    row[_ROW_AT["start"]] = (p0[0], p0[1], p0[2])
    row[_ROW_AT["end"]] = (p1[0], p1[1], p1[2])
    row[_ROW_AT["centre"]] = (c[0], c[1], c[2])
    row[_ROW_AT["work_offset"]] = (offs[0], offs[1], offs[2])
    row[_ROW_AT["plane"]] = plane
    row[_ROW_AT["feed_mm_min"]] = feed if feed > 0 else np.nan
    row[_ROW_AT["s_word"]] = power
    row[_ROW_AT["laser"]] = laser
    row[_ROW_AT["dwell_s"]] = dwell
    row[_ROW_AT["line"]] = line
    rows[i] = tuple(row)
    return i + 1


@jit(python=_put_row_python)
def _put_row(rows, i, k, p0, p1, c, plane, feed, power, laser, dwell, line, offs):
    """Write move row ``i`` (columns not named here keep their fill); returns ``i + 1``."""
    rows[i] = BLANK_ROW[0]
    r = rows[i]
    r.kind = k
    for a in range(3):
        r.start[a] = p0[a]
        r.end[a] = p1[a]
        r.centre[a] = c[a]
        r.work_offset[a] = offs[a]
    r.plane = plane
    r.feed_mm_min = feed if feed > 0 else np.nan
    r.s_word = power
    r.laser = laser
    r.dwell_s = dwell
    r.line = line
    return i + 1


@jit
def _put_record(recs, j, line, k, s0, s1, value, row):
    """Write record ``j``; returns ``j + 1``."""
    r = recs[j]
    r.line = line
    r.kind = k
    r.span[0] = s0
    r.span[1] = s1
    r.value = value
    r.index = row
    return j + 1


#: One rejected line: 1-based line, byte span of the culprit [pos, end), status code
#: number, detail (``D_*``, selects the message) and two numbers for the message.
ERROR_ROW = np.dtype((np.record, [("line", np.int64), ("pos", np.int64), ("end", np.int64),
                      ("code", np.int64), ("detail", np.int64), ("aux", np.float64, (2,))]))

#: One kept non-motion line: 1-based line, kind (index into :data:`RECORD_NAMES`), byte
#: span of its text, numeric value (NaN when none) and the number of moves before it.
RECORD_ROW = np.dtype((np.record, [("line", np.int64), ("kind", np.int64), ("span", np.int64, (2,)),
                       ("value", np.float64), ("index", np.int64)]))

#: The modal state after one line — the one record of it (:class:`labkit.gcode.state.ModalState`
#: reads a row; :func:`interpret` starts from one and ends in one): G numbers of the motion,
#: plane, units, distance, arc-distance and feed-mode (93, 94) groups, the feed (mm/min, NaN
#: while undefined), S, the laser mode (0 M5, 3, 4) and the position (mm, machine); the offsets
#: GRBL keeps: the coordinate system in use (54…59), the G54…G59 origins and the G92 offset
#: (mm, machine), the G43.1 tool length offset (mm) and the G28.1 / G30.1 stored positions
#: (mm, machine); coolant (bit 0 M7, bit 1 M8). Then what the line itself did: ``syncing``
#: (it waits for the planner to empty before it runs, on GRBL: a dwell, G10, G28, G30, G92,
#: a program stop or end, a laser or coolant M word), ``axis_words`` (X, Y or Z in a G-code
#: line), ``motion_word`` (a motion-group G word: G0-G3, G38.x, G80), ``sets_offsets``
#: (G10, G28, G30, G92, G92.1, G43.1, G49, M2, M30), ``states_units`` (G20 or G21),
#: ``states_distance`` (G90 or G91), ``states_coord_system`` (one of G54…G59) and
#: ``machine_coords`` (G53: its axis words are machine positions). A rejected line did nothing.
TRACE_ROW = np.dtype((np.record, [("motion", np.float64), ("plane", np.float64), ("units", np.float64),
                      ("distance", np.float64), ("arc_distance", np.float64),
                      ("feed_mm_min", np.float64), ("s_word", np.float64),
                      ("laser", np.float64), ("position", np.float64, (3,)),
                      ("coord_system", np.float64), ("coord_origins", np.float64, (6, 3)),
                      ("g92", np.float64, (3,)), ("tool_offset", np.float64),
                      ("feed_mode", np.float64), ("coolant", np.int64),
                      ("home28", np.float64, (3,)), ("home30", np.float64, (3,)),
                      ("syncing", np.bool_), ("axis_words", np.bool_), ("motion_word", np.bool_),
                      ("sets_offsets", np.bool_), ("states_units", np.bool_),
                      ("states_distance", np.bool_), ("states_coord_system", np.bool_),
                      ("machine_coords", np.bool_)]))


def initial_state() -> np.ndarray:
    """GRBL's power-on modal state as a one-row :data:`TRACE_ROW` array: G0 G17 G21 G90
    G91.1 G94 G54, no feed, S0, M5, M9, at machine zero with every offset zero."""
    st = np.zeros(1, TRACE_ROW)
    st["motion"], st["plane"], st["units"], st["distance"] = 0, 17, 21, 90
    st["arc_distance"], st["feed_mm_min"], st["coord_system"], st["feed_mode"] = 91.1, np.nan, 54, 94
    return st


#: What :func:`interpret` returns: ``moves`` (array of ``MOVE_ROW``), ``errors`` (of
#: :data:`ERROR_ROW`, at most ``max_errors``), ``error_total`` (all rejected lines),
#: ``records`` (of :data:`RECORD_ROW`) and ``trace`` (of :data:`TRACE_ROW`, one per line
#: when asked, else empty) and ``final`` (the state after the last line, one
#: :data:`TRACE_ROW`).
Interpretation = namedtuple("Interpretation", ["moves", "errors", "error_total", "records",
                                               "trace", "final"])


#: One line's words as the scan reads them: for each letter A-Z whether it is present (0 or
#: 1: numba keeps no bool arrays in a record), its value and the byte span of the word
#: [wpos, wend); the G and M command words (at most :data:`MAX_COMMANDS` each) in the order
#: written, with their spans.
WORDS_ROW = np.dtype((np.record, [("present", np.uint8, (26,)), ("val", np.float64, (26,)),
                      ("wpos", np.int64, (26,)), ("wend", np.int64, (26,)),
                      ("g_val", np.float64, (MAX_COMMANDS,)), ("g_pos", np.int64, (MAX_COMMANDS,)),
                      ("g_end", np.int64, (MAX_COMMANDS,)), ("m_val", np.float64, (MAX_COMMANDS,)),
                      ("m_pos", np.int64, (MAX_COMMANDS,)), ("m_end", np.int64, (MAX_COMMANDS,))]))


@jit
def _put_state(t, motion, plane, inches, absolute, arc_absolute, feed, power, laser, pos,
               coord, wcs, g92, tlo, inverse, cool, home28, home30):
    """Write the modal state into trace record ``t`` (the per-line flags are the caller's)."""
    t.motion = motion
    t.plane = 17 + plane
    t.units = 20 if inches else 21
    t.distance = 90 if absolute else 91
    t.arc_distance = 90.1 if arc_absolute else 91.1
    t.feed_mm_min = feed if feed > 0 else np.nan
    t.s_word = power
    t.laser = laser
    for a in range(3):
        t.position[a] = pos[a]
        t.g92[a] = g92[a]
        t.home28[a] = home28[a]
        t.home30[a] = home30[a]
        for k in range(6):
            t.coord_origins[k, a] = wcs[k, a]
    t.coord_system = 54 + coord
    t.tool_offset = tlo
    t.feed_mode = 93 if inverse else 94
    t.coolant = cool


@jit
def _put_flags(t, syncing, axis_words, motion_word, sets_offsets, states_units, states_distance,
               states_coord_system, machine_coords):
    """Write what the line itself did into trace record ``t`` (see :data:`TRACE_ROW`)."""
    t.syncing = syncing
    t.axis_words = axis_words
    t.motion_word = motion_word
    t.sets_offsets = sets_offsets
    t.states_units = states_units
    t.states_distance = states_distance
    t.states_coord_system = states_coord_system
    t.machine_coords = machine_coords


@functools.lru_cache(maxsize=None)
def _row_class(dtype):
    """A class with ``dtype``'s fields as slots (a slot is the quickest attribute to read)."""
    return type(f"Row{len(dtype.names)}", (), {"__slots__": dtype.names})


def _rows_python(dtype):
    """A one-"row" list for the Python path: the fields of ``dtype`` as attributes (arrays,
    or plain numbers), since a numpy record's fields cost microseconds each to look up."""
    row = _row_class(dtype)()
    for name in dtype.names:
        setattr(row, name, np.zeros(dtype[name].shape, dtype[name].base)
                if dtype[name].shape else dtype[name].base.type(0).item())
    return [row]


@jit(python=lambda: _rows_python(WORDS_ROW))
def _new_words():
    """The per-line word storage of :func:`interpret`: a one-row :data:`WORDS_ROW` array."""
    return np.zeros(1, WORDS_ROW)


@jit(inline="always")
def _scan(buf, ls, le, w, letters, line_limit, grbl_verdicts, grbl_streamed, max_tool):
    """Phase 1 of :func:`interpret`, the scan: read line ``buf[ls:le]`` into its words.

    The controller's line buffer is checked first (``line_limit`` > 0: GRBL drops spaces and
    comments before it counts). Then every word is read left to right into ``w`` (a
    :data:`WORDS_ROW` record): value words by letter, G and M command words in the order
    written. Comments, real-time characters, a checksum, ``$`` lines (a ``$J=`` jog goes on
    as words) and a lone ``%`` are taken as the controller takes them. ``letters`` has bit
    ``k`` set for each letter ``A + k`` the dialect takes; the other arguments are the
    :class:`~labkit.gcode.reader.ParseOptions` fields of the same names.

    Only scalars and a record come in, not arrays: with fourteen arrays handed over the parse
    measured 21-23 % slower than with the scan in :func:`interpret`'s body, this form 2-3.5 %
    (1 M lines, compiled; the views taken here in the kernel, not handed over: as arguments
    they cost as much as arrays, numba counting their references on every line).

    Returns (err, detail, epos, eend, aux0, aux1, is_system, is_jog, ng, nm): the first fault
    (``OK`` when none) with its span and two numbers for its message, whether the line is a
    ``$`` system line or a jog, and how many G and M words were read.
    """
    present, val, wpos, wend = w.present, w.val, w.wpos, w.wend
    g_val, g_pos, g_end, m_val, m_pos, m_end = w.g_val, w.g_pos, w.g_end, w.m_val, w.m_pos, w.m_end

    err = OK
    detail = D_NONE
    epos = ls
    eend = le
    aux0 = 0.0
    aux1 = 0.0
    is_system = False
    is_jog = False

    # ---- phase 0: the controller's line buffer (GRBL drops spaces and comments first)
    if line_limit > 0:
        count = 0
        in_paren = False
        k = ls
        while k < le:
            c = buf[k]
            if in_paren:
                if c == 41:
                    in_paren = False
            elif c == 40:
                in_paren = True
            elif c == 59:
                break
            elif c > 32 and c != 47 and not _is_realtime(c, grbl_verdicts):
                if count >= line_limit - 1:
                    err, epos, eend, aux0 = E_OVERFLOW, k, k + 1, float(line_limit - 1)
                    break
                count += 1
            k += 1

    # ---- phase 1: scan ----------------------------------------------------------
    for k in range(26):
        present[k] = False
    ng = 0
    nm = 0
    checksum_seen = False
    first = True
    i = ls
    while i < le and err == OK:
        c = buf[i]
        if _is_space(c) or _is_realtime(c, grbl_verdicts):
            i += 1
            continue
        if c == 40:   # '(' comment to ')'
            j = i + 1
            while j < le and buf[j] != 41:
                j += 1
            if j >= le and grbl_verdicts:   # GRBL: the comment ends with the line
                break
            if j >= le:
                err, detail, epos, eend = E_DELIMITER, D_UNCLOSED_COMMENT, i, le
                break
            i = j + 1
            continue
        if c == 59:   # ';' comment to end of line
            break
        if c == 42 and grbl_streamed:   # GRBL has no checksum: '*' is no letter
            err, epos, eend = E_EXPECTED_LETTER, i, i + 1
            break
        if c == 42:   # '*' checksum: XOR of every byte before it
            x = 0
            for k in range(ls, i):
                x ^= buf[k]
            j = i + 1
            cs = 0
            nd = 0
            while j < le and 48 <= buf[j] <= 57:
                cs = cs * 10 + (buf[j] - 48)
                nd += 1
                j += 1
            if nd == 0 or nd > 3:
                err, detail, epos, eend = E_BAD_NUMBER, D_CHECKSUM_DIGITS, i, j
                break
            if cs != x:
                err, epos, eend, aux0, aux1 = E_CHECKSUM, i, j, float(x), float(cs)
                break
            checksum_seen = True
            i = j
            continue
        if first and c == 36:   # '$' system line, kept whole; '$J=' a jog (GRBL 1.1)
            if i + 2 < le and (buf[i + 1] == 74 or buf[i + 1] == 106) and buf[i + 2] == 61:
                is_jog = True
                first = False
                i += 3
                continue
            is_system = True
            break
        if first and c == 37:   # '%' alone on its line: the program delimiter
            j = i + 1
            while j < le and _is_space(buf[j]):
                j += 1
            if j < le:          # GRBL reads any other '%' as a non-letter: error 1
                err, detail, epos, eend = E_EXPECTED_LETTER, D_PERCENT, i, i + 1
                break
            if grbl_streamed:    # and a '%' line streamed to it (no program delimiter)
                err, detail, epos, eend = E_EXPECTED_LETTER, D_PERCENT_LINE, i, i + 1
                break
            i = le
            break
        first = False
        if checksum_seen:
            err, detail, epos, eend = E_DELIMITER, D_AFTER_CHECKSUM, i, i + 1
            break
        u = c - 32 if 97 <= c <= 122 else c
        if not (65 <= u <= 90):
            err, epos, eend = E_EXPECTED_LETTER, i, i + 1
            break
        letter = u - 65
        wp = i
        i += 1
        while i < le and _is_space(buf[i]):
            i += 1
        v, i2, st = _read_number(buf, i, le)
        if st == 2 and grbl_verdicts:
            st = 0        # GRBL ends the word there; what follows must start the next one
        if st != 0:
            j = i2
            if st == 2:   # show the whole malformed token, e.g. "X1.2.3"
                while j < le and not (_is_space(buf[j]) or buf[j] == 40 or buf[j] == 59):
                    j += 1
            err, epos, eend = E_BAD_NUMBER, wp, j
            detail = D_NUMBER_NO_DIGITS if st == 1 else (
                D_NUMBER_TRAILING if st == 2 else D_NUMBER_TOO_LARGE)
            break
        i = i2
        if letter == L_G or letter == L_M:      # command words, kept in the order written
            if (ng if letter == L_G else nm) == MAX_COMMANDS:
                err, detail, epos, eend = E_MODAL_GROUP, D_TOO_MANY, wp, i
                break
            if letter == L_G:
                g_val[ng], g_pos[ng], g_end[ng] = v, wp, i
                ng += 1
            else:
                m_val[nm], m_pos[nm], m_end[nm] = v, wp, i
                nm += 1
        else:
            if not (letters >> letter) & 1:
                err, detail, epos, eend = E_UNSUPPORTED, D_UNKNOWN_LETTER, wp, i
                break
            if grbl_verdicts and letter == L_T and v > max_tool:
                err, epos, eend = E_MAX_VALUE, wp, i     # GRBL: as T is read, before a repeat
                break
            if present[letter]:
                err, epos, eend = E_REPEATED, wp, i
                break
            if grbl_verdicts and v < 0 and (letter == L_F or letter == L_N
                                                    or letter == L_P or letter == L_T
                                                    or letter == L_S):
                err, epos, eend = E_NEGATIVE, wp, i      # GRBL: F N P T S as they are read
                break
            present[letter] = True
            val[letter] = v
            wpos[letter] = wp
            wend[letter] = i

    return err, detail, epos, eend, aux0, aux1, is_system, is_jog, ng, nm


#: Phase 2's vectors for one line (:func:`_check` writes them, :func:`_commit` reads them), in
#: mm (machine): the move's ``target``, its arc centre ``ctr``, the work offset ``offs``,
#: G28/G30's two rapids ``inter``/``final``, the G92 offset ``g92_new`` and the G10
#: origin ``new_sys`` the line sets; ``nan3`` (three NaN) for a move without a centre. The
#: scalars of the decision come back from :func:`_check` as one tuple.
CHECKED_ROW = np.dtype((np.record, [(name, np.float64, (3,)) for name in (
    "target", "ctr", "offs", "g92_new", "new_sys", "inter", "final", "nan3")]))

#: The modal state's vectors (mm, machine): the position, the G54-G59 origins, the G92
#: offset and the G28.1/G30.1 stored positions. :func:`interpret` holds views of them.
OFFSETS_ROW = np.dtype((np.record, [("pos", np.float64, (3,)), ("wcs", np.float64, (6, 3)),
                        ("g92", np.float64, (3,)), ("home28", np.float64, (3,)),
                        ("home30", np.float64, (3,))]))

#: The :class:`~labkit.gcode.reader.ParseOptions` fields the check reads (flags as 0/1),
#: with the code lists as tables: ``g_ok[10·G]`` 1 for each G word the dialect takes,
#: ``m_kind[M]`` 1 laser on, 2 laser off, 3 coolant, 4 a kept record (codes below 1000).
DIALECT_ROW = np.dtype((np.record, [("feed_scale", np.float64), ("dwell_scale", np.float64),
                        ("arc_r_tol", np.float64), ("arc_tol_abs", np.float64),
                        ("arc_tol_rel", np.float64), ("full_circle_ok", np.int64),
                        ("require_axis_words", np.int64), ("home_is_origin", np.int64),
                        ("max_tool", np.int64), ("grbl_verdicts", np.int64),
                        ("g_ok", np.uint8, (1000,)), ("m_kind", np.uint8, (1000,))]))


@jit(python=lambda: _rows_python(CHECKED_ROW))
def _new_checked():
    """The check's decision for one line: a one-row :data:`CHECKED_ROW` array."""
    return np.zeros(1, CHECKED_ROW)


@jit(python=lambda: _rows_python(OFFSETS_ROW))
def _new_offsets():
    """The modal state's vectors: a one-row :data:`OFFSETS_ROW` array."""
    return np.zeros(1, OFFSETS_ROW)


@jit(python=lambda: _rows_python(DIALECT_ROW))
def _new_dialect():
    """The dialect's settings the check reads: a one-row :data:`DIALECT_ROW` array."""
    return np.zeros(1, DIALECT_ROW)


@jit(inline="always")
def _word_limit(err, epos, le, grbl_verdicts):
    """Where :func:`_check` stops reading command words, a byte offset of the line ``[.., le)``:
    GRBL checks each word as it reads it, left to right, so a command word left of a fault
    found so far (``err`` at ``epos``) is checked first and its own fault is the one reported;
    an overlong line (``E_OVERFLOW``) and the other dialects' lines are judged whole."""
    if err != OK and grbl_verdicts and err != E_OVERFLOW:
        return epos
    return le + 1


@jit(inline="always")
def _group_fault(groups, grp, unknown, detail):
    """Whether a command word of modal group ``grp`` may join the line's ``groups`` (a bit a
    group): ``(OK, detail)`` when it may; ``(E_UNSUPPORTED, unknown)`` when ``grp`` is −1 (a
    command the dialect does not have); ``(E_MODAL_GROUP, detail)`` when the line has a
    command of that group already (``detail`` is kept: that fault's message is the group's)."""
    if grp < 0:
        return E_UNSUPPORTED, unknown
    if groups & (1 << grp):
        return E_MODAL_GROUP, detail
    return OK, detail


@jit(inline="always")
def _check(w, d, m, ls, le, err, detail, epos, eend, aux0, aux1, is_system, is_jog, ng, nm,
           opt, motion, plane, inches, absolute, arc_absolute, feed, power, laser,
           inverse, coord, tlo):
    """Phase 2 of :func:`interpret`, check and compute: line ``[ls, le)``'s words ``w`` (a
    :data:`WORDS_ROW` record) against the modal state and the dialect ``opt`` (a
    :data:`DIALECT_ROW` record); the decision's vectors are written into ``d`` (a
    :data:`CHECKED_ROW` record), its scalars returned. Nothing of the state changes here:
    ``m`` (:data:`OFFSETS_ROW`) is only read, and the modal scalars come in by value.
    ``err`` … ``aux1`` are the scan's fault.

    Only records and scalars come in and only scalars go back, so that no array is counted
    in and out of the kernel on every line: with the decision left in arrays (as
    arguments) the parse measured +44 %, with the options' code arrays handed over +15-19 %;
    this way +5 % or less against the check written in :func:`interpret`'s body
    (1 M lines, compiled; numba inlines it, see labkit/README.md). The scalars come back as
    a tuple, not in the record: compiled the same, and as Python 37 fields written here and
    read back in :func:`interpret` cost 8 % of the parse (20 000 lines).

    Returns (err, detail, epos, eend, aux0, aux1, groups, motion_new, motion_mode, nonmodal,
    dwell, lookahead, dwell_s, lookahead_p, plane_new, inches_new, absolute_new,
    arc_absolute_new, inverse_new, stop, laser_new, coolant, m_record, machine_coords,
    axis_words, tlo_cmd, coord_new, set_sys, tlo_new, feed_new, power_new, jog_feed,
    move_feed, moving, probing, nhome, move_kind): the first fault (``OK`` when none) with
    its span and two numbers for its message, then what the line will do once committed, in
    the names of :func:`interpret`'s body (``*_new`` the modal value after the line;
    ``nonmodal`` 10·G of its non-modal command; ``nhome`` G28/G30's rapids; ``set_sys`` the
    G10 system it sets, or -1). Feeds in mm/min, lengths in mm.
    """
    present, val, wpos, wend = w.present, w.val, w.wpos, w.wend
    g_val, g_pos, g_end, m_val, m_pos, m_end = w.g_val, w.g_pos, w.g_end, w.m_val, w.m_pos, w.m_end
    pos, wcs, g92, home28, home30 = m.pos, m.wcs, m.g92, m.home28, m.home30
    target, ctr, offs, g92_new, new_sys = d.target, d.ctr, d.offs, d.g92_new, d.new_sys
    inter, final = d.inter, d.final
    tlo_new = tlo
    set_sys = -1
    groups = 0
    motion_new = -1
    dwell = False
    lookahead = False
    plane_new = plane
    inches_new = inches
    absolute_new = absolute
    arc_absolute_new = arc_absolute
    stop = -1
    laser_new = laser
    coolant = -1
    m_record = -1
    gcol_motion = ls
    gcol_nonmodal = ls
    gcol_tlo = ls
    gend_motion = le          # the command word as written ('G02', not 'G0')
    gend_nonmodal = le
    gend_tlo = le
    machine_coords = False
    nonmodal = 0          # 10·G of G10 G28 G28.1 G30 G30.1 G53 G92 G92.1 in the line
    tlo_cmd = 0           # 431 (G43.1) or 490 (G49)
    coord_new = coord
    inverse_new = inverse
    word_limit = _word_limit(err, epos, le, opt.grbl_verdicts)
    grbl_jog = is_jog and opt.grbl_verdicts   # GRBL reads a jog's words as any line's
    jog_refused = -1       # GRBL: the first command word a jog cannot take (error 16, last)
    axis_command = False   # GRBL: a word of G0-G3 G38 G10 G28 G30 G92 G43.1 G49 was read
    if (err == OK or word_limit <= le) and not is_system:
        for k in range(ng):
            if g_pos[k] >= word_limit:
                break
            v = g_val[k]
            t10 = int(round(v * 10.0))
            grp = -1
            if is_jog and not (t10 == 200 or t10 == 210 or t10 == 900 or t10 == 910
                               or t10 == 530):
                if not grbl_jog:
                    err, detail, epos, eend = E_INVALID_JOG, D_JOG_COMMAND, g_pos[k], g_end[k]
                    break
                if jog_refused < 0:
                    jog_refused = k
            if v < 0 or abs(v * 10.0 - t10) > 1e-6:
                err, detail, epos, eend = E_UNSUPPORTED, D_UNKNOWN_G, g_pos[k], g_end[k]
                break
            if not ((is_jog and not grbl_jog) or (t10 < 1000 and opt.g_ok[t10] != 0)):
                base = t10 - t10 % 10
                if t10 % 10 != 0 and (base < 1000 and opt.g_ok[base] != 0) and not (
                        base == 900 or base == 910 or base == 280 or base == 300
                        or base == 920 or base == 610):
                    err, epos, eend = E_NON_INTEGER, g_pos[k], g_end[k]
                else:
                    err, detail, epos, eend = E_UNSUPPORTED, D_UNKNOWN_G, g_pos[k], g_end[k]
                break
            code = t10 // 10
            if opt.grbl_verdicts and (code <= 3 or code == 38 or t10 == 100 or t10 == 280
                                          or t10 == 300 or t10 == 920 or code == 43
                                          or code == 49):
                if axis_command:     # GRBL: checked as the word is read, before its group
                    err, epos, eend = E_AXIS_CONFLICT, g_pos[k], g_end[k]
                    break
                axis_command = True
            if code <= 3 or code == 80 or code == 38:
                grp = G_MOTION
                motion_new = t10 // 10 if code != 38 else t10
                gcol_motion = g_pos[k]
                gend_motion = g_end[k]
            elif code == 4:
                grp = G_NONMODAL
                dwell = True
                gcol_nonmodal = g_pos[k]
                gend_nonmodal = g_end[k]
            elif code == 5:
                grp = G_NONMODAL
                lookahead = True
                gcol_nonmodal = g_pos[k]
                gend_nonmodal = g_end[k]
            elif code == 10 or code == 28 or code == 30 or code == 92 or code == 53:
                grp = G_NONMODAL
                nonmodal = t10
                gcol_nonmodal = g_pos[k]
                gend_nonmodal = g_end[k]
                machine_coords = code == 53
            elif code == 17 or code == 18 or code == 19:
                grp = G_PLANE
                plane_new = code - 17
            elif code == 20 or code == 21:
                grp = G_UNITS
                inches_new = code == 20
            elif t10 == 900 or t10 == 910:
                grp = G_DISTANCE
                absolute_new = code == 90
            elif t10 == 901 or t10 == 911:
                grp = G_ARCDIST
                arc_absolute_new = t10 == 901
            elif code == 93 or code == 94:
                grp = G_FEEDMODE
                inverse_new = code == 93
            elif code == 40:
                grp = G_CUTTER
            elif t10 == 431 or t10 == 490:
                grp = G_TOOLLEN
                tlo_cmd = t10
                gcol_tlo = g_pos[k]
                gend_tlo = g_end[k]
            elif 54 <= code <= 59:
                grp = G_COORD
                coord_new = code - 54
            elif code == 61:
                grp = G_PATH
            fault, fault_detail = _group_fault(groups, grp, D_UNKNOWN_G, detail)
            if fault != OK:
                err, detail, epos, eend = fault, fault_detail, g_pos[k], g_end[k]
                break
            groups |= 1 << grp
    if err == OK and is_jog and nm > 0 and not grbl_jog:
        err, detail, epos, eend = E_INVALID_JOG, D_JOG_COMMAND, m_pos[0], m_end[0]
    word_limit = _word_limit(err, epos, le, opt.grbl_verdicts)
    if (err == OK or word_limit <= le) and not is_system:
        for k in range(nm):
            if m_pos[k] >= word_limit:
                break
            v = m_val[k]
            code = int(round(v))
            grp = -1
            mk = opt.m_kind[code] if 0 <= code < 1000 else 0
            if v < 0 or abs(v - code) > 1e-9:
                err, epos, eend = E_NON_INTEGER, m_pos[k], m_end[k]
                break
            if code == 0 or code == 1 or code == 2 or code == 30:
                grp = M_STOP
                stop = code
            elif mk == 1:
                grp = M_LASER
                laser_new = LASER_DYNAMIC if code == 4 else LASER_CONSTANT
            elif mk == 2:
                grp = M_LASER
                laser_new = LASER_OFF
            elif mk == 3:
                grp = M_COOLANT
                coolant = code
            elif mk == 4:
                grp = M_RECORD
                m_record = code
            fault, fault_detail = _group_fault(groups, grp, D_UNKNOWN_M, detail)
            if fault != OK:
                err, detail, epos, eend = fault, fault_detail, m_pos[k], m_end[k]
                break
            groups |= 1 << grp

    scale = 25.4 if inches_new else 1.0
    feed_new = feed
    power_new = power
    dwell_s = 0.0
    lookahead_p = 0.0
    axis_words = bool(present[L_X] or present[L_Y] or present[L_Z])
    motion_mode = motion_new if motion_new >= 0 else motion
    moving = False
    probing = False
    nhome = 0
    move_kind = RAPID
    zero_arc = False      # a G2/G3 of radius 0 GRBL accepts (it moves as a line)
    jog_feed = 0.0
    move_feed = feed
    feed_ok = feed > 0
    if err == OK and is_jog:
        # GRBL's jog: F and X Y Z only (N allowed); G20/G21, G90/G91 and G53 for this
        # line only; the parser's modal state is left as it was, but for the position.
        if grbl_jog:
            # in GRBL's order: N, F, a dwell's P, unused words, then the commands
            if present[L_N] and math.floor(val[L_N]) > MAX_LINE_NUMBER_GRBL:
                err, epos, eend = E_LINE_NUMBER, wpos[L_N], wend[L_N]
            elif not present[L_F]:
                err, epos, eend = E_UNDEFINED_FEED, ls, le
            elif dwell and not present[L_P]:
                err, detail, epos, eend = E_MISSING_VALUE, D_DWELL_P, gcol_nonmodal, gend_nonmodal
            elif axis_words and val[L_F] == 0:
                err, epos, eend = E_UNDEFINED_FEED, wpos[L_F], wend[L_F]
            for letter in (L_I, L_J, L_K, L_L, L_P, L_R, L_S, L_T):
                if present[letter] and not (letter == L_P and dwell) and (
                        err == OK or (err == E_UNUSED and wpos[letter] < epos)):
                    err, detail, epos, eend = E_UNUSED, D_JOG_WORD, wpos[letter], wend[letter]
            if err == OK and (jog_refused >= 0 or nm > 0):
                err, detail, epos, eend = E_INVALID_JOG, D_JOG_COMMAND, ls, le
                if jog_refused >= 0:
                    epos, eend = g_pos[jog_refused], g_end[jog_refused]
                if nm > 0 and (jog_refused < 0 or m_pos[0] < epos):
                    epos, eend = m_pos[0], m_end[0]
        else:
            for letter in (L_I, L_J, L_K, L_P, L_R, L_S, L_T):
                if present[letter] and (err == OK or wpos[letter] < epos):
                    err, detail, epos, eend = E_UNUSED, D_JOG_WORD, wpos[letter], wend[letter]
            if err == OK and present[L_N]:
                nv = val[L_N]
                if nv < 0 or nv > MAX_LINE_NUMBER or nv != math.floor(nv):
                    err, epos, eend = E_LINE_NUMBER, wpos[L_N], wend[L_N]
        if err == OK:
            if not present[L_F]:
                err, epos, eend = E_UNDEFINED_FEED, ls, le
            elif val[L_F] < 0:
                err, epos, eend = E_NEGATIVE, wpos[L_F], wend[L_F]
            else:
                jog_feed = val[L_F] * scale * opt.feed_scale
                for a in range(3):
                    if present[L_X + a]:
                        v = val[L_X + a] * scale
                        target[a] = v if absolute_new or machine_coords else pos[a] + v
                    else:
                        target[a] = pos[a]
                if axis_words:
                    moving = True
                    move_kind = LINE
                    for a in range(3):
                        if err == OK and not _in_range(target[a]):
                            err, epos, eend = E_OUT_OF_RANGE, wpos[L_X + a], wend[L_X + a]
    if err == OK and not is_system and not is_jog:
        if present[L_N]:
            nv = val[L_N]
            if opt.grbl_verdicts:     # GRBL keeps N's whole part (negative: error 4)
                if math.floor(nv) > MAX_LINE_NUMBER_GRBL:
                    err, epos, eend = E_LINE_NUMBER, wpos[L_N], wend[L_N]
            elif nv < 0 or nv > MAX_LINE_NUMBER or nv != math.floor(nv):
                err, epos, eend = E_LINE_NUMBER, wpos[L_N], wend[L_N]
        if err == OK and present[L_F]:
            if val[L_F] < 0:
                err, epos, eend = E_NEGATIVE, wpos[L_F], wend[L_F]
            else:
                feed_new = val[L_F] * scale * opt.feed_scale
        if inverse_new or (inverse and not present[L_F]):
            # G93: F is 1/min of each feed move, not modal; back in G94 the feed is
            # undefined until an F word (GRBL).
            feed_new = 0.0
        feed_ok = (present[L_F] != 0 and val[L_F] > 0) if inverse_new else feed_new > 0
        if err == OK and present[L_T]:
            if val[L_T] < 0:
                err, epos, eend = E_NEGATIVE, wpos[L_T], wend[L_T]
            elif val[L_T] > opt.max_tool:
                err, epos, eend = E_MAX_VALUE, wpos[L_T], wend[L_T]
        if err == OK and present[L_S]:
            if val[L_S] < 0:
                err, epos, eend = E_NEGATIVE, wpos[L_S], wend[L_S]
            elif m_record < 0:        # S of M104/M140/… is a temperature, not power
                power_new = val[L_S]
        if err == OK and (dwell or lookahead):
            if not present[L_P]:
                err, epos, eend = E_MISSING_VALUE, gcol_nonmodal, gend_nonmodal
                detail = D_DWELL_P if dwell else D_LOOKAHEAD_P
            elif val[L_P] < 0:
                err, epos, eend = E_NEGATIVE, wpos[L_P], wend[L_P]
            elif dwell:
                dwell_s = val[L_P] * opt.dwell_scale
            else:
                lookahead_p = val[L_P]
        # ---- offsets: G10, G92, G43.1 take the axis words as values, not a target
        for a in range(3):
            g92_new[a] = g92[a]
            new_sys[a] = 0.0
        tlo_new = tlo
        set_sys = -1
        homing = nonmodal == 280 or nonmodal == 300
        axis_taken = nonmodal == 100 or nonmodal == 920 or tlo_cmd == 431
        if err == OK and (axis_taken or homing or tlo_cmd != 0) and motion_new >= 0 \
                and motion_new != 80:
            err, epos, eend = E_AXIS_CONFLICT, gcol_motion, gend_motion
        if err == OK and nonmodal == 100:                         # G10 L2 / L20
            p_word = val[L_P] if present[L_P] else 0.0
            l_word = val[L_L] if present[L_L] else 0.0
            if opt.grbl_verdicts:
                # GRBL: P and L by their whole part, a missing one is 0; only both missing
                # is error 28 (G10 L2 X1 sets the active system, G10 P1 X1 is L0: error 20)
                p_word = math.floor(p_word)
                l_word = math.floor(l_word) if l_word >= 0 else math.ceil(l_word)
            if not axis_words:
                err, epos, eend = E_NO_AXIS_WORDS, gcol_nonmodal, gend_nonmodal
            elif not (present[L_L] and present[L_P]) and not (
                    opt.grbl_verdicts and (present[L_L] or present[L_P])):
                err, detail, epos, eend = E_MISSING_VALUE, D_G10_LP, gcol_nonmodal, gend_nonmodal
            elif p_word != math.floor(p_word) or p_word > 6:
                err, epos, eend = E_COORD_SYS, wpos[L_P], wend[L_P]
            elif l_word != 2 and l_word != 20:
                err, detail, epos, eend = E_UNSUPPORTED, D_G10_L, gcol_nonmodal, gend_nonmodal
                if present[L_L]:
                    epos, eend = wpos[L_L], wend[L_L]
            elif l_word == 2 and present[L_R]:
                err, detail, epos, eend = E_UNSUPPORTED, D_G10_R, wpos[L_R], wend[L_R]
            else:
                set_sys = coord_new if p_word == 0 else int(p_word) - 1
                for a in range(3):
                    new_sys[a] = wcs[set_sys, a]
                    if present[L_X + a]:
                        v = val[L_X + a] * scale
                        if l_word == 20:     # the current position becomes v
                            new_sys[a] = pos[a] - g92[a] - v - (tlo if a == 2 else 0.0)
                        else:
                            new_sys[a] = v
                    if not _in_range(new_sys[a]):
                        err, epos, eend = E_OUT_OF_RANGE, gcol_nonmodal, gend_nonmodal
        elif err == OK and nonmodal == 920:                       # G92
            if not axis_words and not present[L_E]:
                err, epos, eend = E_NO_AXIS_WORDS, gcol_nonmodal, gend_nonmodal
            for a in range(3):
                if present[L_X + a]:
                    v = val[L_X + a] * scale
                    g92_new[a] = pos[a] - wcs[coord_new, a] - v - (tlo if a == 2 else 0.0)
                    if err == OK and not _in_range(g92_new[a]):
                        err, epos, eend = E_OUT_OF_RANGE, wpos[L_X + a], wend[L_X + a]
        elif err == OK and nonmodal == 921:                       # G92.1
            for a in range(3):
                g92_new[a] = 0.0
        if err == OK and tlo_cmd == 431:                          # G43.1 Z: dynamic TLO
            if not present[L_Z] or present[L_X] or present[L_Y]:
                err, epos, eend = E_G43_AXIS, gcol_tlo, gend_tlo
            else:
                tlo_new = val[L_Z] * scale
        elif err == OK and tlo_cmd == 490:                        # G49
            tlo_new = 0.0
        for a in range(3):
            offs[a] = wcs[coord_new, a] + g92_new[a]
        offs[2] += tlo_new
        if err == OK and machine_coords and not (motion_mode == 0 or motion_mode == 1):
            err, epos, eend = E_G53_MOTION, gcol_nonmodal, gend_nonmodal
        if err == OK and not axis_taken and (motion_new >= 0 or axis_words or homing):
            for a in range(3):
                if present[L_X + a]:
                    v = val[L_X + a] * scale
                    if machine_coords:
                        target[a] = v
                    elif absolute_new:
                        target[a] = v + offs[a]
                    else:
                        target[a] = pos[a] + v
                else:
                    target[a] = pos[a]
            if homing:
                # G28/G30: rapid to the target (if any axis word), then to the stored
                # position on the named axes (all axes when none is named). Marlin's G28
                # homes: the named axes (or all) end at machine 0.
                nhome = 0
                if axis_words and not opt.home_is_origin:
                    for a in range(3):
                        inter[a] = target[a]
                    nhome = 1
                for a in range(3):
                    named = present[L_X + a] != 0 or not axis_words
                    if opt.home_is_origin:
                        final[a] = 0.0 if named else pos[a]
                    elif not named:
                        final[a] = pos[a]
                    else:
                        final[a] = home28[a] if nonmodal == 280 else home30[a]
                nhome += 1
                for a in range(3):
                    if err == OK and not (_in_range(inter[a]) and _in_range(final[a])):
                        err, epos, eend = E_OUT_OF_RANGE, gcol_nonmodal, gend_nonmodal
                if err != OK:
                    nhome = 0
            elif motion_mode == 80:
                if axis_words:
                    err, epos, eend = E_AXIS_EXIST, gcol_motion, gend_motion
            elif motion_mode >= 382:                                  # G38.2 … G38.5
                same = True
                for a in range(3):
                    same = same and target[a] == pos[a]
                if not axis_words:
                    err, epos, eend = E_NO_AXIS_WORDS, gcol_motion, gend_motion
                elif not feed_ok:
                    err, epos, eend = E_UNDEFINED_FEED, gcol_motion, gend_motion
                elif same:
                    err, detail, epos, eend = E_INVALID_ARC, D_PROBE_TARGET, gcol_motion, gend_motion
                else:
                    moving = True
                    probing = True
                    move_kind = LINE
            elif motion_mode == 0 or motion_mode == 1:
                if not axis_words:
                    if opt.require_axis_words and motion_new >= 0:
                        err, epos, eend = E_NO_AXIS_WORDS, gcol_motion, gend_motion
                elif motion_mode == 1 and not feed_ok:
                    err, epos, eend = E_UNDEFINED_FEED, gcol_motion, gend_motion
                else:
                    moving = True
                    move_kind = RAPID if motion_mode == 0 else LINE
            else:
                a0 = _PLANE_AXES[plane_new, 0]
                a1 = _PLANE_AXES[plane_new, 1]
                lin = _PLANE_AXES[plane_new, 2]
                in_plane = bool(present[L_X + a0] or present[L_X + a1])
                if not feed_ok:
                    err, epos, eend = E_UNDEFINED_FEED, gcol_motion, gend_motion
                elif opt.grbl_verdicts and not in_plane:   # GRBL: before the centre
                    err, epos, eend = (E_NO_PLANE_AXIS if axis_words else E_NO_AXIS_WORDS,
                                       gcol_motion, gend_motion)
                elif present[L_R]:
                    r = val[L_R] * scale
                    dx = target[a0] - pos[a0]
                    dy = target[a1] - pos[a1]
                    q = math.sqrt(dx * dx + dy * dy)
                    if not in_plane:
                        err, epos, eend = E_NO_PLANE_AXIS, gcol_motion, gend_motion
                    elif q <= 1e-9:
                        err, detail, epos, eend = E_INVALID_ARC, D_R_FULL_CIRCLE, wpos[L_R], wend[L_R]
                    else:
                        h2 = r * r - 0.25 * q * q
                        if h2 < 0.0:
                            if 0.5 * q - abs(r) <= opt.arc_r_tol:
                                h2 = 0.0
                            else:
                                err, detail, epos, eend = (E_ARC_RADIUS if opt.grbl_verdicts
                                                           else E_INVALID_ARC), D_R_TOO_SMALL, wpos[L_R], wend[L_R]
                                aux0, aux1 = abs(r), 0.5 * q
                        if err == OK:
                            h = math.sqrt(h2)
                            # Centre left of the chord for a short CCW arc; R < 0 or CW flips it.
                            left = (motion_mode == 3) != (r < 0)
                            sgn = 1.0 if left else -1.0
                            ctr[a0] = 0.5 * (pos[a0] + target[a0]) - sgn * h * dy / q
                            ctr[a1] = 0.5 * (pos[a1] + target[a1]) + sgn * h * dx / q
                            ctr[lin] = pos[lin]
                            moving = True
                else:
                    io0 = L_I + a0
                    io1 = L_I + a1
                    if not (present[io0] or present[io1]):
                        err, epos, eend = E_NO_OFFSET, gcol_motion, gend_motion
                    elif arc_absolute_new and not (present[io0] and present[io1]):
                        err, detail, epos, eend = E_NO_OFFSET, D_ABS_CENTRE, gcol_motion, gend_motion
                    elif not in_plane and not opt.full_circle_ok:
                        err, epos, eend = E_NO_PLANE_AXIS, gcol_motion, gend_motion
                    else:
                        o0 = val[io0] * scale if present[io0] else 0.0
                        o1 = val[io1] * scale if present[io1] else 0.0
                        if arc_absolute_new:
                            ctr[a0] = o0
                            ctr[a1] = o1
                        else:
                            ctr[a0] = pos[a0] + o0
                            ctr[a1] = pos[a1] + o1
                        ctr[lin] = pos[lin]
                        r0 = math.hypot(pos[a0] - ctr[a0], pos[a1] - ctr[a1])
                        r1 = math.hypot(target[a0] - ctr[a0], target[a1] - ctr[a1])
                        dr = abs(r1 - r0)
                        if r0 <= 1e-9 and opt.grbl_verdicts and dr <= opt.arc_tol_abs:
                            # GRBL 1.1h: a circle of radius 0 whose end is within the
                            # tolerance of it is accepted; it goes straight to its end
                            zero_arc = True
                            moving = target[0] != pos[0] or target[1] != pos[1] \
                                or target[2] != pos[2]
                            move_kind = LINE
                        elif r0 <= 1e-9:
                            err, detail, epos, eend = E_INVALID_ARC, D_ZERO_RADIUS, gcol_motion, gend_motion
                        elif dr > opt.arc_tol_abs and dr > opt.arc_tol_rel * r0:
                            err, detail, epos, eend = E_INVALID_ARC, D_RADIUS_MISMATCH, gcol_motion, gend_motion
                            aux0, aux1 = r0, r1
                        else:
                            moving = True
                if moving and not zero_arc:
                    move_kind = ARC_CW if motion_mode == 2 else ARC_CCW
        # The feed of this move: modal, or (G93) the move's length × F.
        move_feed = feed_new
        if err == OK and moving and inverse_new and move_kind != RAPID:
            length = 0.0
            if move_kind >= ARC_CW:
                a0 = _PLANE_AXES[plane_new, 0]
                a1 = _PLANE_AXES[plane_new, 1]
                lin = _PLANE_AXES[plane_new, 2]
                r0 = math.hypot(pos[a0] - ctr[a0], pos[a1] - ctr[a1])
                t0 = math.atan2(pos[a1] - ctr[a1], pos[a0] - ctr[a0])
                t1 = math.atan2(target[a1] - ctr[a1], target[a0] - ctr[a0])
                sweep = (t0 - t1) if move_kind == ARC_CW else (t1 - t0)
                while sweep <= 1e-12:
                    sweep += 2.0 * math.pi
                length = math.hypot(r0 * sweep, target[lin] - pos[lin])
            else:
                for a in range(3):
                    length += (target[a] - pos[a]) ** 2
                length = math.sqrt(length)
            move_feed = val[L_F] * length
        # Positions beyond MAX_ABS_VALUE (e.g. accumulated by G91) or not finite.
        if err == OK and moving:
            for a in range(3):
                if err == OK and not (_in_range(target[a])
                                     and (move_kind < ARC_CW or _in_range(ctr[a]))):
                    err, epos, eend = E_OUT_OF_RANGE, gcol_motion, gend_motion
                    if present[L_X + a]:
                        epos, eend = wpos[L_X + a], wend[L_X + a]
        # Value words no command used.
        if err == OK:
            arc_r = moving and move_kind >= ARC_CW and present[L_R] != 0
            arc_ijk = (moving and move_kind >= ARC_CW and not present[L_R]) or zero_arc
            for letter in (L_I, L_J, L_K, L_R, L_P, L_L):
                if not present[letter]:
                    continue
                used = False
                if letter == L_R:
                    used = arc_r
                elif letter == L_P:
                    used = dwell or lookahead or nonmodal == 100
                elif letter == L_L:
                    used = nonmodal == 100
                else:
                    used = arc_ijk
                if not used and (err == OK or wpos[letter] < epos):
                    err, epos, eend = E_UNUSED, wpos[letter], wend[letter]

    # the decision, as one tuple (see CHECKED_ROW)
    return (err, detail, epos, eend, aux0, aux1, groups, motion_new, motion_mode, nonmodal,
        dwell, lookahead, dwell_s, lookahead_p, plane_new, inches_new, absolute_new,
        arc_absolute_new, inverse_new, stop, laser_new, coolant, m_record, machine_coords,
        axis_words, tlo_cmd, coord_new, set_sys, tlo_new, feed_new, power_new, jog_feed,
        move_feed, moving, probing, nhome, move_kind)


@jit(inline="always")
def _commit(buf, rows, recs, nrows, nrec, ls, le, lineno, is_system, is_jog, decision, w, d, m,
            motion, plane, inches, absolute, arc_absolute, feed, power, laser, inverse, coord,
            tlo, cool):
    """Phase 3 of :func:`interpret`, the commit: line ``[ls, le)`` (number ``lineno``) that
    the check accepted does what ``decision`` (:func:`_check`'s tuple) and ``d`` (its
    :data:`CHECKED_ROW` vectors) say: moves appended to ``rows`` from ``nrows`` on, records
    to ``recs`` from ``nrec`` on (both already large enough), the modal state's vectors in
    ``m`` (:data:`OFFSETS_ROW`) updated in place; ``w`` is the line's words (an M104's S).

    Returns (nrows, nrec, then the modal scalars after the line, in the order taken).
    """
    val, present = w.val, w.present
    pos, wcs, g92, home28, home30 = m.pos, m.wcs, m.g92, m.home28, m.home30
    target, ctr, offs, g92_new, new_sys = d.target, d.ctr, d.offs, d.g92_new, d.new_sys
    inter, final, nan3 = d.inter, d.final, d.nan3
    (err, detail, epos, eend, aux0, aux1, groups, motion_new, motion_mode, nonmodal, dwell,
        lookahead, dwell_s, lookahead_p, plane_new, inches_new, absolute_new, arc_absolute_new,
        inverse_new, stop, laser_new, coolant, m_record, machine_coords, axis_words, tlo_cmd,
        coord_new, set_sys, tlo_new, feed_new, power_new, jog_feed, move_feed, moving, probing,
        nhome, move_kind) = decision
    if is_system:
        s0 = ls
        while _is_space(buf[s0]):
            s0 += 1
        s1 = le
        while s1 > s0 and _is_space(buf[s1 - 1]):
            s1 -= 1
        nrec = _put_record(recs, nrec, lineno, REC_SYSTEM, s0, s1, np.nan, nrows)
    elif is_jog:
        nrec = _put_record(recs, nrec, lineno, REC_JOG, ls, le, jog_feed, nrows)
        if moving:
            # A jog runs as a G1 with the spindle/laser state in effect (GRBL's jog).
            nrows = _put_row(rows, nrows, LINE, pos, target, nan3, 17 + plane, jog_feed,
                             power, laser, 0.0, lineno, offs)
            for a in range(3):
                pos[a] = target[a]
    else:
        feed = feed_new
        power = power_new
        laser = laser_new
        inverse = inverse_new
        coord = coord_new
        tlo = tlo_new
        for a in range(3):
            g92[a] = g92_new[a]
            if set_sys >= 0:
                wcs[set_sys, a] = new_sys[a]
            if nonmodal == 281:
                home28[a] = pos[a]
            elif nonmodal == 301:
                home30[a] = pos[a]
        if coolant >= 0:
            nrec = _put_record(recs, nrec, lineno, REC_COOLANT, ls, le, float(coolant),
                               nrows)
            if coolant == 9:
                cool = 0
            elif coolant == 7 or coolant == 8:
                cool |= 1 << (coolant - 7)
        if m_record >= 0:
            nrec = _put_record(recs, nrec, lineno, REC_PRINTER, ls, le,
                               val[L_S] if present[L_S] else np.nan, nrows)
        if dwell:
            nrows = _put_row(rows, nrows, DWELL, pos, pos, nan3, 17 + plane, feed, power,
                             laser, dwell_s, lineno, offs)
        if lookahead:
            nrec = _put_record(recs, nrec, lineno, REC_LOOKAHEAD, ls, le, lookahead_p,
                               nrows)
        plane = plane_new
        inches = inches_new
        absolute = absolute_new
        arc_absolute = arc_absolute_new
        if motion_new >= 0:
            motion = motion_new
        if nhome == 2:
            nrows = _put_row(rows, nrows, RAPID, pos, inter, nan3, 17 + plane, feed, power,
                             laser, 0.0, lineno, offs)
            for a in range(3):
                pos[a] = inter[a]
        if nhome >= 1:
            nrows = _put_row(rows, nrows, RAPID, pos, final, nan3, 17 + plane, feed, power,
                             laser, 0.0, lineno, offs)
            for a in range(3):
                pos[a] = final[a]
        if moving:
            if probing:
                nrec = _put_record(recs, nrec, lineno, REC_PROBE, ls, le,
                                   motion_mode / 10.0, nrows)
            nrows = _put_row(rows, nrows, move_kind,
                             pos, target, ctr if move_kind >= ARC_CW else nan3,
                             17 + plane, move_feed, power,
                             LASER_OFF if probing else laser,   # GRBL: beam off unless G1/G2/G3
                             0.0, lineno, offs)
            for a in range(3):
                pos[a] = target[a]
        if stop >= 0:
            stop_kind = REC_PAUSE if stop == 0 else (
                REC_OPTIONAL_PAUSE if stop == 1 else REC_END)
            nrec = _put_record(recs, nrec, lineno, stop_kind, ls, le, float(stop), nrows)
            if stop == 2 or stop == 30:
                # GRBL's program-end reset: G1 G17 G90 G94 G54 M5 M9 (G92 stays).
                motion = 1
                plane = 0
                absolute = True
                laser = LASER_OFF
                inverse = False
                coord = 0
                cool = 0
    return (nrows, nrec, motion, plane, inches, absolute, arc_absolute, feed, power, laser,
        inverse, coord, tlo, cool)



def _interpret_work(buf, options, lenient, max_errors, trace):
    # as Python on cncjs's tball job (5,000 and 20,000 lines): 1.0-1.3 µs a byte, 5.2-7.3 µs
    # with every line's state recorded (5.3-5.6 times as much)
    return len(buf) * (6 if trace else 1)


# bytes of text: 1.2-1.7 µs each as Python; numba and the parser's cached code load in ~1 s
# (labkit check, info, preview: Python and compiled meet near 35,000 lines, 770 kB, of that job)
@jit(python_below=750_000, work=_interpret_work)
def interpret(buf, options, lenient, max_errors, trace):
    """Interpret G-code bytes from the modal state ``options.start``; returns an
    :class:`Interpretation`.

    ``options`` is a :class:`labkit.gcode.reader.ParseOptions` (the dialect's settings, read
    by name). ``options.line_limit`` > 0 rejects a line with more significant characters
    (not spaces, comments or ``/``) than a controller's line buffer holds (GRBL error 11).
    ``lenient`` goes on after a rejected line; at most ``max_errors`` diagnostics are kept
    (``error_total`` counts them all); ``trace`` records the modal state after every line.
    ``options.start`` is a one-row :data:`TRACE_ROW` array (:func:`initial_state`: GRBL's
    power-on state); the state after the last line is returned as ``final``.
    """
    n = buf.shape[0]
    nlines_est = 1
    for k in range(n):
        if buf[k] == 10:
            nlines_est += 1
    cap = min(nlines_est + 8, 4096)      # grows by doubling: no big reservation up front

    rows = np.empty(cap, MOVE_ROW)
    nrows = 0
    ecap = 16
    errs = np.empty(ecap, ERROR_ROW)
    nerr = 0
    nerr_total = 0
    rcap = 16
    recs = np.empty(rcap, RECORD_ROW)
    nrec = 0
    states = np.zeros(nlines_est if trace else 0, TRACE_ROW)

    # Modal state, from where the options say the controller is.
    s0 = options.start[0]
    modal = _new_offsets()
    # The dialect's settings the check reads, as one record (code lists as tables: every
    # dialect's codes are below 1000; of lists naming the same M code the first wins, as
    # in the check's order of tests before).
    opts = _new_dialect()
    o = opts[0]
    o.feed_scale, o.dwell_scale = options.feed_scale, options.dwell_scale
    o.max_tool, o.arc_r_tol = options.max_tool, options.arc_r_tol
    o.arc_tol_abs, o.arc_tol_rel = options.arc_tol_abs, options.arc_tol_rel
    o.full_circle_ok, o.require_axis_words = options.full_circle_ok, options.require_axis_words
    o.home_is_origin, o.grbl_verdicts = options.home_is_origin, options.grbl_verdicts
    for k in range(options.g_codes_ok.shape[0]):
        if 0 <= options.g_codes_ok[k] < 1000:
            o.g_ok[options.g_codes_ok[k]] = 1
    for kind, codes in ((4, options.record_m_codes), (3, options.coolant_codes),
                        (2, options.laser_off_codes), (1, options.laser_on_codes)):
        for k in range(codes.shape[0]):
            if 0 <= codes[k] < 1000:
                o.m_kind[codes[k]] = kind
    dec = _new_checked()       # the check's vectors for the line
    # Views that hold no reference to ``modal`` and ``dec``: the check is handed
    # ``modal[0]`` and ``dec[0]`` on every line, which keeps both alive (as ``words``).
    pos, wcs, g92, home28, home30 = (modal[0].pos, modal[0].wcs, modal[0].g92, modal[0].home28,
                                     modal[0].home30)
    target, ctr, offs, g92_new = dec[0].target, dec[0].ctr, dec[0].offs, dec[0].g92_new
    new_sys, inter, final, nan3 = dec[0].new_sys, dec[0].inter, dec[0].final, dec[0].nan3
    for a in range(3):
        pos[a] = s0.position[a]
        g92[a] = s0.g92[a]
        home28[a] = s0.home28[a]
        home30[a] = s0.home30[a]
        for k in range(6):
            wcs[k, a] = s0.coord_origins[k, a]
    motion = int(s0.motion)       # 0-3, 80, or 382-385 (G38.2-G38.5)
    plane = int(s0.plane) - 17    # index into _PLANE_AXES: 0 G17, 1 G18, 2 G19
    inches = s0.units == 20
    absolute = s0.distance == 90
    arc_absolute = s0.arc_distance == 90.1
    feed = s0.feed_mm_min if s0.feed_mm_min > 0 else 0.0   # mm/min; 0 = undefined
    power = s0.s_word
    laser = int(s0.laser)
    inverse = s0.feed_mode == 93  # G93 inverse time
    coord = int(s0.coord_system) - 54
    tlo = s0.tool_offset  # G43.1 dynamic tool length offset (Z), mm
    cool = s0.coolant     # bit 0 M7, bit 1 M8

    # Per-line word storage: one record the scan fills. Its fields are views that hold no
    # reference to ``words``: the scan is handed ``words[0]`` on every line, which keeps
    # ``words`` alive as long as they are used (numba frees an array after its last use).
    words = _new_words()
    present, val, wpos, wend = words[0].present, words[0].val, words[0].wpos, words[0].wend
    letters = 0           # the letters the dialect takes, bit k for letter A + k
    for k in range(26):
        if options.letters_ok[k]:
            letters |= 1 << k
    g_pos, g_end, m_pos, m_end = words[0].g_pos, words[0].g_end, words[0].m_pos, words[0].m_end
    g_val, m_val = words[0].g_val, words[0].m_val
    nan3[:] = np.nan

    ls = 0
    lineno = 0
    while ls <= n:
        # Line bounds [ls, le).
        le = ls
        while le < n and buf[le] != 10:
            le += 1
        lineno += 1
        line_syncs = False
        line_axes = False
        line_motion = False
        line_offsets = False
        line_units = False
        line_distance = False
        line_coords = False
        line_machine = False

        # ---- phase 1: scan (the controller's line buffer, then the words) ----------
        err, detail, epos, eend, aux0, aux1, is_system, is_jog, ng, nm = _scan(
            buf, ls, le, words[0], letters, options.line_limit, options.grbl_verdicts,
            options.grbl_streamed, options.max_tool)

        # ---- phase 2: check and compute (the decision: a tuple, vectors in ``dec[0]``)
        decision = _check(words[0], dec[0], modal[0], ls, le, err, detail, epos, eend, aux0,
                          aux1, is_system, is_jog, ng, nm, opts[0], motion, plane, inches,
                          absolute, arc_absolute, feed, power, laser, inverse, coord, tlo)
        (err, detail, epos, eend, aux0, aux1, groups, motion_new, motion_mode, nonmodal, dwell,
            lookahead, dwell_s, lookahead_p, plane_new, inches_new, absolute_new,
            arc_absolute_new, inverse_new, stop, laser_new, coolant, m_record, machine_coords,
            axis_words, tlo_cmd, coord_new, set_sys, tlo_new, feed_new, power_new, jog_feed,
            move_feed, moving, probing, nhome, move_kind) = decision
        if err != OK:
            nerr_total += 1
        if err != OK and nerr < max_errors:
            if nerr == ecap:
                ecap *= 2
                errs = _grow(errs, ecap)
            e = errs[nerr]
            e.line = lineno
            e.pos = epos
            e.end = eend
            e.code = err
            e.detail = detail
            e.aux[0] = aux0
            e.aux[1] = aux1
            nerr += 1
        if err != OK:
            if not lenient:
                break
        else:
            # ---- phase 3: commit ---------------------------------------------------
            nnew = (1 if dwell else 0) + (1 if moving else 0) + nhome
            if nrows + nnew > cap:
                cap = 2 * cap + nnew
                rows = _grow(rows, cap)
            nrec_new = (1 if is_system else 0) + (1 if is_jog else 0) + (1 if lookahead else 0) \
                + (1 if coolant >= 0 else 0) + (1 if stop >= 0 else 0) + (1 if probing else 0) \
                + (1 if m_record >= 0 else 0)
            if nrec + nrec_new > rcap:
                rcap = 2 * rcap + nrec_new
                recs = _grow(recs, rcap)
            (nrows, nrec, motion, plane, inches, absolute, arc_absolute, feed, power, laser,
                inverse, coord, tlo, cool) = _commit(buf, rows, recs, nrows, nrec, ls, le,
                lineno, is_system, is_jog, decision, words[0], dec[0], modal[0], motion, plane,
                inches, absolute, arc_absolute, feed, power, laser, inverse, coord, tlo, cool)
        # what the line did (a rejected line did nothing)
        did = err == OK and not is_system and not is_jog
        line_syncs = did and (dwell or nonmodal == 100 or nonmodal == 280 or nonmodal == 281
                              or nonmodal == 300 or nonmodal == 301 or nonmodal == 920
                              or nonmodal == 921 or stop >= 0 or coolant >= 0
                              or (groups & (1 << M_LASER)) != 0)
        line_axes = did and axis_words
        line_motion = did and motion_new >= 0
        line_offsets = did and (nonmodal == 100 or nonmodal == 280 or nonmodal == 300
                                or nonmodal == 920 or nonmodal == 921 or tlo_cmd != 0
                                or stop == 2 or stop == 30)
        line_units = did and (groups & (1 << G_UNITS)) != 0
        line_distance = did and (groups & (1 << G_DISTANCE)) != 0
        line_coords = did and (groups & (1 << G_COORD)) != 0
        line_machine = did and machine_coords
        if trace:
            t = states[lineno - 1]
            _put_state(t, motion, plane, inches, absolute, arc_absolute, feed, power, laser, pos,
                       coord, wcs, g92, tlo, inverse, cool, home28, home30)
            _put_flags(t, line_syncs, line_axes, line_motion, line_offsets, line_units,
                       line_distance, line_coords, line_machine)
        ls = le + 1

    end_state = np.zeros(1, TRACE_ROW)
    _put_state(end_state[0], motion, plane, inches, absolute, arc_absolute, feed, power, laser, pos,
               coord, wcs, g92, tlo, inverse, cool, home28, home30)
    _put_flags(end_state[0], line_syncs, line_axes, line_motion, line_offsets, line_units,
               line_distance, line_coords, line_machine)
    return Interpretation(rows[:nrows], errs[:nerr], nerr_total, recs[:nrec],
                          states[:lineno] if trace else states, end_state)
