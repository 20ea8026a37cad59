"""Biarcs: two tangent-continuous circular arcs between two points with given tangents.

[MicroCAM] §6.1.4 replaces the many short lines of a flattened curve by arcs
that match the curve within a tolerance; biarcs are the standard way to do it
with G1 (tangent) continuity, so the machine never sees a kink where the
drawing has none.

A biarc from ``p0`` (unit tangent ``t0``) to ``p1`` (unit tangent ``t1``) is
built here by the *equal tangent length* rule: the two arcs are the ones
inscribed in the control polygon ``p0, q0 = p0 + d·t0, q1 = p1 − d·t1, p1``
with ``|q1 − q0| = 2d``; the joint is ``J = (q0 + q1)/2`` and the tangent
there is along ``q1 − q0``. With ``v = p1 − p0`` the condition
``|v − d(t0 + t1)|² = 4d²`` is the quadratic
``2(t0·t1 − 1)·d² − 2(v·(t0 + t1))·d + v·v = 0`` whose positive root,
written without cancellation, is

    d = v·v / (b + sqrt(b² − a·v·v)),  a = 2(t0·t1 − 1), b = v·(t0 + t1).

It exists unless ``t0 = t1`` and the curve runs backwards (``b ≤ 0``). When
the end tangents are symmetric about the chord, as any circular arc's are,
both arcs lie on that same circle — so a curve that *is* an arc comes back
as one arc once co-circular neighbours are merged.

An arc that starts at ``A`` with unit tangent ``t`` and ends at ``B`` has
signed curvature ``κ = 2·(t × (B − A))/|B − A|²`` (κ > 0 turns left) and
sweep ``2·atan2(t × u, t·u)`` with ``u`` the unit chord; its end tangent is
``t`` mirrored in the chord. κ ≈ 0 is a straight line.

With ``method="biarc"`` the fitting kernels
(:func:`labkit.geometry.arcfit.cubics_to_arcs` and
:func:`labkit.geometry.arcfit.fit_arcs`; their default is the greedy fit,
which uses fewer blocks but may kink within the tolerance) grow each piece as far as one biarc
stays within the tolerance of the curve, measured both ways (curve samples to
the biarc, and biarc samples to the curve's dense polyline).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from labkit.errors import GeometryError
from labkit.geometry.path import Path

__all__ = ["biarc", "arc_from_tangent", "tangent_angles", "LINE_SAGITTA_MM", "MAX_JOINT_REACH"]

#: An arc whose sagitta (its largest distance from its chord) is at most this (mm) is
#: written as its chord. Far below any written resolution; the kink this leaves is half
#: the arc's sweep, at most 4·LINE_SAGITTA_MM / chord (rad). A large radius alone is no
#: reason: a 10 m arc over a 100 mm chord still bows 0.125 mm.
LINE_SAGITTA_MM = 1e-4
#: A biarc whose tangent lines reach further than this many chord lengths (nearly equal
#: tangents pointing away from the chord) is no usable biarc: the fit splits instead.
MAX_JOINT_REACH = 100.0
_FULL_TURN = 2.0 * math.pi - 1e-6


@numba.njit(cache=True)
def _unit(x, y):
    n = math.hypot(x, y)
    if n == 0.0:
        return 0.0, 0.0, 0.0
    return x / n, y / n, n


@numba.njit(cache=True)
def _arc_from_tangent(ax, ay, tx, ty, bx, by):
    """Arc from A (unit tangent t) to B: (cx, cy, sweep); sweep 0 means a line, 2π none."""
    vx, vy = bx - ax, by - ay
    L2 = vx * vx + vy * vy
    if L2 == 0.0:
        return math.nan, math.nan, 0.0
    cr = tx * vy - ty * vx
    dt = tx * vx + ty * vy
    if cr == 0.0 and dt < 0.0:           # the tangent points straight away from B: no arc
        return math.nan, math.nan, 2.0 * math.pi
    sweep = 2.0 * math.atan2(cr, dt)
    k = 2.0 * cr / L2
    # sagitta of the arc over its chord: (L/2)·tan(|sweep|/4)
    if k == 0.0 or 0.5 * math.sqrt(L2) * math.tan(0.25 * abs(sweep)) <= LINE_SAGITTA_MM:
        return math.nan, math.nan, 0.0
    r = 1.0 / k
    return ax - r * ty, ay + r * tx, sweep


@numba.njit(cache=True)
def _two_arcs(p0x, p0y, t0x, t0y, jx, jy, tjx, tjy, p1x, p1y, out):
    """The arcs p0 (tangent t0) → J and J (tangent tj) → p1 into out; False if either closes."""
    c1x, c1y, s1 = _arc_from_tangent(p0x, p0y, t0x, t0y, jx, jy)
    c2x, c2y, s2 = _arc_from_tangent(jx, jy, tjx, tjy, p1x, p1y)
    if abs(s1) >= _FULL_TURN or abs(s2) >= _FULL_TURN:
        return False
    out[0], out[1] = jx, jy
    out[2], out[3], out[4] = c1x, c1y, s1
    out[5], out[6], out[7] = c2x, c2y, s2
    return True


@numba.njit(cache=True)
def _biarc(p0x, p0y, t0x, t0y, p1x, p1y, t1x, t1y, out):
    """Equal-tangent-length biarc; out = (jx, jy, c1x, c1y, s1, c2x, c2y, s2). False if none."""
    vx, vy = p1x - p0x, p1y - p0y
    c = vx * vx + vy * vy
    if c == 0.0:
        return False
    a = 2.0 * (t0x * t1x + t0y * t1y - 1.0)
    b = vx * (t0x + t1x) + vy * (t0y + t1y)
    den = b + math.sqrt(max(b * b - a * c, 0.0))
    if den <= 1e-12 * math.sqrt(c):
        return False
    d = c / den
    if d > MAX_JOINT_REACH * math.sqrt(c):
        return False
    q0x, q0y = p0x + d * t0x, p0y + d * t0y
    q1x, q1y = p1x - d * t1x, p1y - d * t1y
    jx, jy = 0.5 * (q0x + q1x), 0.5 * (q0y + q1y)
    ux, uy, n = _unit(q1x - q0x, q1y - q0y)
    if n == 0.0:
        return False
    return _two_arcs(p0x, p0y, t0x, t0y, jx, jy, ux, uy, p1x, p1y, out)


@numba.njit(cache=True)
def _joint_circle(p0x, p0y, t0x, t0y, p1x, p1y, t1x, t1y):
    """The circle on which every biarc joint between these ends lies: (cx, cy, r); r = 0 when
    it is the straight line through p0 and p1 (equal tangents).

    At the joint the two arcs' tangents agree: twice the chord angle of each arc
    minus its end tangent angle match, so the angle between the chords p0→J and
    J→p1 is fixed and J sees p0p1 under a constant angle — a circle through both
    ends, leaving p0 at the chord direction turned by half the angle from t1 to t0."""
    half = 0.5 * math.atan2(t1x * t0y - t1y * t0x, t1x * t0x + t1y * t0y)
    ux, uy, L = _unit(p1x - p0x, p1y - p0y)
    ch, sh = math.cos(half), math.sin(half)
    cx, cy, sw = _arc_from_tangent(p0x, p0y, ch * ux - sh * uy, sh * ux + ch * uy, p1x, p1y)
    if sw == 0.0 or math.isnan(cx):
        return 0.0, 0.0, 0.0
    return cx, cy, math.hypot(p0x - cx, p0y - cy)


@numba.njit(cache=True)
def _joint_side(qx, qy, p0x, p0y, p1x, p1y, cx, cy, r):
    """Signed side of q relative to the joint circle (or line when r == 0)."""
    if r == 0.0:
        return (p1x - p0x) * (qy - p0y) - (p1y - p0y) * (qx - p0x)
    return math.hypot(qx - cx, qy - cy) - r


@numba.njit(cache=True)
def _biarc_joint(p0x, p0y, t0x, t0y, p1x, p1y, jx, jy, out):
    """The biarc whose joint is J (a point of the joint circle); out as in _biarc."""
    ux, uy, L = _unit(jx - p0x, jy - p0y)
    wx, wy, L2 = _unit(p1x - jx, p1y - jy)
    if L == 0.0 or L2 == 0.0:
        return False
    d = 2.0 * (t0x * ux + t0y * uy)
    tjx, tjy = d * ux - t0x, d * uy - t0y           # t0 mirrored in the first chord
    return _two_arcs(p0x, p0y, t0x, t0y, jx, jy, tjx, tjy, p1x, p1y, out)


@numba.njit(cache=True)
def _seg_distance(qx, qy, ax, ay, bx, by):
    dx, dy = bx - ax, by - ay
    L2 = dx * dx + dy * dy
    if L2 == 0.0:
        return math.hypot(qx - ax, qy - ay)
    t = ((qx - ax) * dx + (qy - ay) * dy) / L2
    t = min(1.0, max(0.0, t))
    return math.hypot(qx - ax - t * dx, qy - ay - t * dy)


@numba.njit(cache=True)
def _arc_distance(qx, qy, ax, ay, cx, cy, sweep, bx, by):
    """Distance from q to the arc A→B (centre c, signed sweep); a line when sweep == 0."""
    if sweep == 0.0:
        return _seg_distance(qx, qy, ax, ay, bx, by)
    sx, sy = ax - cx, ay - cy
    wx, wy = qx - cx, qy - cy
    phi = math.atan2(sx * wy - sy * wx, sx * wx + sy * wy)
    if sweep < 0.0:
        phi = -phi
    if phi < 0.0:
        phi += 2.0 * math.pi
    if phi <= abs(sweep):
        return abs(math.hypot(wx, wy) - math.hypot(sx, sy))
    return min(math.hypot(qx - ax, qy - ay), math.hypot(qx - bx, qy - by))


@numba.njit(cache=True)
def _biarc_error(samples, n, p0x, p0y, p1x, p1y, ba, tol):
    """Two-sided distance between the polyline samples[:n] and the biarc (stops early above tol).

    Curve → biarc: every sample's distance to the nearer arc. Biarc → curve:
    points along each arc to the sample polyline (catches arcs that bulge or
    loop where the samples do not go)."""
    jx, jy = ba[0], ba[1]
    worst = 0.0
    for k in range(n):
        qx, qy = samples[k, 0], samples[k, 1]
        e = min(_arc_distance(qx, qy, p0x, p0y, ba[2], ba[3], ba[4], jx, jy),
                _arc_distance(qx, qy, jx, jy, ba[5], ba[6], ba[7], p1x, p1y))
        if e > worst:
            worst = e
            if worst > tol:
                return worst
    for half in range(2):
        if half == 0:
            ax, ay, cx, cy, sw = p0x, p0y, ba[2], ba[3], ba[4]
        else:
            ax, ay, cx, cy, sw = jx, jy, ba[5], ba[6], ba[7]
        if sw == 0.0:
            continue                      # a line: its points lie between the samples' ends
        sx, sy = ax - cx, ay - cy
        for i in range(1, 8):
            ang = sw * i / 8.0
            ca, sa = math.cos(ang), math.sin(ang)
            qx, qy = cx + ca * sx - sa * sy, cy + sa * sx + ca * sy
            best = math.inf
            for k in range(n - 1):
                dd = _seg_distance(qx, qy, samples[k, 0], samples[k, 1], samples[k + 1, 0], samples[k + 1, 1])
                if dd < best:
                    best = dd
            if best > worst:
                worst = best
                if worst > tol:
                    return worst
    return worst


@numba.njit(cache=True)
def _emit(ba, p0x, p0y, p1x, p1y, verts, centres, sweeps, k):
    """Append the biarc's one or two segments (zero-length ones skipped); returns the new count."""
    jx, jy = ba[0], ba[1]
    if jx != p0x or jy != p0y:
        verts[k + 1, 0], verts[k + 1, 1] = jx, jy
        centres[k, 0], centres[k, 1], sweeps[k] = ba[2], ba[3], ba[4]
        k += 1
    if jx != p1x or jy != p1y:
        verts[k + 1, 0], verts[k + 1, 1] = p1x, p1y
        centres[k, 0], centres[k, 1], sweeps[k] = ba[5], ba[6], ba[7]
        k += 1
    return k


