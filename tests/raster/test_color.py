"""Gray, threshold, invert and gamma against Pillow, scikit-image and hand values."""

import numpy as np
import pytest
from PIL import Image
from skimage import data, exposure
from skimage.color import rgb2gray

from labkit.errors import RasterError
from labkit.raster import (SEED_DEPTHS, adjust_gamma, depth_to_level, invert, threshold,
                           threshold_depths, to_gray)


def test_seed_weights_by_hand():
    px = np.array([[[10, 20, 30]]], dtype=np.uint8)
    assert to_gray(px)[0, 0] == pytest.approx(0.3 * 10 + 0.59 * 20 + 0.11 * 30)


def test_rec601_matches_pillow_L_conversion():
    rgb = data.astronaut()
    ours = to_gray(rgb, "rec601")
    pil = np.asarray(Image.fromarray(rgb).convert("L"), dtype=float)
    # Pillow rounds to integers with fixed-point weights: within one gray level.
    assert np.abs(ours - pil).max() <= 1.0
    assert np.abs(ours - pil).mean() < 0.6


def test_rec709_close_to_skimage_rgb2gray():
    rgb = data.coffee()
    ours = to_gray(rgb, "rec709")
    # skimage uses 0.2125/0.7154/0.0721 (four-decimal BT.709): agree to 0.1 level.
    assert np.abs(ours - rgb2gray(rgb) * 255).max() < 0.1


def test_alpha_composites_on_white():
    rgba = np.zeros((1, 2, 4), np.uint8)
    rgba[0, 1, 3] = 255  # opaque black; pixel 0 fully transparent
    assert to_gray(rgba).tolist() == [[255.0, 0.0]]


def test_bool_and_float_inputs():
    assert to_gray(np.array([[True, False]])).tolist() == [[255.0, 0.0]]
    assert to_gray(np.array([[0.5]])).tolist() == [[127.5]]
    assert to_gray(np.array([[65535]], np.uint16)).tolist() == [[255.0]]


@pytest.mark.parametrize("bad, match", [
    (np.zeros((2, 2, 5)), "1–4 channels"),
    (np.array([[2.0]]), "floats must lie in 0…1"),
    (np.zeros((2, 2), np.int16) - 1, "negative"),
])
def test_to_gray_rejects(bad, match):
    with pytest.raises(RasterError, match=match):
        to_gray(bad)


def test_to_gray_rejects_weights():
    with pytest.raises(RasterError, match="weights must be one of"):
        to_gray(np.zeros((2, 2)), "srgb")
    with pytest.raises(RasterError, match="summing to 1"):
        to_gray(np.zeros((2, 2, 3)), (1, 1, 1))


def test_threshold_is_strictly_darker_than_level():
    g = np.arange(256, dtype=float).reshape(16, 16)
    m = threshold(g, 100)
    assert m.sum() == 100 and m.dtype == bool
    with pytest.raises(RasterError, match="level must be in 0…256"):
        threshold(g, 300)


def test_seed_depths_and_levels():
    # seed 000 §3.4.1: 10 % ↔ 25, 90 % ↔ 230
    assert depth_to_level(10) == 25 and depth_to_level(90) == 230
    levels = [depth_to_level(p) for p in SEED_DEPTHS]
    assert levels == sorted(levels) and len(set(levels)) == 9
    g = to_gray(data.camera())
    masks = threshold_depths(g)
    counts = [int(masks[p].sum()) for p in SEED_DEPTHS]
    assert counts == sorted(counts)  # deeper burns more
    assert counts[4] == int((g < 128).sum())
    with pytest.raises(RasterError, match="percent must be in 0…100"):
        depth_to_level(120)


def test_invert_is_an_involution_and_matches_255_minus():
    cam = data.camera()
    assert np.array_equal(invert(cam), 255 - cam.astype(int))
    assert np.array_equal(invert(invert(cam)), cam)
    g = to_gray(cam)
    assert np.allclose(invert(g), 255 - g)
    with pytest.raises(RasterError, match="labkit gray in 0…255"):
        invert(np.array([[300.0]]))
    with pytest.raises(RasterError, match="bool, uint8 or float"):
        invert(np.array([[3]], dtype=np.int32))


def test_gamma_matches_skimage():
    g = to_gray(data.camera())
    for gamma in (0.5, 1.0, 2.2):
        ref = exposure.adjust_gamma(g / 255.0, gamma) * 255.0
        assert np.allclose(adjust_gamma(g, gamma), ref, atol=1e-9)
    with pytest.raises(RasterError, match="gamma must be"):
        adjust_gamma(g, 0)
