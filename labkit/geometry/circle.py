"""Circles and circular arcs: orientation, circumcentre, sweep, length, extents.

Everything here is plain 2-D vector algebra on numpy arrays (last axis = x, y),
written with cross and dot products so that vertical chords, which break the
slope formulas in [LaserApp] and [DobotLaser], need no special case.

Sign conventions: a sweep angle is in radians, positive counter-clockwise
(G3), negative clockwise (G2), with magnitude in (0, 2π]. An arc whose end
equals its start is a full circle, as in GRBL.
"""

from __future__ import annotations

import math

import numpy as np

from labkit._array import scalar_or_array
from labkit.errors import GeometryError

__all__ = [
    "ANGULAR_EPSILON",
    "orientation",
    "cross2",
    "circumcentre",
    "sweep_angle",
    "arc_length",
    "arc_point",
    "arc_points",
    "arc_chord_points",
    "XY_AXES",
    "mid_arc_point",
    "chord_segments",
    "grbl_segments",
    "arc_bounds",
]

#: GRBL's ARC_ANGULAR_TRAVEL_EPSILON (rad): sweeps closer to 0 than this count as full circles.
ANGULAR_EPSILON = 5e-7


def cross2(u, v):
    """z component of the cross product of 2-D vectors (broadcasts over leading axes)."""
    u = np.asarray(u, dtype=float)
    v = np.asarray(v, dtype=float)
    return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]


def orientation(a, b, c, *, rel_tol=1e-12):
    """Turn direction of the path a → b → c.

    Parameters
    ----------
    a, b, c : array_like, shape (..., 2)
        Points in mm.
    rel_tol : float
        Cross products smaller than ``rel_tol`` times the product of the two
        edge lengths count as collinear (0). This keeps the test scale-free.

    Returns
    -------
    int or ndarray of int
        +1 counter-clockwise (left turn), -1 clockwise (right turn), 0 collinear.

    Notes
    -----
    [DobotLaser] compares slopes, which divides by zero on vertical chords; the
    sign of the cross product (b − a) × (c − a) has no such case.

    Examples
    --------
    >>> orientation((0, 0), (1, 0), (1, 1))
    1
    >>> orientation((0, 0), (0, 1), (1, 2))   # vertical first edge, turning right
    -1
    >>> orientation((0, 0), (1, 1), (2, 2))
    0
    """
    a = np.asarray(a, dtype=float)
    ab = np.asarray(b, dtype=float) - a
    ac = np.asarray(c, dtype=float) - a
    cr = cross2(ab, ac)
    scale = np.hypot(ab[..., 0], ab[..., 1]) * np.hypot(ac[..., 0], ac[..., 1])
    sign = np.where(np.abs(cr) <= rel_tol * scale, 0, np.sign(cr)).astype(int)
    return scalar_or_array(sign)


