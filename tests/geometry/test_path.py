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


def _bounds_arc_by_arc(p):
    """Path.bounds as it was: circle.arc_bounds of every arc, one at a time."""
    from labkit.geometry.circle import arc_bounds

    lo, hi = p.vertices.min(axis=0), p.vertices.max(axis=0)
    for i in np.flatnonzero(p.is_arc):
        box = arc_bounds(p.vertices[i], p.vertices[i + 1], p.centres[i], p.sweeps[i])
        lo, hi = np.minimum(lo, box[0]), np.maximum(hi, box[1])
    return np.array([lo, hi])


def _random_chains(count, seed=0):
    """Chains of 1-19 lines and arcs of every size and sweep (radii 1 um to 1 m), arc starts on
    the axes among them."""
    rng = np.random.default_rng(seed)
    paths = []
    for _ in range(count):
        n = int(rng.integers(1, 20))
        v = [rng.normal(0, 50, 2)]
        cs, ss = [], []
        for _ in range(n):
            s = v[-1]
            sweep = 0.0 if rng.random() < 0.2 else rng.uniform(-2 * np.pi + 1e-6, 2 * np.pi - 1e-6)
            if sweep == 0.0:
                v.append(s + rng.normal(0, 5, 2))
                cs.append([np.nan, np.nan])
            else:
                r = 10 ** rng.uniform(-3, 3)
                a0 = rng.integers(-4, 5) * np.pi / 2 if rng.random() < 0.3 else rng.uniform(-np.pi, np.pi)
                c = s - r * np.array([np.cos(a0), np.sin(a0)])
                rr = math.hypot(*(s - c))
                a = math.atan2(s[1] - c[1], s[0] - c[0]) + sweep
                v.append(c + rr * np.array([math.cos(a), math.sin(a)]))
                cs.append(c)
            ss.append(sweep)
        paths.append(Path(np.array(v), np.array(cs), np.array(ss)))
    return paths


def test_bounds_of_all_arcs_at_once_are_arc_bounds_numbers():
    """Path.bounds and bounds_each (every path at once) give circle.arc_bounds' boxes exactly, on
    random chains of arcs of every size and sweep, starts on the axes among them."""
    from labkit.geometry.path import bounds_each

    paths = _random_chains(400)
    ref = np.array([_bounds_arc_by_arc(p) for p in paths])
    np.testing.assert_array_equal(np.array([p.bounds() for p in paths]), ref)
    np.testing.assert_array_equal(bounds_each(paths), ref)
    assert bounds_each([]).shape == (0, 2, 2)


def test_samples_of_all_paths_at_once_are_each_paths_samples():
    """sample_each (every path in one pass) gives each Path.sample's points exactly; and,
    independently, every sample of an arc lies on its circle and every chord stays within the
    tolerance of the arc (sagitta r(1 - cos(phi/2)), the closed form)."""
    from labkit.geometry.path import sample_each

    paths = _random_chains(300, seed=1) + [Path.rectangle(0, 0, 2, 1), Path.circle((1, 1), 1e-3)]
    for tol in (0.1, 0.01, 1e-4):
        got = sample_each(paths, tol)
        assert len(got) == len(paths)
        for p, q in zip(paths, got):
            np.testing.assert_array_equal(q, p.sample(tol))
    p = Path.circle((3, 4), 5)
    q = sample_each([p], 0.01)[0]
    np.testing.assert_allclose(np.hypot(q[:, 0] - 3, q[:, 1] - 4), 5, rtol=1e-12)
    step = 2 * math.pi / (len(q) - 1)
    assert 5 * (1 - math.cos(step / 2)) <= 0.01
    assert sample_each([], 0.1) == []
    with pytest.raises(GeometryError, match="tol_mm must be > 0"):
        sample_each([p], 0)
