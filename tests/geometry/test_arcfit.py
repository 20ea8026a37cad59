"""Curve → arcs: tolerance against dense svgelements samples, and far fewer blocks than lines."""

import numpy as np
import pytest
import svgelements as se
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from labkit.errors import GeometryError
from labkit.geometry import Path, cubics_to_arcs, fit_arcs, flatten_cubic, hausdorff

coord = st.floats(-60, 60)
cubics = st.lists(st.tuples(coord, coord), min_size=4, max_size=4).map(np.array)


def _dense(ctrl, n=20001):
    c = se.CubicBezier(*[complex(*p) for p in ctrl])
    return np.array([[p.x, p.y] for p in (c.point(t) for t in np.linspace(0, 1, n))])


@given(cubics, st.sampled_from([0.1, 0.01]))
@settings(max_examples=40, deadline=None)
def test_cubic_to_arcs_within_tolerance(ctrl, tol):
    assume(np.ptp(ctrl, axis=0).max() > 1e-3)
    p = cubics_to_arcs(ctrl[None], tol)
    np.testing.assert_allclose(p.start, ctrl[0])
    np.testing.assert_allclose(p.end, ctrl[-1])
    assert p.deviation_mm <= tol
    assert hausdorff(p, Path.polyline(_dense(ctrl))) <= tol + 1e-9


def test_arcs_use_far_fewer_blocks_than_lines():
    rng = np.random.default_rng(7)
    ratios = []
    for _ in range(20):
        ctrl = rng.uniform(0, 50, (4, 2))
        lines = len(flatten_cubic(ctrl, tol_mm=0.01)) - 1
        arcs = cubics_to_arcs(ctrl[None], 0.01).n_segments
        ratios.append(arcs / lines)
    assert np.median(ratios) < 0.3


def test_circle_samples_give_one_arc_per_half():
    t = np.linspace(0, 2 * np.pi, 721)
    pts = np.c_[3 + 7 * np.cos(t), -1 + 7 * np.sin(t)]
    pts[-1] = pts[0]
    p = fit_arcs(pts, 1e-4, closed=True)
    assert p.n_segments == 2 and p.is_arc.all()
    np.testing.assert_allclose(p.centres, [[3, -1], [3, -1]], atol=1e-6)
    np.testing.assert_allclose(p.radii_mm(), 7, atol=1e-6)


def test_sparse_polygon_keeps_straight_edges():
    square = np.array([[0, 0], [10, 0], [10, 10], [0, 10], [0, 0]], float)
    p = fit_arcs(square, 0.1, closed=True)
    assert not p.is_arc.any() and p.n_segments == 4


def test_lines_only_mode():
    t = np.linspace(0, np.pi, 400)
    p = fit_arcs(np.c_[np.cos(t), np.sin(t)] * 10, 0.01, arcs=False)
    assert not p.is_arc.any()
    assert hausdorff(p, Path.arc((0, 0), 10, 0, np.pi)) <= 0.0101


def test_errors():
    with pytest.raises(GeometryError, match="at least 2 points"):
        fit_arcs([[0, 0]], 0.1)
    with pytest.raises(GeometryError, match="tol_mm must be > 0"):
        fit_arcs([[0, 0], [1, 1]], 0)
    with pytest.raises(GeometryError, match="all points coincide"):
        fit_arcs([[1, 1], [1, 1]], 0.1)
    with pytest.raises(GeometryError, match="tol_mm must be > 0"):
        cubics_to_arcs(np.zeros((1, 4, 2)), -1)
