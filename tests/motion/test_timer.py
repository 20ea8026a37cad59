"""Step timing and the step pulse train: formulas by hand, consistency with the plan."""

import math

import numpy as np
import pytest
from .motion_jobs import random_polyline_moves, zigzag_moves

from labkit.errors import MotionError
from labkit.motion import CBR40, arc_lattice_points, lines_points
from labkit.motion.pipeline import plan
from labkit.motion.timer import (
    block_points,
    isqrt,
    step_blocks,
    step_trace,
    tick_cycles,
    tick_rates,
    timer_period,
)
from labkit.toolpath import LaserMode, MovesBuilder


def test_cbr40_period_formula_by_hand():
    # Period = Timer_clk / (f · (Prescaler + 1)) − 1, rounded up: 48 MHz, prescaler 3, 1 kHz
    assert timer_period(1000, prescaler=3) == 48_000_000 // 4000 - 1
    assert timer_period(7, timer_clock_hz=100, prescaler=0) == math.ceil(100 / 7) - 1
    f = np.arange(1000, 60000, 37)
    per = np.asarray(timer_period(f))
    actual = 48e6 / tick_cycles(per)
    assert np.all(actual <= f) and np.all(actual > f * (1 - f / 48e6))      # never faster
    with pytest.raises(MotionError, match="freq_hz must be whole Hz >= 1"):
        timer_period(0)
    with pytest.raises(MotionError, match="freq_hz must be whole Hz >= 1"):
        timer_period(1000.5)
    with pytest.raises(MotionError, match="prescaler must be an integer >= 0"):
        timer_period(1000, prescaler=-1)
    with pytest.raises(MotionError, match="above the timer's counting rate"):
        timer_period(1000, timer_clock_hz=500)


def test_isqrt_is_exact():
    x = np.concatenate([np.arange(0, 5000), np.array([2 ** 52 - 1, 2 ** 52, 10 ** 15 + 7])])
    r = isqrt(x)
    assert np.all(r * r <= x) and np.all((r + 1) * (r + 1) > x)


@pytest.mark.parametrize("law", ["linear", "accel"])
def test_tick_rates_sample_the_profile_at_tick_starts(law):
    moves = zigzag_moves(rows=3, width_mm=5.0, segments_per_row=2)
    p = plan(moves, planner="normal", law=law)
    sb = step_blocks(p)
    for j, i in enumerate(p.motion):
        row = sb.row(i)
        f = tick_rates(row["ticks"], row["f_entry"], row["f_peak"], row["f_exit"], row["f_min"],
                       row["up"], row["down"], law)
        assert f[0] == row["f_entry"] and f[-1] == row["f_exit"] and f.max() <= row["f_peak"]
        scale = row["ticks"] / p.profiles.length_mm[j]
        k = np.arange(row["ticks"])
        prof = p.profiles
        # rising ramp sampled at the start of each tick, falling ramp at its end
        if law == "linear":
            rise = prof.entry_mm_s[j] + prof.up[j] * k / scale
            fall = prof.exit_mm_s[j] + prof.down[j] * (row["ticks"] - 1 - k) / scale
        else:
            rise = np.sqrt(prof.entry_mm_s[j] ** 2 + 2 * prof.up[j] * k / scale)
            fall = np.sqrt(prof.exit_mm_s[j] ** 2 + 2 * prof.down[j] * (row["ticks"] - 1 - k) / scale)
        want = np.maximum(np.minimum(np.minimum(rise, prof.peak_mm_s[j]), fall) * scale, row["f_min"])
        # integer rates sit at most the floors below (1 Hz each; √(2k) for the rounded α of the accel law)
        slack = 2 + (0 if law == "linear" else np.sqrt(2 * k))
        assert np.all(f <= want + 1e-6) and np.all(f >= want - slack - 1e-6)


def test_step_trace_reaches_every_target_and_keeps_time():
    moves = random_polyline_moves(2, n=25)
    p = plan(moves, planner="junction")
    tr = step_trace(p)
    pos = p.blocks.start_steps[0] + np.cumsum(tr.step, axis=0)
    for i in p.motion:
        last = np.flatnonzero(tr.block == i)[-1]
        assert np.array_equal(pos[last], p.blocks.end_steps[i])
    assert np.all(np.diff(tr.cycle) > 0)
    assert np.all(tr.period < 2 ** CBR40.timer_bits)
    # the step-timed job runs each tick at the rate of its start: a little slower than the profiles
    t_steps = tr.time_s[-1] + (p.blocks.dwell_s[p.motion[-1] + 1:].sum())
    assert p.job_time_s < t_steps < p.job_time_s * 1.02


