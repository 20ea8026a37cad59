"""Compiled drawing of line pieces into a pixel grid, for :func:`labkit.viz.gcode.rasterize_moves`.

A digital differential analyser: each piece is walked one pixel step at a time along its
longer axis, so the work is the drawn length in pixels and the memory is the grid alone.
"""

from __future__ import annotations

import math

import numpy as np

from labkit._jit import jit


@jit
def draw_pieces(x0, y0, x1, y1, value, burning, power, travel):
    """Draw pieces (in pixel units) into ``power`` (max of ``value``) or ``travel`` (True)."""
    rows, cols = power.shape
    for k in range(x0.shape[0]):
        dx = x1[k] - x0[k]
        dy = y1[k] - y0[k]
        steps = int(math.ceil(max(abs(dx), abs(dy)))) + 1
        for s in range(steps):
            t = s / (steps - 1) if steps > 1 else 0.0
            ix = int(round(x0[k] + dx * t))
            iy = int(round(y0[k] + dy * t))
            if ix < 0:
                ix = 0
            elif ix >= cols:
                ix = cols - 1
            if iy < 0:
                iy = 0
            elif iy >= rows:
                iy = rows - 1
            if burning[k]:
                if value[k] > power[iy, ix]:
                    power[iy, ix] = value[k]
            else:
                travel[iy, ix] = True


def draw(pieces, value, burning, shape):
    """``power`` (NaN where nothing burns) and ``travel`` grids of ``shape``."""
    power = np.full(shape, -1.0)
    travel = np.zeros(shape, np.bool_)
    p = np.ascontiguousarray(pieces, dtype=np.float64)
    draw_pieces(p[:, 0, 0].copy(), p[:, 0, 1].copy(), p[:, 1, 0].copy(), p[:, 1, 1].copy(),
                np.asarray(value, np.float64), np.asarray(burning, np.bool_), power, travel)
    power[power < 0] = np.nan
    return power, travel
