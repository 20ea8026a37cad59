"""Compiled drawing of line pieces into a pixel grid, for :func:`labkit.viz.gcode.rasterize_moves`.

A digital differential analyser: each piece is walked one pixel step at a time along its
longer axis, so the work is the drawn length in pixels and the memory is the grid alone.
Run as Python (a small job in a process that has not loaded numba: a command's preview of a
small file), the same steps are taken by numpy, a bounded number of steps at a time.
"""

from __future__ import annotations

import math

import numpy as np

from labkit._jit import jit


#: Pixel steps the numpy twin takes at once (about 40 bytes each).
NUMPY_STEPS = 1 << 20


def _draw_pieces_numpy(x0, y0, x1, y1, value, burning, power, travel):
    """:func:`draw_pieces` with numpy: the same steps, rounding and clipping, in batches."""
    rows, cols = power.shape
    dx = x1 - x0
    dy = y1 - y0
    steps = np.ceil(np.maximum(np.abs(dx), np.abs(dy))).astype(np.int64) + 1
    ends = np.cumsum(steps)
    burned = value[burning]
    uniform = len(burned) > 0 and bool((burned == burned[0]).all())
    level = burned[0] if uniform else 0.0
    first = 0
    while first < len(steps):
        done = ends[first - 1] if first else 0
        stop = max(first + 1, int(np.searchsorted(ends, done + NUMPY_STEPS, side="right")))
        k = np.repeat(np.arange(first, stop), steps[first:stop])
        s = np.arange(len(k)) + done - (ends[k] - steps[k])        # step within its piece
        t = s / np.maximum(steps[k] - 1, 1)
        ix = np.clip(np.rint(x0[k] + dx[k] * t), 0, cols - 1).astype(np.int64)
        iy = np.clip(np.rint(y0[k] + dy[k] * t), 0, rows - 1).astype(np.int64)
        on = burning[k]
        if uniform:                  # one power (most vector and threshold jobs): a plain store
            rows_on, cols_on = iy[on], ix[on]
            power[rows_on, cols_on] = np.maximum(power[rows_on, cols_on], level)
        else:
            np.maximum.at(power, (iy[on], ix[on]), value[k[on]])
        travel[iy[~on], ix[~on]] = True
        first = stop


@jit(python_below=8_000_000, python=_draw_pieces_numpy)
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
