"""Look-ahead planners and whole-job plans: rules, invariants and independent references."""

import math
from pathlib import Path

import numpy as np
import pytest
from .motion_jobs import random_polyline_moves, zigzag_moves

from labkit.errors import MotionError
from labkit.motion import CBR40
from labkit.motion.blocks import BlockFifo, BlockKind, build_blocks
from labkit.motion.planner import PLANNERS, junction_speed_caps, lookahead
from labkit.motion.pipeline import plan
from labkit.toolpath import LaserMode, MovesBuilder

PLANNER_LAWS = [(p, law) for p in PLANNERS for law in ("linear", "accel")]


def _reach(v, d, slope, law):
    return v + slope * d if law == "linear" else math.sqrt(v * v + 2 * slope * d)


def _check_invariants(p):
    la, prof = p.lookahead, p.profiles
    v = la.speed_mm_s
    # entry of block k+1 is the exit of block k (same number, by construction of the profiles),
    # except across a dwell: the machine stands still there, and each side ramps from or to
    # its own floor (its rest speed, or its cap when that is lower), as at the job's ends
    b_all = p.blocks
    dwell_between = np.array([np.any(b_all.kind[a + 1:c] == BlockKind.DWELL)
                              for a, c in zip(p.motion[:-1], p.motion[1:])], bool)
    flowing = ~dwell_between
    assert np.array_equal(prof.entry_mm_s[1:][flowing], prof.exit_mm_s[:-1][flowing])
    floor = np.minimum(p.blocks[p.motion].rest_mm_s, la.cap_mm_s)
    assert np.array_equal(prof.exit_mm_s[:-1][dwell_between], floor[:-1][dwell_between])
    assert np.array_equal(prof.entry_mm_s[1:][dwell_between], floor[1:][dwell_between])
    # speeds never exceed the block caps, junction caps, or the machine's axis limits
    b = p.blocks[p.motion]
    assert np.all(prof.peak_mm_s <= la.cap_mm_s * (1 + 1e-12))
    assert np.all(la.cap_mm_s <= b.limit_mm_s * (1 + 1e-12))
    assert np.all(v <= la.junction_cap_mm_s * (1 + 1e-12))
    axis_speed = np.abs(b.unit_in) * prof.peak_mm_s[:, None]
    assert np.all(axis_speed[b.kind == 1] <= CBR40.max_rate_mm_s * (1 + 1e-9))
    # every profile is feasible: the exit is reachable from the entry and back
    for k in range(len(prof)):
        L, ve, vx = prof.length_mm[k], prof.entry_mm_s[k], prof.exit_mm_s[k]
        assert vx <= _reach(ve, L, prof.up[k], p.law) * (1 + 1e-9)
        assert ve <= _reach(vx, L, prof.down[k], p.law) * (1 + 1e-9)
    # start and end of the job at rest
    assert v[0] == pytest.approx(b.rest_mm_s[0]) and v[-1] == pytest.approx(b.rest_mm_s[-1])


@pytest.mark.parametrize("planner,law", PLANNER_LAWS)
def test_invariants_on_random_jobs(planner, law, random_job):
    _check_invariants(plan(random_job, planner=planner, law=law, buffer_blocks=6))


@pytest.mark.parametrize("planner,law", PLANNER_LAWS)
def test_invariants_on_a_zigzag(planner, law):
    _check_invariants(plan(zigzag_moves(segments_per_row=3), planner=planner, law=law))


def test_junction_planner_respects_grbl_junction_speeds():
    p = plan(random_polyline_moves(9, n=120), planner="junction")
    la = p.lookahead
    assert la.over_limit.sum() == 0
    b = p.blocks[p.motion]
    ref = junction_speed_caps(b.unit_out[:-1], b.unit_in[1:], CBR40.accel_mm_s2, 0.01)
    inner = la.speed_mm_s[1:-1]
    assert np.all(inner <= np.maximum(ref, la.junction_rest_mm_s[1:-1]) * (1 + 1e-12))


