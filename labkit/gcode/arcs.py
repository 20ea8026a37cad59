"""Arcs as G-code writes them: centres from I J K or from R, sweeps, flattening.

The parser computes the same centres inside its compiled kernel; these
functions are the readable, per-arc versions for teaching, tests and
generators. Plane-free 2-D helpers live in :mod:`labkit.geometry.circle`.

[LaserApp] appendix A gives the two centres of an arc of radius R through P1
and P2: with the chord Q = |P2 − P1|, its midpoint P3 and H = √(R² − (Q/2)²),

    C = P3 ± H · ((y1 − y2)/Q, (x2 − x1)/Q).

The arc wanted is the one whose sweep (counter-clockwise from P1 to P2 for
G3, clockwise for G2) is under 180° when R > 0 and over 180° when R < 0.
"""

from __future__ import annotations

import math

import numpy as np

from labkit.errors import GeometryError
from labkit.geometry.circle import (
    arc_chord_points,
    arc_length,
    chord_segments,
    grbl_segments,
    mid_arc_point,
    orientation,
    sweep_angle,
)
from labkit.toolpath.moves import PLANE_AXES, MoveKind, Moves

__all__ = [
    "centre_from_offsets",
    "centres_from_radius",
    "centre_from_radius",
    "arc_angles",
    "arc_length",
    "radius_mismatch",
    "chord_segments",
    "grbl_segments",
    "mid_arc_point",
    "orientation",
    "arc_polyline",
    "moves_polylines",
]


def centre_from_offsets(start, offsets, *, absolute=False):
    """Arc centre from I J K words.

    Parameters
    ----------
    start : array_like
        Arc start in mm.
    offsets : array_like
        The I J K values in mm (same length as ``start``).
    absolute : bool
        G90.1 (offsets are the centre itself) instead of the usual G91.1
        (offsets are measured from the start).

    Examples
    --------
    >>> centre_from_offsets([10, 0], [5, 0]).tolist()
    [15.0, 0.0]
    >>> centre_from_offsets([10, 0], [5, 0], absolute=True).tolist()
    [5.0, 0.0]
    """
    s = np.asarray(start, dtype=float)
    o = np.asarray(offsets, dtype=float)
    return o.copy() if absolute else s + o


def centres_from_radius(start, end, radius, *, r_tol_mm=0.0):
    """Both centres of the circles of radius |R| through ``start`` and ``end`` ([LaserApp] app. A).

    Parameters
    ----------
    start, end : array_like, shape (2,)
        In-plane end points, mm.
    radius : float
        R in mm (its sign does not matter here).
    r_tol_mm : float
        |R| may fall short of half the chord by this much and still count
        as a half circle (both centres are then the chord's midpoint).

    Returns
    -------
    ndarray, shape (2, 2)
        ``[P3 + H·n, P3 − H·n]`` with n = ((y1 − y2)/Q, (x2 − x1)/Q).

    Raises
    ------
    GeometryError
        When start equals end (R cannot define a full circle) or when |R|
        is shorter than half the chord by more than ``r_tol_mm``.

    Examples
    --------
    >>> centres_from_radius([0, 0], [2, 0], 1.0).round(12).tolist()
    [[1.0, 0.0], [1.0, 0.0]]
    >>> centres_from_radius([0, 0], [0, 2], 5.0**0.5).round(12).tolist()   # vertical chord
    [[-2.0, 1.0], [2.0, 1.0]]
    """
    p1 = np.asarray(start, dtype=float)
    p2 = np.asarray(end, dtype=float)
    q = math.hypot(*(p2 - p1))
    if q <= 1e-9:
        raise GeometryError("an arc by R needs an end point different from its start "
                            "(a full circle cannot be given by R; use I J K)")
    h2 = radius * radius - 0.25 * q * q
    if h2 < 0:
        if 0.5 * q - abs(radius) > r_tol_mm:
            raise GeometryError(f"arc radius {abs(radius):.6g} mm is smaller than half the chord "
                                f"{0.5 * q:.6g} mm")
        h2 = 0.0
    h = math.sqrt(h2)
    p3 = 0.5 * (p1 + p2)
    n = np.array([(p1[1] - p2[1]) / q, (p2[0] - p1[0]) / q])
    return np.array([p3 + h * n, p3 - h * n])


