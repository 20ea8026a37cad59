"""Distances between paths: the measure every conversion is checked with.

Segments are cut into pieces no longer than a grid cell and filed by their
mid points, so each query searches only nearby cells (a compiled ring search):
near O(m + n) for m points against n segments.

:func:`path_distance` is the exact distance from points to a chain of lines
and arcs (to a segment: the foot of the perpendicular or the nearer end; to
an arc: the radial distance when the point lies in the arc's angular span,
else the nearer end). :func:`hausdorff` is the symmetric Hausdorff distance
between two sets of paths — the largest distance from any point of either
to the other — evaluated on samples of each within ``sample_tol_mm``.
"""

from __future__ import annotations

import math
from typing import Sequence, Union

import numpy as np

from labkit._jit import jit
from labkit.geometry._grid import buckets
from labkit.geometry.path import Path, paths_bounds

__all__ = ["path_distance", "hausdorff"]

PathLike = Union[Path, Sequence[Path]]


@jit
def _seg_dist(qx, qy, ax, ay, bx, by, cx, cy, r, a0, sw):
    """Exact distance from (qx, qy) to one line (sw == 0) or arc segment."""
    if sw == 0.0:
        dx, dy = bx - ax, by - ay
        L2 = dx * dx + dy * dy
        t = 0.0 if L2 == 0.0 else ((qx - ax) * dx + (qy - ay) * dy) / L2
        t = min(1.0, max(0.0, t))
        return math.hypot(qx - ax - t * dx, qy - ay - t * dy)
    ux, uy = qx - cx, qy - cy
    ang = math.atan2(uy, ux) - a0        # angle from the arc start, in the arc's direction
    if sw < 0.0:
        ang = -ang
    ang = ang % (2.0 * math.pi)
    if ang <= abs(sw):
        return abs(math.hypot(ux, uy) - r)
    return min(math.hypot(qx - ax, qy - ay), math.hypot(qx - bx, qy - by))


def _seg_dist_numpy(qx, qy, ax, ay, bx, by, cx, cy, r, a0, sw):
    """:func:`_seg_dist` of many point–segment pairs at once (arrays of one length)."""
    dx, dy = bx - ax, by - ay
    L2 = dx * dx + dy * dy
    with np.errstate(invalid="ignore", divide="ignore"):
        t = np.where(L2 == 0.0, 0.0, ((qx - ax) * dx + (qy - ay) * dy) / L2)
    t = np.minimum(1.0, np.maximum(0.0, t))
    line = np.hypot(qx - ax - t * dx, qy - ay - t * dy)
    ux, uy = qx - cx, qy - cy
    ang = np.arctan2(uy, ux) - a0
    ang = np.where(sw < 0.0, -ang, ang) % (2.0 * math.pi)
    ends = np.minimum(np.hypot(qx - ax, qy - ay), np.hypot(qx - bx, qy - by))
    arc = np.where(ang <= np.abs(sw), np.abs(np.hypot(ux, uy) - r), ends)
    return np.where(sw == 0.0, line, arc)


#: Point–segment pairs the numpy twin of _grid_dist measures at once (~100 MB of temporaries).
_PAIRS_AT_ONCE = 1 << 20


