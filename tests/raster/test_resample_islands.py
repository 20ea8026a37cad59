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


@pytest.mark.parametrize("method", ["bicubic", "nearest"])
def test_one_pixel_per_beam_gives_the_pixels_back_as_scikit_image_does(method):
    from skimage.transform import resize

    rng = np.random.default_rng(11)
    gray = rng.integers(0, 256, (37, 53)).astype(np.float64)
    mask = gray > 128
    for img in (gray, mask):
        r = resample_to_beam(img, beam_mm=0.1, pixel_mm=0.1, method=method)
        ref = resize(img.astype(np.float64) * (255.0 if img.dtype == bool else 1.0), img.shape,
                     order=3 if method == "bicubic" else 0, mode="edge", preserve_range=True)
        if img.dtype == bool:
            assert r.image.dtype == bool and np.array_equal(r.image, ref >= 128)
        else:
            assert np.allclose(r.image, ref, atol=1e-9)
        assert r.shape == img.shape and np.allclose(r.error_mm, 0.0)


def test_zigzag_at_one_pixel_per_beam_neither_imports_scikit_image_nor_compiles_edge_kernels(tmp_path):
    import subprocess
    import sys
    from pathlib import Path

    from PIL import Image

    root = Path(__file__).resolve().parents[2]
    img = np.full((40, 60), 255, np.uint8)
    img[10:30, 5:50] = 0
    Image.fromarray(img).save(tmp_path / "a.png", dpi=(254, 254))
    code = ("import sys\nfrom labkit.cli import main\n"
            f"status = main(['img2gcode', {str(tmp_path / 'a.png')!r}, '-o', "
            f"{str(tmp_path / 'a.gcode')!r}, '--beam', '0.1', '--preview', 'none'])\n"
            "from labkit.raster import _edge_kernels as k\n"
            "print(status, 'skimage' in sys.modules, [f.__name__ for f in (k.magnitude3x3,"
            " k.magnitude2x2) if f.dispatcher is not None])")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=root,
                         env={**__import__("os").environ, "PYTHONPATH": str(root)}, timeout=300)
    assert out.stdout.strip().splitlines()[-1] == "0 False []", out.stdout + out.stderr


@pytest.mark.parametrize("shape, out", [((45, 50), (158, 176)), ((100, 80), (33, 61)), ((30, 40), (30, 97)),
                                        ((64, 64), (17, 200)), ((1, 9), (3, 20))])
def test_bicubic_is_scikit_images_resize_value_for_value(shape, out):
    """The bicubic resampling calls scipy as scikit-image's ``resize`` does (without importing
    scikit-image): up, down and mixed, the same float64 values."""
    from skimage.transform import resize

    from labkit.raster.resample import _cubic

    gray = np.random.default_rng(sum(shape)).uniform(0, 255, shape)
    shrinking = out[0] < shape[0] or out[1] < shape[1]
    expected = resize(gray, out, order=3, mode="edge", anti_aliasing=shrinking, preserve_range=True)
    np.testing.assert_array_equal(_cubic(gray, *out), expected)


def test_a_gray_job_does_not_import_scikit_image():
    code = ("import sys, numpy as np; from labkit.raster.engrave import image_to_job; "
            "image_to_job(np.arange(64, dtype=np.uint8).reshape(8, 8) * 4, mode='gray', beam_mm=0.1, width_mm=2.0); "
            "print(sorted({m.split('.')[0] for m in sys.modules} & {'skimage', 'scipy'}))")
    import os
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=root, timeout=300,
                         env={**os.environ, "PYTHONPATH": str(root)})
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["['scipy']"]
