"""Compiled scan-line builder for gray and dithered engraving (used by :mod:`labkit.raster.engrave`)."""

from __future__ import annotations

import numpy as np

from labkit._jit import jit


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
def scan_lines(power, bidirectional, skip_px, overscan_px, fill, out_x0, out_x1, out_row, out_s):
    """Cuts along rows, bottom row first, in pixel units (x at pixel edges).

    Per burn span: an overscan lead-in at S 0, one cut per run of equal S
    (S 0 where a short white gap is crossed), an overscan lead-out at S 0.
    With ``fill`` False only counts. Returns the number of cuts.
    """
    rows, cols = power.shape
    starts = np.empty(cols, dtype=np.int64)
    stops = np.empty(cols, dtype=np.int64)
    k = 0
    line = 0
    for r in range(rows - 1, -1, -1):
        row = power[r]
        n = _spans(row, skip_px, starts, stops)
        if n == 0:
            continue
        backwards = bidirectional and line % 2 == 1
        line += 1
        for q in range(n):
            s = n - 1 - q if backwards else q
            a = starts[s]
            b = stops[s]
            # lead-in, runs, lead-out; reversed spans are walked from b down to a
            if fill:
                out_row[k] = r
                out_s[k] = 0
                if backwards:
                    out_x0[k] = b + overscan_px
                    out_x1[k] = b
                else:
                    out_x0[k] = a - overscan_px
                    out_x1[k] = a
            k += 1
            if backwards:
                c = b
                while c > a:
                    e = c - 1
                    while e > a and row[e - 1] == row[c - 1]:
                        e -= 1
                    if fill:
                        out_row[k] = r
                        out_s[k] = row[c - 1]
                        out_x0[k] = c
                        out_x1[k] = e
                    k += 1
                    c = e
            else:
                c = a
                while c < b:
                    e = c + 1
                    while e < b and row[e] == row[c]:
                        e += 1
                    if fill:
                        out_row[k] = r
                        out_s[k] = row[c]
                        out_x0[k] = c
                        out_x1[k] = e
                    k += 1
                    c = e
            if fill:
                out_row[k] = r
                out_s[k] = 0
                if backwards:
                    out_x0[k] = a
                    out_x1[k] = a - overscan_px
                else:
                    out_x0[k] = b
                    out_x1[k] = b + overscan_px
            k += 1
    return k
