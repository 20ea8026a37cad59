"""Compiled scan-line builder for gray and dithered engraving (used by :mod:`labkit.raster.engrave`).

It writes the rows of :class:`~labkit.toolpath.moves.Moves` directly — the cuts in scan
order and a rapid before each cut that does not start where the last one ended, exactly
as ``Moves.from_cuts`` joins cuts — so a photo's millions of cuts are never held as
intermediate arrays (x, y, row and S per cut, then start and end points, then columns).
"""

from __future__ import annotations

import math

import numpy as np

from labkit._jit import jit

#: MoveKind values (kept as plain ints for the kernel).
_RAPID = 0
_LINE = 1

#: A rapid is inserted only where the gap is larger than this, mm (``Moves.from_cuts``).
RAPID_TOL_MM = 1e-9


@jit
def _spans(row, skip_px, starts, stops):
    """Burn spans of one row: runs of S > 0 joined across white gaps shorter than ``skip_px``."""
    cols = row.shape[0]
    n = 0
    c = 0
    while c < cols:
        if row[c] == 0:
            c += 1
            continue
        if n > 0 and c - stops[n - 1] < skip_px:
            n -= 1  # gap too short to skip: cross it with the beam off
        else:
            starts[n] = c
        while c < cols and row[c] != 0:
            c += 1
        stops[n] = c
        n += 1
    return n


@jit
def _put(k, x0, x1, y, s, pixel_mm, last, fill, kind, start, end, s_word):
    """Append the cut x0 → x1 (pixel units) at height y (mm) with power S, preceded by a
    rapid from the last end point when it starts elsewhere. Returns the next row."""
    sx = x0 * pixel_mm
    ex = x1 * pixel_mm
    dx = sx - last[0]
    dy = y - last[1]
    if math.sqrt(dx * dx + dy * dy + 0.0) > RAPID_TOL_MM:
        if fill:
            kind[k] = _RAPID
            start[k, 0] = last[0]
            start[k, 1] = last[1]
            start[k, 2] = 0.0
            end[k, 0] = sx
            end[k, 1] = y
            end[k, 2] = 0.0
            s_word[k] = s
        k += 1
    if fill:
        kind[k] = _LINE
        start[k, 0] = sx
        start[k, 1] = y
        start[k, 2] = 0.0
        end[k, 0] = ex
        end[k, 1] = y
        end[k, 2] = 0.0
        s_word[k] = s
    last[0] = ex
    last[1] = y
    return k + 1


@jit(python_below=150_000)  # pixels: up to ~7 µs each as Python (a photo), ~1 s at 150,000
def scan_moves(power, bidirectional, skip_px, overscan_px, pixel_mm, fill, kind, start, end, s_word):
    """Moves rows along the image rows, bottom row first (x at pixel edges, y at row centres).

    Per burn span: an overscan lead-in at S 0, one cut per run of equal S (S 0 where a
    short white gap is crossed), an overscan lead-out at S 0; without overscan the
    zero-length lead-ins and lead-outs are left out. With ``fill`` False only counts.
    Returns the number of rows (cuts and rapids).
    """
    rows, cols = power.shape
    starts = np.empty(cols, dtype=np.int64)
    stops = np.empty(cols, dtype=np.int64)
    last = np.zeros(2, dtype=np.float64)          # where the head is: the origin first
    lead = overscan_px != 0.0
    k = 0
    line = 0
    for r in range(rows - 1, -1, -1):
        row = power[r]
        n = _spans(row, skip_px, starts, stops)
        if n == 0:
            continue
        y = (rows - r - 0.5) * pixel_mm
        backwards = bidirectional and line % 2 == 1
        line += 1
        for q in range(n):
            s = n - 1 - q if backwards else q
            a = starts[s]
            b = stops[s]
            # lead-in, runs, lead-out; reversed spans are walked from b down to a
            if lead:
                if backwards:
                    k = _put(k, b + overscan_px, b, y, 0, pixel_mm, last, fill, kind, start, end, s_word)
                else:
                    k = _put(k, a - overscan_px, a, y, 0, pixel_mm, last, fill, kind, start, end, s_word)
            if backwards:
                c = b
                while c > a:
                    e = c - 1
                    while e > a and row[e - 1] == row[c - 1]:
                        e -= 1
                    k = _put(k, c, e, y, row[c - 1], pixel_mm, last, fill, kind, start, end, s_word)
                    c = e
            else:
                c = a
                while c < b:
                    e = c + 1
                    while e < b and row[e] == row[c]:
                        e += 1
                    k = _put(k, c, e, y, row[c], pixel_mm, last, fill, kind, start, end, s_word)
                    c = e
            if lead:
                if backwards:
                    k = _put(k, a, a - overscan_px, y, 0, pixel_mm, last, fill, kind, start, end, s_word)
                else:
                    k = _put(k, b, b + overscan_px, y, 0, pixel_mm, last, fill, kind, start, end, s_word)
    return k