@numba.njit(cache=True)
def _emit_line(p1x, p1y, verts, centres, sweeps, k):
    verts[k + 1, 0], verts[k + 1, 1] = p1x, p1y
    centres[k, 0], centres[k, 1], sweeps[k] = math.nan, math.nan, 0.0
    return k + 1


@numba.njit(cache=True)
def _merge(verts, centres, sweeps, k, eps):
    """Merge neighbours that are one primitive: co-circular arcs turning the same way (their
    union sweeping less than a full turn) and collinear lines. Returns the new count."""
    if k == 0:
        return 0
    w = 0
    for i in range(1, k):
        s0, s1 = sweeps[w], sweeps[i]
        same = False
        if s0 != 0.0 and s1 != 0.0 and s0 * s1 > 0.0 and abs(s0 + s1) < 2.0 * math.pi - 1e-3:
            r0 = math.hypot(verts[w, 0] - centres[w, 0], verts[w, 1] - centres[w, 1])
            r1 = math.hypot(verts[i, 0] - centres[i, 0], verts[i, 1] - centres[i, 1])
            dc = math.hypot(centres[w, 0] - centres[i, 0], centres[w, 1] - centres[i, 1])
            same = dc <= eps and abs(r0 - r1) <= eps
        elif s0 == 0.0 and s1 == 0.0:
            ax, ay = verts[w, 0], verts[w, 1]
            bx, by = verts[i + 1, 0], verts[i + 1, 1]
            # the shared vertex lies on the combined chord, between its ends
            mx, my = verts[i, 0], verts[i, 1]
            dx, dy = bx - ax, by - ay
            L2 = dx * dx + dy * dy
            if L2 > 0.0:
                t = ((mx - ax) * dx + (my - ay) * dy) / L2
                same = 0.0 < t < 1.0 and abs((mx - ax) * dy - (my - ay) * dx) <= eps * math.sqrt(L2)
        if same:
            sweeps[w] = s0 + s1
            verts[w + 1] = verts[i + 1]
        else:
            w += 1
            verts[w + 1] = verts[i + 1]
            centres[w] = centres[i]
            sweeps[w] = sweeps[i]
    return w + 1