def test_junction_speed_formula_by_hand():
    # 60° turn on one axis' acceleration budget: cosθ = −u1·u2 = −0.5, sin(θ/2) = sqrt(0.75).
    u1 = np.array([1.0, 0, 0])
    u2 = np.array([0.5, math.sqrt(0.75), 0])
    s = math.sqrt(0.75)
    j = (u2 - u1) / np.linalg.norm(u2 - u1)             # (−0.5, 0.866)/1 → a limited by y
    a = min(500 / abs(j[0]), 500 / abs(j[1]))
    expected = math.sqrt(a * 0.01 * s / (1 - s))
    assert junction_speed_caps(u1, u2, 500.0, 0.01) == pytest.approx(expected)
    assert junction_speed_caps(u1, u1, 500.0, 0.01) == np.inf           # straight on
    assert junction_speed_caps(u1, -u1, 500.0, 0.01) == 0.0             # reversal


def _whole_job_two_pass(L, up, down, jcap, law):
    """Textbook planner with an unlimited buffer: one backward, one forward pass."""
    n = len(L)
    v = list(jcap)
    for k in range(n - 1, -1, -1):
        v[k] = min(v[k], _reach(v[k + 1], L[k], down[k], law))
    for k in range(n):
        v[k + 1] = min(v[k + 1], _reach(v[k], L[k], up[k], law))
    return np.array(v)


def test_unlimited_buffer_equals_the_textbook_two_pass():
    moves = random_polyline_moves(3, n=80)
    p = plan(moves, planner="junction", buffer_blocks=10_000)
    la = p.lookahead
    ref = _whole_job_two_pass(p.profiles.length_mm, p.profiles.up, p.profiles.down,
                              la.junction_cap_mm_s, "accel")
    np.testing.assert_allclose(la.speed_mm_s, ref, rtol=1e-13)


def _fifo_stream_reference(L, up, down, jcap, jrest, depth, law):
    """Parser, planner and runner around a BlockFifo, in plain Python."""
    n = len(L)
    fifo = BlockFifo(depth)
    nxt = 0
    entry = jcap[0]
    out = [entry]
    while nxt < n or not fifo.empty:
        while nxt < n and not fifo.full:          # parser fills the buffer
            fifo.push(nxt)
            nxt += 1
        k = fifo[0]
        last = fifo[len(fifo) - 1]
        vb = jrest[last + 1]                      # the buffer must be able to stop
        for j in range(last, k, -1):
            vb = min(jcap[j], _reach(vb, L[j], down[j], law))
        exit_ = min(vb, _reach(entry, L[k], up[k], law))
        fifo.pop()                                # the runner takes block k
        out.append(exit_)
        entry = exit_
    return np.array(out)


@pytest.mark.parametrize("depth", [1, 2, 5, 16])
def test_windowed_kernel_equals_a_fifo_stream(depth):
    p = plan(random_polyline_moves(1, n=60), planner="junction", buffer_blocks=depth)
    la = p.lookahead
    ref = _fifo_stream_reference(p.profiles.length_mm, p.profiles.up, p.profiles.down,
                                 la.junction_cap_mm_s, la.junction_rest_mm_s, depth, "accel")
    np.testing.assert_allclose(la.speed_mm_s, ref, rtol=1e-13)


def test_deeper_buffers_never_slow_the_job():
    moves = zigzag_moves(rows=6, segments_per_row=12, width_mm=6.0)
    times = [plan(moves, planner="junction", buffer_blocks=d).job_time_s for d in (1, 2, 4, 8, 16, 64)]
    assert all(a >= b - 1e-12 for a, b in zip(times, times[1:]))
    assert times[0] > times[-1] * 1.2
    # a buffer of one block stops at every junction
    one = plan(moves, planner="junction", buffer_blocks=1)
    np.testing.assert_allclose(one.lookahead.speed_mm_s, one.lookahead.junction_rest_mm_s)


def test_mbla_modes_on_a_zigzag_follow_cbr40_fig17():
    moves = zigzag_moves(rows=20, segments_per_row=4)
    plans = {m: plan(moves, planner=m) for m in ("fast", "normal", "hq")}
    t = {m: p.job_time_s for m, p in plans.items()}
    assert t["fast"] <= t["normal"] < t["hq"]
    # high quality joins only collinear blocks: each row's 4 power steps, never the step-overs
    hq = plans["hq"]
    b = hq.blocks[hq.motion]
    for g in np.unique(hq.lookahead.super_block):
        u = b.unit_in[hq.lookahead.super_block == g]
        assert np.allclose(u, u[0])
    # super blocks start and end at rest
    for p in plans.values():
        sb = p.lookahead.super_block
        edges = np.flatnonzero(np.diff(sb)) + 1
        np.testing.assert_allclose(p.lookahead.speed_mm_s[edges], p.lookahead.junction_rest_mm_s[edges])
        assert np.bincount(sb).max() <= p.lookahead.buffer_blocks


