"""Moves → G-code text, in the dialect of the machine that will run it.

The writer keeps the modal state the controller will have and writes only
what changes: the motion word when the motion mode changes (on every motion line for a
controller without modal motion, such as stock Marlin), an axis only
when its written coordinate changes, F and S only when they change.
Numbers get the decimals the tolerance needs ([MicroCAM] §6.1.5: the
generator works out the digits from the tolerance) and no trailing zeros.

Arc offsets I J K are measured from the point actually written for the
arc's start, so rounding never makes an arc fail the controller's radius
check; arcs always state their in-plane end point, which lets GRBL accept
full circles. Reading the text back with :func:`labkit.gcode.parse`
reproduces the program within the written resolution.

Examples
--------
>>> from labkit.toolpath import MovesBuilder, LaserMode
>>> b = MovesBuilder(feed_mm_min=1200, s_word=300, laser=LaserMode.CONSTANT)
>>> b.rapid(x=5, y=5); b.line(x=15); b.line(y=15); b.arc_ccw(x=5, y=15, i=-5, j=0)
>>> print(emit(b.build(), header=False, footer=False))
M3 S300
G0 X5 Y5
G1 X15 F1200
Y15
G3 X5 Y15 I-5 J0
"""

from __future__ import annotations

import math
import textwrap

import numpy as np

from labkit import __version__
from labkit.errors import EmitError
from labkit._jit import expecting
from labkit.gcode import _emit_kernel as EK
from labkit.gcode.dialects import DIALECTS, Dialect, get_dialect
from labkit.toolpath.moves import MoveKind, Moves, check_moves
from labkit.units import s_within

__all__ = ["emit", "write_gcode", "comment_lines", "decimals_for", "format_number",
           "VALUE_DECIMALS", "LINE_CHARS"]

#: Decimals written for F, S and P values.
VALUE_DECIMALS = 4

#: A number is written from an integer count of its last decimal; above 2**53 counts a
#: float64 no longer holds every integer, so the digits written would not be the value.
_EXACT_LIMIT = 2.0 ** 53

#: Longest line labkit writes, comments included: GRBL 1.1's 80-byte line buffer holds 79
#: characters (recorded: tests/vectors/grbl/line_length.json). A comment line that short
#: fits even a sender or controller that counts comments, as GRBL's stream.py does.
LINE_CHARS = DIALECTS["grbl"].line_buffer_chars - 1

#: The header's warning for GRBL when travel is written with the beam mode still on.
GRBL_TRAVEL_WARNING = (
    "G0 travel runs with M3/M4 and S in effect: GRBL keeps the beam off on G0 only in "
    "laser mode ($32=1); with $32=0 (GRBL's default) every rapid burns. Set $32=1, "
    "or write the program with travel_beam_off=True (M5 before each rapid).")

#: Rows written at once by :func:`emit` (their integer copies and output buffer: ~35 MB).
EMIT_ROWS = 1 << 18

# Records that are written back as they were read, and what a program end resets.
_RECORD_WORD = {"pause": "M0", "optional_pause": "M1", "end": "M2"}


def decimals_for(tol_mm: float) -> int:
    """Decimals needed so that rounding stays within half of ``tol_mm``.

    Rounding to d decimals moves a coordinate by at most ½·10⁻ᵈ mm, so
    d = ⌈−log₁₀ tol⌉ keeps the written error within tol/2, leaving the other
    half of the budget to the geometry (curve flattening, arc fitting).

    >>> decimals_for(0.01), decimals_for(0.005), decimals_for(0.001), decimals_for(1.0)
    (2, 3, 3, 0)
    """
    if not tol_mm > 0:
        raise ValueError(f"tol_mm must be > 0 mm, got {tol_mm!r}")
    return max(0, math.ceil(-math.log10(tol_mm) - 1e-9))


def format_number(value: float, decimals: int) -> str:
    """A number as the emitter writes it: rounded, no trailing zeros, no ``-0``.

    >>> format_number(12.50, 3), format_number(-0.0001, 3), format_number(3.0, 2)
    ('12.5', '0', '3')
    """
    scaled = int(round(value * 10 ** decimals))
    out = np.zeros(48, np.uint8)
    used = EK._put_scaled(out, 0, scaled, decimals)
    return out[:used].tobytes().decode()