def tangent_angles(path: Path) -> np.ndarray:
    """Kink at each interior vertex of a path, rad (0 where it is tangent-continuous).

    The angle between the end tangent of segment i and the start tangent of
    segment i + 1 (lines along their chord, arcs perpendicular to the radius),
    for i = 0 … n − 2; for a closed path the kink at its start/end vertex is
    appended.

    Examples
    --------
    >>> from labkit.geometry import Path
    >>> tangent_angles(Path.rectangle(0, 0, 2, 1)).round(6).tolist()
    [1.570796, 1.570796, 1.570796, 1.570796]
    >>> tangent_angles(Path.circle((0, 0), 3)).round(9).tolist()
    [0.0, 0.0]
    """
    v, c, s = path.vertices, path.centres, path.sweeps
    n = len(s)
    start = np.diff(v, axis=0)
    end = start.copy()
    arc = s != 0
    if arc.any():
        r0 = v[:-1][arc] - c[arc]
        r1 = v[1:][arc] - c[arc]
        sign = np.sign(s[arc])[:, None]
        start[arc] = sign * np.c_[-r0[:, 1], r0[:, 0]]
        end[arc] = sign * np.c_[-r1[:, 1], r1[:, 0]]
    start /= np.linalg.norm(start, axis=1, keepdims=True)
    end /= np.linalg.norm(end, axis=1, keepdims=True)
    a, b = end[:-1], start[1:]
    if path.closed and n > 1:
        a, b = np.vstack([a, end[-1:]]), np.vstack([b, start[:1]])
    return np.abs(np.arctan2(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0], np.sum(a * b, axis=1)))


