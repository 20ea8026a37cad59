"""The Path model: lengths, bounds, areas, reversal and transforms against closed forms."""

import math

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from labkit.errors import GeometryError
from labkit.geometry import Path, hausdorff, paths_bounds, total_length, count_segments
from labkit.geometry import transform as tf


def test_circle_length_area_bounds():
    c = Path.circle((3, 4), 5)
    assert c.length_mm == pytest.approx(2 * math.pi * 5)
    assert c.signed_area_mm2() == pytest.approx(math.pi * 25)
    assert c.reversed().signed_area_mm2() == pytest.approx(-math.pi * 25)
    np.testing.assert_allclose(c.bounds(), [[-2, -1], [8, 9]])


def test_rounded_rectangle_area_matches_shapely():
    # a 20 x 10 rectangle with 3 mm corner arcs, built from lines and quarter arcs
    r = 3.0
    verts, cents, sweeps = [(r, 0)], [], []
    corners = [((20 - r, r), -math.pi / 2), ((20 - r, 10 - r), 0.0), ((r, 10 - r), math.pi / 2),
               ((r, r), math.pi)]
    for (cx, cy), a in corners:
        verts.append((cx + r * math.cos(a), cy + r * math.sin(a)))
        cents.append((np.nan, np.nan)); sweeps.append(0.0)
        verts.append((cx + r * math.cos(a + math.pi / 2), cy + r * math.sin(a + math.pi / 2)))
        cents.append((cx, cy)); sweeps.append(math.pi / 2)
    p = Path(verts, cents, sweeps, closed=True)
    want = shapely.box(0, 0, 20, 10).buffer(0).area - (4 - math.pi) * r * r
    assert p.signed_area_mm2() == pytest.approx(want)
    assert p.length_mm == pytest.approx(2 * (20 + 10) - 8 * r + 2 * math.pi * r)


def test_arc_bounds_include_axis_crossings():
    p = Path.arc((0, 0), 10, math.radians(80), math.radians(20))
    np.testing.assert_allclose(p.bounds()[1, 1], 10.0)


@given(st.floats(-3, 3), st.floats(0.5, 3), st.floats(-20, 20), st.floats(-20, 20), st.booleans())
@settings(max_examples=40, deadline=None)
def test_similarity_keeps_arcs(rot, s, dx, dy, mirror):
    m = tf.compose(tf.translate(dx, dy), tf.rotate(rot), tf.scale(-s if mirror else s, s))
    p = Path.arc((1, 2), 4, 0.3, 2.0)
    q = p.transformed(m)
    assert q.n_segments == 1 and q.is_arc.all()
    exact = Path.polyline(tf.apply(m, p.sample(1e-5)))
    assert hausdorff(q, exact) < 1e-4


@given(st.floats(-1.0, 1.0), st.floats(0.3, 3), st.floats(-3, 3))
@settings(max_examples=30, deadline=None)
def test_non_similarity_arc_becomes_ellipse_within_tol(skew_a, sx, rot):
    m = tf.compose(tf.rotate(rot), tf.scale(sx, 1.0), tf.skew(skew_a))
    p = Path.arc((5, 0), 10, -0.4, 4.0)
    q = p.transformed(m, tol_mm=0.01)
    exact = Path.polyline(tf.apply(m, p.sample(1e-5)))
    assert q.deviation_mm <= 0.01
    assert hausdorff(q, exact) <= 0.01 + 1e-6
    np.testing.assert_allclose(q.start, exact.start, atol=1e-9)
    np.testing.assert_allclose(q.end, exact.end, atol=1e-9)


def test_rolled_and_reversed_keep_length():
    p = Path.rectangle(0, 0, 4, 2)
    assert p.rolled(2).length_mm == pytest.approx(12)
    np.testing.assert_allclose(p.rolled(2).start, [4, 2])
    assert p.reversed().signed_area_mm2() == pytest.approx(-8)


def test_collections():
    ps = [Path.rectangle(0, 0, 1, 1), Path.circle((5, 5), 1)]
    assert total_length(ps) == pytest.approx(4 + 2 * math.pi)
    assert count_segments(ps) == (4, 2)
    np.testing.assert_allclose(paths_bounds(ps), [[0, 0], [6, 6]])


def test_bad_paths_raise():
    with pytest.raises(GeometryError, match="at least 2 vertices"):
        Path([(0, 0)])
    with pytest.raises(GeometryError, match="full turn"):
        Path([(1, 0), (1, 0)], [(0, 0)], [2 * math.pi])
    with pytest.raises(GeometryError, match="fill_rule"):
        Path([(0, 0), (1, 0)], fill_rule="odd")
    with pytest.raises(GeometryError, match="radius must be > 0"):
        Path.arc((0, 0), 0, 0, 1)
    with pytest.raises(GeometryError, match="only a closed path"):
        Path([(0, 0), (1, 0)]).rolled(1)
    with pytest.raises(GeometryError, match="tol_mm must be > 0"):
        Path.circle((0, 0), 1).sample(0)
