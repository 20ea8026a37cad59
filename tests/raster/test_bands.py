"""The zig-zag and spiral modes at one pixel per beam threshold the image band by band:
the same mask, and so the same job, as thresholding the whole gray image at once."""

import numpy as np
import pytest

from labkit.raster import engrave, image_to_job, invert, mask_job, threshold, to_gray


def _image(kind, rng):
    if kind == "L":
        return rng.integers(0, 256, (53, 37), dtype=np.uint8)
    if kind == "RGB":
        return rng.integers(0, 256, (53, 37, 3), dtype=np.uint8)
    if kind == "RGBA":
        return rng.integers(0, 256, (53, 37, 4), dtype=np.uint8)
    return rng.integers(0, 65536, (53, 37), dtype=np.uint16)


@pytest.mark.parametrize("kind", ["L", "RGB", "RGBA", "I;16"])
@pytest.mark.parametrize("inverted", [False, True])
@pytest.mark.parametrize("mode", ["zigzag", "spiral"])
def test_banded_threshold_gives_the_whole_image_job(kind, inverted, mode, monkeypatch):
    rng = np.random.default_rng(5)
    img = _image(kind, rng)
    monkeypatch.setattr(engrave, "BAND_PIXELS", 100)      # bands of 2 rows
    job = image_to_job(img, mode=mode, beam_mm=0.2, pixel_mm=0.2, invert=inverted, level=100)
    gray = to_gray(img)
    mask = threshold(invert(gray) if inverted else gray, 100)
    if kind == "RGBA":
        mask &= img[:, :, 3] != 0          # fully transparent: nothing here, even inverted
    ref = mask_job(mask, pixel_mm=0.2, mode=mode)
    assert job.report.shape == mask.shape
    for name in ref.moves.column_names():
        a, b = getattr(job.moves, name), getattr(ref.moves, name)
        assert np.array_equal(a, b, equal_nan=a.dtype.kind == "f"), name


def test_bands_are_used_only_at_one_pixel_per_beam(monkeypatch):
    calls = []
    real = engrave._mask_in_bands
    monkeypatch.setattr(engrave, "_mask_in_bands", lambda *a: calls.append(1) or real(*a))
    img = np.random.default_rng(1).integers(0, 256, (20, 30), dtype=np.uint8)
    image_to_job(img, mode="zigzag", beam_mm=0.2, pixel_mm=0.2)
    assert calls == [1]
    image_to_job(img, mode="zigzag", beam_mm=0.4, pixel_mm=0.2)     # resampled: whole image
    image_to_job(img, mode="zigzag", beam_mm=0.2, pixel_mm=0.2, blur=True)   # a 3×3 filter
    assert calls == [1]


@pytest.mark.parametrize("level", [0, 1, 127.5, 128, 200.25, 255, 256])
@pytest.mark.parametrize("inverted", [False, True])
def test_eight_bit_gray_is_thresholded_as_labkit_gray(level, inverted):
    """8-bit gray (a PNG's L mode) is compared as it is, without a float copy of the image:
    the mask of to_gray's 0…255 floats at every level, fractional ones too."""
    img = np.arange(256, dtype=np.uint8).reshape(16, 16)
    gray = to_gray(img)
    expected = threshold(invert(gray) if inverted else gray, level)
    np.testing.assert_array_equal(engrave._mask_in_bands(img, "seed", inverted, level), expected)
