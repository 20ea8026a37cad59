"""Curves to circular arcs within a tolerance (seed 001 §6.1.4).

Cutting a curve as many short lines makes many G-code blocks and short
segments, and seed 001 measured that segments shorter than ~0.4 mm keep a
controller below the programmed feed. Replacing runs of points by arcs
(G2/G3) that stay within a tolerance gives fewer, longer blocks.

Method: greedy longest-run fitting. From the current point, the run of
following samples is grown (doubling, then bisecting) as long as one
primitive fits all of them within ``tol_mm``: first a straight line if the
samples are within 5 % of the tolerance of the chord, else the circle through the run's first,
middle and last samples (every sample's distance to the circle, and the
samples must advance monotonically around it, less than a full turn, and the
arc must not bulge more than the tolerance from the chord between two
samples, which is what the input polyline draws there), and only when the
samples are too straight for a circle of radius ≤ 10 m, a line within the full
tolerance. The
arcs meet end to end at samples of the curve, so the result is continuous;
unlike biarcs it is not forced tangent-continuous, but needs no tangents
and meets the same tolerance with a similar count of blocks.

The input must be dense: samples of the true curve (from
:func:`labkit.geometry.bezier.flatten_cubics` at a fraction of the
tolerance, or a polyline from a scanner or a DXF spline).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from labkit.errors import GeometryError
from labkit.geometry.bezier import flatten_cubics
from labkit.geometry.path import Path

__all__ = ["fit_arcs", "cubics_to_arcs", "FLATTEN_SHARE"]

#: Share of the tolerance spent on sampling the curve before fitting (the rest fits).
FLATTEN_SHARE = 0.15
_MAX_RADIUS_MM = 1e4
#: Lines are preferred only when this close (share of tol); otherwise an arc is tried first,
#: so that lines do not eat into the corner arcs of an offset.
LINE_SHARE = 0.05


@numba.njit(cache=True)
def _line_fits(p, i, j, tol):
    sx, sy = p[i, 0], p[i, 1]
    dx, dy = p[j, 0] - sx, p[j, 1] - sy
    L2 = dx * dx + dy * dy
    worst = 0.0
    for k in range(i + 1, j):
        qx, qy = p[k, 0] - sx, p[k, 1] - sy
        if L2 == 0.0:
            d = math.hypot(qx, qy)
        else:
            t = min(1.0, max(0.0, (qx * dx + qy * dy) / L2))
            d = math.hypot(qx - t * dx, qy - t * dy)
        if d > tol:
            return -1.0
        worst = max(worst, d)
    return worst


@numba.njit(cache=True)
def _arc_fits(p, i, j, tol, out):
    """Circle through p[i], p[mid], p[j]; out = (cx, cy, sweep).

    Returns the max error, -1 if it does not fit, -2 if the points are too
    nearly straight for a usable circle."""
    m = (i + j) // 2
    ax, ay = p[i, 0], p[i, 1]
    ux, uy = p[m, 0] - ax, p[m, 1] - ay
    vx, vy = p[j, 0] - ax, p[j, 1] - ay
    d = 2.0 * (ux * vy - uy * vx)
    u2 = ux * ux + uy * uy
    v2 = vx * vx + vy * vy
    if abs(d) <= 1e-14 * math.sqrt(u2 * v2) or d == 0.0:
        return -2.0
    cx = ax + (vy * u2 - uy * v2) / d
    cy = ay + (ux * v2 - vx * u2) / d
    r = math.hypot(ax - cx, ay - cy)
    if r > _MAX_RADIUS_MM:
        return -2.0
    sign = 1.0 if d > 0 else -1.0
    sweep = 0.0
    worst = 0.0
    px, py = ax - cx, ay - cy
    for k in range(i + 1, j + 1):
        qx, qy = p[k, 0] - cx, p[k, 1] - cy
        e = abs(math.hypot(qx, qy) - r)
        if e > tol:
            return -1.0
        worst = max(worst, e)
        step = math.atan2(px * qy - py * qx, px * qx + py * qy)
        if step * sign < 0.0:
            return -1.0
        # the input between two samples is a straight chord: the arc bulges from it by
        # its sagitta, which must fit too (matters for sparse polylines such as polygons)
        half = 0.5 * math.hypot(qx - px, qy - py)
        sag = r - math.sqrt(max(r * r - half * half, 0.0))
        if sag + e > tol:
            return -1.0
        sweep += step
        px, py = qx, qy
    if abs(sweep) >= 2.0 * math.pi - 1e-6:
        return -1.0
    out[0], out[1], out[2] = cx, cy, sweep
    return worst


@numba.njit(cache=True)
def _try(p, i, j, tol, allow_arcs, buf):
    """Fit samples i..j: a near-exact line, else an arc, else (if the samples are too
    straight for a circle of usable radius) a line within tol."""
    if not allow_arcs:
        return _line_fits(p, i, j, tol), 0
    e = _line_fits(p, i, j, LINE_SHARE * tol)
    if e >= 0.0:
        return e, 0
    if j - i >= 2:
        e = _arc_fits(p, i, j, tol, buf)
        if e >= 0.0:
            return e, 1
        if e == -1.0:
            return -1.0, 0
    return _line_fits(p, i, j, tol), 0


@numba.njit(cache=True)
def _fit_kernel(p, tol, allow_arcs):
    n = p.shape[0]
    ends = np.empty(n, np.int64)
    centres = np.full((n, 2), np.nan)
    sweeps = np.zeros(n)
    k = 0
    worst_all = 0.0
    buf = np.empty(3)
    best_buf = np.empty(3)
    i = 0
    while i < n - 1:
        # exponential then binary search for the longest run i..j one primitive fits
        best_j, best_kind, best_err = i + 1, 0, 0.0
        lo, hi = i + 1, n          # lo fits (adjacent points always fit a line); hi does not
        step = 2
        while True:
            j = i + step
            if j >= n:
                j = n - 1
            e, kind = _try(p, i, j, tol, allow_arcs, buf)
            if e >= 0.0:
                lo, best_j, best_kind, best_err = j, j, kind, e
                best_buf[:] = buf
                if j == n - 1:
                    hi = n
                    break
                step *= 2
            else:
                hi = j
                break
        while hi - lo > 1:
            j = (lo + hi) // 2
            e, kind = _try(p, i, j, tol, allow_arcs, buf)
            if e >= 0.0:
                lo, best_j, best_kind, best_err = j, j, kind, e
                best_buf[:] = buf
            else:
                hi = j
        ends[k] = best_j
        if best_kind == 1:
            centres[k, 0] = best_buf[0]
            centres[k, 1] = best_buf[1]
            sweeps[k] = best_buf[2]
        worst_all = max(worst_all, best_err)
        k += 1
        i = best_j
    return ends[:k], centres[:k], sweeps[:k], worst_all


def fit_arcs(points, tol_mm, *, arcs=True, closed=False, base_deviation_mm=0.0, **meta) -> Path:
    """Replace a dense polyline by fewer lines and circular arcs within ``tol_mm``.

    Parameters
    ----------
    points : array_like, shape (n, 2)
        Samples of a curve, mm, in order (n ≥ 2).
    tol_mm : float
        Largest distance of any sample from the primitive replacing it, mm.
    arcs : bool
        False allows straight lines only (a polyline simplification).
    closed : bool
        The points form a loop (first = last).
    base_deviation_mm : float
        Deviation already in the samples (added to the reported deviation).
    **meta
        Layer and colours of the :class:`Path`.

    Returns
    -------
    Path
        Its vertices are a subset of ``points``; ``deviation_mm`` is the largest
        sample distance measured plus ``base_deviation_mm``.

    Examples
    --------
    Two hundred samples of a half circle become one arc:

    >>> import numpy as np
    >>> t = np.linspace(0, np.pi, 200)
    >>> p = fit_arcs(np.c_[10 * np.cos(t), 10 * np.sin(t)], 0.001)
    >>> p.n_segments, round(float(p.radii_mm()[0]), 6), round(float(p.sweeps[0]), 6)
    (1, 10.0, 3.141593)
    """
    p = np.ascontiguousarray(points, dtype=float).reshape(-1, 2)
    if len(p) < 2:
        raise GeometryError(f"fit_arcs needs at least 2 points, got {len(p)}")
    if not tol_mm > 0:
        raise GeometryError(f"tol_mm must be > 0 mm, got {tol_mm!r}")
    keep = np.r_[True, np.any(np.diff(p, axis=0) != 0, axis=1)]
    p = p[keep]
    if len(p) < 2:
        raise GeometryError("fit_arcs: all points coincide")
    if closed and len(p) >= 5:
        # fit the two halves of a loop apart, so that a circle becomes two half arcs
        # rather than one arc short of a full turn plus a sliver
        mid = len(p) // 2
        e1, c1, s1, w1 = _fit_kernel(p[:mid + 1], float(tol_mm), bool(arcs))
        e2, c2, s2, w2 = _fit_kernel(p[mid:], float(tol_mm), bool(arcs))
        ends = np.concatenate([e1, e2 + mid])
        centres, sweeps, worst = np.vstack([c1, c2]), np.concatenate([s1, s2]), max(w1, w2)
    else:
        ends, centres, sweeps, worst = _fit_kernel(p, float(tol_mm), bool(arcs))
    verts = np.vstack([p[:1], p[ends]])
    return Path(verts, centres, sweeps, closed=closed,
                deviation_mm=float(worst) + base_deviation_mm, **meta)


def cubics_to_arcs(ctrls, tol_mm, *, arcs=True, start=None, **meta) -> Path:
    """A chain of cubic Beziers (m, 4, 2) as lines and arcs within ``tol_mm``.

    The curves are sampled by De Casteljau halving at ``FLATTEN_SHARE·tol_mm``
    and the samples fitted by :func:`fit_arcs` with the rest of the budget.

    Examples
    --------
    A quarter circle drawn as the usual cubic (k = 0.5523) comes back as one arc:

    >>> k = 0.5522847498
    >>> p = cubics_to_arcs([[[10, 0], [10, 10 * k], [10 * k, 10], [0, 10]]], 0.01)
    >>> p.n_segments, int(p.is_arc.sum()), round(float(p.radii_mm()[0]), 2)
    (1, 1, 10.0)
    """
    if not tol_mm > 0:
        raise GeometryError(f"tol_mm must be > 0 mm, got {tol_mm!r}")
    c = np.asarray(ctrls, dtype=float).reshape(-1, 4, 2)
    flat_tol = FLATTEN_SHARE * tol_mm
    pts, _ = flatten_cubics(c, flat_tol)
    first = c[:1, 0] if start is None else np.asarray(start, dtype=float).reshape(1, 2)
    dense = np.vstack([first, pts])
    if not arcs:
        return fit_arcs(dense, tol_mm - flat_tol, arcs=False, base_deviation_mm=flat_tol, **meta)
    return fit_arcs(dense, tol_mm - flat_tol, base_deviation_mm=flat_tol, **meta)
