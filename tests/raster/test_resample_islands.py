"""Pixel density adjustment (closed forms, scikit-image) and 4-connected islands (scipy)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import ndimage as ndi
from skimage import data

from labkit.errors import RasterError
from labkit.raster import island_sizes, label_islands, physical_size_mm, resample_to_beam


def test_nearest_integer_upscale_is_kron():
    rng = np.random.default_rng(2)
    art = rng.random((12, 9)) < 0.5  # pixel art
    r = resample_to_beam(art, beam_mm=0.1, pixel_mm=0.3, method="nearest")
    assert np.array_equal(r.image, np.kron(art, np.ones((3, 3), bool)))
    assert r.error_mm == pytest.approx((0.0, 0.0), abs=1e-12)


@given(rows=st.integers(1, 60), cols=st.integers(1, 60),
       width=st.floats(0.5, 80.0), beam=st.floats(0.05, 0.5))
@settings(max_examples=60, deadline=None)
def test_size_error_is_at_most_half_a_beam(rows, cols, width, beam):
    r = resample_to_beam(np.zeros((rows, cols)), beam_mm=beam, width_mm=width, method="nearest")
    tw, th = physical_size_mm((rows, cols), width_mm=width)
    assert r.target_mm == pytest.approx((tw, th))
    for err, target in zip(r.error_mm, (tw, th)):
        assert abs(err) <= beam / 2 + 1e-9 or round(target / beam) == 0
    assert r.size_mm == pytest.approx((r.shape[1] * beam, r.shape[0] * beam))


def test_bicubic_mask_rethresholded_and_close_to_nearest():
    horse = ~data.horse()  # True = horse = burn
    r = resample_to_beam(horse, beam_mm=0.2, pixel_mm=0.1, method="bicubic")
    n = resample_to_beam(horse, beam_mm=0.2, pixel_mm=0.1, method="nearest")
    assert r.image.dtype == bool and r.shape == (164, 200)
    assert abs(r.image.mean() - horse.mean()) < 0.01
    assert (r.image != n.image).mean() < 0.03  # they differ only along the outline


def test_bicubic_gray_keeps_range_and_mean():
    cam = data.camera().astype(float)
    r = resample_to_beam(cam, beam_mm=0.15, width_mm=51.2)
    assert r.image.min() >= 0 and r.image.max() <= 255
    assert abs(r.image.mean() - cam.mean()) < 1.0


def test_resample_errors():
    img = np.zeros((4, 4))
    with pytest.raises(RasterError, match="exactly one of"):
        resample_to_beam(img, beam_mm=0.1)
    with pytest.raises(RasterError, match="exactly one of"):
        resample_to_beam(img, beam_mm=0.1, dpi=300, width_mm=5)
    with pytest.raises(RasterError, match="beam_mm must be"):
        resample_to_beam(img, beam_mm=0, dpi=300)
    with pytest.raises(RasterError, match="method must be one of"):
        resample_to_beam(img, beam_mm=0.1, dpi=300, method="lanczos")
    with pytest.raises(RasterError, match="dpi must be a finite number > 0"):
        physical_size_mm((4, 4), dpi=-3)


def test_islands_match_scipy_4_connectivity():
    rng = np.random.default_rng(3)
    for p in (0.3, 0.55, 0.7):
        m = rng.random((64, 80)) < p
        labels, n = label_islands(m)
        ref, n_ref = ndi.label(m)  # default structure: 4-connected
        assert n == n_ref
        # same partition: a one-to-one map between label sets
        pairs = np.unique(np.stack([labels[m], ref[m]]), axis=1)
        assert pairs.shape[1] == n
        assert island_sizes(labels, n).sum() == m.sum()


def test_diagonal_pixels_are_separate_islands():
    m = np.eye(4, dtype=bool)
    assert label_islands(m)[1] == 4
    with pytest.raises(RasterError, match="boolean array"):
        label_islands(np.eye(3))
