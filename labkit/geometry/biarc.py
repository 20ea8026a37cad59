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

This module is the readable version, in plain numpy, for learning and for checking:
the compiled fit (``method="biarc"`` of :func:`labkit.geometry.arcfit.cubics_to_arcs`
and :func:`~labkit.geometry.arcfit.fit_arcs`, in the private
:mod:`labkit.geometry._biarcfit`) builds the same biarcs with the same formulas and is
tested against these functions.
"""

from __future__ import annotations

import math

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

    Signed curvature κ = 2·(t × (B − A))/|B − A|², sweep 2·atan2(t × u, t·u) with u the
    unit chord; the centre lies 1/κ to the left of the tangent.

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
    n = math.hypot(t[0], t[1])
    if n == 0.0:
        raise GeometryError("arc_from_tangent: tangent must be a non-zero vector")
    t = t / n
    chord = b - a
    length = math.hypot(chord[0], chord[1])
    if length == 0.0:
        return np.array([np.nan, np.nan]), 0.0
    u = chord / length
    cross = t[0] * u[1] - t[1] * u[0]
    dot = t[0] * u[0] + t[1] * u[1]
    if cross == 0.0 and dot < 0.0:
        raise GeometryError("arc_from_tangent: the tangent points straight away from the end: "
                            "no arc leaves along it and comes back (it would be a full circle)")
    sweep = 2.0 * math.atan2(cross, dot)
    sagitta = abs(length / 2.0 * math.tan(sweep / 4.0))
    if sagitta <= LINE_SAGITTA_MM:
        return np.array([np.nan, np.nan]), 0.0           # as good as its chord
    kappa = 2.0 * cross / length
    centre = a + np.array([-t[1], t[0]]) / kappa
    return centre, float(sweep)


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
    n0, n1 = math.hypot(*t0), math.hypot(*t1)
    if n0 == 0.0 or n1 == 0.0:
        raise GeometryError("biarc: tangents t0 and t1 must be non-zero vectors")
    if np.array_equal(p0, p1):
        raise GeometryError(f"biarc: end points coincide at {p0.tolist()}; a biarc needs distinct ends")
    t0, t1 = t0 / n0, t1 / n1
    v = p1 - p0
    a = 2.0 * (t0 @ t1 - 1.0)
    b = v @ (t0 + t1)
    den = b + math.sqrt(max(b * b - a * (v @ v), 0.0))
    none = ("biarc: no biarc joins these ends (equal tangents pointing back along the chord, "
            "or tangent lines reaching too far); split the curve first")
    if den <= 1e-12 * math.sqrt(v @ v):
        raise GeometryError(none)
    d = (v @ v) / den                                    # the quadratic's positive root
    if d > MAX_JOINT_REACH * math.sqrt(v @ v):
        raise GeometryError(none)
    q0, q1 = p0 + d * t0, p1 - d * t1
    if np.array_equal(q0, q1):
        raise GeometryError(none)
    joint = (q0 + q1) / 2.0
    verts, centres, sweeps = [p0], [], []
    for start, tangent, end in ((p0, t0, joint), (joint, q1 - q0, p1)):
        if np.array_equal(start, end):
            continue                                     # the joint fell on an end point
        c, s = arc_from_tangent(start, tangent, end)
        if abs(s) >= 2.0 * math.pi - 1e-6:
            raise GeometryError(none)
        verts.append(end)
        centres.append(c)
        sweeps.append(s)
    return Path(np.array(verts), np.array(centres).reshape(-1, 2), np.array(sweeps), **meta)