def test_lines_and_arcs_in_the_trace_are_the_bresenham_walks():
    b = MovesBuilder(feed_mm_min=900, s_word=300, laser=LaserMode.CONSTANT)
    b.line(x=0.4, y=0.13)
    b.arc_cw(x=0.4, y=-0.27, i=0.0, j=-0.2, z=0.05)         # half a helix turn, r = 0.2 mm
    p = plan(b.build(), planner="normal")
    spm = np.asarray(CBR40.steps_per_mm)
    blk = p.blocks
    line_pts = block_points(blk, 0, spm)
    ref, _ = lines_points(blk.start_steps[:1], blk.end_steps[:1])
    assert np.array_equal(line_pts, ref)
    arc_pts = block_points(blk, 1, spm)
    plane = arc_lattice_points(blk.start_steps[1, :2], blk.end_steps[1, :2], blk.centre_mm[1, :2] * spm[0],
                       clockwise=True, radius=0.2 * spm[0], sweep_rad=blk.sweep_rad[1])
    assert np.array_equal(arc_pts[:, :2], plane)
    assert np.array_equal(arc_pts[-1], blk.end_steps[1])
    assert np.all(np.diff(arc_pts[:, 2]) >= 0)              # the helix only rises
    tr = step_trace(p)
    assert len(tr) == blk.ticks.sum()
    assert tr.dir_bits[tr.block == 1].max() > 0


def test_dwell_time_counts_in_the_trace():
    b = MovesBuilder(feed_mm_min=600)
    b.line(x=0.01)
    b.dwell(0.5)
    b.line(x=0.02)
    p = plan(b.build(), planner="hq")
    tr = step_trace(p)
    first = tr.cycle[tr.block == 2][0]
    last = tr.cycle[tr.block == 0][-1]
    assert first - last >= 0.5 * CBR40.timer_clock_hz
    assert step_blocks(p).dwell_cycles[1] == 24_000_000


def test_tick_rates_argument_error():
    with pytest.raises(MotionError, match="ramp law must be 'linear' or 'accel'"):
        tick_rates(10, 1000, 2000, 1000, 1000, 10, 10, "cubic")


def test_plan_tables_select_and_join_rows_as_their_columns_do():
    # Blocks, Profiles, StepBlocks and StepTrace share one table behaviour (labkit._array.
    # ColumnTable): checked against numpy's own indexing of each column, and a trace made in
    # small pieces joined back against the trace made whole.
    from dataclasses import fields

    from labkit.motion.timer import iter_step_chunks

    p = plan(zigzag_moves(), planner="hq")
    sb = step_blocks(p)
    whole = step_trace(p)
    tables = {"blocks": p.blocks, "profiles": p.profiles, "step blocks": sb, "trace": whole}
    rng = np.random.default_rng(7)
    for name, table in tables.items():
        cols = {f.name: getattr(table, f.name) for f in fields(table)}
        arrays = {k: v for k, v in cols.items() if isinstance(v, np.ndarray)}
        n = len(next(iter(arrays.values())))
        assert len(table) == n > 3, name
        mask = rng.random(n) < 0.5
        for index in (mask, slice(1, None, 2), np.array([n - 1, 0]), 2, -1):
            picked = table[index]
            expect_rows = np.arange(n)[index]
            assert len(picked) == np.atleast_1d(expect_rows).size, (name, index)
            for k, v in cols.items():
                got = getattr(picked, k)
                if k in arrays:
                    want = v[np.atleast_1d(expect_rows)]
                    assert np.array_equal(got, want, equal_nan=True), (name, k, index)
                else:
                    assert got == v, (name, k)
    pieces = list(iter_step_chunks(p, max_ticks=97))
    assert len(pieces) > 3
    joined = type(whole).concat(pieces)
    for f in fields(whole):
        assert np.array_equal(getattr(joined, f.name), getattr(whole, f.name)), f.name
