"""Bresenham interpolation: lines and circular arcs on the step lattice.

A controller can only move each motor a whole step at a time, so a straight
line or an arc in millimetres becomes a staircase of lattice points, one
*tick* of the step timer apart. Everything here is integer arithmetic on
positions in steps (see :func:`labkit.motion.blocks.to_steps` for mm → steps).

Integer semantics (what the firmware must reproduce)
----------------------------------------------------
Line from S to E, Δ_i = E_i − S_i, N = max |Δ_i| ticks. The *driver* is the
axis with the largest |Δ| (the first one on ties, X before Y before Z); it
steps every tick. Every axis i keeps ``err_i = 2·|Δ_i| − N``; at each tick
k = 1…N, axis i steps (towards E) when ``err_i ≥ 0`` and then
``err_i −= 2N``; afterwards ``err_i += 2·|Δ_i|``. In closed form the offset
after tick k is ``floor((2·k·|Δ_i| + N) / (2N))``: the exact position
``k·|Δ_i|/N`` rounded to the nearest step, halves rounded away from S.
The lattice points are identical to :func:`skimage.draw.line` (which rounds
halves the same way); note that reversing a line can change which of two
equally near points a tie picks.

Direction bits: bit i is set when axis i moves in the negative direction
(GRBL's convention), see :func:`direction_bits`.

Arcs ([CBR40] §J) walk the circle octant by octant: in each octant the axis
along which the circle runs faster is the driver and steps every tick, the
other is driven and steps only when that brings the point closer to the
circle, comparing the integer error e = x² + y² − r² of the candidates
([CBR40] eq. 4: step x when |e(x−1, y+1)| < |e(x, y+1)|). Details in
:func:`arc_lattice_points`.
"""

from __future__ import annotations

import math

import numpy as np

from labkit.budget import check_budget
from labkit.errors import MotionError
from labkit.motion import _bresenham as K

__all__ = [
    "line_points",
    "line_steps",
    "lines_points",
    "lines_points_closed_form",
    "direction_bits",
    "arc_lattice_points",
    "circle_points",
    "steps_from_points",
    "arc_octants",
    "ARC_SCALE",
    "MIN_ARC_RADIUS_STEPS",
]

#: Fixed-point sub-steps per step for an arc's centre and radius (2⁸).
ARC_SCALE = 256

#: Largest (radius + 4) × scale (fixed-point sub-steps) for which X² + Y² − R² stays exact
#: in int64 near the circle (√(2⁶³) ≈ 3.04e9); larger radii walk with fewer sub-steps.
_MAX_FIXED_RADIUS = 3_000_000_000

#: Arcs with a smaller radius (in steps) are drawn as a line to the end point.
MIN_ARC_RADIUS_STEPS = 2


def _as_lattice(name, value, dims=None) -> np.ndarray:
    arr = np.asarray(value)
    if arr.ndim != 1 or (dims is not None and arr.shape[0] != dims) or arr.shape[0] not in (2, 3):
        want = f"{dims} integers" if dims else "2 or 3 integers"
        raise MotionError(f"{name} must be a point of {want} (steps), got shape {arr.shape}")
    if arr.dtype.kind == "f":
        if not np.all(np.isfinite(arr)) or not np.all(arr == np.round(arr)):
            raise MotionError(f"{name} must hold whole steps, got {arr.tolist()}")
    elif arr.dtype.kind not in "iu":
        raise MotionError(f"{name} must hold integers (steps), got dtype {arr.dtype}")
    return arr.astype(np.int64)