def _scaled(values, decimals, undefined=-1):
    arr = np.asarray(values, dtype=np.float64)
    out = np.round(arr * 10.0 ** decimals)
    out[~np.isfinite(arr)] = undefined
    return out.astype(np.int64)


def _record_line(rec, dialect: Dialect) -> str | None:
    if rec.kind == "system":
        return rec.text
    if rec.kind in _RECORD_WORD:
        return "M30" if rec.kind == "end" and rec.value == 30 else _RECORD_WORD[rec.kind]
    if rec.kind == "coolant":
        return f"M{int(rec.value)}"
    if rec.kind == "lookahead":
        return f"G5 P{format_number(rec.value, 0)}" if dialect.lookahead_g5 else None
    return None


def emit(moves: Moves, *, dialect: str | Dialect = "grbl", tol_mm: float = 0.001,
         arcs: str = "ijk", header: bool = True, footer: bool = True,
         comment: str | None = None, travel_beam_off: bool | None = None,
         compact: bool = False) -> str:
    """Write a program as G-code text.

    Parameters
    ----------
    moves : Moves
        The program (positions in mm, feeds in mm/min, dwells in s).
    dialect : str or Dialect
        Target controller: ``"grbl"``, ``"labkit-fw"`` or ``"marlin"``. Sets
        the units of F and G4 P, the S range (S is rescaled from
        ``moves.s_max``), whether rapids switch the beam off by themselves
        and whether lines carry ``N`` numbers and ``*`` checksums.
    tol_mm : float
        Coordinate resolution budget, mm: coordinates get
        :func:`decimals_for` ``(tol_mm)`` decimals (at least 3 when the
        program has arcs, so that written arcs pass GRBL's radius check).
    arcs : {"ijk", "r"}
        Centre offsets (exact) or signed radius R. With ``"r"``, full circles
        and near-half circles (where R pins the centre badly) still use I J K.
    header, footer : bool
        Write the preamble (units, absolute mode, laser off) and the epilogue
        (laser off, program end).
    comment : str, optional
        A comment line for the header (e.g. what made the file).
    travel_beam_off : bool, optional
        True: write ``M5`` before every rapid made with the beam mode on, and
        ``M3``/``M4 S…`` again before the next feed move, so travel never burns
        whatever the controller's settings. False: rely on the controller
        (GRBL's laser mode, ``$32=1``, keeps the beam off on G0; the header
        says so). Default: the dialect's choice (False for grbl, True for marlin).
    compact : bool
        The fewest bytes for the same program, for long raster jobs on a serial link
        (issue 30): words without spaces (``G1X.1S868``), no ``0`` before a decimal
        point, and every straight move written absolute (G90) or relative (G91),
        whichever makes the whole text shorter (arcs stay absolute); a program left
        relative gets ``G90`` before the footer. GRBL and the labkit firmware read it;
        stock Marlin wants spaces, so it is refused there. Comments stay in the header.

    Returns
    -------
    str
        The program, one block per line, ending with a newline.

    Raises
    ------
    EmitError
        When ``moves`` is not a :class:`~labkit.toolpath.Moves` (text, a dict, …).
        For a feed move without a positive feed rate, a position, arc centre,
        power or dwell that is not finite, a power outside 0…``s_max``, or a
        coordinate too large to write exactly with the decimals in use.
    ValueError
        For an unknown option.

    Examples
    --------
    >>> from labkit.toolpath import MovesBuilder, LaserMode
    >>> b = MovesBuilder(feed_mm_min=600, s_word=500, laser=LaserMode.CONSTANT)
    >>> b.line(x=10); b.rapid(x=20); b.line(x=30)
    >>> print(emit(b.build(), header=False, footer=False, travel_beam_off=True))
    M3 S500
    G1 X10 F600
    M5
    G0 X20
    M3 S500
    G1 X30
    >>> b = MovesBuilder(feed_mm_min=600, s_word=500, laser=LaserMode.DYNAMIC)
    >>> b.rapid(x=100.5, y=0.05); b.line(x=100.6); b.line(x=100.9, s_word=200); b.line(x=100.5, s_word=0)
    >>> print(emit(b.build(), header=False, footer=False, compact=True))
    M4S500
    G91G0X100.5Y.05
    G1X.1F600
    X.3S200
    X-.4S0
    G90
    >>> b = MovesBuilder(feed_mm_min=600); b.rapid(x=1e17)
    >>> emit(b.build())
    Traceback (most recent call last):
    ...
    labkit.errors.EmitError: move 0 (generated): X 1e+17 mm cannot be written exactly with 3 decimals (largest 9.007e+12 mm); expected coordinates of a real machine
    """
    # every value is checked below, where it is written; here only that it is a program
    check_moves(moves, finite=False, error=EmitError)
    d = get_dialect(dialect)
    if arcs not in ("ijk", "r"):
        raise ValueError(f"arcs must be 'ijk' or 'r', got {arcs!r}")
    if compact and not d.modal_motion:
        raise ValueError(f"compact G-code is for controllers that read words without spaces and "
                         f"modal motion (grbl, labkit-fw), not {d.name}")
    n = len(moves)
    is_arc = moves.is_arc
    decimals = decimals_for(tol_mm)
    if is_arc.any():
        decimals = max(decimals, 3)
    _refuse_unwritable(moves, d, decimals)
    beam_off_by_controller = d.rapids_beam_off if travel_beam_off is None else not travel_beam_off

    start_i = _scaled(moves.start[0] if n else np.zeros(3), decimals)
    r_mode = np.zeros(n, np.int8)
    if arcs == "r" and is_arc.any():
        sweep = np.abs(moves.sweep_rad())
        full = sweep > 2 * math.pi - 1e-6
        near_half = np.abs(sweep - math.pi) < 0.05     # H/R < sin(0.025): the centre is ill-defined
        use_r = is_arc & ~full & ~near_half
        r_mode[use_r] = np.where(sweep[use_r] > math.pi, -1, 1)

    rec_lines, rec_rows, rec_reset = [], [], []
    for rec in moves.records:
        text = _record_line(rec, d)
        if text is not None:
            rec_lines.append(text.encode("utf-8"))
            rec_rows.append(min(rec.index, n))
            rec_reset.append(rec.kind == "end")
    rec_text = np.frombuffer(b"".join(rec_lines) or b"\0", np.uint8)
    bounds = np.cumsum([0] + [len(t) for t in rec_lines])
    rec_span = np.stack([bounds[:-1], bounds[1:]], axis=1).astype(np.int64) if rec_lines \
        else np.zeros((0, 2), np.int64)

    pre, number = _header_lines(d, comment, beam_off_by_controller) if header else ([], 1)
    fmt = EK.EmitFormat(decimals=decimals, value_decimals=VALUE_DECIMALS,
                        inline_power=bool(d.inline_power),
                        rapid_laser_off=bool(beam_off_by_controller),
                        numbered=bool(d.line_numbers), checksums=bool(d.checksums),
                        modal_motion=bool(d.modal_motion), compact=bool(compact))
    records = EK.EmitRecords(row=np.asarray(rec_rows, np.int64), text=rec_text, span=rec_span,
                             reset=np.asarray(rec_reset, np.bool_))
    # The body in blocks of rows: each block's integer columns and output buffer (~130 bytes a
    # row) live only while it is written; the writer's modal state carries across blocks.
    state = np.array([*start_i, -1, 17, -2, -1, EK.LASER_OFF, 0, 0, 0], np.int64)
    text = bytearray(_number_lines(pre, d, 1).encode("ascii"))
    centre = np.nan_to_num(moves.centre) if is_arc.any() else moves.centre   # only arcs read it
    rows = EMIT_ROWS if n > EMIT_ROWS else max(n, 1)
    # write_moves declared: the G90/G91 choice before it decides Python or compiled for both
    with expecting(emit_work(n)):
        for lo in range(0, max(n, 1), rows):
            part = slice(lo, lo + rows)
            block = EK.EmitRows(kind=moves.kind[part].astype(np.int64), end=_scaled(moves.end[part], decimals),
                                centre=np.ascontiguousarray(centre[part]),
                                plane=moves.plane[part].astype(np.int64),
                                feed=_scaled(d.feed_from_mm_min(moves.feed_mm_min[part]), VALUE_DECIMALS),
                                power=_scaled(moves.s_word[part].astype(np.float64) * (d.s_max / moves.s_max),
                                              VALUE_DECIMALS),
                                laser=moves.laser[part].astype(np.int64),
                                dwell=_scaled(d.dwell_from_s(moves.dwell_s[part]), VALUE_DECIMALS),
                                r_mode=r_mode[part].astype(np.int64))
            relative = (EK.choose_relative(block.kind, block.end, state[:3], state[10], decimals,
                                            lo + rows >= n) if compact
                        else np.zeros(len(block.kind), np.int8))
            body, number = EK.write_moves(block, state, fmt, number, records, lo, relative)
            text += memoryview(body)                 # (numpy would read += as its own addition)
            del block, body
    post = (["G90"] if state[10] else []) + (["M5", "M2"] if footer else [])
    text += _number_lines(post, d, number).encode("ascii")
    return text.decode("ascii")


