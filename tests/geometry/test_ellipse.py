"""Ellipse → arcs: the seed's points, the reported deviation against an independent measure."""

import math

import numpy as np
import pytest
from scipy.spatial import cKDTree
from hypothesis import given, settings
from hypothesis import strategies as st

from labkit.errors import GeometryError
from labkit.geometry import (Path, curvature_weighted_points, default_arcs_per_quadrant,
                             ellipse_arc_to_arcs, ellipse_point, ellipse_to_arcs, hausdorff)


def _dense_ellipse(c, rx, ry, rot, t0=0.0, dt=2 * math.pi, n=100_001):
    return ellipse_point(c, rx, ry, rot, t0 + dt * np.linspace(0, 1, n))


def _arc_samples(p, per_arc):
    out = []
    for i in range(p.n_segments):
        c = p.centres[i]
        r = np.hypot(*(p.vertices[i] - c))
        a0 = np.arctan2(*(p.vertices[i] - c)[::-1])
        t = a0 + p.sweeps[i] * np.linspace(0, 1, per_arc)
        out.append(c + r * np.c_[np.cos(t), np.sin(t)])
    return np.vstack(out)


def test_points_have_the_weighted_curvatures():
    a, b, n = 30.0, 12.0, 5
    pts = curvature_weighted_points(a, b, n)
    np.testing.assert_allclose(pts[:, 0] ** 2 / a**2 + pts[:, 1] ** 2 / b**2, 1.0, atol=1e-12)
    # seed 000 eq. 14 at each point equals the linear blend of eq. 17
    k = a * b / ((b * pts[:, 0] / a) ** 2 + (a * pts[:, 1] / b) ** 2) ** 1.5
    w = np.arange(n + 1) / n
    np.testing.assert_allclose(k, (1 - w) * a / b**2 + w * b / a**2, rtol=1e-9)


def test_seed_default_count():
    assert default_arcs_per_quadrant(2, 1) == 16       # seed 000 fig. 3.26: ratio 2 → 16 arcs
    assert default_arcs_per_quadrant(1, 2) == 16
    assert default_arcs_per_quadrant(2, 1.5) == 11
    p = ellipse_to_arcs((0, 0), 2, 1)
    assert p.n_segments == 64 and p.closed


@pytest.mark.parametrize("method", ["midpoint", "seed"])
@pytest.mark.parametrize("n", [2, 3, 8])
def test_reported_deviation_is_the_true_one(method, n):
    p = ellipse_to_arcs((5, -3), 25, 10, 0.4, arcs_per_quadrant=n, method=method)
    dense = _dense_ellipse((5, -3), 25, 10, 0.4)
    # independent: nearest-sample distances (scipy k-d tree) between very dense samples
    # of both curves; with spacing s the excess is only ~s²/(8d)
    fine = _dense_ellipse((5, -3), 25, 10, 0.4, n=1_000_001)
    arcs = _arc_samples(p, 4000)
    ref = max(cKDTree(fine).query(arcs)[0].max(), cKDTree(arcs).query(fine)[0].max())
    assert p.deviation_mm == pytest.approx(ref, rel=0.01, abs=2e-5)
    assert hausdorff(p, Path.polyline(dense)) == pytest.approx(p.deviation_mm, rel=0.01, abs=2e-5)


def test_arcs_join_end_to_end_and_run_ccw():
    p = ellipse_to_arcs((0, 0), 30, 10, arcs_per_quadrant=4)
    assert np.all(p.sweeps > 0)
    r = p.radii_mm()
    end_r = np.hypot(*(p.vertices[1:] - p.centres).T)
    np.testing.assert_allclose(end_r, r, rtol=1e-9)
    assert p.signed_area_mm2() == pytest.approx(math.pi * 30 * 10, rel=3e-3)


def test_midpoint_beats_seed_at_equal_count():
    a = ellipse_to_arcs((0, 0), 20, 10, arcs_per_quadrant=6, method="midpoint").deviation_mm
    b = ellipse_to_arcs((0, 0), 20, 10, arcs_per_quadrant=6, method="seed").deviation_mm
    assert a < b


@given(st.floats(1, 50), st.floats(1, 50), st.floats(-3, 3), st.floats(-6, 6), st.floats(-6.2, 6.2),
       st.sampled_from([0.1, 0.01, 0.001]))
@settings(max_examples=40, deadline=None)
def test_partial_arcs_meet_tolerance(rx, ry, rot, t0, dt, tol):
    if abs(dt) < 1e-3:
        dt = 1.0
    c, s = math.cos(rot), math.sin(rot)
    jac = np.array([[c, -s], [s, c]]) @ np.diag([rx, ry])
    p = ellipse_arc_to_arcs((1, 2), jac, t0, dt, tol_mm=tol)
    dense = _dense_ellipse((1, 2), rx, ry, rot, t0, dt, 20_001)
    np.testing.assert_allclose(p.start, dense[0], atol=1e-9)
    np.testing.assert_allclose(p.end, dense[-1], atol=1e-9)
    assert p.deviation_mm <= tol
    assert hausdorff(p, Path.polyline(dense)) <= tol * 1.01 + 1e-5


def test_errors():
    with pytest.raises(GeometryError, match="radii must be > 0"):
        ellipse_to_arcs((0, 0), 0, 1)
    with pytest.raises(GeometryError, match="arcs_per_quadrant must be >= 1"):
        ellipse_to_arcs((0, 0), 2, 1, arcs_per_quadrant=0)
    with pytest.raises(GeometryError, match="method must be"):
        ellipse_to_arcs((0, 0), 2, 1, method="eberly")
    with pytest.raises(GeometryError, match="tol_mm must be > 0"):
        ellipse_to_arcs((0, 0), 2, 1, tol_mm=-1)
    with pytest.raises(GeometryError, match="within ±2π"):
        ellipse_arc_to_arcs((0, 0), np.eye(2), 0, 7)
    with pytest.raises(GeometryError, match="degenerate"):
        ellipse_arc_to_arcs((0, 0), np.array([[1, 1], [1, 1.0]]), 0, 1)
