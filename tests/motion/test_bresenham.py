"""Bresenham lines and arcs against scikit-image and against their own invariants."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from skimage.draw import circle_perimeter, line, line_nd

from labkit.errors import MotionError
from labkit.motion.bresenham import (
    arc_lattice_points,
    circle_points,
    direction_bits,
    line_points,
    line_steps,
    lines_points,
    lines_points_closed_form,
    steps_from_points,
)

coord = st.integers(-2000, 2000)


def test_100k_random_lines_match_skimage_line():
    rng = np.random.default_rng(20240501)
    n = 100_000
    # half short lines (many exact ties), half long ones
    starts = rng.integers(-50, 50, (n, 2))
    ends = np.where(np.arange(n)[:, None] % 2 == 0,
                    starts + rng.integers(-8, 9, (n, 2)),
                    rng.integers(-150, 150, (n, 2)))
    pts, off = lines_points(starts, ends)
    for j in range(n):
        (x0, y0), (x1, y1) = starts[j], ends[j]
        rr, cc = line(y0, x0, y1, x1)          # skimage: (row, col) = (y, x)
        ours = pts[off[j]:off[j + 1]]
        assert np.array_equal(ours[:, 0], cc) and np.array_equal(ours[:, 1], rr), (starts[j], ends[j])


def test_sequential_walk_batch_kernel_and_closed_form_agree():
    rng = np.random.default_rng(7)
    for dims in (2, 3):
        starts = rng.integers(-500, 500, (400, dims))
        ends = rng.integers(-500, 500, (400, dims))
        pts, off = lines_points(starts, ends)
        closed, off2 = lines_points_closed_form(starts, ends)
        assert np.array_equal(pts, closed) and np.array_equal(off, off2)
        for j in range(len(starts)):
            assert np.array_equal(line_points(starts[j], ends[j]), pts[off[j]:off[j + 1]])


def _has_tie(delta):
    n = np.abs(delta).max()
    for d in np.abs(delta):
        g = math.gcd(int(d), int(n)) if n else 1
        if d and (n // g) % 2 == 0:
            return True
    return False


def test_3d_lines_match_skimage_line_nd_except_documented_ties():
    rng = np.random.default_rng(11)
    tie_free = ties = 0
    for _ in range(3000):
        s = rng.integers(-40, 40, 3)
        e = rng.integers(-40, 40, 3)
        ours = line_points(s, e)
        theirs = np.stack(line_nd(s, e, endpoint=True), axis=1)
        if not _has_tie(e - s):
            tie_free += 1
            assert np.array_equal(ours, theirs), (s, e)
        else:
            # line_nd rounds exact halves to even; we round them away from the start.
            ties += 1
            n = np.abs(e - s).max()
            k = np.arange(n + 1)[:, None]
            exact = s + (e - s) * k / n
            differ = ours != theirs
            assert np.all(np.abs(exact[differ] - np.round(exact[differ]) - 0) == 0.5)
    assert tie_free > 1000 and ties > 100


@settings(max_examples=300, deadline=None)
@given(st.lists(coord, min_size=3, max_size=3), st.lists(coord, min_size=3, max_size=3),
       st.sampled_from([2, 3]))
def test_line_invariants(s, e, dims):
    s, e = np.array(s[:dims]), np.array(e[:dims])
    pts = line_points(s, e)
    delta = e - s
    n = int(np.abs(delta).max())
    assert len(pts) == n + 1
    assert np.array_equal(pts[0], s) and np.array_equal(pts[-1], e)
    steps = line_steps(s, e)
    assert np.array_equal(np.abs(steps).sum(axis=0), np.abs(delta))      # exact step counts
    assert np.all(steps * np.sign(delta) >= 0)                          # never backwards
    if n:
        driver = int(np.argmax(np.abs(delta)))
        assert np.all(np.abs(steps[:, driver]) == 1)                    # driver steps every tick
        k = np.arange(n + 1)[:, None]
        assert np.all(np.abs(pts - (s + delta * k / n)) <= 0.5)         # nearest lattice point


def test_direction_bits_convention():
    assert direction_bits([1, 1, 1]) == 0
    assert direction_bits([-1, 0, 0]) == 1
    assert direction_bits([0, -1, -1]) == 6
    assert direction_bits([[-3, 2], [4, -5]]).tolist() == [1, 2]


@pytest.mark.parametrize("centre", [(0, 0), (17, -5), (-300, 1234)])
def test_full_circles_match_skimage_circle_perimeter(centre):
    cx, cy = centre
    for r in range(1, 260):
        rr, cc = circle_perimeter(cy, cx, r)      # method="bresenham"
        theirs = set(zip(cc.tolist(), rr.tolist()))
        pts = circle_points([cx, cy], r)
        assert set(map(tuple, pts.tolist())) == theirs, r
        assert np.array_equal(pts[0], pts[-1])
        steps_from_points(pts)                    # 8-connected


def _random_arc(rng, r_lo, r_hi):
    r = rng.uniform(r_lo, r_hi)
    c = rng.uniform(-5000, 5000, 2)
    a0 = rng.uniform(0, 2 * math.pi)
    sw = rng.uniform(1e-3, 2 * math.pi) * rng.choice([-1, 1])
    p0 = c + r * np.array([math.cos(a0), math.sin(a0)])
    p1 = c + r * np.array([math.cos(a0 + sw), math.sin(a0 + sw)])
    return np.floor(p0 + 0.5).astype(int), np.floor(p1 + 0.5).astype(int), c, r, sw


@pytest.mark.parametrize("r_lo,r_hi", [(4, 30), (30, 3000)])
def test_random_arcs_stay_within_half_a_step_and_end_exactly(r_lo, r_hi):
    rng = np.random.default_rng(r_hi)
    for _ in range(3000):
        s, e, c, r, sw = _random_arc(rng, r_lo, r_hi)
        pts = arc_lattice_points(s, e, c, clockwise=sw < 0, radius=r, sweep_rad=sw)
        assert np.array_equal(pts[0], s) and np.array_equal(pts[-1], e)
        steps_from_points(pts)                                  # 8-connected, one step per axis
        dev = np.abs(np.hypot(*(pts[1:-1] - c).T) - r)
        assert np.all(dev <= 0.5 + 1 / (8 * r) + 1 / 256), (s, e, c, r, sw, dev.max())
        # never backwards along the arc: the turn from one point to the next has the arc's sign
        rel = pts - c
        turn = rel[:-1, 0] * rel[1:, 1] - rel[:-1, 1] * rel[1:, 0]
        assert np.all(turn * np.sign(sw) >= -1e-9)
        # ticks: between arc length / √2 and arc length (+ the two rounded ends)
        length = abs(sw) * r
        assert length / math.sqrt(2) - 3 <= len(pts) - 1 <= length + 3


def test_quarter_arc_by_hand():
    # [CBR40] eq. 4 worked by hand for r = 5, first octant from (5, 0): y drives;
    # at y = 1, 2 x stays (|e(4, y)| > |e(5, y)|), at y = 3: e(5,3) = 9, e(4,3) = 0 → x steps.
    pts = arc_lattice_points([5, 0], [0, 5], [0.0, 0.0], clockwise=False)
    assert pts.tolist() == [[5, 0], [5, 1], [5, 2], [4, 3], [3, 4], [2, 5], [1, 5], [0, 5]]
    cw = arc_lattice_points([0, 5], [5, 0], [0.0, 0.0], clockwise=True)
    assert cw.tolist() == pts[::-1].tolist()


def test_arc_short_and_full_sweeps_in_one_octant():
    c = np.array([0.3, -0.2])
    s = np.array([1000, 0])
    e = np.array([995, 100])
    short = arc_lattice_points(s, e, c, clockwise=False, sweep_rad=0.1)
    full = arc_lattice_points(s, e, c, clockwise=False, sweep_rad=0.1 + 2 * math.pi - 0.2)
    assert len(short) < 110 < 5000 < len(full)


def test_tiny_radius_is_a_line():
    assert arc_lattice_points([0, 0], [1, 1], [0.5, 0.5], clockwise=False).tolist() == [[0, 0], [1, 1]]


@pytest.mark.parametrize("kwargs,match", [
    (dict(start=[0, 0, 0], end=[1, 1], centre=[0, 0]), "start must be a point of 2 integers"),
    (dict(start=[0.5, 0], end=[1, 1], centre=[0, 0]), "whole steps"),
    (dict(start=[10, 0], end=[0, 10], centre=[0, np.nan]), "centre must be 2 finite"),
    (dict(start=[10, 0], end=[0, 10], centre=[0, 0], radius=-1.0), "radius must be > 0"),
    (dict(start=[10, 0], end=[0, 10], centre=[0, 0], scale=0), "scale must be an integer"),
    (dict(start=[10, 0], end=[0, 10], centre=[0, 0], sweep_rad=-1.0), "positive sweep"),
])
def test_arc_argument_errors(kwargs, match):
    with pytest.raises(MotionError, match=match):
        arc_lattice_points(clockwise=False, **kwargs)


def test_line_argument_errors():
    with pytest.raises(MotionError, match="end must be a point of 3 integers"):
        line_points([0, 0, 0], [1, 2])
    with pytest.raises(MotionError, match="must hold integers"):
        line_points(["a", "b"], [1, 2])
    with pytest.raises(MotionError, match=r"shape \(n, 2\) or \(n, 3\)"):
        lines_points(np.zeros((3, 4), int), np.zeros((3, 4), int))
    with pytest.raises(MotionError, match="integer arrays"):
        lines_points(np.zeros((3, 2)), np.zeros((3, 2)))
    with pytest.raises(MotionError, match="8-connected"):
        steps_from_points([[0, 0], [2, 0]])
    with pytest.raises(MotionError, match="radius must be an integer >= 1"):
        circle_points([0, 0], 0)