def line_points(start, end) -> np.ndarray:
    """Lattice points of the Bresenham line from ``start`` to ``end``, both included.

    Parameters
    ----------
    start, end : array_like of 2 or 3 ints
        Positions in steps.

    Returns
    -------
    ndarray of int64, shape (N + 1, d)
        One row per tick, N = max |Δ| (the driver axis' step count).

    Notes
    -----
    The sequential integer-error form of [CBR40] §I (eq. 3 multiplied by the
    driver's Δ to avoid the division); the module docstring gives the exact
    rule. :func:`lines_points` computes the same points in closed form for
    many lines at once.

    Examples
    --------
    >>> line_points([0, 0], [5, 2]).tolist()
    [[0, 0], [1, 0], [2, 1], [3, 1], [4, 2], [5, 2]]
    >>> line_points([0, 0, 0], [-2, 4, 1]).T.tolist()
    [[0, -1, -1, -2, -2], [0, 1, 2, 3, 4], [0, 0, 1, 1, 1]]
    """
    s = _as_lattice("start", start)
    e = _as_lattice("end", end, s.shape[0])
    return K.line_walk(s, e)


def steps_from_points(points) -> np.ndarray:
    """Per-tick steps (−1, 0, +1 per axis) between consecutive lattice points.

    Raises
    ------
    MotionError
        If two consecutive points are more than one step apart on an axis.

    Examples
    --------
    >>> steps_from_points([[0, 0], [1, 0], [2, -1]]).tolist()
    [[1, 0], [1, -1]]
    """
    pts = np.asarray(points, dtype=np.int64)
    d = np.diff(pts, axis=0)
    if d.size and np.abs(d).max() > 1:
        raise MotionError("points are not 8-connected: a tick would move an axis more than one step")
    return d.astype(np.int8)


def line_steps(start, end) -> np.ndarray:
    """Per-tick steps of a Bresenham line: int8 array (N, d) of −1, 0, +1.

    Examples
    --------
    >>> line_steps([0, 0], [3, -1]).tolist()
    [[1, 0], [1, -1], [1, 0]]
    """
    return steps_from_points(line_points(start, end))


def direction_bits(delta) -> int | np.ndarray:
    """Direction bit mask of a move: bit i set when axis i moves negative.

    Parameters
    ----------
    delta : array_like, shape (..., d)
        Displacements in steps (or any signed numbers).

    Examples
    --------
    >>> direction_bits([5, -3, 0])
    2
    >>> direction_bits([[-1, -1, 1], [0, 0, -7]]).tolist()
    [3, 4]
    """
    d = np.asarray(delta)
    bits = ((d < 0).astype(np.int64) << np.arange(d.shape[-1])).sum(axis=-1)
    return int(bits) if np.ndim(bits) == 0 else bits


def lines_points(starts, ends) -> tuple[np.ndarray, np.ndarray]:
    """Bresenham points of many lines at once (one compiled pass over the batch).

    Parameters
    ----------
    starts, ends : array_like of int, shape (n, d)
        End points in steps.

    Returns
    -------
    points : ndarray of int64, shape (sum(N_j + 1), d)
        All lines' points, line after line.
    offsets : ndarray of int64, shape (n + 1,)
        Line j is ``points[offsets[j]:offsets[j + 1]]``.

    Notes
    -----
    The error walk of :func:`line_points` runs for every line inside one
    compiled loop that writes into a single preallocated array, so no Python
    code runs per line. Its closed form — tick k puts axis i at
    S_i + sign(Δ_i)·floor((2k|Δ_i| + N) / (2N)) — is
    :func:`lines_points_closed_form`; the tests check the two agree.

    Examples
    --------
    >>> pts, off = lines_points([[0, 0], [3, 3]], [[2, 1], [3, 1]])
    >>> [pts[off[j]:off[j + 1]].tolist() for j in range(2)]
    [[[0, 0], [1, 1], [2, 1]], [[3, 3], [3, 2], [3, 1]]]
    """
    s = np.asarray(starts)
    e = np.asarray(ends)
    if s.ndim != 2 or s.shape != e.shape or s.shape[1] not in (2, 3):
        raise MotionError(f"starts and ends must both have shape (n, 2) or (n, 3), "
                          f"got {s.shape} and {e.shape}")
    if s.dtype.kind not in "iu" or e.dtype.kind not in "iu":
        raise MotionError("starts and ends must be integer arrays (steps)")
    s = np.ascontiguousarray(s, dtype=np.int64)
    e = np.ascontiguousarray(e, dtype=np.int64)
    counts = np.abs(e - s).max(axis=1) + 1
    offsets = np.zeros(len(s) + 1, np.int64)
    np.cumsum(counts, out=offsets[1:])
    check_budget("held_steps", float(offsets[-1]),
                 cause=f"{len(s)} line(s) with {int(counts.max()) - 1:,} steps on the longest",
                 option="the job's length or the machine's steps per mm")
    pts = np.empty((offsets[-1], s.shape[1]), np.int64)
    K.lines_walk(s, e, offsets, pts)
    return pts, offsets


