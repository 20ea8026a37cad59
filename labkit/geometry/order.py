"""Cutting order: minimise travel between chains ([MicroCAM] §6.1.3.1, fig. 6-13).

The head must visit every chain once; travel (laser off) is wasted time. The
problem is a travelling-salesman path with choices: an open chain may be cut
in either direction, a closed chain may start at any of its vertices.

1. **Greedy nearest neighbour on a grid.** From the current head position,
   cut next the chain whose entry point is nearest. Entry points (both ends of
   open chains, every vertex of closed chains) sit in a uniform grid; the
   search visits rings of cells outwards and stops once no unvisited ring can
   hold anything nearer. O(n) per step in the worst case, near O(1) typical.
2. **2-opt improvement.** Reversing a block of the order (and the direction
   of every chain in it) replaces two travel moves by two others. For each
   chain end, only moves that join it to one of its k nearest chain ends
   (k-d tree) are tried — the standard neighbour-list 2-opt — pass after
   pass until no move gains.

Parts must not drop out before their holes are cut, so by default a chain
that lies inside a closed chain is cut before it (``inner_first``): the
greedy step only offers chains whose insides are done, and 2-opt rejects a
reversal that would put a container before its contents.

Both loops are compiled with numba; :func:`travel_length` is the reference
they are tested against (brute force on small cases in the tests).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from labkit._jit import jit
from labkit.errors import GeometryError
from labkit.geometry._grid import buckets, nearest_neighbours
from labkit.geometry.path import Path, sample_each

__all__ = ["Ordering", "order_segments", "order_paths", "travel_length", "containment_parents", "greedy_grid"]


@dataclass(frozen=True)
class Ordering:
    """An order in which to cut items: labkit's one ordering result, of
    :func:`order_segments` (chains, mm) and of :func:`labkit.raster.pathing.connect`
    (raster runs, half-pixel units).

    Attributes
    ----------
    order : ndarray of int
        Item indices in cutting order.
    reversed : ndarray of bool
        Per position: cut that item backwards (end → start); ``flipped`` is the same array
        under the raster modules' word.
    entry : ndarray of int
        Per position: candidate (vertex) index where a closed item is entered
        (-1 for open items, and for every raster run).
    travel_mm : float
        Travel length from ``origin`` through the order, mm (NaN where not measured in mm:
        raster runs).
    greedy_travel_mm : float
        The same after the greedy step only.
    moves : int
        Improving 2-opt moves applied (work done).
    examined : int
        Distances computed to candidate entry points by the greedy search (work done).
    method : str
        How the order was found: ``"grid"`` (:func:`greedy_grid`, then 2-opt when asked),
        or the raster methods ``"indexed"``, ``"reference"`` and ``"scan"``.
    """

    order: np.ndarray
    reversed: np.ndarray
    entry: np.ndarray | None = None
    travel_mm: float = math.nan
    greedy_travel_mm: float = math.nan
    moves: int = 0
    examined: int = 0
    method: str = "grid"

    def __post_init__(self):
        if self.entry is None:                    # every item open
            object.__setattr__(self, "entry", np.full(len(self.order), -1, np.int64))

    @property
    def flipped(self) -> np.ndarray:
        """``reversed``, as the raster modules name it."""
        return self.reversed


def travel_length(starts, ends, origin=(0.0, 0.0)) -> float:
    """Travel of cutting items in the given order: origin → start₀, end₀ → start₁, … (mm).

    >>> travel_length([[1, 0], [5, 0]], [[2, 0], [9, 0]])
    4.0
    """
    s = np.asarray(starts, dtype=float).reshape(-1, 2)
    e = np.asarray(ends, dtype=float).reshape(-1, 2)
    if not len(s):
        return 0.0
    prev = np.vstack([np.asarray(origin, dtype=float)[None], e[:-1]])
    return float(np.hypot(*(s - prev).T).sum())


# -- greedy nearest neighbour on a grid -----------------------------------------------------

# views: as Python it indexes its arrays element by element, on Python scalars (~20 % faster)
@jit(python_below=200_000, views=True)  # ~1 µs an element as Python
def greedy_grid(cx, cy, ex, ey, citem, n_items, remaining, parent, ox, oy, cell, x0, y0, nx, ny):
    """Greedy nearest-entry order over candidates filed in a uniform grid (compiled).

    The one greedy search of labkit: chains here, raster runs in
    :func:`labkit.raster.pathing.connect`. Each item (a chain, a raster run) has one or
    more candidates — an entry point (cx, cy) and the exit (ex, ey) reached by cutting it
    that way. From the head position the nearest eligible candidate is taken, ties going
    to the lower candidate index (so a caller that numbers an item's variants after the
    item, ``2i`` forward and ``2i + 1`` reversed, gets ties by item, then direction —
    [LaserApp]'s O(n²) scan exactly). The search visits square rings of cells and stops
    once every unsearched cell is strictly farther than the best candidate; a taken
    item's candidates are swap-removed from their cells. ``remaining[i] > 0`` (contents
    of item i not yet cut) makes item i ineligible; taking an item decrements
    ``remaining[parent[item]]``.

    Returns (picked candidate per step, travel length, candidates examined, whether every
    item could be taken — False when parent links form a cycle).
    """
    m = cx.shape[0]
    key, order_c, start = buckets(cx, cy, cell, x0, y0, nx, ny)
    items = order_c.copy()                      # per cell, its live candidates first
    pos = np.empty(m, np.int64)
    for s in range(m):
        pos[items[s]] = s
    live = np.zeros(nx * ny, np.int64)
    for k in range(m):
        live[key[k]] += 1
    # candidates of one item, to retire them all when it is taken
    item_c_start = np.zeros(n_items + 1, np.int64)
    for k in range(m):
        item_c_start[citem[k] + 1] += 1
    for k in range(n_items):
        item_c_start[k + 1] += item_c_start[k]
    item_c = np.empty(m, np.int64)
    fill = item_c_start[:-1].copy()
    for k in range(m):
        item_c[fill[citem[k]]] = k
        fill[citem[k]] += 1
    out = np.empty(n_items, np.int64)
    px, py = ox, oy
    total = 0.0
    examined = 0
    constrained = False
    for i in range(n_items):
        constrained |= remaining[i] > 0
    for step in range(n_items):
        qx = min(max(int(math.floor((px - x0) / cell)), 0), nx - 1)
        qy = min(max(int(math.floor((py - y0) / cell)), 0), ny - 1)
        best, best_d = -1, np.inf
        r = 0
        while True:
            for gy in range(max(qy - r, 0), min(qy + r, ny - 1) + 1):
                edge_row = gy == qy - r or gy == qy + r
                gx = max(qx - r, 0)
                while gx <= min(qx + r, nx - 1):
                    c = gy * nx + gx
                    for s in range(start[c], start[c] + live[c]):
                        k = items[s]
                        examined += 1
                        if constrained and remaining[citem[k]] > 0:
                            continue
                        dx = cx[k] - px
                        dy = cy[k] - py
                        d = dx * dx + dy * dy
                        if d < best_d or (d == best_d and k < best):
                            best_d, best = d, k
                    if edge_row or gx == qx + r:
                        gx += 1
                    else:
                        gx = qx + r             # inner rows: only the ring's two side cells
            if qx - r <= 0 and qy - r <= 0 and qx + r >= nx - 1 and qy + r >= ny - 1:
                break                           # the whole grid is searched
            if best >= 0:
                # nearest unsearched cell border, per side still open
                lb = np.inf
                if qx - r > 0:
                    lb = min(lb, px - (x0 + (qx - r) * cell))
                if qx + r < nx - 1:
                    lb = min(lb, x0 + (qx + r + 1) * cell - px)
                if qy - r > 0:
                    lb = min(lb, py - (y0 + (qy - r) * cell))
                if qy + r < ny - 1:
                    lb = min(lb, y0 + (qy + r + 1) * cell - py)
                if lb > 0 and lb * lb > best_d:
                    break
            r += 1
        if best < 0:
            return out[:step], total, examined, False     # nothing eligible: a precedence cycle
        it = citem[best]
        for s in range(item_c_start[it], item_c_start[it + 1]):
            k = item_c[s]
            c = key[k]
            last = start[c] + live[c] - 1
            q = items[last]
            items[pos[k]] = q
            pos[q] = pos[k]
            items[last] = k
            pos[k] = last
            live[c] -= 1
        if parent[it] >= 0:
            remaining[parent[it]] -= 1
        out[step] = best
        total += math.sqrt(best_d)
        px, py = ex[best], ey[best]
    return out, total, examined, True


# -- 2-opt with neighbour lists ---------------------------------------------------------------

@jit
def _d(ax, ay, bx, by):
    return math.hypot(ax - bx, ay - by)


@jit
def _block_ok(tour, pos, parent, has_parent, i, j):
    """Reversing [i, j] keeps every item before its container (none has both inside)."""
    if not has_parent:
        return True
    for q in range(i, j + 1):
        par = parent[tour[q]]
        if par >= 0 and pos[par] >= i and pos[par] <= j:
            return False
    return True


@jit
def _reverse(tour, flip, pos, i, j):
    """Reverse positions i..j of the tour and the direction of every item in it."""
    lo, hi = i, j
    while lo < hi:
        t0 = tour[lo]
        tour[lo] = tour[hi]
        tour[hi] = t0
        lo += 1
        hi -= 1
    for q in range(i, j + 1):
        t = tour[q]
        flip[t] = 1 - flip[t]
        pos[t] = q


@jit(python_below=150_000)  # ~5.6 µs an element as Python (51–1,988 items: 1,479–57,652 elements)
def _two_opt(tour, flip, p_in, p_out, neigh_item, parent, ox, oy, max_passes):
    """tour: item per position; flip[item]: cut backwards; p_in/p_out (n, 2, 2): entry/exit
    point of each item for flip = 0 / 1. neigh_item (n, k): items whose ends are near."""
    n = tour.shape[0]
    pos = np.empty(n, np.int64)
    for i in range(n):
        pos[tour[i]] = i
    has_parent = False
    for i in range(n):
        if parent[i] >= 0:
            has_parent = True
            break
    moves = 0
    for _pass in range(max_passes):
        improved = False
        # prefix reversals [0, j]: the new first edge leaves the origin (no neighbour list has it)
        for j in range(n):
            t0, tj = tour[0], tour[j]
            old = _d(ox, oy, p_in[t0, flip[t0], 0], p_in[t0, flip[t0], 1])
            new = _d(ox, oy, p_out[tj, flip[tj], 0], p_out[tj, flip[tj], 1])
            if j + 1 < n:
                ta = tour[j + 1]
                old += _d(p_out[tj, flip[tj], 0], p_out[tj, flip[tj], 1],
                          p_in[ta, flip[ta], 0], p_in[ta, flip[ta], 1])
                new += _d(p_in[t0, flip[t0], 0], p_in[t0, flip[t0], 1],
                          p_in[ta, flip[ta], 0], p_in[ta, flip[ta], 1])
            if new < old - 1e-9 and _block_ok(tour, pos, parent, has_parent, 0, j):
                _reverse(tour, flip, pos, 0, j)
                moves += 1
                improved = True
        for a in range(n):
            for kk in range(neigh_item.shape[1]):
                b = neigh_item[a, kk]
                if b < 0 or b == a:
                    continue
                pa, pb = pos[a], pos[b]
                if pa > pb:
                    pa, pb = pb, pa
                # move 1: new edge out[pa] -> out[pb], reverse block [pa + 1, pb]
                # move 2: new edge in[pa] -> in[pb], reverse block [pa, pb - 1]
                for mv in range(2):
                    if mv == 0:
                        i, j = pa + 1, pb
                    else:
                        i, j = pa, pb - 1
                    if i > j:
                        continue
                    ti, tj = tour[i], tour[j]
                    if i == 0:
                        bx, by = ox, oy
                    else:
                        tb = tour[i - 1]
                        bx, by = p_out[tb, flip[tb], 0], p_out[tb, flip[tb], 1]
                    iin_x, iin_y = p_in[ti, flip[ti], 0], p_in[ti, flip[ti], 1]
                    jout_x, jout_y = p_out[tj, flip[tj], 0], p_out[tj, flip[tj], 1]
                    old = _d(bx, by, iin_x, iin_y)
                    new = _d(bx, by, jout_x, jout_y)
                    if j + 1 < n:
                        ta = tour[j + 1]
                        ax_, ay_ = p_in[ta, flip[ta], 0], p_in[ta, flip[ta], 1]
                        old += _d(jout_x, jout_y, ax_, ay_)
                        new += _d(iin_x, iin_y, ax_, ay_)
                    if new < old - 1e-9 and _block_ok(tour, pos, parent, has_parent, i, j):
                        _reverse(tour, flip, pos, i, j)
                        moves += 1
                        improved = True
                        break
        if not improved:
            break
    return moves


# -- public API ---------------------------------------------------------------------------

def order_segments(starts, ends, *, closed_points=None, origin=(0.0, 0.0), improve=True,
                   parent=None, neighbours=8, max_passes=5) -> Ordering:
    """Order items (open segments and closed loops) to minimise travel.

    Parameters
    ----------
    starts, ends : array_like, shape (n, 2)
        Start and end of each open item, mm (may be cut in either direction).
    closed_points : sequence of arrays (k_i, 2), optional
        Closed items after the n open ones: the vertices where each may be
        entered (it is left where it was entered).
    origin : (x, y)
        Head position before the first cut, mm.
    improve : bool
        Run the 2-opt improvement after the greedy step.
    parent : array of int, optional
        For every item (open then closed) the item that must be cut AFTER it
        (its innermost container), -1 for none.
    neighbours : int
        Size of each end's neighbour list for 2-opt.
    max_passes : int
        Most 2-opt passes over all items.

    Returns
    -------
    Ordering

    Examples
    --------
    >>> o = order_segments([[10, 0], [1, 0], [5, 0]], [[11, 0], [2, 0], [4, 0]])
    >>> o.order.tolist(), o.reversed.tolist(), o.travel_mm
    ([1, 2, 0], [False, True, False], 8.0)
    """
    s = np.asarray(starts, dtype=float).reshape(-1, 2)
    e = np.asarray(ends, dtype=float).reshape(-1, 2)
    if s.shape != e.shape:
        raise GeometryError(f"starts and ends differ in shape: {s.shape} vs {e.shape}")
    closed = [np.asarray(c, dtype=float).reshape(-1, 2) for c in (closed_points or [])]
    if any(len(c) == 0 for c in closed):
        raise GeometryError("every closed item needs at least one entry point")
    n_open = len(s)
    n = n_open + len(closed)
    if neighbours < 1:
        raise GeometryError(f"neighbours must be >= 1, got {neighbours!r}")
    if n == 0:
        z = np.zeros(0, np.int64)
        return Ordering(z, z.astype(bool), z, 0.0, 0.0)
    par = np.full(n, -1, np.int64) if parent is None else np.asarray(parent, dtype=np.int64).copy()
    if par.shape != (n,) or np.any(par >= n) or np.any(par == np.arange(n)):
        raise GeometryError(f"parent must hold one item index (or -1) per item, {n} items")
    # candidates: open items twice (forward, reversed), closed items once per vertex
    cl_sizes = np.array([len(c) for c in closed], np.int64)
    # open item i: candidate 2i forward, 2i + 1 reversed (ties go by item, then direction)
    cx = np.concatenate([np.stack([s[:, 0], e[:, 0]], 1).ravel()] + [c[:, 0] for c in closed])
    cy = np.concatenate([np.stack([s[:, 1], e[:, 1]], 1).ravel()] + [c[:, 1] for c in closed])
    ex = np.concatenate([np.stack([e[:, 0], s[:, 0]], 1).ravel()] + [c[:, 0] for c in closed])
    ey = np.concatenate([np.stack([e[:, 1], s[:, 1]], 1).ravel()] + [c[:, 1] for c in closed])
    citem = np.concatenate([np.repeat(np.arange(n_open), 2),
                            np.repeat(np.arange(n_open, n), cl_sizes)]).astype(np.int64)
    cvert = np.concatenate([np.full(2 * n_open, -1), *[np.arange(k) for k in cl_sizes]]).astype(np.int64)
    remaining = np.bincount(par[par >= 0], minlength=n).astype(np.int64)
    lo = np.minimum(cx.min(), origin[0]), np.minimum(cy.min(), origin[1])
    hi = np.maximum(cx.max(), origin[0]), np.maximum(cy.max(), origin[1])
    span = max(hi[0] - lo[0], hi[1] - lo[1], 1e-9)
    cell = max(span / max(1.0, math.sqrt(len(cx) / 2.0)), 1e-9)
    nx = int((hi[0] - lo[0]) / cell) + 1
    ny = int((hi[1] - lo[1]) / cell) + 1
    picked, greedy_travel, examined, ok = greedy_grid(cx, cy, ex, ey, citem, n, remaining, par,
                                               float(origin[0]), float(origin[1]), cell, float(lo[0]),
                                               float(lo[1]), nx, ny)
    if not ok:
        raise GeometryError("parent links form a cycle: no order can cut every item after its contents")
    order = citem[picked]
    is_rev = (picked < 2 * n_open) & (picked % 2 == 1)
    entry = cvert[picked]
    moves = 0
    travel = float(greedy_travel)
    if improve and n > 2:
        p_in = np.empty((n, 2, 2))
        p_out = np.empty((n, 2, 2))
        p_in[:n_open, 0], p_out[:n_open, 0] = s, e
        p_in[:n_open, 1], p_out[:n_open, 1] = e, s
        ci = picked[order >= n_open]
        p_cl = np.stack([cx[ci], cy[ci]], axis=1)
        cl_items = order[order >= n_open]
        p_in[cl_items, 0] = p_in[cl_items, 1] = p_cl
        p_out[cl_items, 0] = p_out[cl_items, 1] = p_cl
        flip = np.zeros(n, np.int64)
        flip[order[is_rev]] = 1
        ends_pts = np.vstack([p_in[:, 0], p_out[:, 0]])
        kq = min(neighbours + 1, len(ends_pts))
        nb = nearest_neighbours(ends_pts, kq) % n
        neigh = np.concatenate([nb[:n], nb[n:]], axis=1).astype(np.int64)
        tour = order.astype(np.int64).copy()
        moves = int(_two_opt(tour, flip, p_in, p_out, neigh, par, float(origin[0]),
                             float(origin[1]), int(max_passes)))
        order = tour
        is_rev = flip[order].astype(bool)
        entry_by_item = np.full(n, -1, np.int64)
        entry_by_item[citem[picked]] = cvert[picked]
        entry = entry_by_item[order]
        ins = p_in[order, flip[order]]
        outs = p_out[order, flip[order]]
        travel = travel_length(ins, outs, origin)
    return Ordering(np.asarray(order, np.int64), np.asarray(is_rev, bool), np.asarray(entry, np.int64),
                    travel, float(greedy_travel), moves, int(examined))


def containment_parents(paths: Sequence[Path], tol_mm=0.05) -> np.ndarray:
    """Innermost closed path containing each path (-1 for none).

    A path is inside a closed path when its first vertex is; shapely's
    STRtree finds the candidates, so this is O(n log n) for separate parts.
    """
    import shapely

    n = len(paths)
    parent = np.full(n, -1, np.int64)
    closed = [i for i, p in enumerate(paths) if p.closed and p.n_segments >= 2]
    if not closed:
        return parent
    rings = sample_each([paths[i] for i in closed], tol_mm)
    # all polygons in one shapely call (the same rings as shapely.Polygon of each)
    polys = shapely.polygons(shapely.linearrings(np.concatenate(rings),
                                                 indices=np.repeat(np.arange(len(rings)), [len(r) for r in rings])))
    areas = np.abs(shapely.area(polys))
    tree = shapely.STRtree(polys)
    pts = shapely.points(np.array([p.vertices[min(1, p.n_segments - 1)] for p in paths]))
    pi, ti = tree.query(pts, predicate="within")
    own_area = np.zeros(n)
    own_area[closed] = areas
    best_area = np.full(n, np.inf)
    for a, b in zip(pi, ti):
        # a container must be larger than what it holds (guards overlaps and itself)
        if areas[b] <= own_area[a] or areas[b] >= best_area[a]:
            continue
        best_area[a], parent[a] = areas[b], closed[b]
    return parent


def order_paths(paths: Sequence[Path], *, origin=(0.0, 0.0), improve=True, inner_first=True,
                neighbours=8) -> list[Path]:
    """Paths in a cutting order with little travel (directions and entry points chosen).

    Parameters
    ----------
    paths : sequence of Path
    origin : (x, y)
        Head position before the first cut, mm.
    improve : bool
        2-opt after the greedy step.
    inner_first : bool
        Cut everything inside a closed path before that path.
    neighbours : int
        Neighbour-list size for 2-opt.

    Returns
    -------
    list of Path
        Open paths possibly reversed, closed paths possibly started elsewhere.

    Examples
    --------
    A hole is cut before the part around it, even though the part's edge is nearer:

    >>> part = Path.rectangle(0, 0, 50, 50)
    >>> hole = Path.circle((25, 25), 5)
    >>> [p.n_segments for p in order_paths([part, hole])]
    [2, 4]
    """
    paths = list(paths)
    if not paths:
        return []
    open_idx = [i for i, p in enumerate(paths) if not p.closed]
    closed_idx = [i for i, p in enumerate(paths) if p.closed]
    items = open_idx + closed_idx
    s = np.array([paths[i].start for i in open_idx]).reshape(-1, 2)
    e = np.array([paths[i].end for i in open_idx]).reshape(-1, 2)
    cl = [paths[i].vertices[:-1] for i in closed_idx]
    parent = None
    if inner_first:
        raw = containment_parents(paths)
        where = {orig: k for k, orig in enumerate(items)}
        parent = np.array([where[raw[i]] if raw[i] >= 0 else -1 for i in items], np.int64)
    o = order_segments(s, e, closed_points=cl, origin=origin, improve=improve, parent=parent,
                       neighbours=neighbours)
    out = []
    for k, rev, ent in zip(o.order, o.reversed, o.entry):
        p = paths[items[k]]
        if p.closed:
            out.append(p.rolled(int(ent)) if ent > 0 else p)
        else:
            out.append(p.reversed() if rev else p)
    return out
