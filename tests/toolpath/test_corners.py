"""Constant-velocity corner loops (seed 001 §6.1.3.1): geometry by hand, and the speed they buy."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from labkit.errors import GeometryError
from labkit.motion import plan
from labkit.motion.power import dose_uniformity
from labkit.toolpath import LaserMode, MoveKind, MovesBuilder
from labkit.toolpath.corners import add_corner_loops, turn_angles

A = 500.0          # mm/s²
FEED = 1200.0      # mm/min = 20 mm/s → v²/a = 0.8 mm


def polyline(points, feed=FEED, laser=LaserMode.CONSTANT):
    b = MovesBuilder(feed_mm_min=feed, s_word=500, laser=laser)
    b.rapid(x=points[0][0], y=points[0][1])
    for x, y in points[1:]:
        b.line(x=x, y=y)
    return b.build()


def _directions(m, i):
    if m.kind[i] == MoveKind.LINE or m.kind[i] == MoveKind.RAPID:
        d = m.end[i, :2] - m.start[i, :2]
        d = d / np.linalg.norm(d)
        return d, d
    sign = 1 if m.kind[i] == MoveKind.ARC_CCW else -1
    out = []
    for p in (m.start[i, :2], m.end[i, :2]):
        r = p - m.centre[i, :2]
        out.append(sign * np.array([-r[1], r[0]]) / np.linalg.norm(r))
    return out


def _check_loops(orig, looped):
    # continuous, same cuts in the same order, detours dark and tangent where they meet a cut
    assert np.allclose(looped.start[1:], looped.end[:-1], atol=1e-9)
    on = looped.laser_on
    assert np.allclose(looped.start[on], orig.start[orig.laser_on])
    assert np.allclose(looped.end[on], orig.end[orig.laser_on])
    for i in range(1, len(looped)):
        if looped.kind[i - 1] == MoveKind.RAPID or looped.kind[i] == MoveKind.RAPID:
            continue
        if on[i - 1] != on[i]:
            _, d_out = _directions(looped, i - 1)
            d_in, _ = _directions(looped, i)
            assert np.dot(d_out, d_in) > 1 - 1e-9, i


def test_square_gets_triangular_loops_with_the_seed_radius():
    m = polyline([(0, 0), (10, 0), (10, 10), (0, 10)])
    looped, rep = add_corner_loops(m, accel_mm_s2=A)
    assert (rep["triangle_loops"], rep["arc_loops"], rep["leads"]) == (2, 0, 2)
    _check_loops(m, looped)
    # r1 = max(TA, TD)·Feed with TA = v/a = 40 ms: 0.8 mm beyond (10, 0) along +x, fillets r1/5
    dark = looped[~looped.laser_on & (looped.kind != MoveKind.RAPID)]
    assert np.isclose(dark.end[:, 0].max(), 10.8 + 0.4 + 1e-12) or dark.end[:, 0].max() <= 10.8 + 1e-9
    arcs = dark[dark.is_arc]
    assert np.allclose(arcs.radius_mm(), 0.16)
    assert np.allclose(np.abs(arcs.sweep_rad()), math.radians(135))          # π − θ/2 each
    # the loop stays within r1 of the corner
    first_loop = dark[(dark.start[:, 1] >= -1) & (dark.end[:, 0] > 9.5) & (dark.end[:, 1] < 1)]
    assert np.all(np.linalg.norm(first_loop.end[:, :2] - [10, 0], axis=1) <= 0.8 + 1e-9)


def test_shallow_corner_gets_a_tangent_arc_loop():
    theta = math.radians(20)
    m = polyline([(0, 0), (10, 0), (10 + 10 * math.cos(theta), 10 * math.sin(theta))])
    looped, rep = add_corner_loops(m, accel_mm_s2=A, leads=False)
    assert (rep["arc_loops"], rep["triangle_loops"], rep["leads"]) == (1, 0, 0)
    _check_loops(m, looped)
    arc = looped[looped.is_arc]
    assert arc.radius_mm()[0] == pytest.approx(0.8)                            # ρ = v²/a
    assert abs(arc.sweep_rad()[0]) == pytest.approx(2 * math.pi - theta)      # 360° − θ around
    assert arc.kind[0] == MoveKind.ARC_CW                                       # left corner: loops right
    ext = looped[(~looped.laser_on) & (looped.kind == MoveKind.LINE)]
    assert np.allclose(np.linalg.norm(ext.end - ext.start, axis=1), 0.8 * math.tan(theta / 2))


def test_reversal_goes_out_and_back():
    m = polyline([(0, 0), (10, 0), (0, 0)])
    looped, rep = add_corner_loops(m, accel_mm_s2=A, leads=False)
    assert rep["triangle_loops"] == 1
    dark = looped[~looped.laser_on & (looped.kind == MoveKind.LINE)]
    assert dark.end[0, 0] == pytest.approx(10.8) and dark.end[1, 0] == pytest.approx(10.0)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.floats(-40, 40), st.floats(-40, 40)), min_size=3, max_size=8, unique=True),
       st.sampled_from(["junction", "normal"]))
def test_loops_keep_every_cut_at_the_feed(points, planner):
    pts = np.array(points)
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    if seg.min() < 2.0:          # the seed's loops assume segments longer than the ramps
        return
    m = polyline(pts.tolist())
    looped, _ = add_corner_loops(m, accel_mm_s2=A)
    _check_loops(m, looped)
    p = plan(looped, planner="junction", buffer_blocks=32)
    prof = p.profiles
    on = p.blocks[p.motion].laser_on
    assert np.allclose(prof.entry_mm_s[on], 20.0) and np.allclose(prof.exit_mm_s[on], 20.0)
    assert np.allclose(prof.peak_mm_s[on], 20.0)


def test_uniformity_gain_under_constant_power():
    m = polyline([(0, 0), (10, 0), (10, 10), (0, 10), (0, 0)])
    before = plan(m, planner="junction").burn_profile(0.01)
    after = plan(add_corner_loops(m, accel_mm_s2=A)[0], planner="junction").burn_profile(0.01)
    u0 = dose_uniformity(before["dose_mj_per_mm"], before["speed_mm_s"], before["feed_mm_s"])
    u1 = dose_uniformity(after["dose_mj_per_mm"], after["speed_mm_s"], after["feed_mm_s"])
    assert u0["cv"] > 0.2 and u0["slow_fraction"] > 0.05 and u0["max_over_mean"] > 5
    assert u1["cv"] < 1e-9 and u1["slow_fraction"] == 0.0


def test_corners_a_junction_controller_takes_at_full_feed_can_be_skipped():
    pts = [(0, 0), (10, 0), (20, 0.05)]             # 0.29° turn
    m = polyline(pts)
    assert add_corner_loops(m, accel_mm_s2=A, min_turn_deg=0.1)[1]["arc_loops"] == 1
    assert add_corner_loops(m, accel_mm_s2=A, min_turn_deg=0.1,
                            junction_deviation_mm=0.01)[1]["arc_loops"] == 0


def test_turn_angles():
    a, side = turn_angles([[1, 0], [1, 0]], [[0, -1], [1, 0]])
    assert np.allclose(np.degrees(a), [90, 0]) and side.tolist() == [-1, 0]


@pytest.mark.parametrize("kwargs,match", [
    (dict(accel_mm_s2=0), "accel_mm_s2 must be > 0"),
    (dict(accel_mm_s2=A, split_deg=180), r"split_deg must be in \(0, 180\)"),
    (dict(accel_mm_s2=A, min_turn_deg=50), r"min_turn_deg must be in \[0, split_deg\)"),
    (dict(accel_mm_s2=A, fillet_ratio=0), r"fillet_ratio must be in \(0, 1\]"),
])
def test_argument_errors(kwargs, match):
    with pytest.raises(GeometryError, match=match):
        add_corner_loops(polyline([(0, 0), (1, 0)]), **kwargs)