def arc_from_tangent(start, tangent, end) -> tuple[np.ndarray, float]:
    """The circular arc leaving ``start`` along ``tangent`` and ending at ``end``.

    Returns
    -------
    centre : ndarray (2,)
        mm (NaN when the arc is a straight line).
    sweep : float
        Signed sweep, rad (CCW > 0; 0 for a line).

    Examples
    --------
    >>> c, s = arc_from_tangent((1, 0), (0, 1), (-1, 0))      # half of the unit circle
    >>> c.round(12).tolist(), round(s, 12)
    ([0.0, 0.0], 3.141592653590)
    """
    a, t, b = (np.asarray(x, dtype=float).reshape(2) for x in (start, tangent, end))
    tx, ty, n = _unit(t[0], t[1])
    if n == 0.0:
        raise GeometryError("arc_from_tangent: tangent must be a non-zero vector")
    cx, cy, s = _arc_from_tangent(a[0], a[1], tx, ty, b[0], b[1])
    return np.array([cx, cy]), float(s)


def biarc(p0, t0, p1, t1, **meta) -> Path:
    """The equal-tangent-length biarc from ``p0`` (tangent ``t0``) to ``p1`` (tangent ``t1``).

    Parameters
    ----------
    p0, p1 : array_like (2,)
        End points, mm.
    t0, t1 : array_like (2,)
        Tangent directions at the ends (any non-zero length).
    **meta
        Layer and colours of the :class:`Path`.

    Returns
    -------
    Path
        Two segments (arcs, or lines where an arc is straight) meeting with a
        common tangent; one segment when the joint falls on an end point.

    Raises
    ------
    GeometryError
        When the points coincide, a tangent is zero, or no biarc exists
        (equal tangents pointing away from the chord).

    Notes
    -----
    See the module docstring for the construction ([MicroCAM] §6.1.4 asks
    for curves as arcs; the biarc is the tangent-continuous way).

    Examples
    --------
    Tangents of a quarter circle give the quarter circle (two arcs of one circle):

    >>> p = biarc((10, 0), (0, 1), (0, 10), (-1, 0))
    >>> p.n_segments, p.radii_mm().round(9).tolist(), p.centres.round(9).tolist()
    (2, [10.0, 10.0], [[0.0, 0.0], [0.0, 0.0]])

    An S-bend: the arcs turn opposite ways, with the same tangent at the joint:

    >>> s = biarc((0, 0), (1, 0), (10, 4), (1, 0))
    >>> np.sign(s.sweeps).tolist(), float(tangent_angles(s).max()) < 1e-12
    ([1.0, -1.0], True)
    """
    p0, t0, p1, t1 = (np.asarray(x, dtype=float).reshape(2) for x in (p0, t0, p1, t1))
    u0 = _unit(t0[0], t0[1])
    u1 = _unit(t1[0], t1[1])
    if u0[2] == 0.0 or u1[2] == 0.0:
        raise GeometryError("biarc: tangents t0 and t1 must be non-zero vectors")
    if np.array_equal(p0, p1):
        raise GeometryError(f"biarc: end points coincide at {p0.tolist()}; a biarc needs distinct ends")
    out = np.empty(8)
    if not _biarc(p0[0], p0[1], u0[0], u0[1], p1[0], p1[1], u1[0], u1[1], out):
        raise GeometryError("biarc: no biarc joins these ends (equal tangents pointing back along "
                            "the chord); split the curve first")
    verts = np.empty((3, 2))
    verts[0] = p0
    centres = np.empty((2, 2))
    sweeps = np.empty(2)
    k = _emit(out, p0[0], p0[1], p1[0], p1[1], verts, centres, sweeps, 0)
    return Path(verts[:k + 1], centres[:k], sweeps[:k], **meta)