def centre_from_radius(start, end, radius, clockwise, *, r_tol_mm=0.0):
    """The centre G2/G3 with R selects, by [LaserApp]'s sweep rule.

    Parameters
    ----------
    start, end : array_like, shape (2,)
        In-plane end points, mm.
    radius : float
        R in mm: positive for the short arc (sweep < 180°), negative for the long one.
    clockwise : bool
        G2 (True) or G3 (False).

    Examples
    --------
    >>> centre_from_radius([1, 0], [0, 1], 1.0, clockwise=False).round(12).tolist()
    [0.0, 0.0]
    >>> centre_from_radius([1, 0], [0, 1], -1.0, clockwise=False).round(12).tolist()
    [1.0, 1.0]
    """
    candidates = centres_from_radius(start, end, radius, r_tol_mm=r_tol_mm)
    sweeps = np.abs([sweep_angle(start, end, c, clockwise) for c in candidates])
    # R > 0 wants the sweep under half a turn, R < 0 over it; at exactly half a turn both agree.
    pick = int(np.argmin(sweeps)) if radius > 0 else int(np.argmax(sweeps))
    return candidates[pick]


def arc_angles(start, end, centre, clockwise):
    """Start angle (rad, CCW from +x) and signed sweep (rad, CCW positive).

    >>> [round(a, 6) for a in arc_angles([0, 1], [-1, 0], [0, 0], clockwise=False)]
    [1.570796, 1.570796]
    """
    s = np.asarray(start, dtype=float) - np.asarray(centre, dtype=float)
    return math.atan2(s[1], s[0]), float(sweep_angle(start, end, centre, clockwise))


def radius_mismatch(start, end, centre, *, tol_mm=0.005, tol_rel=0.001):
    """Whether an I J K arc's end is off its circle by more than GRBL allows.

    GRBL rejects the arc (error 33) when the radii at start and end differ
    by more than ``tol_mm`` **and** by more than ``tol_rel`` of the radius.

    Returns
    -------
    (bool, float)
        Rejected?, and the difference of the radii in mm.

    >>> radius_mismatch([10, 0], [0, 10.004], [0, 0])
    (False, 0.004)
    >>> radius_mismatch([100, 0], [0, 100.05], [0, 0])    # 0.05 mm ≤ 0.1 % of 100 mm
    (False, 0.05)
    >>> radius_mismatch([10, 0], [0, 10.02], [0, 0])
    (True, 0.02)
    """
    c = np.asarray(centre, dtype=float)
    r0 = math.hypot(*(np.asarray(start, dtype=float) - c))
    r1 = math.hypot(*(np.asarray(end, dtype=float) - c))
    dr = abs(r1 - r0)
    return bool(dr > tol_mm and dr > tol_rel * r0), round(dr, 12)


def arc_polyline(start, end, centre, clockwise, *, plane=17, tol_mm=0.01):
    """Flatten a (helical) arc in any plane into 3-D points within ``tol_mm``.

    Parameters
    ----------
    start, end, centre : array_like, shape (3,)
        X Y Z in mm; the centre's linear-axis coordinate is ignored.
    clockwise : bool
    plane : {17, 18, 19}
        G17 (XY), G18 (ZX) or G19 (YZ).
    tol_mm : float
        Largest distance between a chord and the arc, mm.

    Returns
    -------
    ndarray, shape (k + 1, 3)
        From ``start`` to ``end`` exactly; the linear axis moves in
        proportion to the angle (a helix).

    Examples
    --------
    >>> pts = arc_polyline([1, 0, 0], [1, 0, 2], [0, 0, 0], False, tol_mm=0.01)   # one helix turn
    >>> len(pts), pts[len(pts) // 2].round(6).tolist()
    (24, [-0.990686, -0.136167, 1.043478])
    """
    start = np.asarray(start, dtype=float)
    end = np.asarray(end, dtype=float)
    centre = np.asarray(centre, dtype=float)
    a0, a1, lin = PLANE_AXES[int(plane)]
    p0, p1, c = start[[a0, a1]], end[[a0, a1]], centre[[a0, a1]]
    r = math.hypot(*(p0 - c))
    sweep = float(sweep_angle(p0, p1, c, clockwise))
    n = chord_segments(r, sweep, tol_mm)
    return arc_chord_points(start, end, centre, [[a0, a1, lin]], [r], [sweep], [n])[0]


def moves_polylines(moves: Moves, *, tol_mm=0.01):
    """Every motion of a program as a 3-D polyline (arcs flattened within ``tol_mm``).

    Returns
    -------
    list of ndarray
        One (k, 3) array per row of ``moves`` (dwell rows give a single point).
    """
    out = []
    for i in range(len(moves)):
        k = moves.kind[i]
        if k in (MoveKind.ARC_CW, MoveKind.ARC_CCW):
            out.append(arc_polyline(moves.start[i], moves.end[i], moves.centre[i],
                                    k == MoveKind.ARC_CW, plane=int(moves.plane[i]), tol_mm=tol_mm))
        elif k == MoveKind.DWELL:
            out.append(moves.start[i:i + 1].copy())
        else:
            out.append(np.vstack([moves.start[i], moves.end[i]]))
    return out