def test_fast_mode_gives_one_acceleration_and_one_deceleration_per_super_block():
    b = MovesBuilder(feed_mm_min=600, s_word=300, laser=LaserMode.DYNAMIC)
    b.line(x=5)
    b.line(x=10, feed_mm_min=1500)         # fastest block of the set
    b.line(x=10, y=5, feed_mm_min=300)     # a right-angle corner
    b.line(x=20, y=5, feed_mm_min=900)
    p = plan(b.build(), planner="fast")
    assert p.lookahead.n_super_blocks == 1
    assert np.allclose(p.lookahead.cap_mm_s, 25.0)
    v = p.lookahead.speed_mm_s
    peak = int(np.argmax(v))
    assert np.all(np.diff(v[:peak + 1]) >= 0) and np.all(np.diff(v[peak:]) <= 0)
    # normal keeps every block's own speed: the 300 mm/min block stays at 5 mm/s
    normal = plan(b.build(), planner="normal")
    assert normal.profiles.peak_mm_s[2] == pytest.approx(5.0)
    assert normal.lookahead.over_limit.sum() > 0          # corners passed above GRBL's limit


def test_rapid_feed_changes_and_dwells_split_super_blocks():
    b = MovesBuilder(feed_mm_min=600, s_word=300, laser=LaserMode.CONSTANT)
    b.line(x=5)
    b.line(x=10)
    b.rapid(x=20)
    b.line(x=25)
    b.dwell(0.5)
    b.line(x=30)
    p = plan(b.build(), planner="normal")
    assert p.lookahead.super_block.tolist() == [0, 0, 1, 2, 3]
    assert p.summary().dwell_time_s == 0.5
    j = plan(b.build(), planner="junction")
    # the dwell forces a stop in the junction planner too
    assert j.lookahead.speed_mm_s[4] == pytest.approx(j.lookahead.junction_rest_mm_s[4])


def _simulate_job_time(p, dt):
    """Drive the planned speeds with fixed time steps (RK4 on ds/dt = v(s)), independently of
    the profile time formulas; dwells added."""
    prof = p.profiles
    lin = p.law == "linear"
    ends = np.cumsum(prof.length_mm)
    starts = ends - prof.length_mm

    def v_of(s):
        k = min(int(np.searchsorted(ends, s, side="right")), len(ends) - 1)
        x = min(max(s - starts[k], 0.0), prof.length_mm[k])
        up = prof.entry_mm_s[k] + prof.up[k] * x if lin else math.sqrt(
            prof.entry_mm_s[k] ** 2 + 2 * prof.up[k] * x)
        rem = prof.length_mm[k] - x
        down = prof.exit_mm_s[k] + prof.down[k] * rem if lin else math.sqrt(
            prof.exit_mm_s[k] ** 2 + 2 * prof.down[k] * rem)
        return max(min(up, prof.cap_mm_s[k], down), 1e-6)

    total = ends[-1]
    s, t = 0.0, 0.0
    while True:
        k1 = v_of(s)
        k2 = v_of(s + 0.5 * dt * k1)
        k3 = v_of(s + 0.5 * dt * k2)
        k4 = v_of(s + dt * k3)
        ds = dt * (k1 + 2 * k2 + 2 * k3 + k4) / 6
        if s + ds >= total:
            return t + (total - s) / ds * dt + p.blocks.dwell_s.sum()
        s += ds
        t += dt


@pytest.mark.parametrize("planner,law", [("junction", "accel"), ("hq", "linear"), ("fast", "linear"),
                                         ("normal", "accel")])
def test_job_time_matches_fine_step_integration(planner, law):
    moves = zigzag_moves(rows=4, width_mm=8.0, segments_per_row=3)
    p = plan(moves, planner=planner, law=law)
    t_num = _simulate_job_time(p, dt=2e-4)
    assert p.job_time_s == pytest.approx(t_num, rel=1e-3)


