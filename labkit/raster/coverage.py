"""Rasterise Moves back onto the pixel grid: which pixels a program burns, how often, how hard.

This is the independent check of every raster path generator: it knows
nothing about runs, spirals or scan lines, only the moves. A pixel is burned
by a laser-on move when its centre lies on the move; where two consecutive
laser-on moves meet at a pixel centre (a corner of a polyline) that pixel is
counted once.
"""

from __future__ import annotations

import numpy as np

from labkit.errors import RasterError
from labkit.toolpath.moves import MoveKind, Moves

__all__ = ["burn_map"]


def burn_map(moves: Moves, shape, pixel_mm: float, *, tol_mm: float = 1e-6):
    """Count and power of the laser passing over each pixel centre.

    Parameters
    ----------
    moves : Moves
        A program whose laser-on moves are horizontal or vertical lines,
        with the image's bottom-left corner at X0 Y0.
    shape : (int, int)
        (rows, columns) of the image.
    pixel_mm : float
        Pixel size, mm.
    tol_mm : float
        How close a move must run to a centre line, mm.

    Returns
    -------
    count : ndarray of int64, shape ``shape``
        How many times each pixel centre is burned.
    power : ndarray of float64, shape ``shape``
        Sum of the S values that burned it (= its S where count is 1).

    Raises
    ------
    RasterError
        A laser-on move that is an arc, diagonal, off the pixel centre lines
        or outside the image.

    Examples
    --------
    >>> m = Moves.from_cuts([[0.0, 0.5]], [[3.0, 0.5]], feed_mm_min=600, s_word=200)
    >>> count, power = burn_map(m, (1, 4), 1.0)
    >>> count.tolist(), power.tolist()
    ([[1, 1, 1, 0]], [[200.0, 200.0, 200.0, 0.0]])
    """
    rows, cols = int(shape[0]), int(shape[1])
    on = moves.laser_on
    if (on & (moves.kind != MoveKind.LINE)).any():
        raise RasterError("burn_map handles straight G1 cuts only; found a laser-on arc")
    idx = np.flatnonzero(on)
    count = np.zeros(rows * cols, np.int64)
    power = np.zeros(rows * cols, np.float64)
    # In chunks of moves, so that a photo's millions of cuts never need a dozen arrays of
    # their length at once; each chunk also looks at the first move of the next one (a
    # corner shared across the chunk border).
    for lo in range(0, len(idx), CHUNK_MOVES):
        _burn_chunk(moves, idx, lo, min(lo + CHUNK_MOVES, len(idx)), rows, cols, pixel_mm, tol_mm,
                    count, power)
    return count.reshape(rows, cols), power.reshape(rows, cols)


#: Laser-on moves rasterised at once by :func:`burn_map`.
CHUNK_MOVES = 1 << 18


def _burn_chunk(moves, all_idx, first_move, stop, rows, cols, pixel_mm, tol_mm, count, power):
    """Add the burns of laser-on moves ``all_idx[first_move:stop]`` to ``count`` and ``power``."""
    idx = all_idx[first_move:stop + 1]                # one more: a corner shared with the next chunk
    inner = stop - first_move
    a = moves.start[idx, :2] / pixel_mm - 0.5   # in pixel-centre coordinates: centre c at c
    b = moves.end[idx, :2] / pixel_mm - 0.5
    s = moves.s_word[idx].astype(np.float64)
    tol = tol_mm / pixel_mm
    # corners: consecutive laser-on moves meeting at a pixel centre share that pixel
    joined = (idx[1:] == idx[:-1] + 1) & np.all(np.abs(b[:-1] - a[1:]) <= tol, axis=1)
    at_centre = joined & np.all(np.abs(b[:-1] - np.rint(b[:-1])) <= tol, axis=1)
    corners = np.rint(b[:-1][at_centre]).astype(np.int64)
    corner_s = s[1:][at_centre]                    # the second move gives its pixel back
    idx, a, b, s = idx[:inner], a[:inner], b[:inner], s[:inner]
    horizontal = np.abs(a[:, 1] - b[:, 1]) <= tol
    vertical = np.abs(a[:, 0] - b[:, 0]) <= tol
    if not (horizontal | vertical).all():
        bad = idx[~(horizontal | vertical)][0]
        raise RasterError(f"move {bad} is diagonal; burn_map needs horizontal or vertical cuts")
    # fixed coordinate (the centre line) and the interval along the move
    fixed = np.where(horizontal, a[:, 1], a[:, 0])
    lo = np.where(horizontal, np.minimum(a[:, 0], b[:, 0]), np.minimum(a[:, 1], b[:, 1]))
    hi = np.where(horizontal, np.maximum(a[:, 0], b[:, 0]), np.maximum(a[:, 1], b[:, 1]))
    line = np.rint(fixed)
    if (np.abs(fixed - line) > tol).any():
        bad = idx[np.abs(fixed - line) > tol][0]
        raise RasterError(f"move {bad} runs between pixel centre lines (pixel {pixel_mm} mm)")
    first = np.ceil(lo - tol).astype(np.int64)
    last = np.floor(hi + tol).astype(np.int64)
    n = np.maximum(last - first + 1, 0)
    line = line.astype(np.int64)
    limit_fixed = np.where(horizontal, rows, cols)
    limit_along = np.where(horizontal, cols, rows)
    if ((n > 0) & ((line < 0) | (line >= limit_fixed) | (first < 0) | (last >= limit_along))).any():
        raise RasterError("a laser-on move burns outside the image")
    owner = np.repeat(np.arange(len(idx)), n)
    along = first[owner] + np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)
    x = np.where(horizontal[owner], along, line[owner])
    y = np.where(horizontal[owner], line[owner], along)
    flat = (rows - 1 - y) * cols + x
    if len(flat):
        # only the band of pixels this chunk touches
        base, top = int(flat.min()), int(flat.max()) + 1
        count[base:top] += np.bincount(flat - base, minlength=top - base)
        power[base:top] += np.bincount(flat - base, weights=s[owner], minlength=top - base)
    if len(corners):
        shared = (rows - 1 - corners[:, 1]) * cols + corners[:, 0]
        np.subtract.at(count, shared, 1)
        np.subtract.at(power, shared, corner_s)
