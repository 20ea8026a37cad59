"""Scan-line builder for gray and dithered engraving (used by :mod:`labkit.raster.engrave`).

It writes the rows of :class:`~labkit.toolpath.moves.Moves` directly — the cuts in scan
order and a rapid before each cut that does not start where the last one ended, exactly
as ``Moves.from_cuts`` joins cuts — so a photo's millions of cuts are never held as
intermediate arrays (x, y, row and S per cut, then start and end points, then columns).

The kernel walks the pixels one by one; run as Python that costs about 5 µs a move and
0.3 µs a pixel (a second or more for a 300 × 300 photo), so its Python form is a numpy
twin (:func:`_scan_moves_numpy`) that finds the runs of equal S from the changes along
each row and places every move by its index: about 0.3 µs a move (a 512² photograph,
205,000 moves: 58-79 ms, compiled 22-29 ms, the kernel's own code as Python 3.5 s; the
ladder's 512² mask, 2,612 moves: 2-3 ms), a few times the compiled time but far less than
loading numba, so a gray job never loads numba for its scan alone.
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


#: Image pixels the numpy twin scans at once (its working memory: ~40 bytes a pixel of the
#: band and ~150 bytes a move made from it).
SCAN_BAND_PIXELS = 1 << 18


def _scan_moves_numpy(power, bidirectional, skip_px, overscan_px, pixel_mm, fill, kind, start, end,
                      s_word):
    """:func:`scan_moves` with numpy, a band of rows at a time: the same rows, bit for bit.

    In each row the runs of equal S lie between the places where S changes (the row padded
    with S 0 at both ends). A run of S 0 at least ``skip_px`` long ends a span; the runs
    left, in walk order (reversed on backward lines), make the cuts, each span with its
    lead-in and lead-out, and a rapid before a span whose first cut does not start where
    the last cut ended (the kernel's test, the same floating-point operations). Cuts
    inside a span always meet, so only spans can need a rapid.
    """
    rows, cols = power.shape
    lead = 1 if overscan_px != 0.0 else 0
    last_x, last_y = 0.0, 0.0                   # where the head is: the origin first
    k = 0
    line = 0
    step = max(1, SCAN_BAND_PIXELS // max(cols, 1))
    for top in range(rows, 0, -step):
        r_rows = np.arange(top - 1, max(top - step, 0) - 1, -1)        # the band, bottom row first
        padded = np.zeros((len(r_rows), cols + 2), power.dtype)
        padded[:, 1:-1] = power[r_rows]
        change_row, change_at = np.nonzero(padded[:, 1:] != padded[:, :-1])
        del padded
        pair = np.flatnonzero(change_row[1:] == change_row[:-1])       # consecutive changes, one row
        if not len(pair):
            continue
        run_row = change_row[pair]
        c = change_at[pair]
        e = change_at[pair + 1]
        del change_row, change_at
        v = power[r_rows[run_row], c]
        gap = (v == 0) & ~(e - c < skip_px)         # white too long to cross: the span ends
        first_in_row = np.ones(len(pair), bool)
        first_in_row[1:] = run_row[1:] != run_row[:-1]
        new_span = first_in_row.copy()
        new_span[1:] |= gap[:-1]
        keep = ~gap
        run_row, c, e, v, new_span = run_row[keep], c[keep], e[keep], v[keep], new_span[keep]
        del pair, gap, keep, first_in_row
        n_runs = len(c)
        # spans in row order (left to right): first and last run, row
        span_first = np.flatnonzero(new_span)
        span_last = np.append(span_first[1:], n_runs) - 1
        span_row = run_row[span_first]
        a = c[span_first]
        b = e[span_last]
        runs_in_span = span_last - span_first + 1
        new_line = np.ones(len(span_first), bool)
        new_line[1:] = span_row[1:] != span_row[:-1]
        line_of_span = line + np.cumsum(new_line) - 1
        line = int(line_of_span[-1]) + 1
        backwards = (line_of_span % 2 == 1) if bidirectional else np.zeros(len(span_first), bool)
        # walk order of the spans: backward lines right to left
        line_first = np.flatnonzero(new_line)
        line_len = np.diff(np.append(line_first, len(span_first)))
        first_of_line = np.repeat(line_first, line_len)
        at = np.arange(len(span_first))
        walk = np.where(backwards, first_of_line + (first_of_line + np.repeat(line_len, line_len) - 1 - at), at)
        order = np.empty_like(walk)
        order[walk] = at                        # order[w]: the span walked w-th
        a, b, span_row, backwards, runs_in_span, span_first = (x[order] for x in (a, b, span_row, backwards,
                                                                                 runs_in_span, span_first))
        y = (rows - r_rows[span_row] - 0.5) * pixel_mm
        sx = np.where(backwards, b + overscan_px, a - overscan_px) * pixel_mm    # first cut's start
        ex = np.where(backwards, a - overscan_px, b + overscan_px) * pixel_mm    # last cut's end
        prev_x = np.concatenate([[last_x], ex[:-1]])
        prev_y = np.concatenate([[last_y], y[:-1]])
        dx = sx - prev_x
        dy = y - prev_y
        rapid = np.sqrt(dx * dx + dy * dy + 0.0) > RAPID_TOL_MM
        del dx, dy
        made = rapid + (2 * lead + runs_in_span)
        last_x, last_y = float(ex[-1]), float(y[-1])
        if not fill:
            k += int(made.sum())
            continue
        at_span = k + np.cumsum(made) - made                    # first row of each span
        k += int(made.sum())
        # the runs in walk order: spans in walk order, each span's runs reversed when backwards
        span_of_run = np.repeat(np.arange(len(made)), runs_in_span)
        rank = np.arange(n_runs) - np.repeat(np.cumsum(runs_in_span) - runs_in_span, runs_in_span)
        back_run = backwards[span_of_run]
        src = span_first[span_of_run] + np.where(back_run, runs_in_span[span_of_run] - 1 - rank, rank)
        rc, re_, rv = c[src], e[src], v[src]
        groups = [(at_span[span_of_run] + rapid[span_of_run] + lead + rank, _LINE,
                   np.where(back_run, re_, rc) * pixel_mm, None, np.where(back_run, rc, re_) * pixel_mm,
                   y[span_of_run], rv)]
        del rc, re_, src, rank, back_run
        if lead:
            lead_s = np.zeros(len(made), v.dtype)
            groups.append((at_span + rapid, _LINE, sx, None, np.where(backwards, b, a) * pixel_mm, y, lead_s))
            groups.append((at_span + rapid + 1 + runs_in_span, _LINE, np.where(backwards, a, b) * pixel_mm,
                           None, ex, y, lead_s))
        if rapid.any():
            first_s = lead_s if lead else rv[np.cumsum(runs_in_span) - runs_in_span]
            groups.append((at_span[rapid], _RAPID, prev_x[rapid], prev_y[rapid], sx[rapid], y[rapid],
                           first_s[rapid]))
        # every end, then every start: when start and end are views of one array of points
        # (each row starts where the last ended) a row's start is the point it is written from,
        # as in the kernel, which writes a row's start after the row before it
        for where, _, _, _, x1, y1, _ in groups:
            end[where, 0] = x1
            end[where, 1] = y1
            end[where, 2] = 0.0
        for where, move_kind, x0, y0, _, y1, s in groups:
            start[where, 0] = x0
            start[where, 1] = y1 if y0 is None else y0
            start[where, 2] = 0.0
            kind[where] = move_kind
            s_word[where] = s
    return k


# the numpy twin: ~0.03 µs a pixel, ~0.2 µs a row it writes (8 elements): 1 s at ~40 M elements
@jit(python_below=40_000_000, python=_scan_moves_numpy)
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
