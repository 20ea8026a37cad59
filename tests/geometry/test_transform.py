"""Affine transforms against svgelements' Matrix and the SVD ellipse image against dense samples."""

import math

import numpy as np
import pytest
import svgelements as se
from hypothesis import given, settings
from hypothesis import strategies as st

from labkit.errors import GeometryError
from labkit.geometry import transform as tf

angles = st.floats(-3.0, 3.0)
scales = st.floats(0.2, 5.0)


def _se(m: se.Matrix) -> np.ndarray:
    return tf.matrix(m.a, m.b, m.c, m.d, m.e, m.f)


def test_compose_matches_svg_nesting():
    # <g transform="translate(10 5) rotate(30)"><g transform="scale(2 0.5) skewX(20)">…
    ours = tf.compose(tf.translate(10, 5), tf.rotate(math.radians(30)), tf.scale(2, 0.5),
                      tf.skew(math.radians(20)))
    theirs = se.Matrix("translate(10 5) rotate(30) scale(2 0.5) skewX(20)")
    pts = np.array([[0, 0], [1, 2], [-3, 4.5]])
    want = np.array([theirs.point_in_matrix_space(p) for p in pts], dtype=float)
    np.testing.assert_allclose(tf.apply(ours, pts), want, atol=1e-12)
    np.testing.assert_allclose(ours, _se(theirs), atol=1e-12)


def test_rotate_about_point_and_skew_y():
    m = tf.rotate(math.pi, about=(1, 1))
    np.testing.assert_allclose(tf.apply(m, [[0, 0]]), [[2, 2]], atol=1e-12)
    theirs = se.Matrix("skewY(15)")
    np.testing.assert_allclose(tf.skew(0, math.radians(15)), _se(theirs), atol=1e-12)


@given(angles, scales, scales, angles, st.booleans())
@settings(max_examples=60, deadline=None)
def test_ellipse_image_reproduces_the_mapped_ellipse(rot, rx, ry, skew_a, mirror):
    a = tf.compose(tf.skew(skew_a * 0.4), tf.scale(-1.3 if mirror else 1.3, 0.7), tf.rotate(rot))[:2, :2]
    jac = a @ np.array([[math.cos(0.3), -math.sin(0.3)], [math.sin(0.3), math.cos(0.3)]]) @ np.diag([rx, ry])
    R, r, phi, sgn, shift = tf.ellipse_image(jac)
    assert R >= r > 0
    t = np.linspace(0, 2 * np.pi, 97)
    exact = (jac @ np.stack([np.cos(t), np.sin(t)])).T
    u = sgn * t + shift
    c, s = math.cos(phi), math.sin(phi)
    std = np.stack([R * np.cos(u), r * np.sin(u)], axis=1) @ np.array([[c, s], [-s, c]])
    np.testing.assert_allclose(std, exact, atol=1e-9 * max(R, 1))


def test_similarity_detection():
    assert tf.is_similarity(tf.compose(tf.rotate(1.0), tf.scale(3), tf.translate(4, 5)))
    assert tf.similarity_scale(tf.scale(-2, 2)) == pytest.approx(2.0)
    assert not tf.is_similarity(tf.scale(2, 1))
    assert not tf.is_similarity(tf.skew(0.1))


def test_bad_matrix_is_refused():
    with pytest.raises(GeometryError, match="3x3"):
        tf.apply(np.eye(4), [[0, 0]])
    with pytest.raises(GeometryError, match="finite"):
        tf.apply(np.full((3, 3), np.nan), [[0, 0]])