def circumcentre(a, b, c):
    """Centre of the circle through three points, by the determinant form.

    Parameters
    ----------
    a, b, c : array_like, shape (..., 2)
        Points in mm.

    Returns
    -------
    ndarray, shape (..., 2)
        Centre in mm; NaN where the points are collinear (no circle).

    Notes
    -----
    With u = b − a, v = c − a and d = 2·(u × v), the centre is
    a + (v_y·|u|² − u_y·|v|², u_x·|v|² − v_x·|u|²) / d — the intersection of
    the perpendicular bisectors without slopes, so vertical chords need no
    special case ([LaserApp] intersected bisector slopes).

    Examples
    --------
    >>> circumcentre((1, 0), (0, 1), (-1, 0)).round(12)
    array([0., 0.])
    >>> circumcentre((0, 0), (0, 2), (2, 0))      # a vertical chord
    array([1., 1.])
    """
    a = np.asarray(a, dtype=float)
    ab = np.asarray(b, dtype=float) - a
    ac = np.asarray(c, dtype=float) - a
    d = 2.0 * cross2(ab, ac)
    ab2 = (ab * ab).sum(axis=-1)
    ac2 = (ac * ac).sum(axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        ux = (ac[..., 1] * ab2 - ab[..., 1] * ac2) / d
        uy = (ab[..., 0] * ac2 - ac[..., 0] * ab2) / d
    centre = a + np.stack([ux, uy], axis=-1)
    scale = np.sqrt(ab2 * ac2)
    collinear = np.abs(d) <= 1e-14 * np.where(scale > 0, scale, 1.0)
    return np.where(collinear[..., None], np.nan, centre)


def sweep_angle(start, end, centre, clockwise):
    """Signed angle swept from ``start`` to ``end`` around ``centre``.

    Parameters
    ----------
    start, end, centre : array_like, shape (..., 2)
        Points in mm.
    clockwise : bool or array of bool
        True for G2, False for G3.

    Returns
    -------
    float or ndarray
        Radians; negative for clockwise arcs, in [-2π, 0) or (0, 2π].
        ``start == end`` gives a full turn (±2π), as GRBL does.

    Examples
    --------
    >>> round(sweep_angle((1, 0), (0, 1), (0, 0), clockwise=False), 6)   # quarter CCW
    1.570796
    >>> round(sweep_angle((1, 0), (0, 1), (0, 0), clockwise=True), 6)    # three quarters CW
    -4.712389
    >>> round(sweep_angle((1, 0), (1, 0), (0, 0), clockwise=True), 6)    # full circle
    -6.283185
    """
    c = np.asarray(centre, dtype=float)
    r0 = np.asarray(start, dtype=float) - c
    r1 = np.asarray(end, dtype=float) - c
    ang = np.arctan2(cross2(r0, r1), (r0 * r1).sum(axis=-1))
    cw = np.asarray(clockwise, dtype=bool)
    ang = np.where(cw & (ang >= -ANGULAR_EPSILON), ang - 2.0 * math.pi, ang)
    ang = np.where(~cw & (ang <= ANGULAR_EPSILON), ang + 2.0 * math.pi, ang)
    return scalar_or_array(ang)


def arc_length(radius, sweep, linear_travel=0.0):
    """Length of a (helical) arc in mm: sqrt((|sweep|·r)² + h²).

    >>> round(arc_length(10.0, math.pi), 6)
    31.415927
    >>> round(arc_length(1.0, 2 * math.pi, linear_travel=1.0), 6)   # one helix turn
    6.362265
    """
    return scalar_or_array(np.hypot(np.abs(sweep) * radius, linear_travel))


def arc_point(centre, radius, angle):
    """Point at ``angle`` (rad, CCW from +x) on a circle; broadcasts."""
    c = np.asarray(centre, dtype=float)
    ang = np.asarray(angle, dtype=float)
    return c + np.stack([radius * np.cos(ang), radius * np.sin(ang)], axis=-1)


def arc_points(start, end, centre, clockwise, *, tol_mm=None, n=None):
    """Sample an arc as a polyline from ``start`` to ``end`` (both included exactly).

    Parameters
    ----------
    start, end, centre : array_like, shape (2,)
        mm.
    clockwise : bool
        Direction (G2 = True).
    tol_mm : float, optional
        Maximum chord deviation (sagitta) in mm; sets the number of chords.
    n : int, optional
        Number of chords instead of ``tol_mm``.

    Returns
    -------
    ndarray, shape (k + 1, 2)

    Examples
    --------
    >>> arc_points([1, 0], [0, 1], [0, 0], False, n=2).round(6).tolist()
    [[1.0, 0.0], [0.707107, 0.707107], [0.0, 1.0]]
    """
    start = np.asarray(start, dtype=float)
    end = np.asarray(end, dtype=float)
    centre = np.asarray(centre, dtype=float)
    r = float(np.hypot(*(start - centre)))
    sweep = float(sweep_angle(start, end, centre, clockwise))
    if n is None:
        if tol_mm is None:
            raise ValueError("give tol_mm (chord tolerance in mm) or n (number of chords)")
        n = chord_segments(r, sweep, tol_mm)
    if n < 1:
        raise ValueError(f"n must be >= 1 chord, got {n}")
    s3, e3, c3 = (np.r_[q, 0.0][None] for q in (start, end, centre))
    pts, _, _ = arc_chord_points(s3, e3, c3, XY_AXES, [r], [sweep], [n])
    return pts[:, :2]


#: Axis order (first arc axis, second arc axis, linear axis) of the XY plane.
XY_AXES = np.array([[0, 1, 2]])


def arc_chord_points(start, end, centre, axes, radius, sweep, counts):
    """Points of k arcs (or helices) cut into chords of equal angle, all in one array.

    The one place labkit turns arcs into points: the G-code preview, GRBL's chords for
    the motion reference and the virtual machine, and the flattening of parsed programs
    all call it (with chord counts from :func:`chord_segments` or :func:`grbl_segments`).

    Parameters
    ----------
    start, end, centre : array_like, shape (k, 3)
        Arc ends and centres, mm (the centre's linear-axis coordinate is ignored).
    axes : array_like of int, shape (k, 3) or (1, 3)
        Per arc: its first and second arc axis and its linear axis (``PLANE_AXES``).
    radius, sweep : array_like, shape (k,)
        Radius (mm) and signed sweep (rad, counter-clockwise positive).
    counts : array_like of int, shape (k,)
        Chords per arc (≥ 1).

    Returns
    -------
    points : ndarray, shape (sum(counts) + k, 3)
        Each arc's ``counts[i] + 1`` points in turn, from its start to its end (both exact);
        the linear axis moves in proportion to the angle.
    owner : ndarray of int
        The arc each point belongs to.
    t : ndarray
        Each point's share of its arc's sweep, 0…1.

    Examples
    --------
    >>> pts, owner, t = arc_chord_points([[1, 0, 0]], [[-1, 0, 2]], [[0, 0, 0]], XY_AXES,
    ...                                  [1.0], [np.pi], [2])
    >>> pts.round(6).tolist(), owner.tolist()
    ([[1.0, 0.0, 0.0], [0.0, 1.0, 1.0], [-1.0, 0.0, 2.0]], [0, 0, 0])
    """
    start = np.asarray(start, dtype=float).reshape(-1, 3)
    end = np.asarray(end, dtype=float).reshape(-1, 3)
    centre = np.asarray(centre, dtype=float).reshape(-1, 3)
    k = np.arange(len(start))
    axes = np.broadcast_to(np.asarray(axes, dtype=np.int64).reshape(-1, 3), (len(k), 3))
    radius = np.asarray(radius, dtype=float).reshape(-1)
    sweep = np.asarray(sweep, dtype=float).reshape(-1)
    counts = np.asarray(counts, dtype=np.int64).reshape(-1)
    c0, c1 = centre[k, axes[:, 0]], centre[k, axes[:, 1]]
    ang0 = np.arctan2(start[k, axes[:, 1]] - c1, start[k, axes[:, 0]] - c0)
    npts = counts + 1
    owner = np.repeat(k, npts)
    first = np.cumsum(npts) - npts
    t = (np.arange(int(npts.sum())) - np.repeat(first, npts)) / counts[owner]
    ang = ang0[owner] + sweep[owner] * t
    pts = np.empty((len(owner), 3))
    j = np.arange(len(owner))
    pts[j, axes[owner, 0]] = c0[owner] + radius[owner] * np.cos(ang)
    pts[j, axes[owner, 1]] = c1[owner] + radius[owner] * np.sin(ang)
    z0 = start[k, axes[:, 2]]
    pts[j, axes[owner, 2]] = z0[owner] + (end[k, axes[:, 2]] - z0)[owner] * t
    pts[first] = start
    pts[first + counts] = end
    return pts, owner, t


def chord_segments(radius, sweep, tol_mm):
    """Fewest equal chords whose sagitta stays within ``tol_mm``.

    Each chord spanning angle φ deviates r·(1 − cos(φ/2)) from the arc, so
    n = ceil(|sweep| / (2·acos(1 − tol/r))). Compare :func:`grbl_segments`.

    >>> chord_segments(10.0, math.pi, 0.01)
    36
    """
    if not tol_mm > 0:
        raise ValueError(f"tol_mm must be > 0 mm, got {tol_mm!r}")
    radius = np.asarray(radius, dtype=float)
    ratio = np.clip(1.0 - tol_mm / np.where(radius > 0, radius, 1.0), -1.0, 1.0)
    step = 2.0 * np.arccos(ratio)
    n = np.ceil(np.abs(sweep) / np.where(step > 0, step, np.inf) - 1e-9)
    return scalar_or_array(np.maximum(n, 1).astype(np.int64))


def grbl_segments(radius, sweep, tol_mm=0.002):
    """GRBL's arc segment count: floor(½·|sweep|·r / sqrt(ε·(2r − ε))), at least 1.

    ``tol_mm`` is GRBL's ``$12`` arc tolerance (default 0.002 mm). GRBL rounds
    down, so its chords may exceed ε slightly; :func:`chord_segments` never does.

    >>> grbl_segments(10.0, math.pi, 0.01)
    35
    """
    radius = np.asarray(radius, dtype=float)
    n = np.floor(0.5 * np.abs(sweep) * radius / np.sqrt(tol_mm * (2.0 * radius - tol_mm)))
    return scalar_or_array(np.maximum(n, 1).astype(np.int64))


def mid_arc_point(start, end, centre, clockwise):
    """The point halfway along an arc — [DobotLaser]'s "circular point".

    A Dobot arm's ARC command takes one point on the arc instead of the
    centre. It lies where the line through the centre perpendicular to the
    chord meets the circle; of the two crossings, the one that makes
    start → point → end turn the arc's way (clockwise for G2) is on the arc.

    Parameters
    ----------
    start, end, centre : array_like, shape (2,)
        mm; ``start`` must differ from ``end`` (a full circle has no
        unique answer: split it first).
    clockwise : bool

    Returns
    -------
    ndarray, shape (2,)

    Examples
    --------
    >>> mid_arc_point((0, -1), (0, 1), (0, 0), clockwise=False).round(12)   # vertical chord
    array([1., 0.])
    >>> mid_arc_point((0, -1), (0, 1), (0, 0), clockwise=True).round(12)
    array([-1.,  0.])
    """
    start = np.asarray(start, dtype=float)
    end = np.asarray(end, dtype=float)
    centre = np.asarray(centre, dtype=float)
    chord = end - start
    q = math.hypot(*chord)
    r = math.hypot(*(start - centre))
    if q <= 1e-12 * max(r, 1.0):
        raise GeometryError("mid_arc_point: start and end coincide (a full circle); "
                            "split the circle into two arcs first")
    normal = np.array([-chord[1], chord[0]]) / q     # chord rotated +90°
    want = -1 if clockwise else 1
    for cand in (centre + r * normal, centre - r * normal):
        if orientation(start, cand, end) == want:
            return cand
    raise GeometryError("mid_arc_point: degenerate arc (zero radius or centre off the chord's bisector)")


def arc_bounds(start, end, centre, sweep):
    """Axis-aligned box of a 2-D arc: its end points plus every axis crossing it sweeps.

    Parameters
    ----------
    start, end, centre : array_like, shape (2,)
    sweep : float
        Signed sweep (rad) from :func:`sweep_angle`.

    Returns
    -------
    ndarray, shape (2, 2)
        ``[[xmin, ymin], [xmax, ymax]]`` in mm.

    >>> arc_bounds((1, 0), (-1, 0), (0, 0), math.pi)    # upper half circle
    array([[-1.,  0.],
           [ 1.,  1.]])
    """
    start = np.asarray(start, dtype=float)
    end = np.asarray(end, dtype=float)
    centre = np.asarray(centre, dtype=float)
    r = math.hypot(*(start - centre))
    a0 = math.atan2(start[1] - centre[1], start[0] - centre[0])
    pts = [start, end]
    lo, hi = (a0, a0 + sweep) if sweep >= 0 else (a0 + sweep, a0)
    k = math.ceil(lo / (math.pi / 2))
    while k * (math.pi / 2) <= hi + 1e-15:
        ang = k * (math.pi / 2)
        pts.append(centre + r * np.array([round(math.cos(ang)), round(math.sin(ang))]))
        k += 1
    pts = np.array(pts)
    return np.array([pts.min(axis=0), pts.max(axis=0)])