def lines_points_closed_form(starts, ends) -> tuple[np.ndarray, np.ndarray]:
    """:func:`lines_points` by the closed form, in numpy only (slower; kept as the
    independent statement of the rule that the tests compare against).

    Examples
    --------
    >>> pts, off = lines_points_closed_form([[0, 0]], [[5, 2]])
    >>> pts.tolist()
    [[0, 0], [1, 0], [2, 1], [3, 1], [4, 2], [5, 2]]
    """
    s = np.asarray(starts, dtype=np.int64)
    delta = np.asarray(ends, dtype=np.int64) - s
    mag = np.abs(delta)
    n = mag.max(axis=1)
    counts = n + 1
    offsets = np.zeros(len(s) + 1, np.int64)
    np.cumsum(counts, out=offsets[1:])
    line = np.repeat(np.arange(len(s)), counts)
    k = np.arange(offsets[-1], dtype=np.int64) - offsets[line]
    nn = np.maximum(n, 1)[line]
    pts = np.empty((offsets[-1], s.shape[1]), np.int64)
    for i in range(s.shape[1]):
        m = mag[line, i]
        pts[:, i] = s[line, i] + np.sign(delta[line, i]) * ((2 * k * m + nn) // (2 * nn))
    return pts, offsets


def _fixed(value: float, scale: int) -> int:
    """Round half away from zero (C's llround) after scaling."""
    v = value * scale
    return int(math.floor(v + 0.5)) if v >= 0 else -int(math.floor(-v + 0.5))


def arc_octants(points, centre, scale: int = ARC_SCALE) -> np.ndarray:
    """The counter-clockwise octant of each lattice point about an arc's centre, as the
    octant walk of :func:`arc_lattice_points` classifies it.

    Parameters
    ----------
    points : array_like of int, shape (n, 2)
        Lattice points, steps.
    centre : sequence of 2 float
        The arc's centre, steps (rounded to ``scale`` sub-steps, as the walk rounds it).
    scale : int
        Fixed-point sub-steps per step.

    Returns
    -------
    ndarray of int, shape (n,)
        0…7: octant ``k`` holds the angles in [45k°, 45(k+1)°); in octants 0, 3, 4 and 7
        the walk steps Y every tick (Y drives), in the others X.

    Examples
    --------
    >>> arc_octants([[3, 1], [1, 3], [-3, 1], [0, -3]], (0.0, 0.0)).tolist()
    [0, 1, 3, 6]
    """
    pts = np.asarray(points, np.int64).reshape(-1, 2)
    q = int(scale)
    cxq, cyq = _fixed(float(centre[0]), q), _fixed(float(centre[1]), q)
    return np.array([K.octant_ccw(q * int(x) - cxq, q * int(y) - cyq) for x, y in pts], np.int64)


def arc_lattice_points(start, end, centre, *, clockwise: bool, radius: float | None = None,
               sweep_rad: float | None = None, scale: int = ARC_SCALE) -> np.ndarray:
    """Lattice points of a circular arc walked octant by octant ([CBR40] §J).

    Parameters
    ----------
    start, end : array_like of 2 ints
        First and last point in steps (the rounded program coordinates).
    centre : array_like of 2 floats
        Arc centre in steps (need not be on the lattice).
    clockwise : bool
        G2 (True) or G3 (False).
    radius : float, optional
        Radius in steps; default the distance start–centre.
    sweep_rad : float, optional
        Signed sweep (CCW positive) of the programmed arc; it only decides
        how many octants are walked when start and end share one (a short
        arc or almost a full circle). Default: from the angles of start and
        end; ``start == end`` is a full circle.
    scale : int
        Fixed-point sub-steps per step for centre and radius (≥ 1); reduced for
        radii so large that ``(r + 4)·scale`` would exceed 3·10⁹ (int64 exactness).

    Returns
    -------
    ndarray of int64, shape (N + 1, 2)
        8-connected points from ``start`` to ``end``; N ticks.

    Raises
    ------
    MotionError
        Bad arguments, or a walk that does not close (cannot happen for
        radius ≥ :data:`MIN_ARC_RADIUS_STEPS`; reported rather than hidden).

    Notes
    -----
    Integer semantics. The centre and radius become fixed point:
    Cx = llround(cx·q), Cy = llround(cy·q), R = llround(r·q) with q =
    ``scale``; a lattice point (x, y) has relative coordinates X = q·x − Cx,
    Y = q·y − Cy and error e = X² + Y² − R² (exact in int64 for radii up to
    ~10⁷ steps). Octants are half-open, [45k°, 45(k+1)°) counter-clockwise
    from +X (a clockwise arc is walked as the counter-clockwise arc of its
    mirror image y → −y). In octants 0, 3, 4 and 7 (|X| > |Y|) Y is the
    driver, in 1, 2, 5 and 6 X is. Each tick the driver steps; then of the
    driven axis' three options (stay, step forward along the circle, step
    back) the one with the smallest |e| wins, ties keeping the earlier of
    stay, forward, back. On the circle the backward option never wins, so
    this is exactly [CBR40]'s comparison |e(x−1, y+1)| < |e(x, y+1)|.
    Two rules handle the end points, which rounding may leave up to √2/2
    step off the circle: the first tick goes to the 8-neighbour of the start
    with the smallest |e| among those that do not go backwards along the arc
    (from a start on the circle that is normally the walk's own first tick); and the
    walk counts octant crossings, and in the end point's octant stops when its
    driver coordinate reaches the end's (stepping onto the end itself when
    it is adjacent) or before a tick that would leave that octant; a
    Bresenham line (:func:`line_points`, normally no tick at all) then lands
    on the end point — so the last point is always ``end``.

    Every point but the two (rounded) end points lies within about half a
    step of the true circle: within ½ + 1/(8r) + 1/q steps for r ≥ 4 steps
    (the 1/(8r) because |e| compares squared radii rather than radii), within
    0.65 step for smaller radii. On a full circle
    with integer centre and radius the points are those of
    :func:`skimage.draw.circle_perimeter` (Bresenham's method uses the same
    |e| comparison).

    Examples
    --------
    >>> arc_lattice_points([5, 0], [0, 5], [0, 0], clockwise=False).tolist()
    [[5, 0], [5, 1], [5, 2], [4, 3], [3, 4], [2, 5], [1, 5], [0, 5]]
    >>> len(circle_points([0, 0], 10))
    57
    """
    s = _as_lattice("start", start, 2)
    e = _as_lattice("end", end, 2)
    c = np.asarray(centre, dtype=float)
    if c.shape != (2,) or not np.all(np.isfinite(c)):
        raise MotionError(f"centre must be 2 finite numbers (steps), got {np.asarray(centre).tolist()}")
    if not (isinstance(scale, (int, np.integer)) and 1 <= scale <= 2 ** 12):
        raise MotionError(f"scale must be an integer in 1…4096 sub-steps per step, got {scale!r}")
    r = float(np.hypot(*(s - c))) if radius is None else float(radius)
    if not (math.isfinite(r) and r > 0):
        raise MotionError(f"radius must be > 0 steps, got {radius!r}")
    if r < MIN_ARC_RADIUS_STEPS:
        return line_points(s, e)
    if (r + 4) * scale > _MAX_FIXED_RADIUS:
        # e = X² + Y² − R² must stay exact in int64: a large radius gets fewer sub-steps
        # (a 1/q-step centre is far finer than such an arc needs), never overflowed errors.
        scale = int(_MAX_FIXED_RADIUS // (r + 4))
        if scale < 1:
            raise MotionError(f"arc radius {r:.6g} steps is beyond the exact integer walk "
                              f"(at most {_MAX_FIXED_RADIUS - 4:.6g} steps); cut the arc into "
                              "chords instead (--arc-tol, GRBL's $12)")
    if clockwise:   # walk the mirror image counter-clockwise
        pts = arc_lattice_points(s * [1, -1], e * [1, -1], c * [1, -1], clockwise=False, radius=r,
                         sweep_rad=None if sweep_rad is None else -sweep_rad, scale=scale)
        return pts * np.array([1, -1])
    q = int(scale)
    cxq, cyq, rq = _fixed(c[0], q), _fixed(c[1], q), _fixed(r, q)
    o_s = K.octant_ccw(q * s[0] - cxq, q * s[1] - cyq)
    o_e = K.octant_ccw(q * e[0] - cxq, q * e[1] - cyq)
    if sweep_rad is None:
        a0 = math.atan2(s[1] - c[1], s[0] - c[0])
        a1 = math.atan2(e[1] - c[1], e[0] - c[0])
        sweep_rad = (a1 - a0) % (2 * math.pi)
        if np.array_equal(s, e) or sweep_rad == 0.0:
            sweep_rad = 2 * math.pi
    if sweep_rad <= 0:
        raise MotionError(f"a counter-clockwise arc needs a positive sweep, got {sweep_rad!r} rad")
    base = (o_e - o_s) % 8
    n_cross = base + 8 * round((sweep_rad / (math.pi / 4) - base) / 8)
    # Ticks of an 8-connected walk never exceed the arc's length in steps (each octant's
    # driver span is shorter than its arc) plus a few per octant for the rounded ends,
    # so memory follows the arc's length, not its radius.
    max_ticks = int(min(8 * (r + 2) * max(1, math.ceil(sweep_rad / (2 * math.pi))),
                        1.05 * r * sweep_rad + 8 * (abs(n_cross) + 3))) + 16
    check_budget("held_steps", max_ticks, cause=f"an arc of radius {r:.6g} steps sweeping "
                 f"{math.degrees(sweep_rad):.4g}°", option="the arc, or give --arc-tol to cut arcs into chords")
    pts, ok = K.arc_walk_ccw(int(s[0]), int(s[1]), int(e[0]), int(e[1]), cxq, cyq, rq, q,
                             int(n_cross), max_ticks)
    if not ok:
        raise MotionError(f"arc walk from {s.tolist()} to {e.tolist()} around {c.tolist()} "
                          f"(r = {r:g} steps) did not close")
    return pts


def circle_points(centre, radius: int) -> np.ndarray:
    """A full circle walked counter-clockwise from angle 0 (integer centre and radius).

    Returns the N + 1 points of :func:`arc_lattice_points` (first = last = centre + (r, 0)).

    Examples
    --------
    >>> circle_points([0, 0], 2)[:4].tolist()
    [[2, 0], [2, 1], [1, 2], [0, 2]]
    """
    c = _as_lattice("centre", centre, 2)
    if not (isinstance(radius, (int, np.integer)) and radius >= 1):
        raise MotionError(f"radius must be an integer >= 1 step, got {radius!r}")
    s = c + [int(radius), 0]
    if radius < MIN_ARC_RADIUS_STEPS:   # r = 1: the four axis points, joined diagonally
        return c + np.array([[1, 0], [0, 1], [-1, 0], [0, -1], [1, 0]])
    return arc_lattice_points(s, s, c.astype(float), clockwise=False, radius=float(radius))
