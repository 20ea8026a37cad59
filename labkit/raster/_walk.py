"""Compiled spiral (contour-parallel) walk of [LaserApp] §3.4.1, "Segment Pathing"."""

from __future__ import annotations

import numpy as np

from labkit._jit import jit

# Headings in clockwise order as seen with y up (image rows grow downwards):
# up, right, down, left. Turning right = +1, left = +3 (mod 4).
_DR = np.array([-1, 0, 1, 0], dtype=np.int64)
_DC = np.array([0, 1, 0, -1], dtype=np.int64)


@jit
def spiral_walk(mask):
    """Walk every marked pixel once; return the polylines' corner pixels.

    Start at the first unvisited marked pixel scanning rows from the bottom
    one, left to right, heading up. At each pixel try the neighbour to the
    left of the heading, then straight ahead, then to the right; the first
    marked, unvisited one is the next pixel (a turn makes the current pixel
    a corner). The current pixel is marked visited before moving on. When
    none of the three is free the walk is at a dead end: the sub-path ends
    there and the search for a start pixel resumes.

    Returns
    -------
    rows, cols : int64 arrays
        Vertices (start, corners, end) of all sub-paths, one after another.
    offsets : int64 array
        Sub-path k has vertices ``offsets[k]:offsets[k+1]`` (one vertex for
        a lone pixel).
    """
    n_rows, n_cols = mask.shape
    free = np.zeros((n_rows, n_cols), dtype=np.uint8)
    marked = 0
    for r in range(n_rows):
        for c in range(n_cols):
            if mask[r, c]:
                free[r, c] = 1
                marked += 1
    vr = np.empty(marked, dtype=np.int64)
    vc = np.empty(marked, dtype=np.int64)
    offsets = np.empty(marked + 1, dtype=np.int64)
    offsets[0] = 0
    nv = 0
    ns = 0
    scan = 0
    total = n_rows * n_cols
    while True:
        # The first free pixel in scan order only moves forward: visited pixels never come back.
        while scan < total:
            r = n_rows - 1 - scan // n_cols
            c = scan % n_cols
            if free[r, c]:
                break
            scan += 1
        if scan >= total:
            break
        heading = 0
        free[r, c] = 0
        vr[nv] = r
        vc[nv] = c
        nv += 1
        at_vertex = True
        while True:
            found = False
            h = heading
            rr = r
            cc = c
            for turn in (3, 0, 1):  # left, straight, right
                h = (heading + turn) % 4
                rr = r + _DR[h]
                cc = c + _DC[h]
                if 0 <= rr < n_rows and 0 <= cc < n_cols and free[rr, cc]:
                    found = True
                    break
            if not found or h != heading:
                if not at_vertex:
                    vr[nv] = r
                    vc[nv] = c
                    nv += 1
                if not found:
                    break
                heading = h
            r = rr
            c = cc
            free[r, c] = 0
            at_vertex = False
        ns += 1
        offsets[ns] = nv
    return vr[:nv], vc[:nv], offsets[:ns + 1]