def test_summary_and_trace():
    b = MovesBuilder(feed_mm_min=600, s_word=500, laser=LaserMode.DYNAMIC)
    b.line(x=10, line=1)
    b.rapid(x=20, line=2)
    b.dwell(0.25, line=3)
    p = plan(b.build(), planner="hq")
    s = p.summary()
    assert (s.blocks, s.motion_blocks, s.super_blocks) == (3, 2, 2)
    assert s.cut_length_mm == pytest.approx(10.0, abs=1e-3)
    assert s.travel_length_mm == pytest.approx(10.0, abs=1e-3)
    assert s.laser_on_time_s == pytest.approx(p.profiles.time_s[0])
    assert s.job_time_s == pytest.approx(p.profiles.time_s.sum() + 0.25)
    tr = p.trace()
    assert tr["line"].tolist() == [1, 2, 3]
    assert tr["kind"].tolist() == ["LINE", "RAPID", "DWELL"]
    assert tr["power_mw"].tolist() == [1250.0, 0.0, 0.0]
    assert tr["time_s"].sum() == pytest.approx(s.job_time_s)
    smp = p.sample(500)
    assert smp["power_mw"].max() == pytest.approx(1250.0)        # M4 at the programmed speed
    assert np.all(smp["power_mw"][smp["block"] != 0] == 0)
    assert smp["distance_mm"][-1] == pytest.approx(20.0, abs=1e-3)


@pytest.mark.parametrize("kwargs,match", [
    (dict(planner="grbl"), "planner must be one of junction, fast, normal, hq"),
    (dict(law="cubic"), "ramp law must be one of"),
    (dict(buffer_blocks=0), "buffer_blocks must be an integer >= 1"),
])
def test_plan_argument_errors(kwargs, match):
    with pytest.raises(MotionError, match=match):
        plan(zigzag_moves(rows=2), **kwargs)


def test_lookahead_argument_errors():
    blk = build_blocks(zigzag_moves(rows=2))
    with pytest.raises(MotionError, match="motion blocks only"):
        b = MovesBuilder(feed_mm_min=100)
        b.dwell(1.0)
        lookahead(build_blocks(b.build()))
    with pytest.raises(MotionError, match="stop_before must have n"):
        lookahead(blk, stop_before=[True])


def test_sample_argument_error():
    with pytest.raises(MotionError, match="n must be an integer >= 2 samples"):
        plan(zigzag_moves(rows=2)).sample(1)


def test_an_empty_program_plans_to_nothing():
    from labkit.toolpath import Moves

    p = plan(Moves.empty())
    s = p.summary()
    assert (s.blocks, s.super_blocks, s.job_time_s) == (0, 0, 0.0)
    assert len(p.trace()) == 0
    assert p.sample(5)["speed_mm_s"].tolist() == [0.0] * 5
    assert len(p.burn_profile()["dose_mj_per_mm"]) == 0


@pytest.mark.parametrize("planner", ["junction", "normal"])
def test_sync_lines_and_stops_rest_the_machine(planner):
    """Where GRBL syncs (a new S alone, M8, G92, M5 between collinear cuts) and at a pause, the
    machine stands still: the junction speed is the rest speed there, and the time between is
    each side's run from and to rest (the same as with a dwell of no time). A new S on a motion
    line rides with its move: no stop there."""
    from labkit.gcode import grbl_sync_lines, parse

    text = ("G21 G90\nM3 S100\nG1 X3 F1200\nS300\nG1 X6\nG1 X9 S500\nM8\nG1 X12\nG92 X0\n"
            "G1 X3\nM0\nG1 X6\nM5\nG0 X0\n")
    sync = grbl_sync_lines(text)
    assert sync == [2, 4, 7, 9, 13]
    p = plan(parse(text), planner=planner, sync_lines=sync)
    v = p.lookahead.speed_mm_s
    rest = p.lookahead.junction_rest_mm_s
    stopped = v <= rest * (1 + 1e-12)
    # junctions: 0 start, 1 (S300), 2 (S500 rides: no stop), 3 (M8), 4 (G92), 5 (M0), 6 (M5), end
    assert stopped.tolist() == [True, True, False, True, True, True, True, True]
    # the independent reference: the same cuts with a dwell of no time at every stop
    dwelled = text.replace("S300\n", "S300\nG4 P0\n").replace("M8\n", "M8\nG4 P0\n") \
        .replace("G92 X0\n", "G92 X0\nG4 P0\n").replace("M0\n", "G4 P0\n") \
        .replace("M5\n", "M5\nG4 P0\n")
    ref = plan(parse(dwelled), planner=planner)
    assert np.allclose(p.profiles.entry_mm_s, ref.profiles.entry_mm_s, rtol=1e-12)
    assert np.allclose(p.profiles.exit_mm_s, ref.profiles.exit_mm_s, rtol=1e-12)
    assert math.isclose(p.job_time_s, ref.job_time_s, rel_tol=1e-12)
    free = plan(parse(text.replace("M0\n", "")), planner=planner)
    assert free.job_time_s < p.job_time_s


