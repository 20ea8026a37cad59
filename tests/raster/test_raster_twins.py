"""The raster kernels' Python forms (what a command runs until numba would pay for itself) give
the compiled results bit for bit: the numpy scan of gray and dithered jobs and the list-based
error diffusion, on random images made here with every corner the kernels have (white gaps
exactly as long as the skip, zero-length rapids, one-pixel rows, tiny pixels), and the
estimate of a dithered job's moves that lets the first kernel decide for the whole job."""

from __future__ import annotations

import numpy as np
import pytest

from labkit import _jit
from labkit.raster import _diffuse, _scanlines
from labkit.raster.diffusion import DIFFUSION
from labkit.raster.engrave import _move_columns, dithered_moves_estimate


def _scan(power, args, how, shared):
    """Count, then fill (as gray_job does), with start and end one array of points (shared)
    or two arrays of their own; returns the rows."""
    with _jit.forced(how):
        n = _scanlines.scan_moves(power, *args, False, *_move_columns(0))
        if shared:
            columns = _move_columns(n)
        else:
            columns = (np.zeros(n, np.int8), np.full((n, 3), 7.0), np.full((n, 3), 9.0), np.zeros(n, np.float32))
        assert _scanlines.scan_moves(power, *args, True, *columns) == n
    return columns


def _power(rng, trial):
    rows, cols = int(rng.integers(1, 30)), int(rng.integers(1, 60))
    kind = trial % 4
    if kind == 0:                        # few levels, many equal runs
        p = rng.integers(0, 4, (rows, cols)) * rng.integers(0, 2, (rows, cols))
    elif kind == 1:                      # a dithered job: full power or nothing
        p = (rng.random((rows, cols)) < 0.3) * 1000
    elif kind == 2:                      # a photograph: a new S every pixel, white gaps
        p = rng.integers(0, 1001, (rows, cols))
        p[rng.random((rows, cols)) < 0.4] = 0
    else:                                # one row burns
        p = np.zeros((rows, cols), np.int64)
        p[rng.integers(0, rows)] = 5
    return p.astype(np.int64)


@pytest.mark.parametrize("seed", range(4))
def test_the_numpy_scan_writes_the_kernels_rows(seed):
    rng = np.random.default_rng(seed)
    no_rapid = 0
    for trial in range(150):
        power = _power(rng, trial)
        pixel = float(rng.choice([0.1, 0.2, 0.25, 1.0, 0.05, 1e-10]))
        overscan = float(rng.choice([0.0, 0.0, 1.0, 2.5, 0.3]))
        # a skip of exactly two overscans: a gap that long joins the overscans end to end
        skip = max(float(rng.choice([0.0, 1.0, 2.0, 5.0, 7.3, 2 * overscan])), 2 * overscan)
        args = (bool(rng.integers(0, 2)), skip, overscan, pixel)
        for shared in (True, False):
            a = _scan(power, args, "python", shared)
            b = _scan(power, args, "compiled", shared)
            for x, y in zip(a, b):
                np.testing.assert_array_equal(x, y, err_msg=f"{trial} {args} {shared}")
        no_rapid += int((a[0] == 0).sum() < _spans(power, skip))   # a span began where the last ended
    assert no_rapid > 5


def _spans(power, skip_px):
    """Burn spans of every row: runs of S > 0 joined across white gaps shorter than the skip."""
    spans = 0
    for row in power.tolist():
        stop = None
        for c, s in enumerate(row):
            if s and (c == 0 or not row[c - 1]):
                spans += stop is None or c - stop >= skip_px
            if s and (c + 1 == len(row) or not row[c + 1]):
                stop = c + 1
    return spans


def test_the_numpy_scan_in_bands_gives_the_rows_of_one_band(monkeypatch):
    rng = np.random.default_rng(9)
    power = rng.integers(0, 1001, (40, 50))
    power[rng.random((40, 50)) < 0.5] = 0
    args = (True, 30.0, 10.0, 0.1)
    whole = _scan(power, args, "python", True)
    monkeypatch.setattr(_scanlines, "SCAN_BAND_PIXELS", 120)        # two rows a band
    banded = _scan(power, args, "python", True)
    for x, y in zip(whole, banded):
        np.testing.assert_array_equal(x, y)


@pytest.mark.parametrize("method", sorted(DIFFUSION))
def test_the_python_diffusion_makes_the_kernels_dots(method):
    rng = np.random.default_rng(len(method))
    table = np.array(DIFFUSION[method])
    for trial in range(40):
        gray = rng.uniform(0, 255, (int(rng.integers(1, 25)), int(rng.integers(1, 40))))
        if trial % 3 == 0:
            gray = np.round(gray)
        if trial % 5 == 0:
            gray = 255.0 * (rng.random(gray.shape) < 0.5)
        args = (float(rng.choice([128.0, 100.0, 0.0, 256.0])), table[:, 0].astype(np.int64),
                table[:, 1].astype(np.int64), table[:, 2].copy(), bool(trial % 2))
        left = {}
        dots = {}
        for how in ("python", "compiled", "py_func"):
            work = gray.copy()
            if how == "py_func":                         # the kernel's own code as Python
                dots[how] = _diffuse.diffuse.py_func(work, *args)
            else:
                with _jit.forced(how):
                    dots[how] = _diffuse.diffuse(work, *args)
            left[how] = work
        for how in ("compiled", "py_func"):
            np.testing.assert_array_equal(dots["python"], dots[how])
            np.testing.assert_array_equal(left["python"], left[how])      # the same error carried


def test_the_estimate_of_a_dithered_jobs_moves():
    """Before dithering, the moves the dots will make: within 0.6-1.25 of what is made on the
    photograph of data/images (at a 0.3 mm beam, its file's 72 dpi) and its drawings (one
    pixel per beam)."""
    from pathlib import Path

    from labkit.raster import image_to_job, read_image
    from labkit.raster.color import to_gray
    from labkit.raster.resample import resample_to_beam

    folder = Path(__file__).resolve().parents[2] / "data" / "images"
    checked = 0
    for name, beam, dpi in (("photo_500x450_72dpi.jpg", 0.3, 72), ("gray_card.png", 0.1, 254),
                            ("waves.png", 0.1, 254), ("heart.png", 0.1, 254)):
        img = read_image(folder / name)
        job = image_to_job(img, mode="dither", beam_mm=beam, dpi=dpi)
        gray = resample_to_beam(to_gray(img.pixels), beam_mm=beam, dpi=dpi, pixel_aspect=img.pixel_aspect).image
        ratio = len(job.moves) / dithered_moves_estimate(gray)
        assert 0.6 <= ratio <= 1.25, (name, ratio)
        checked += 1
    assert checked == 4
    assert dithered_moves_estimate(np.full((4, 6), 255.0)) == 0             # white: nothing
    assert dithered_moves_estimate(np.full((4, 6), 127.5)) == 24            # half gray: a move a pixel
