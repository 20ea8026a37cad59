"""Gray and dithered engraving write their Moves rows directly (issue 27: a 500 × 450 px photo
took 1.1 GB): the rows must be exactly what ``Moves.from_cuts`` makes of the scan's cuts, as
before. The cuts here come from a plain-Python scan written from the rules in ``gray_job``'s
docstring: rows bottom first, spans of burn joined across white gaps shorter than the skip,
an S 0 lead-in and lead-out of the overscan, one cut per run of equal S, every other line
reversed when bidirectional."""

from __future__ import annotations

import numpy as np
import pytest

from labkit.raster import gray_job, power_map
from labkit.toolpath.moves import LaserMode, Moves


def reference_cuts(power, *, bidirectional, skip_px, overscan_px):
    """(x0, x1, row, S) per cut, in pixel units, plain Python."""
    cuts = []
    line = 0
    rows = len(power)
    for r in range(rows - 1, -1, -1):
        row = [int(v) for v in power[r]]
        spans = []
        c = 0
        while c < len(row):
            if row[c] == 0:
                c += 1
                continue
            stop = c
            while stop < len(row) and row[stop] != 0:
                stop += 1
            if spans and c - spans[-1][1] < skip_px:
                spans[-1][1] = stop            # a short white gap: crossed with the beam off
            else:
                spans.append([c, stop])
            c = stop
        if not spans:
            continue
        backwards = bidirectional and line % 2 == 1
        line += 1
        for a, b in (reversed(spans) if backwards else spans):
            runs = []
            c = a
            while c < b:
                e = c
                while e < b and row[e] == row[c]:
                    e += 1
                runs.append((c, e, row[c]))
                c = e
            if backwards:
                lead_in, lead_out = (b + overscan_px, b), (a, a - overscan_px)
                runs = [(e, c, s) for c, e, s in reversed(runs)]
            else:
                lead_in, lead_out = (a - overscan_px, a), (b, b + overscan_px)
            if overscan_px:
                cuts.append((*lead_in, r, 0))
            cuts += [(c, e, r, s) for c, e, s in runs]
            if overscan_px:
                cuts.append((*lead_out, r, 0))
    return cuts


def reference_moves(power, *, pixel_mm, feed, bidirectional, skip_px, overscan_px, laser, s_max):
    cuts = reference_cuts(power, bidirectional=bidirectional, skip_px=skip_px, overscan_px=overscan_px)
    rows = power.shape[0]
    x0, x1, row, s = (np.array([c[k] for c in cuts], dtype=float) for k in range(4))
    y = (rows - row - 0.5) * pixel_mm
    return Moves.from_cuts(np.stack([x0 * pixel_mm, y], axis=1), np.stack([x1 * pixel_mm, y], axis=1),
                           feed_mm_min=feed, s_word=s, laser=laser, s_max=s_max)


def _gray(rng, shape):
    """Gray with white gaps of every length (1 px to whole rows), flat runs and noise."""
    g = rng.integers(0, 256, shape).astype(float)
    g[rng.random(shape) < 0.35] = 255.0
    g[:, 5:9] = 255.0                                   # a gap longer than short skips
    g[2] = 255.0                                        # an empty row
    g[4, 10:20] = 40.0                                  # one long run of equal S
    return g


@pytest.mark.parametrize("bidirectional", [True, False])
@pytest.mark.parametrize("overscan_mm, skip_white_mm", [(2.0, 5.0), (0.0, 0.0), (0.3, 0.2), (0.0, 1.0)])
@pytest.mark.parametrize("dither", [None, "floyd-steinberg"])
def test_gray_moves_are_what_from_cuts_makes_of_the_scan(bidirectional, overscan_mm, skip_white_mm, dither):
    rng = np.random.default_rng(11)
    pixel_mm = 0.2
    gray = _gray(rng, (17, 41))
    job = gray_job(gray, pixel_mm=pixel_mm, feed_mm_min=2400, min_power=0.1, max_power=0.9,
                   overscan_mm=overscan_mm, skip_white_mm=skip_white_mm, bidirectional=bidirectional,
                   dither=dither, laser=LaserMode.DYNAMIC, s_max=1000)
    power = job.target
    if dither is None:
        assert np.array_equal(power, power_map(gray, min_power=0.1, max_power=0.9))
    ref = reference_moves(power, pixel_mm=pixel_mm, feed=2400, bidirectional=bidirectional,
                          skip_px=max(skip_white_mm, 2 * overscan_mm) / pixel_mm,
                          overscan_px=overscan_mm / pixel_mm, laser=LaserMode.DYNAMIC, s_max=1000)
    assert len(ref) > 100
    for name in Moves.column_names():
        a, b = getattr(job.moves, name), getattr(ref, name)
        assert a.dtype == b.dtype and np.array_equal(a, b, equal_nan=a.dtype.kind == "f"), name
    assert job.moves.s_max == ref.s_max


def test_an_all_white_image_gives_no_moves():
    job = gray_job(np.full((3, 4), 255.0), pixel_mm=0.1)
    assert len(job.moves) == 0 and job.report.marked_pixels == 0


def test_line_bounds_match_the_arc_aware_box():
    """Moves.bounds takes the end points' box for programs without arcs (no copy of every
    column): the same box as the per-row extents it uses with arcs."""
    job = gray_job(_gray(np.random.default_rng(2), (9, 30)), pixel_mm=0.5, overscan_mm=1.0)
    for mask in (None, job.moves.laser_on):
        keep = job.moves.is_motion if mask is None else mask
        lo, hi = job.moves[keep].extents()
        assert np.array_equal(job.moves.bounds(mask), np.array([lo.min(axis=0), hi.max(axis=0)]))


def test_the_moves_are_counted_against_the_budgets_before_they_are_made(monkeypatch):
    from labkit.budget import BUDGETS
    from labkit.errors import BudgetError
    from labkit.raster import engrave

    gray = _gray(np.random.default_rng(4), (12, 30))
    n = len(gray_job(gray, pixel_mm=0.1).moves)
    made = []
    real = engrave._move_columns
    monkeypatch.setattr(engrave, "_move_columns", lambda k: made.append(k) or real(k))
    monkeypatch.delenv("LABKIT_BUDGET_SCALE", raising=False)
    monkeypatch.setitem(BUDGETS, "raster_bytes", n * engrave.BYTES_PER_GRAY_MOVE - 1)
    with pytest.raises(BudgetError, match=rf"raster bytes .* 30 × 12 px gray job of {n} moves"):
        gray_job(gray, pixel_mm=0.1)
    assert made == [0]                                   # counted, no row made
    monkeypatch.setitem(BUDGETS, "raster_bytes", n * engrave.BYTES_PER_GRAY_MOVE)
    monkeypatch.setitem(BUDGETS, "moves", n - 1)
    with pytest.raises(BudgetError, match=rf"{n - 1:,}\) from a 30 × 12 px gray job"):
        gray_job(gray, pixel_mm=0.1)