def emit_work(n_moves: int) -> dict:
    """The compiled kernels :func:`emit` runs on a program of ``n_moves`` rows and the array
    elements it hands them (14 a row: the 13 columns of a block and its G90/G91 choice), as
    :func:`labkit._jit.expecting` takes them: a job that will write its moves declares the
    work before its first kernel, so that kernel decides Python or compiled for all of it.

    >>> [(k.name.rsplit(".", 1)[-1], n) for k, n in emit_work(1000).items()]
    [('write_moves', 14000)]
    """
    return {EK.write_moves: 14 * int(n_moves)}


def _where(moves: Moves, i: int) -> str:
    line = int(moves.line[i])
    return f"move {i} ({f'source line {line}' if line else 'generated'})"


def _refuse_unwritable(moves: Moves, d: Dialect, decimals: int) -> None:
    """Raise :class:`EmitError` for the first number that cannot be written truthfully."""
    limit_mm = _EXACT_LIMIT / 10.0 ** decimals
    # Each check first over the whole column without temporaries (min and max: NaN fails
    # them too); only a column that fails is searched row by row for the first culprit.
    # A photo's millions of rows pass in milliseconds instead of a second of temporaries.
    is_arc = moves.is_arc
    checks = [("", moves.end, lambda: moves.is_motion | (moves.kind == MoveKind.DWELL))]
    if len(moves):
        checks.append(("start ", moves.start[:1], lambda: np.ones(1, bool)))
    if is_arc.any():
        checks.append(("arc centre ", np.where(is_arc[:, None], moves.centre, 0.0), lambda: is_arc))
    for what, xyz, which_rows in checks:
        if not len(xyz) or (-limit_mm < xyz.min() and xyz.max() < limit_mm):
            continue
        rows = which_rows()
        bad = rows[:, None] & ~(np.abs(xyz) < limit_mm)        # catches NaN and inf too
        if bad.any():
            i, a = map(int, np.argwhere(bad)[0])
            v = float(xyz[i, a])
            why = (f"is not finite ({v})" if not math.isfinite(v) else
                   f"{v:.6g} mm cannot be written exactly with {decimals} decimals "
                   f"(largest {limit_mm:.4g} mm)")
            raise EmitError(f"{_where(moves, i)}: {what}{'XYZ'[a]} {why}; "
                            "expected coordinates of a real machine")
    feed = moves.feed_mm_min
    is_feed = moves.is_feed
    smallest = 0.5 * 10.0 ** -VALUE_DECIMALS    # anything below is written as F0
    fed = feed[is_feed]
    if len(fed) and not (d.feed_from_mm_min(fed.min()) >= smallest
                         and fed.max() < _EXACT_LIMIT / 10.0 ** VALUE_DECIMALS):
        written = d.feed_from_mm_min(feed)      # F as the dialect writes it (mm/s for labkit-fw)
        bad = is_feed & ~((written >= smallest) & (feed < _EXACT_LIMIT / 10.0 ** VALUE_DECIMALS))
        i = int(np.flatnonzero(bad)[0])
        raise EmitError(f"{_where(moves, i)} is a feed move without a feed rate the program can "
                        f"state (got {float(feed[i])!r} mm/min; F is written with "
                        f"{VALUE_DECIMALS} decimals and must not round to 0); set feed_mm_min")
    if not (moves.s_max > 0 and math.isfinite(moves.s_max)):
        raise EmitError(f"s_max must be a finite number > 0, got {moves.s_max!r}")
    power = moves.s_word
    if len(power) and not (s_within(float(power.min()), moves.s_max) and s_within(float(power.max()), moves.s_max)):
        power = power.astype(np.float64)
        bad = moves.is_motion & ~s_within(power, moves.s_max)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise EmitError(f"{_where(moves, i)}: power S {float(power[i])!r} is outside "
                            f"0…{moves.s_max:g} (s_max); expected a finite S within the laser's range")
    dwell = moves.dwell_s
    if len(dwell) and 0 <= dwell.min() and dwell.max() < 1e9:
        return
    bad = ~((dwell >= 0) & (dwell < 1e9))
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise EmitError(f"{_where(moves, i)}: dwell {float(dwell[i])!r} s; expected 0 <= dwell "
                        "< 1e9 s")


