"""Compiled kernels of :mod:`labkit.motion.planner`: grouping and the two passes."""

from __future__ import annotations

import numpy as np

from labkit._jit import jit

from labkit.motion._ramp import reach_nb


@jit(python_below=200_000)  # ~1–2 µs an element as Python (9 arrays of n blocks, window 16–32)
def windowed_passes(length, up, down, jcap, jrest, rest, floor, window, law):
    """Junction speeds (n + 1) of n blocks planned through a buffer of ``window`` blocks.

    ``jcap[j]`` caps the speed at junction j (entry of block j; j = n is the
    end), ``jrest[j]`` is the rest speed there. ``floor[k]`` is the speed block
    k never runs below (its rest speed): below it the speed changes at once, so
    a block has to slow down only to its floor and the junction takes the rest.
    Block k's entry is fixed when it starts running; its exit is the smaller of
    (a) the backward pass over the blocks k+1 … k+window−1 from a stop at the
    end of the buffer (at the rest speed there, or lower: at most what the
    block past the buffer can slow down from to its own rest speed ``rest[j]``
    within its length, since a later window can end there) and
    (b) what accelerating from the entry (or the floor) over block k reaches
    (forward pass). Every later window then finds a feasible plan: whatever it
    asks at a junction, the block before it can reach it or its floor.
    """
    n = length.shape[0]
    v = np.empty(n + 1)
    v[0] = jcap[0]
    for k in range(n):
        j_end = min(k + window, n)
        vb = jrest[j_end]
        if j_end < n:
            # the block past the window may have to stop within itself (the next
            # window can end lower than this rest speed): start no faster than that
            vb = min(vb, reach_nb(min(rest[j_end], vb), length[j_end], down[j_end], law))
        for j in range(j_end - 1, k, -1):
            vb = min(jcap[j], reach_nb(max(vb, floor[j]), length[j], down[j], law))
        v[k + 1] = min(vb, reach_nb(max(v[k], floor[k]), length[k], up[k], law))
    return v


@jit(python_below=200_000)  # one pass: well under 1 µs an element as Python
def group_blocks(breaks, same_dir, max_size, need_same_dir):
    """Super block id of each block: a new group starts at a break, when the group is
    full, or (high quality) when the direction changes. ``breaks[k]`` / ``same_dir[k]``
    describe the junction before block k."""
    n = breaks.shape[0]
    gid = np.empty(n, np.int64)
    g = -1
    size = 0
    for k in range(n):
        new = k == 0 or breaks[k] or size >= max_size or (need_same_dir and not same_dir[k])
        if new:
            g += 1
            size = 0
        gid[k] = g
        size += 1
    return gid
