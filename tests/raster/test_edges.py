"""Edge detectors against scikit-image, against their own kernels, and on hand-made masks."""

import math

import numpy as np
import pytest
from skimage import data, filters

from labkit.errors import RasterError
from labkit.raster import (SKIMAGE_FACTOR, canny, detect_edges, edge_angle, gradients, max_magnitude,
                           prewitt, roberts, sobel, sxor)

IMAGES = {"camera": data.camera, "coins": data.coins, "text": data.text, "page": data.page}
OURS = {"roberts": roberts, "sobel": sobel, "prewitt": prewitt}
THEIRS = {"roberts": filters.roberts, "sobel": filters.sobel, "prewitt": filters.prewitt}


@pytest.mark.parametrize("name", sorted(IMAGES))
@pytest.mark.parametrize("op", sorted(OURS))
def test_magnitude_equals_skimage_up_to_its_scale(name, op):
    img = IMAGES[name]()
    ours = OURS[op](img) / SKIMAGE_FACTOR[op]
    theirs = THEIRS[op](img)
    assert ours.shape == theirs.shape
    assert np.abs(ours - theirs).max() < 1e-12  # every pixel, borders included


@pytest.mark.parametrize("border", ["nearest", "constant"])
@pytest.mark.parametrize("op", ["sobel", "prewitt"])
def test_other_borders_match_skimage_modes(op, border):
    img = data.coins()
    ours = OURS[op](img, border=border) / SKIMAGE_FACTOR[op]
    theirs = THEIRS[op](img, mode=border)
    assert np.abs(ours - theirs).max() < 1e-12


@pytest.mark.parametrize("op", sorted(OURS))
def test_fused_kernel_equals_separate_convolutions(op):
    img = data.camera()
    gx, gy = gradients(img, op)
    assert np.allclose(OURS[op](img), np.hypot(gx, gy), atol=1e-9)


@pytest.mark.parametrize("op", sorted(OURS))
def test_pseudo_is_exactly_l1_of_the_kernels(op):
    # seed 000: the pseudo-convolution gives |Gx| + |Gy| in one pass — equal to the kernel L1 sum.
    img = data.coins()
    gx, gy = gradients(img, op)
    assert np.array_equal(OURS[op](img, pseudo=True), np.abs(gx) + np.abs(gy))


@pytest.mark.parametrize("op", sorted(OURS))
def test_pseudo_differs_from_l2_within_root_two(op):
    # Where it is not equal: L2 ≤ L1 ≤ √2·L2, equal only where one component is zero.
    img = data.camera()
    l2, l1 = OURS[op](img), OURS[op](img, pseudo=True)
    assert np.all(l1 >= l2 - 1e-9) and np.all(l1 <= math.sqrt(2) * l2 + 1e-9)
    gx, gy = gradients(img, op)
    axis_aligned = (gx == 0) | (gy == 0)
    assert np.allclose(l1[axis_aligned], l2[axis_aligned])
    assert (l1[~axis_aligned] > l2[~axis_aligned]).all()


def test_roberts_on_black_and_white_gives_0_1_2():
    # seed 000 §2.5.3: on a BW image the (L1) Roberts values are 0, 1 (corner) and 2 (edge).
    m = np.zeros((6, 6)); m[2:5, 1:4] = 1
    vals = roberts(m, pseudo=True, border="nearest")
    assert set(np.unique(vals)) == {0.0, 1.0, 2.0}
    assert vals[4, 3] == 1.0  # the bottom-right corner sees one differing diagonal
    assert vals[2, 2] == 0.0 and vals[0, 0] == 0.0


def test_sxor_hand_made():
    m = np.array([[0, 0, 0, 0, 0],
                  [0, 1, 1, 0, 0],
                  [0, 1, 0, 0, 0],
                  [0, 0, 0, 0, 1]], dtype=bool)
    # rows: I(i) xor I(i+1); columns: I(:,j) xor I(:,j+1); outside = unmarked.
    expected = np.array([[0, 1, 1, 0, 0],
                         [1, 0, 1, 0, 0],
                         [1, 1, 0, 0, 1],
                         [0, 0, 0, 1, 1]], dtype=bool)
    assert np.array_equal(sxor(m), expected)
    expected_nearest = expected.copy(); expected_nearest[3, 4] = False
    assert np.array_equal(sxor(m, border="nearest"), expected_nearest)


def test_sxor_of_full_and_empty():
    assert not sxor(np.zeros((3, 4), bool)).any()
    assert not sxor(np.ones((3, 4), bool), border="nearest").any()
    full = sxor(np.ones((3, 4), bool))
    assert full[-1].all() and full[:, -1].all() and full.sum() == 6


def test_sxor_properties_random():
    rng = np.random.default_rng(1)
    for _ in range(20):
        m = rng.random((9, 11)) < 0.4
        e = sxor(m)
        # each edge pixel has a 4-neighbour below or right of different value
        below = np.vstack([m[1:], np.zeros((1, 11), bool)])
        right = np.hstack([m[:, 1:], np.zeros((9, 1), bool)])
        assert np.array_equal(e, (m != below) | (m != right))
        assert np.array_equal(sxor(~m, border="nearest"), sxor(m, border="nearest"))


def test_edge_angle_seed_formula():
    gx, gy = np.array([1.0, 0.0, -1.0]), np.array([1.0, 1.0, 0.0])
    assert np.allclose(edge_angle(gx, gy), np.arctan2(gy, gx) - 3 * np.pi / 4)
    assert edge_angle(0.0, 2.0, roberts_offset=False) == pytest.approx(np.pi / 2)


def test_detect_edges_threshold_and_blur():
    cam = data.camera()
    mag = sobel(cam)
    assert np.array_equal(detect_edges(cam, "sobel", threshold=300.0), mag >= 300.0)
    noisy = np.clip(cam + np.random.default_rng(0).normal(0, 25, cam.shape), 0, 255)
    t = 0.25 * max_magnitude("sobel")
    assert detect_edges(noisy, threshold=t, blur=True).sum() < detect_edges(noisy, threshold=t).sum()
    assert max_magnitude("prewitt") >= prewitt(cam).max()
    assert max_magnitude("roberts", pseudo=True) >= roberts(cam, pseudo=True).max()


def test_canny_and_sxor_through_detect_edges():
    horse = data.horse().astype(float) * 255
    e = detect_edges(horse, "canny", sigma=2.0)
    assert e.dtype == bool and 0 < e.sum() < horse.size // 20
    assert np.array_equal(detect_edges(horse, "sxor"), sxor(horse < 128))
    assert np.array_equal(canny(horse, sigma=2.0), e)


def test_edge_errors():
    with pytest.raises(RasterError, match="operator must be one of"):
        detect_edges(np.zeros((4, 4)), "laplace")
    with pytest.raises(RasterError, match="not a boolean mask"):
        sobel(np.zeros((4, 4), bool))
    with pytest.raises(RasterError, match="boolean array"):
        sxor(np.zeros((4, 4)))
    with pytest.raises(RasterError, match="border must be 'constant' or 'nearest'"):
        sxor(np.zeros((4, 4), bool), border="reflect")
    with pytest.raises(RasterError, match="threshold must be >= 0"):
        detect_edges(np.zeros((4, 4)), threshold=-1)
    with pytest.raises(RasterError, match="border must be one of"):
        roberts(np.zeros((4, 4)), border="wrap")
    with pytest.raises(RasterError, match="sigma must be > 0"):
        canny(np.zeros((4, 4)), sigma=0)
    with pytest.raises(RasterError, match="operator must be one of"):
        gradients(np.zeros((4, 4)), "canny")
