"""Compiled greedy nearest-first segment ordering: the seed's O(n²) scan and a grid index.

Both pick, from the current position, the remaining segment whose entry
point is nearest (squared distance on the half-pixel integer grid, so there
is no rounding), ties going to the lower segment index and then to the
unreversed direction. With that total order on (distance², index, reversed)
the two give the identical sequence; they differ only in how many
candidates they look at.
"""

from __future__ import annotations

import numba
import numpy as np

_BIG = np.iinfo(np.int64).max


@numba.njit(cache=True, inline="always")
def _dist2(ax, ay, bx, by):
    dx = ax - bx
    dy = ay - by
    return dx * dx + dy * dy


@numba.njit(cache=True, inline="always")
def _exit_point(sx, sy, ex, ey, i, flipped):
    """Where the head is after cutting segment i (its start if run backwards)."""
    if flipped:
        return sx[i], sy[i]
    return ex[i], ey[i]


@numba.njit(cache=True)
def greedy_reference(sx, sy, ex, ey, reversible, ox, oy):
    """[LaserApp] §3.4.1: look at every remaining segment at every step.

    The remaining segments are kept in their original order and the chosen
    one is removed from the list, as the seed does. Returns (order,
    reversed flags, candidates examined).
    """
    n = sx.shape[0]
    remaining = np.arange(n)
    left = n
    order = np.empty(n, dtype=np.int64)
    flipped = np.zeros(n, dtype=np.bool_)
    px = ox
    py = oy
    examined = 0
    for step in range(n):
        best_k = -1
        best_d = _BIG
        best_f = False
        for k in range(left):
            i = remaining[k]
            d = _dist2(sx[i], sy[i], px, py)
            if d < best_d:
                best_d, best_k, best_f = d, k, False
            if reversible:
                d = _dist2(ex[i], ey[i], px, py)
                if d < best_d:
                    best_d, best_k, best_f = d, k, True
        examined += left * (2 if reversible else 1)
        i = remaining[best_k]
        order[step] = i
        flipped[step] = best_f
        for k in range(best_k, left - 1):
            remaining[k] = remaining[k + 1]
        left -= 1
        px, py = _exit_point(sx, sy, ex, ey, i, best_f)
    return order, flipped, examined


@numba.njit(cache=True)
def greedy_indexed(sx, sy, ex, ey, reversible, ox, oy, cell):
    """The same greedy order, with entry points bucketed in a uniform grid of ``cell`` units.

    A query looks at the grid cells in square rings around its own cell and
    stops once the nearest cell border of the rings not yet searched is
    farther than the best candidate found (strictly, so an equally near
    candidate with a lower index is never missed). Taken points are
    swap-removed from their cell. Returns (order, reversed flags,
    candidates examined).
    """
    n = sx.shape[0]
    ends = 2 if reversible else 1
    npts = n * ends
    px_all = np.empty(npts, dtype=np.int64)
    py_all = np.empty(npts, dtype=np.int64)
    for i in range(n):
        px_all[i * ends] = sx[i]
        py_all[i * ends] = sy[i]
        if reversible:
            px_all[i * ends + 1] = ex[i]
            py_all[i * ends + 1] = ey[i]
    max_x = 0
    max_y = 0
    for p in range(npts):
        max_x = max(max_x, px_all[p])
        max_y = max(max_y, py_all[p])
    gw = max_x // cell + 1
    gh = max_y // cell + 1
    cell_of = np.empty(npts, dtype=np.int64)
    counts = np.zeros(gw * gh + 1, dtype=np.int64)
    for p in range(npts):
        cell_of[p] = (py_all[p] // cell) * gw + px_all[p] // cell
        counts[cell_of[p] + 1] += 1
    start = np.cumsum(counts)
    live = counts[1:].copy()
    fill = start[:-1].copy()
    items = np.empty(npts, dtype=np.int64)
    pos = np.empty(npts, dtype=np.int64)
    for p in range(npts):
        k = fill[cell_of[p]]
        items[k] = p
        pos[p] = k
        fill[cell_of[p]] += 1

    order = np.empty(n, dtype=np.int64)
    flipped = np.zeros(n, dtype=np.bool_)
    qx = ox
    qy = oy
    examined = 0
    for step in range(n):
        cx = min(max(qx // cell, 0), gw - 1)
        cy = min(max(qy // cell, 0), gh - 1)
        best_d = _BIG
        best_p = -1
        ring = 0
        while True:
            x0 = cx - ring
            x1 = cx + ring
            y0 = cy - ring
            y1 = cy + ring
            for gy in range(max(y0, 0), min(y1, gh - 1) + 1):
                edge_row = gy == y0 or gy == y1
                gx = max(x0, 0)
                while gx <= min(x1, gw - 1):
                    c = gy * gw + gx
                    base = start[c]
                    for k in range(base, base + live[c]):
                        p = items[k]
                        d = _dist2(px_all[p], py_all[p], qx, qy)
                        examined += 1
                        # key (distance², segment, reversed) = (d, p // ends, p % ends): p orders both
                        if d < best_d or (d == best_d and p < best_p):
                            best_d = d
                            best_p = p
                    if edge_row or gx == x1:
                        gx += 1
                    else:
                        gx = x1  # inside rows: only the two side cells belong to this ring
            if x0 <= 0 and y0 <= 0 and x1 >= gw - 1 and y1 >= gh - 1:
                break
            if best_p >= 0:
                # distance from the query to the nearest unsearched cell, per open side
                # (integer coordinates: a point left of x0·cell is at x ≤ x0·cell − 1)
                lb = _BIG
                if x0 > 0:
                    lb = min(lb, qx - x0 * cell + 1)
                if x1 < gw - 1:
                    lb = min(lb, (x1 + 1) * cell - qx)
                if y0 > 0:
                    lb = min(lb, qy - y0 * cell + 1)
                if y1 < gh - 1:
                    lb = min(lb, (y1 + 1) * cell - qy)
                if lb * lb > best_d:
                    break
            ring += 1
        i = best_p // ends
        f = reversible and best_p % ends == 1
        order[step] = i
        flipped[step] = f
        for e in range(ends):
            p = i * ends + e
            c = cell_of[p]
            k = pos[p]
            last = start[c] + live[c] - 1
            q = items[last]
            items[k] = q
            pos[q] = k
            items[last] = p
            pos[p] = last
            live[c] -= 1
        qx, qy = _exit_point(sx, sy, ex, ey, i, f)
    return order, flipped, examined
