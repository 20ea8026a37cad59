"""Bezier evaluation, De Casteljau split and both flatteners against svgelements."""

import numpy as np
import pytest
import svgelements as se
from hypothesis import given, settings
from hypothesis import strategies as st

from labkit.errors import GeometryError
from labkit.geometry import (Path, cubic_point, flatness, flatten_adaptive_t, flatten_cubic,
                             flatten_cubics, hausdorff, quad_to_cubic, split_cubic)

coord = st.floats(-100, 100)
cubics = st.lists(st.tuples(coord, coord), min_size=4, max_size=4).map(np.array)


def _svg_dense(ctrl, n=20001):
    # svgelements evaluates the curve itself (npoint: the same points as point(t) one by one)
    return se.CubicBezier(*[complex(*p) for p in ctrl]).npoint(np.linspace(0, 1, n))


def test_point_matches_svgelements():
    ctrl = np.array([[0, 0], [10, 30], [40, -20], [50, 10]], float)
    c = se.CubicBezier(*[complex(*p) for p in ctrl])
    for t in (0, 0.1, 0.5, 0.77, 1):
        p = c.point(t)
        np.testing.assert_allclose(cubic_point(ctrl, t), [p.x, p.y], atol=1e-12)


def test_quadratic_elevation_is_exact():
    q = se.QuadraticBezier(0j, 30 + 40j, 60 + 0j)
    cub = quad_to_cubic((0, 0), (30, 40), (60, 0))
    for t in np.linspace(0, 1, 11):
        p = q.point(t)
        np.testing.assert_allclose(cubic_point(cub, t), [p.x, p.y], atol=1e-12)


@given(cubics, st.floats(0.0, 1.0))
@settings(max_examples=50, deadline=None)
def test_split_halves_trace_the_curve(ctrl, t):
    left, right = split_cubic(ctrl, t)
    s = np.linspace(0, 1, 7)
    np.testing.assert_allclose(cubic_point(left, s), cubic_point(ctrl, t * s), atol=1e-9)
    np.testing.assert_allclose(cubic_point(right, s), cubic_point(ctrl, t + (1 - t) * s), atol=1e-9)


def test_seed_eq24_is_distance_to_line():
    ctrl = [[0, 0], [-5, 3], [15, -2], [10, 0]]
    assert flatness(ctrl, segment=False) == pytest.approx(3.0)
    assert flatness(ctrl) == pytest.approx(np.hypot(5, 3))     # segment distance sees the overshoot


@given(cubics, st.sampled_from([0.1, 0.01]))
@settings(max_examples=40, deadline=None)
def test_flatten_meets_absolute_tolerance(ctrl, tol):
    pts = flatten_cubic(ctrl, tol_mm=tol)
    np.testing.assert_allclose(pts[0], ctrl[0])
    np.testing.assert_allclose(pts[-1], ctrl[-1])
    assert hausdorff(Path.polyline(pts), Path.polyline(_svg_dense(ctrl))) <= tol + 1e-6


def test_relative_rule_scales_with_size_and_absolute_does_not():
    small = np.array([[0, 0], [0, 1], [1, 1], [1, 0]], float)
    n_rel = [len(flatten_cubic(small * k, chord_fraction=0.01)) for k in (1, 100)]
    n_abs = [len(flatten_cubic(small * k, tol_mm=0.01)) for k in (1, 100)]
    assert n_rel[0] == n_rel[1]
    assert n_abs[1] > 4 * n_abs[0]


def test_batch_equals_single():
    rng = np.random.default_rng(3)
    ctrls = rng.uniform(-50, 50, (20, 4, 2))
    pts, counts = flatten_cubics(ctrls, 0.05)
    assert counts.sum() == len(pts)
    k = 0
    for c, n in zip(ctrls, counts):
        np.testing.assert_array_equal(pts[k:k + n], flatten_cubic(c, tol_mm=0.05)[1:])
        k += n


def test_adaptive_t_stays_near_cap_and_counts_work():
    ctrl = np.array([[0, 0], [20, 60], [60, -40], [80, 20]], float)
    work = {}
    pts = flatten_adaptive_t(ctrl, 0.05, counter=work)
    h = hausdorff(Path.polyline(pts), Path.polyline(_svg_dense(ctrl)))
    assert h <= 0.05 * 1.05             # measured on samples, so not a strict bound
    assert work["trials"] >= len(pts) - 1
    casteljau = flatten_cubic(ctrl, tol_mm=0.05)
    assert abs(len(pts) - len(casteljau)) < len(casteljau)


def test_errors():
    with pytest.raises(GeometryError, match="exactly one of tol_mm"):
        flatten_cubic([[0, 0], [1, 1], [2, 1], [3, 0]])
    with pytest.raises(GeometryError, match="tol_mm must be > 0"):
        flatten_cubic([[0, 0], [1, 1], [2, 1], [3, 0]], tol_mm=0)
    with pytest.raises(GeometryError, match="chord_fraction must be in"):
        flatten_cubic([[0, 0], [1, 1], [2, 1], [3, 0]], chord_fraction=2)
    with pytest.raises(GeometryError, match="4 control points"):
        split_cubic([[0, 0], [1, 1]])
    with pytest.raises(GeometryError, match="t must be in"):
        split_cubic([[0, 0], [1, 1], [2, 1], [3, 0]], 1.5)
    with pytest.raises(GeometryError, match="error_cap must be > 0"):
        flatten_adaptive_t([[0, 0], [1, 1], [2, 1], [3, 0]], 0)
    with pytest.raises(GeometryError, match="increment_growth must be > 1"):
        flatten_adaptive_t([[0, 0], [1, 1], [2, 1], [3, 0]], 0.1, increment_growth=1)
