"""3×3 convolution against scipy.ndimage.convolve for every border mode."""

import numpy as np
import pytest
from scipy import ndimage as ndi
from skimage import data

from labkit.errors import RasterError
from labkit.raster import BLUR_KERNEL, BOX_KERNEL, SHARPEN_KERNEL, blur, convolve3x3, sharpen


@pytest.mark.parametrize("border", ["reflect", "nearest", "constant"])
def test_convolve_matches_scipy(border):
    rng = np.random.default_rng(4)
    img = rng.uniform(0, 255, (37, 23))
    kernel = rng.normal(size=(3, 3))  # not symmetric: checks the flip too
    ours = convolve3x3(img, kernel, border=border, cval=7.0)
    ref = ndi.convolve(img, kernel, mode=border, cval=7.0)
    assert np.allclose(ours, ref, atol=1e-9)


def test_kernels_sum_to_one_and_keep_flat_images():
    for k in (SHARPEN_KERNEL, BLUR_KERNEL, BOX_KERNEL):
        assert k.sum() == pytest.approx(1.0)
    flat = np.full((8, 9), 93.0)
    assert np.allclose(blur(flat), flat) and np.allclose(sharpen(flat), flat)


def test_blur_reduces_noise_and_sharpen_raises_it():
    cam = data.camera().astype(float)
    lap = lambda a: np.abs(ndi.laplace(a)).mean()  # noqa: E731
    assert lap(blur(cam)) < lap(cam) < lap(sharpen(cam, clip=False))


def test_sharpen_clip():
    step = np.array([[0.0, 0.0, 255.0, 255.0]])
    assert sharpen(step).min() >= 0 and sharpen(step).max() <= 255
    assert sharpen(step, clip=False).max() > 255


def test_errors():
    with pytest.raises(RasterError, match="shape \\(3, 3\\)"):
        convolve3x3(np.zeros((4, 4)), np.ones((5, 5)))
    with pytest.raises(RasterError, match="border must be one of"):
        convolve3x3(np.zeros((4, 4)), BOX_KERNEL, border="wrap")
    with pytest.raises(RasterError, match="kind must be one of"):
        blur(np.zeros((4, 4)), kind="median")
    with pytest.raises(RasterError, match="2-D array"):
        blur(np.zeros(4))
