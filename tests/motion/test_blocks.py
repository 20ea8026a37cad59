"""Blocks: steps, lengths, caps, power, arcs, the FIFO, and every error path."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from labkit.errors import MotionError
from labkit.geometry.circle import grbl_segments
from labkit.motion import CBR40, arc_lattice_points, load_machine
from labkit.motion.blocks import BlockFifo, BlockKind, build_blocks, expand_arcs, to_steps
from labkit.toolpath import LaserMode, Moves, MovesBuilder


def test_to_steps_rounds_halves_away_from_zero():
    spm = 2.0
    assert to_steps([0.25, -0.25, 0.75, -0.75, 1.0], spm).tolist() == [1, -1, 2, -2, 2]


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.floats(-50, 50), st.floats(-50, 50)), min_size=1, max_size=30))
def test_blocks_chain_without_accumulating_rounding(points):
    b = MovesBuilder(feed_mm_min=900)
    for x, y in points:
        b.line(x=x, y=y)
    moves = b.build()
    blk = build_blocks(moves)
    end = to_steps(moves.end[-1], CBR40.steps_per_mm)
    start = to_steps(moves.start[0], CBR40.steps_per_mm)
    assert np.array_equal(start + blk.steps.sum(axis=0), end)
    assert np.array_equal(blk.ticks, np.abs(blk.steps).max(axis=1))
    assert np.all(blk.ticks > 0)                       # zero-step moves make no block
    np.testing.assert_allclose(np.linalg.norm(blk.unit_in, axis=1), 1.0)
    # length is that of the rounded step displacement
    np.testing.assert_allclose(blk.length_mm, np.linalg.norm(blk.steps / CBR40.steps_per_mm, axis=1))


def test_caps_follow_feed_and_axis_limits():
    b = MovesBuilder(feed_mm_min=6000)
    b.line(x=10)                 # feed 100 mm/s > 25.77 mm/s axis limit
    b.rapid(x=20, y=10)          # diagonal rapid: each axis may run at its limit
    b.line(x=20, y=10.00002)     # 0.04 step: rounds to no step, no block
    b.line(x=21, feed_mm_min=600)
    blk = build_blocks(b.build())
    vmax = 1546.0875 / 60
    assert len(blk) == 3
    assert blk.cap_mm_s.tolist() == pytest.approx([vmax, vmax * math.sqrt(2), 10.0], rel=1e-4)
    assert blk.accel_mm_s2.tolist() == pytest.approx([500.0, 500 * math.sqrt(2), 500.0], rel=1e-4)
    assert blk.rapid.tolist() == [False, True, False]
    # rest speed: the driver at 1 kHz
    assert blk.rest_mm_s[0] == pytest.approx(1000 / CBR40.steps_per_mm[0], rel=1e-6)


def test_power_and_ratio():
    b = MovesBuilder(feed_mm_min=1200, s_word=400, laser=LaserMode.DYNAMIC)
    b.line(x=1)
    b.rapid(x=2)
    b.line(x=3, laser=LaserMode.OFF)
    b.line(x=4, laser=LaserMode.CONSTANT, s_word=2000)     # S above s_max clips to full power
    blk = build_blocks(b.build())
    assert blk.power_mw.tolist() == [1000.0, 0.0, 0.0, 2500.0]
    assert blk.power_ratio.tolist() == [50.0, 0.0, 0.0, 125.0]
    assert blk.laser_mode.tolist() == [4, 0, 0, 3]


def test_arc_block_matches_its_octant_walk():
    b = MovesBuilder(feed_mm_min=1200)
    b.rapid(x=10, y=0)
    b.arc_ccw(x=0, y=10, i=-10, j=0)
    blk = build_blocks(b.build())
    arc = blk[1]
    assert arc.kind[0] == BlockKind.ARC
    spm = CBR40.steps_per_mm[0]
    pts = arc_lattice_points(arc.start_steps[0, :2], arc.end_steps[0, :2], [0.0, 0.0], clockwise=False,
                     radius=10 * spm, sweep_rad=math.pi / 2)
    assert arc.ticks[0] == len(pts) - 1
    assert arc.length_mm[0] == pytest.approx(10 * math.pi / 2)
    np.testing.assert_allclose(arc.unit_in[0], [0, 1, 0], atol=1e-12)
    np.testing.assert_allclose(arc.unit_out[0], [-1, 0, 0], atol=1e-12)
    assert arc.cap_mm_s[0] == pytest.approx(min(20.0, math.sqrt(500 * 10)))


def test_expand_arcs_is_grbl_chords():
    b = MovesBuilder(feed_mm_min=600, s_word=100, laser=LaserMode.CONSTANT)
    b.rapid(x=5, y=0)
    b.arc_cw(x=-5, y=0, i=-5, j=0, line=7)                 # half circle, r = 5 mm
    moves = expand_arcs(b.build(), 0.002)
    n = grbl_segments(5.0, math.pi, 0.002)
    assert len(moves) == 1 + n
    ends = moves.end[1:, :2]
    np.testing.assert_allclose(np.hypot(*ends.T), 5.0, atol=1e-12)
    assert np.all(ends[:-1, 1] < 0)                        # clockwise from +x goes below
    assert set(moves.line[1:].tolist()) == {7}
    assert moves.lengths_mm()[1:].sum() == pytest.approx(n * 10 * math.sin(math.pi / (2 * n)), rel=1e-12)
    blk = build_blocks(b.build(), arc_tol_mm=0.002)
    assert np.all(blk.kind == BlockKind.LINE) and len(blk) == 1 + n
    with pytest.raises(MotionError, match="tol_mm must be > 0 mm"):
        expand_arcs(b.build(), 0.0)


def test_fifo_ring_buffer():
    f = BlockFifo(3)
    assert f.empty and not f.full
    for i in range(3):
        f.push(i)
    assert f.full and list(f) == [0, 1, 2]
    with pytest.raises(MotionError, match="block buffer full \\(3 blocks\\)"):
        f.push(3)
    assert f.pop() == 0
    f.push(3)                                # wraps around
    assert [f[i] for i in range(len(f))] == [1, 2, 3]
    while not f.empty:
        f.pop()
    with pytest.raises(MotionError, match="block buffer empty"):
        f.pop()
    with pytest.raises(IndexError, match="out of range"):
        f[0]
    with pytest.raises(MotionError, match="capacity must be an integer >= 1"):
        BlockFifo(0)


def test_build_errors_name_the_line():
    b = MovesBuilder()
    b.line(x=1, line=4)
    with pytest.raises(MotionError, match=r"move 0 \(line 4\): no feed rate in effect"):
        build_blocks(b.build())
    gap = Moves(kind=[1, 1], start=[[0, 0, 0], [5, 0, 0]], end=[[1, 0, 0], [6, 0, 0]],
                feed_mm_min=[600, 600], line=[1, 2])
    with pytest.raises(MotionError, match=r"move 1 \(line 2\) starts at \[5.0, 0.0, 0.0\]"):
        build_blocks(gap)
    diode = load_machine("grbl-diode")       # 80 steps/mm on X, 400 on Z
    b = MovesBuilder(feed_mm_min=600, plane=18)
    b.arc_cw(x=2, z=0, i=1, k=0, line=9)
    with pytest.raises(MotionError, match=r"line 9.*equal steps/mm.*arc_tol_mm"):
        build_blocks(b.build(), diode)
    assert len(build_blocks(b.build(), diode, arc_tol_mm=0.01)) > 1
    b = MovesBuilder(feed_mm_min=600)
    b.arc_ccw(x=0, y=0, z=50, i=0.01, j=0, line=3)        # tiny circle, tall helix
    with pytest.raises(MotionError, match=r"line 3.*helix rises"):
        build_blocks(b.build())
    b = MovesBuilder(feed_mm_min=600)
    b.arc_ccw(x=0, y=2, i=0, j=1.1, line=5)             # radius 1.1 at the start, 0.9 at the end
    with pytest.raises(MotionError, match=r"line 5.*arc radius 1.1 mm at the start but 0.9 mm"):
        build_blocks(b.build())
    with pytest.raises(MotionError, match="moves must be a labkit.toolpath.Moves"):
        build_blocks([1, 2, 3])


def test_dwells_and_empty_programs():
    b = MovesBuilder(feed_mm_min=600)
    b.dwell(0.5, line=2)
    blk = build_blocks(b.build())
    assert blk.kind.tolist() == [BlockKind.DWELL] and blk.dwell_s.tolist() == [0.5]
    assert len(build_blocks(Moves.empty())) == 0
    df = blk.to_dataframe()
    assert df["kind"].tolist() == ["DWELL"] and "start_steps_x" in df
