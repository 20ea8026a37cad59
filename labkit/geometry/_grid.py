"""A uniform grid of buckets over points: the spatial index of ordering and distances."""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True)
def buckets(x, y, cell, x0, y0, nx, ny):
    """File points into grid cells (clamped to the grid).

    Returns ``key`` (cell of each point), ``order`` (point indices sorted by
    cell) and ``start`` (CSR offsets: the points of cell c are
    ``order[start[c]:start[c + 1]]``).
    """
    gx = np.minimum(np.maximum(((x - x0) / cell).astype(np.int64), 0), nx - 1)
    gy = np.minimum(np.maximum(((y - y0) / cell).astype(np.int64), 0), ny - 1)
    key = gy * nx + gx
    order = np.argsort(key, kind="mergesort")
    start = np.zeros(nx * ny + 1, np.int64)
    for k in range(x.shape[0]):
        start[key[k] + 1] += 1
    for k in range(nx * ny):
        start[k + 1] += start[k]
    return key, order, start
