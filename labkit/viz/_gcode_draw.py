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


#: A piece along an axis whose length is this close below a whole number of pixels is
#: walked step by step (see :func:`_spans_along_axes`).
_WHOLE_MARGIN = 1e-6


def _spans_along_axes(x0, y0, x1, y1):
    """The pieces along an axis whose steps are one unbroken run of pixels, and that run.

    A piece with dy exactly 0 takes ceil(|dx|) + 1 steps of |dx| / ceil(|dx|) pixels each:
    below one pixel unless |dx| is whole, so consecutive steps round to the same or the
    next column and the pixels are every column from the first step's to the last's
    (dx exactly 0 the same, across rows). A whole or nearly whole |dx| makes steps of a
    pixel, whose roundings may skip a column (halves round to even): those pieces, and
    every other piece, are left to the step-by-step walk. Returns (which pieces, along x
    or y, the fixed row or column, the first and last pixel along the axis), rounded and
    clipped later by the caller.
    """
    dx = x1 - x0
    dy = y1 - y0
    horizontal = dy == 0.0
    vertical = (dx == 0.0) & ~horizontal
    length = np.where(horizontal, np.abs(dx), np.abs(dy))
    part = length - np.floor(length)
    unbroken = (horizontal | vertical) & ((length == 0.0) | ((part > 0.0) & (part < 1.0 - _WHOLE_MARGIN)))
    k = np.flatnonzero(unbroken)
    along_x = horizontal[k]
    fixed = np.where(along_x, y0[k], x0[k])
    first = np.where(along_x, x0[k], y0[k])
    last = np.where(along_x, x0[k] + dx[k] * 1.0, y0[k] + dy[k] * 1.0)    # the last step, t = 1
    return unbroken, along_x, fixed, first, last


def _fill_runs(grid_shape, along_x, fixed, first, last):
    """Which pixels the runs cover: counts of runs starting minus runs ended, summed along
    each row (or column), as a boolean grid. O(runs + pixels), whatever the runs' lengths."""
    rows, cols = grid_shape
    out = np.zeros((rows, cols), np.bool_)
    for axis_x in (True, False):
        pick = along_x == axis_x
        if not pick.any():
            continue
        n_lines, n_along = (rows, cols) if axis_x else (cols, rows)
        line = np.clip(np.rint(fixed[pick]), 0, n_lines - 1).astype(np.int64)
        a = np.clip(np.rint(first[pick]), 0, n_along - 1).astype(np.int64)
        b = np.clip(np.rint(last[pick]), 0, n_along - 1).astype(np.int64)
        lo, hi = np.minimum(a, b), np.maximum(a, b)
        width = n_along + 1
        delta = (np.bincount(line * width + lo, minlength=n_lines * width)
                 - np.bincount(line * width + hi + 1, minlength=n_lines * width))
        covered = np.cumsum(delta.reshape(n_lines, width)[:, :n_along], axis=1) > 0
        out |= covered if axis_x else covered.T
    return out


def _draw_pieces_numpy(x0, y0, x1, y1, value, burning, power, travel):
    """:func:`draw_pieces` with numpy: the same steps, rounding and clipping, in batches;
    travel, and burning pieces of one power, along an axis (a raster job's every piece) as
    whole runs of pixels (:func:`_spans_along_axes`)."""
    rows, cols = power.shape
    burned = value[burning]
    uniform = len(burned) > 0 and bool((burned == burned[0]).all())
    runs, along_x, fixed, first, last = _spans_along_axes(x0, y0, x1, y1)
    on_run = burning[runs]
    if (~on_run).any():
        travel |= _fill_runs(power.shape, along_x[~on_run], fixed[~on_run], first[~on_run], last[~on_run])
    if uniform and on_run.any():
        covered = _fill_runs(power.shape, along_x[on_run], fixed[on_run], first[on_run], last[on_run])
        np.maximum(power, np.where(covered, burned[0], -np.inf), out=power)
        del covered
    else:
        runs[runs] = ~on_run                    # burning pieces of several powers: walked below
    rest = np.flatnonzero(~runs)
    if len(rest) < len(x0):
        x0, y0, x1, y1, value, burning = (a[rest] for a in (x0, y0, x1, y1, value, burning))
    dx = x1 - x0
    dy = y1 - y0
    steps = np.ceil(np.maximum(np.abs(dx), np.abs(dy))).astype(np.int64) + 1
    ends = np.cumsum(steps)
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