def test_a_planner_resting_at_zero_ramps_from_zero_and_ticks_at_the_timer_floor():
    """grbl-diode (GRBL's planner rests at 0, its timer ticks no slower than 31 Hz): a 10 mm cut
    at 600 mm/min ramps 0 -> 10 mm/s -> 0 at 1000 mm/s² (closed form: 2 x 10 ms over 0.05 mm,
    9.9 mm at 10 mm/s: 1.01 s); planned from the 31 Hz floor v0 = 0.3875 mm/s each ramp is
    v0 / a shorter and v0² / 2a shorter in length, which the cruise at 10 mm/s takes back:
    2 (v0 / a - v0² / (2 a · 10)) = 0.760 ms in all. The step blocks are the same integers either way: a stop enters and leaves
    at the timer's floor, f_min = 31 Hz, and no tick runs slower."""
    from labkit.motion import load_machine
    from labkit.motion.timer import step_blocks, tick_rates

    grbl = load_machine("grbl-diode")
    b = MovesBuilder(feed_mm_min=600)
    b.line(x=10)
    moves = b.build()
    zero, floor = plan(moves, grbl), plan(moves, grbl.replace(rest_at_zero=False))
    assert zero.profiles.entry_mm_s[0] == zero.profiles.exit_mm_s[0] == 0.0
    assert zero.job_time_s == pytest.approx(2 * 0.01 + 9.9 / 10, rel=1e-12)
    v0 = 31 / 80
    assert zero.job_time_s - floor.job_time_s == pytest.approx(2 * (v0 / 1000 - v0 ** 2 / 2000 / 10), rel=1e-9)
    sz, sf = step_blocks(zero), step_blocks(floor)
    for name in ("ticks", "f_entry", "f_peak", "f_exit", "f_min", "up", "down"):
        assert sz.row(0)[name] == sf.row(0)[name], name
    row = sz.row(0)
    assert row["f_entry"] == row["f_exit"] == row["f_min"] == 31
    rates = tick_rates(row["ticks"], row["f_entry"], row["f_peak"], row["f_exit"], row["f_min"],
                       row["up"], row["down"], row["law"])
    assert rates.min() == 31
    # [CBR40]'s linear ramps cannot start from 0: with them the floor is the rest
    lin = plan(moves, grbl, planner="hq")
    assert lin.profiles.entry_mm_s[0] == pytest.approx(31 / 80)


def test_sync_lines_read_from_a_trace_are_the_parsed_ones():
    """A caller that has the program's strict trace (``labkit stream``'s job) gets the same sync
    lines from it as from the interpreter's own traced run, and the job's ETA plan stops there
    as ``labkit plan`` does (the stream read the program twice before)."""
    from labkit.gcode import grbl_sync_lines, parse, parse_with_states, reader
    from labkit.machine.stream import Job
    from labkit.motion.stall import controller_sync_lines

    texts = ["G21 G90\nM3 S100\nG1 X3 F1200\nS300\nG1 X6\nG1 X9 S500\nM8\nG1 X12\nG92 X0\n"
             "G1 X3\nM0\nG1 X6\nM5\nG0 X0\n",
             (Path(__file__).resolve().parents[2] / "data/gcode/cncjs/jsdc-laser.gcode").read_text()]
    for text in texts:
        reader._SYNC_LINES_SEEN.clear()
        parsed = grbl_sync_lines(text)
        reader._SYNC_LINES_SEEN.clear()
        assert grbl_sync_lines(text, trace=parse_with_states(text)[1]) == parsed
        assert parsed                       # both programs switch the laser
        reader._SYNC_LINES_SEEN.clear()
        job = Job.from_text(text, machine="grbl-diode")
        want = plan(parse(text), "grbl-diode", sync_lines=controller_sync_lines(text, "grbl-diode"))
        assert math.isclose(job.job_time_s, want.job_time_s, rel_tol=1e-12)
        assert want.job_time_s > plan(parse(text), "grbl-diode").job_time_s