def comment_lines(text: str, width: int = LINE_CHARS) -> list[str]:
    """``text`` as ``;`` comment lines of at most ``width`` characters each.

    Long lines are wrapped at spaces (a word longer than a line is cut), so every line
    fits a controller's line buffer and a counting sender's receive buffer.

    Parameters
    ----------
    text : str
        The comment; each of its lines starts a new comment line.
    width : int
        Longest comment line in characters, ``"; "`` included (at least 3).

    Returns
    -------
    list of str
        The lines, without line ends.

    Examples
    --------
    >>> comment_lines("rows: 1 = 500 mW, 2 = 1000 mW, 3 = 1500 mW", width=24)
    ['; rows: 1 = 500 mW, 2 =', '; 1000 mW, 3 = 1500 mW']
    >>> comment_lines("first\\n\\nthird")
    ['; first', ';', '; third']
    """
    if width < 3:
        raise ValueError(f"width must be at least 3 characters ('; ' and one more), got {width!r}")
    lines = []
    for part in text.splitlines():
        pieces = textwrap.wrap(part, width - 2, break_on_hyphens=False)
        lines += [f"; {piece}" for piece in pieces] or [";"]
    return lines


def _header_lines(d: Dialect, comment, beam_off_by_controller: bool):
    lines = comment_lines(f"labkit {__version__}, dialect {d.name}")
    if comment:
        lines += comment_lines(comment)
    if d.name == "grbl" and beam_off_by_controller:
        lines += comment_lines(GRBL_TRAVEL_WARNING)
    elif not beam_off_by_controller:
        lines += comment_lines("travel: M5 before every rapid, M3/M4 again before the next cut")
    lines += ["G21 G90", "M5"]
    numbered = sum(1 for line in lines if not line.startswith(";"))
    return lines, 1 + numbered


def _number_lines(lines, d: Dialect, first: int) -> str:
    out, number = [], first
    for line in lines:
        if line.startswith(";") or not (d.line_numbers or d.checksums):
            out.append(line)
            continue
        if d.line_numbers:
            line = f"N{number} {line}"
            number += 1
        if d.checksums:
            x = 0
            for b in line.encode("ascii"):
                x ^= b
            line = f"{line}*{x}"
        out.append(line)
    return "".join(f"{line}\n" for line in out)


def write_gcode(path, moves: Moves, **options) -> int:
    """Write :func:`emit` ``(moves, **options)`` to ``path``; returns the number of lines.

    The text goes to a temporary file that replaces ``path`` only when complete
    (:func:`labkit._files.atomic_output`): a full disk or Ctrl-C leaves the old file or none.
    """
    from labkit._files import atomic_output

    text = emit(moves, **options)
    with atomic_output(path, "w", encoding="ascii", newline="\n") as fh:
        fh.write(text)
    return text.count("\n")
