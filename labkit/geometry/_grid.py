"""A uniform grid of buckets over points: the spatial index of ordering and distances."""

from __future__ import annotations

import math

import numba
import numpy as np


@numba.njit(cache=True)
def buckets(x, y, cell, x0, y0, nx, ny):
    """File points into grid cells (clamped to the grid).

    Returns ``key`` (cell of each point), ``order`` (point indices sorted by
    cell) and ``start`` (CSR offsets: the points of cell c are
    ``order[start[c]:start[c + 1]]``).
    """
    n = x.shape[0]
    key = np.empty(n, np.int64)
    start = np.zeros(nx * ny + 1, np.int64)
    for k in range(n):
        gx = min(max(int(math.floor((x[k] - x0) / cell)), 0), nx - 1)
        gy = min(max(int(math.floor((y[k] - y0) / cell)), 0), ny - 1)
        key[k] = gy * nx + gx
        start[key[k] + 1] += 1
    for c in range(nx * ny):
        start[c + 1] += start[c]
    order = np.empty(n, np.int64)             # a counting sort: stable, O(n + cells)
    fill = start[:-1].copy()
    for k in range(n):
        order[fill[key[k]]] = k
        fill[key[k]] += 1
    return key, order, start