def _grid_dist_numpy(px, py, ax, ay, bx, by, cx, cy, r, a0, sw, mx, my, cell, x0, y0, nx, ny):
    """:func:`_grid_dist` as numpy, for when it runs as Python: every query against the
    segments filed in the 3 × 3 cells around it at once. Where the nearest of those lies
    within cell/2, no farther cell can hold a nearer one (the kernel's ring rule, stopping
    at ring 1), so that is the kernel's answer (to rounding: numpy's hypot); the few other
    queries go through the kernel's own ring search."""
    gx = np.clip(np.floor((mx - x0) / cell), 0, nx - 1).astype(np.int64)
    gy = np.clip(np.floor((my - y0) / cell), 0, ny - 1).astype(np.int64)
    key = gy * nx + gx
    order = np.argsort(key, kind="stable")
    start = np.concatenate(([0], np.cumsum(np.bincount(key, minlength=nx * ny))))
    qgx = np.floor((px - x0) / cell)
    qgy = np.floor((py - y0) / cell)
    inside = (qgx >= 0) & (qgx < nx) & (qgy >= 0) & (qgy < ny)
    queries = np.flatnonzero(inside)
    qgx, qgy = qgx[queries].astype(np.int64), qgy[queries].astype(np.int64)
    best = np.full(px.shape[0], np.inf)
    for oy in (-1, 0, 1):
        for ox in (-1, 0, 1):
            xx, yy = qgx + ox, qgy + oy
            ok = (xx >= 0) & (xx < nx) & (yy >= 0) & (yy < ny)
            q, c = queries[ok], (yy * nx + xx)[ok]
            n = start[c + 1] - start[c]
            q, c, n = q[n > 0], c[n > 0], n[n > 0]
            # queries in chunks of about _PAIRS_AT_ONCE pairs: memory stays bounded where
            # many segments share a cell (a dense detail in a wide drawing)
            ends = np.searchsorted(np.cumsum(n), np.arange(1, 1 + n.sum() // _PAIRS_AT_ONCE) * _PAIRS_AT_ONCE)
            for lo, hi in zip(np.r_[0, ends + 1], np.r_[ends + 1, len(q)]):
                if lo >= hi:
                    continue
                qq, cc, nn = q[lo:hi], c[lo:hi], n[lo:hi]
                first = np.cumsum(nn) - nn
                qi = np.repeat(qq, nn)
                k = order[np.repeat(start[cc] - first, nn) + np.arange(int(nn.sum()))]
                d = _seg_dist_numpy(px[qi], py[qi], ax[k], ay[k], bx[k], by[k], cx[k], cy[k],
                                    r[k], a0[k], sw[k])
                best[qq] = np.minimum(best[qq], np.minimum.reduceat(d, first))
    rest = np.flatnonzero(~(inside & (best <= 0.5 * cell)))
    if len(rest):
        view = lambda v: memoryview(np.ascontiguousarray(v))   # noqa: E731  Python floats
        best[rest] = _ring_search(
            view(px[rest]), view(py[rest]), *(view(v) for v in (ax, ay, bx, by, cx, cy, r, a0, sw, mx, my)),
            cell, x0, y0, nx, ny)
    return best


# as Python the numpy twin above runs: ~0.3–0.4 µs an element (28,000 and 280,000 measured),
# a load of numba at ~2.5 M; set lower, as queries far from every segment take the slow search
@jit(python_below=1_000_000, python=_grid_dist_numpy)
def _grid_dist(px, py, ax, ay, bx, by, cx, cy, r, a0, sw, mx, my, cell, x0, y0, nx, ny):
    """Distance of every query point to the nearest segment. Segments are no longer than
    ``cell`` and filed in the grid cell of their mid point, so all of a segment lies within
    cell/2 of that cell; rings of cells are searched outwards until no farther ring can hold
    anything nearer."""
    _, order, start = buckets(mx, my, cell, x0, y0, nx, ny)
    out = np.empty(px.shape[0])
    for i in range(px.shape[0]):
        qgx = int(math.floor((px[i] - x0) / cell))
        qgy = int(math.floor((py[i] - y0) / cell))
        # rings start where the grid does (a query far outside jumps straight to it)
        r0 = max(0, -qgx, qgx - (nx - 1), -qgy, qgy - (ny - 1))
        best = np.inf
        ring = r0
        while True:
            for yy in range(qgy - ring, qgy + ring + 1):
                if yy < 0 or yy >= ny:
                    continue
                edge = yy == qgy - ring or yy == qgy + ring
                xx = qgx - ring
                while xx <= qgx + ring:
                    if 0 <= xx < nx:
                        c = yy * nx + xx
                        for s in range(start[c], start[c + 1]):
                            k = order[s]
                            d = _seg_dist(px[i], py[i], ax[k], ay[k], bx[k], by[k], cx[k], cy[k],
                                          r[k], a0[k], sw[k])
                            if d < best:
                                best = d
                    if edge or ring == 0:
                        xx += 1
                    else:
                        xx += 2 * ring
            # any cell beyond this ring is at least ring·cell away; its segments reach cell/2 out
            if best <= ring * cell - 0.5 * cell or ring > nx + ny + r0:
                break
            ring += 1
        out[i] = best
    return out


_ring_search = _grid_dist.py_func      # the kernel's own search as Python, for the twin's rest


def _split_segments(ps: list[Path], max_len: float):
    """All segments as arrays, each cut into pieces no longer than ``max_len``."""
    a = np.vstack([p.vertices[:-1] for p in ps])
    b = np.vstack([p.vertices[1:] for p in ps])
    c = np.vstack([p.centres for p in ps])
    sw = np.concatenate([p.sweeps for p in ps])
    c = np.where(np.isnan(c), 0.0, c)
    rad = np.hypot(*(a - c).T)
    length = np.where(sw == 0, np.hypot(*(b - a).T), np.abs(sw) * rad)
    k = np.maximum(np.ceil(length / max_len).astype(np.int64), 1)
    idx = np.repeat(np.arange(len(a)), k)
    j = np.arange(k.sum()) - np.repeat(np.cumsum(k) - k, k)
    f0, f1 = j / k[idx], (j + 1) / k[idx]
    a0_full = np.arctan2(a[:, 1] - c[:, 1], a[:, 0] - c[:, 0])
    is_arc = sw[idx] != 0
    ang0 = a0_full[idx] + sw[idx] * f0
    ang1 = a0_full[idx] + sw[idx] * f1
    ci, ri = c[idx], rad[idx]
    pa = np.where(is_arc[:, None], ci + ri[:, None] * np.c_[np.cos(ang0), np.sin(ang0)],
                  a[idx] + (b - a)[idx] * f0[:, None])
    pb = np.where(is_arc[:, None], ci + ri[:, None] * np.c_[np.cos(ang1), np.sin(ang1)],
                  a[idx] + (b - a)[idx] * f1[:, None])
    angm = 0.5 * (ang0 + ang1)
    mid = np.where(is_arc[:, None], ci + ri[:, None] * np.c_[np.cos(angm), np.sin(angm)], 0.5 * (pa + pb))
    return pa, pb, ci, ri, ang0, sw[idx] / k[idx], mid


def _as_list(p: PathLike) -> list[Path]:
    return [p] if isinstance(p, Path) else list(p)


def path_distance(paths: PathLike, points) -> np.ndarray:
    """Distance (mm) from each point (m, 2) to the nearest point of the paths.

    Examples
    --------
    >>> arc = Path.arc((0, 0), 10, 0.0, np.pi / 2)          # quarter circle in quadrant 1
    >>> path_distance(arc, [[0, 0], [20, 0], [-10, 0]]).round(6).tolist()
    [10.0, 10.0, 14.142136]
    """
    ps = _as_list(paths)
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    lo, hi = paths_bounds(ps)
    n_seg = sum(p.n_segments for p in ps)
    span = max(float(np.max(hi - lo)), 1e-9)
    cell = max(span / max(1.0, math.sqrt(n_seg)), span / 4096, 1e-9)
    pa, pb, c, r, a0, sw, mid = _split_segments(ps, cell)
    nx = int((hi[0] - lo[0]) / cell) + 1
    ny = int((hi[1] - lo[1]) / cell) + 1
    f = lambda v: np.ascontiguousarray(v, dtype=float)   # noqa: E731
    return _grid_dist(f(pts[:, 0]), f(pts[:, 1]), f(pa[:, 0]), f(pa[:, 1]), f(pb[:, 0]), f(pb[:, 1]),
                      f(c[:, 0]), f(c[:, 1]), f(r), f(a0), f(sw), f(mid[:, 0]), f(mid[:, 1]),
                      float(cell), float(lo[0]), float(lo[1]), nx, ny)


def _densify(pts: np.ndarray, step_mm: float) -> np.ndarray:
    seg = np.diff(pts, axis=0)
    n = np.maximum(np.ceil(np.hypot(*seg.T) / step_mm).astype(np.int64), 1)
    first = np.repeat(np.cumsum(n) - n, n)                   # index of each piece's first point
    t = (np.arange(int(n.sum())) - first) / np.repeat(n, n)   # k / n_k, k = 0 … n_k − 1
    base = np.repeat(pts[:-1], n, axis=0)
    return np.vstack([base + np.repeat(seg, n, axis=0) * t[:, None], pts[-1:]])


def hausdorff(a: PathLike, b: PathLike, *, sample_tol_mm=1e-6, step_mm=0.05) -> float:
    """Symmetric Hausdorff distance between two sets of paths, mm.

    Each side is sampled (arcs within ``sample_tol_mm``, points at most
    ``step_mm`` apart) and measured exactly against the other side's lines
    and arcs.

    Examples
    --------
    >>> outer, inner = Path.circle((0, 0), 10), Path.circle((0, 0), 9.5)
    >>> round(hausdorff(outer, inner), 9)
    0.5
    """
    la, lb = _as_list(a), _as_list(b)
    pa = np.vstack([_densify(p.sample(sample_tol_mm), step_mm) for p in la])
    pb = np.vstack([_densify(p.sample(sample_tol_mm), step_mm) for p in lb])
    return float(max(path_distance(lb, pa).max(), path_distance(la, pb).max()))
