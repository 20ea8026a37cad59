"""A uniform grid of buckets over points: the spatial index of ordering and distances."""

from __future__ import annotations

import math

import numpy as np

from labkit._jit import jit


@jit(python_below=100_000)
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


#: Up to this many points, :func:`close_pairs` and :func:`nearest_neighbours` compare all
#: pairs at once (a few MB) rather than import scipy's k-d tree (~0.4 s) for a small drawing.
ALL_PAIRS_BELOW = 2048


def _squared_distances(p: np.ndarray) -> np.ndarray:
    return ((p[:, None, :] - p[None, :, :]) ** 2).sum(axis=-1)


def close_pairs(points, r: float) -> np.ndarray:
    """Index pairs (i < j) of points at most ``r`` apart, shape (k, 2), in no set order.

    >>> close_pairs(np.array([[0, 0], [3, 0], [0.5, 0]]), 1.0).tolist()
    [[0, 2]]
    """
    p = np.asarray(points, float)
    if len(p) < ALL_PAIRS_BELOW:
        i, j = np.nonzero(np.triu(_squared_distances(p) <= r * r, k=1))
        return np.stack([i, j], axis=1)
    from scipy.spatial import cKDTree

    return cKDTree(p).query_pairs(r, output_type="ndarray")


def nearest_neighbours(points, k: int) -> np.ndarray:
    """Indices of each point's ``k`` nearest points (itself first), shape (n, k).

    >>> nearest_neighbours(np.array([[0.0, 0], [5, 0], [1, 0]]), 2).tolist()
    [[0, 2], [1, 2], [2, 0]]
    """
    p = np.asarray(points, float)
    if len(p) < ALL_PAIRS_BELOW:
        return np.argsort(_squared_distances(p), axis=1, kind="stable")[:, :k]
    from scipy.spatial import cKDTree

    return np.asarray(cKDTree(p).query(p, k=k)[1]).reshape(len(p), -1)
