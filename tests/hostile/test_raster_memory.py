"""Big raster jobs (issue 11): a few bytes per pixel at one pixel per beam, and a job whose
working memory would exceed the raster_bytes budget is refused by name before the work."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from labkit.budget import BUDGETS
from labkit.errors import BudgetError
from labkit.raster import engrave, image_to_job

SIDE = 6000          # 36 Mpx: 74 bytes a pixel (the old peak) would be 2.7 GB


@pytest.fixture(scope="module")
def big_png(tmp_path_factory):
    """A 6000 × 6000 px page at 254 dpi (one pixel per 0.1 mm beam): a disc and stripes."""
    yy, xx = np.mgrid[:SIDE, :SIDE]
    dark = ((xx - SIDE / 2) ** 2 + (yy - SIDE / 2) ** 2 < (SIDE / 3) ** 2) | ((xx // 400) % 3 == 0)
    path = tmp_path_factory.mktemp("big") / "page.png"
    Image.fromarray(np.where(dark, 0, 255).astype(np.uint8)).save(path, dpi=(254, 254))
    return path


def test_a_36_megapixel_zigzag_job_stays_within_a_few_bytes_a_pixel(big_png, tmp_path, run_labkit):
    # 36 Mpx at 8 bytes a pixel is 288 MB: the ceiling (above the interpreter's base) is
    # 300 MB, far below what float64 gray alone (8 B/px) plus any full-size copy needs.
    out = tmp_path / "page.gcode"
    r = run_labkit(["img2gcode", big_png, "-o", out, "--beam", "0.1", "--mode", "zigzag",
                    "--preview", "none", "--force"], time_s=300, memory_mb=300)
    assert r.code == 0, r.stderr
    dark = int((np.asarray(Image.open(big_png)) < 128).sum())
    marked = next(line for line in r.stdout.splitlines() if line.startswith("marked pixels"))
    assert int(marked.split()[-1]) == dark and out.read_text().count("G1") > 1000


def test_a_job_beyond_the_memory_budget_is_refused_by_name(big_png, tmp_path, run_labkit):
    # gray mode resamples and holds float64 per pixel: 36 Mpx × 88 B > 2 GB (scale 0.5).
    r = run_labkit(["img2gcode", big_png, "-o", tmp_path / "g.gcode", "--beam", "0.1",
                    "--mode", "gray", "--preview", "none", "--force"], time_s=120, memory_mb=400,
                   env={"LABKIT_BUDGET_SCALE": "0.5"})
    assert r.code == 1 and not (tmp_path / "g.gcode").exists()
    assert "raster bytes (budget 2,000,000,000) from a 6,000 × 6,000 px image engraved as " \
           "6,000 × 6,000 beam pixels (gray)" in r.stderr
    assert "reduce the size (width, height, dpi) or raise the beam diameter" in r.stderr


def test_the_estimate_is_checked_before_any_pixel_work(monkeypatch):
    monkeypatch.setattr(engrave, "to_gray", lambda *a, **k: pytest.fail("worked before checking"))
    monkeypatch.delenv("LABKIT_BUDGET_SCALE", raising=False)
    img = np.zeros((2000, 3000), np.uint8)
    need = engrave.working_bytes(img.shape, img.shape, "gray")
    monkeypatch.setitem(BUDGETS, "raster_bytes", 0.99 * need)
    with pytest.raises(BudgetError, match=r"raster bytes .* 3,000 × 2,000 px image"):
        image_to_job(img, mode="gray", beam_mm=0.1, pixel_mm=0.1)
    monkeypatch.setitem(BUDGETS, "raster_bytes", 1.01 * need)
    monkeypatch.setattr(engrave, "to_gray", lambda *a, **k: "reached")
    with pytest.raises(Exception) as caught:
        image_to_job(img, mode="gray", beam_mm=0.1, pixel_mm=0.1)
    assert not isinstance(caught.value, BudgetError)      # past the check: the work began


def test_image_size_is_checked_by_the_pixels_budget_before_decoding(tmp_path, monkeypatch):
    import warnings

    from PIL import Image as PILImage

    from labkit.raster import read_image

    path = tmp_path / "page.png"
    PILImage.fromarray(np.full((100, 120), 200, np.uint8)).save(path)
    monkeypatch.delenv("LABKIT_BUDGET_SCALE", raising=False)
    monkeypatch.setattr(PILImage, "MAX_IMAGE_PIXELS", 1000)   # Pillow would refuse 12,000 px
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert read_image(path).pixels.shape == (100, 120)
    assert PILImage.MAX_IMAGE_PIXELS == 1000                   # Pillow's setting restored
    monkeypatch.setitem(BUDGETS, "pixels", 11_999)
    with pytest.raises(BudgetError, match=r"12,000 pixels .* reading the 120 × 100 px image"):
        read_image(path)


#: Peak resident memory per move of a gray job above the same command on a tiny image.
#: Measured 163-166 B on the 500 × 450 photo with its preview (156-158 B without): Moves
#: 123 B allocated, the G-code text, one block of the emitter's integer copies and output
#: buffer, the summary's block temporaries and scikit-image's resampling (both commands load
#: numba, and scipy with it: ~225 MB for the tiny image; LABKIT_JIT=compiled makes the tiny
#: one load them too, since the size rule runs it as Python). Before issue 29's previews it was 239-243 B (matplotlib's import and
#: 2.8-megapixel burn image, the emitter's full-length copies), before issue 27 about 425 B.
GRAY_BYTES_PER_MOVE = 200

_PEAK_RSS = ("import resource, subprocess, sys; r = subprocess.run(sys.argv[1:], capture_output=True); "
             "sys.exit(r.stderr.decode()) if r.returncode else "
             "print(r.stdout.decode(), resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)")


def _peak_rss_mb(args, tmp_path):
    """(stdout, peak resident MB) of ``labkit ARGS`` in a fresh process."""
    import os
    import subprocess
    import sys

    from tests.hostile.conftest import ROOT

    # both runs load the compiled kernels (and numba, scipy with them) as the photo's job
    # does by the size rule: the difference is the job's own memory, not an import
    env = dict(os.environ, PYTHONPATH=str(ROOT), LABKIT_JIT="compiled")
    done = subprocess.run([sys.executable, "-c", _PEAK_RSS, sys.executable, "-m", "labkit", *map(str, args)],
                          capture_output=True, text=True, env=env, cwd=tmp_path, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    out, rss_kb = done.stdout.rsplit(None, 1)
    return out, int(rss_kb) / 1024.0


def test_a_photo_in_gray_mode_costs_a_few_hundred_bytes_a_move(tmp_path):
    """The issue's photo (500 × 450 px at 72 dpi: 1764 × 1587 beam pixels, 2.26 M moves),
    with the default preview, against the same command on an 8 × 8 px image."""
    from tests.hostile.conftest import ROOT

    photo = ROOT / "data" / "images" / "photo_500x450_72dpi.jpg"
    tiny = tmp_path / "tiny.png"
    Image.fromarray(np.arange(64, dtype=np.uint8).reshape(8, 8) * 4).save(tiny, dpi=(254, 254))
    _, base_mb = _peak_rss_mb(["img2gcode", tiny, "-o", tmp_path / "t.gcode", "--mode", "gray"], tmp_path)
    out, photo_mb = _peak_rss_mb(["img2gcode", photo, "-o", tmp_path / "p.gcode", "--mode", "gray"], tmp_path)
    moves = int(next(line for line in out.splitlines() if line.startswith("moves / rapids")).split()[-3])
    assert moves > 2_000_000
    assert (photo_mb - base_mb) * 2**20 / moves <= GRAY_BYTES_PER_MOVE, (base_mb, photo_mb, moves)
