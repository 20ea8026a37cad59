"""[LaserApp]'s greedy nearest-first segment ordering, compiled: the O(n²) scan.

It picks, from the current position, the remaining segment whose entry point is
nearest (squared distance on the half-pixel integer grid, so there is no rounding),
ties going to the lower segment index and then to the unreversed direction. The grid
search labkit uses for every ordering (:func:`labkit.geometry.order.greedy_grid`)
follows the same total order on (distance², index, reversed), so this scan is the
readable reference it is tested against; they differ only in how many candidates
they look at.
"""

from __future__ import annotations

import numpy as np

from labkit._jit import jit

_BIG = np.iinfo(np.int64).max


@jit(inline="always")
def _dist2(ax, ay, bx, by):
    dx = ax - bx
    dy = ay - by
    return dx * dx + dy * dy


@jit(inline="always")
def _exit_point(sx, sy, ex, ey, i, flipped):
    """Where the head is after cutting segment i (its start if run backwards)."""
    if flipped:
        return sx[i], sy[i]
    return ex[i], ey[i]


@jit
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
