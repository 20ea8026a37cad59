"""Every image mode a file can hold burns what it shows: black burns, white and
transparent do not, at every bit depth (checked pixel by pixel with burn_map)."""

import numpy as np
import pytest
from PIL import Image

from labkit.errors import RasterError
from labkit.raster.coverage import burn_map
from labkit.raster.engrave import image_to_job
from labkit.raster.io import read_image

#: A 12 × 16 page, white, with a black 4 × 6 block (rows 3–6, columns 5–10).
SHAPE = (12, 16)
BLOCK = (slice(3, 7), slice(5, 11))


def intended():
    mask = np.zeros(SHAPE, bool)
    mask[BLOCK] = True
    return mask


def burned(path):
    img = read_image(path)
    job = image_to_job(img.pixels, mode="zigzag", beam_mm=0.1, pixel_mm=0.1, resample="nearest")
    count, _ = burn_map(job.moves, SHAPE, 0.1)
    return count


def page(mode, white, black):
    im = Image.new(mode, SHAPE[::-1], white)
    px = im.load()
    for r in range(3, 7):
        for c in range(5, 11):
            px[c, r] = black
    return im


@pytest.mark.parametrize("mode,white,black", [
    ("1", 1, 0),                         # Pillow's 1-bit True is white
    ("L", 255, 0),
    ("I;16", 65535, 0),
    ("I", 65535, 0),                     # 32-bit TIFF (and some Pillows' 16-bit PNGs)
    ("RGB", (255, 255, 255), (0, 0, 0)),
    ("LA", (255, 255), (0, 255)),
    ("RGBA", (255, 255, 255, 255), (0, 0, 0, 255)),
    ("CMYK", (0, 0, 0, 0), (0, 0, 0, 255)),
])
def test_each_mode_burns_exactly_the_black_block(tmp_path, mode, white, black):
    ext = {"CMYK": "jpg", "I": "tif"}.get(mode, "png")
    path = tmp_path / f"page_{mode.replace(';', '_')}.{ext}"
    im = page(mode, white, black)
    if mode == "CMYK":
        im.save(path, quality=100, subsampling=0)
    else:
        im.save(path)
    assert np.array_equal(burned(path) > 0, intended())
    assert burned(path).max() == 1


def test_palette_and_transparent_pixels_do_not_burn(tmp_path):
    rgba = page("RGBA", (255, 255, 255, 255), (0, 0, 0, 255))
    px = rgba.load()
    for c in range(0, 16):
        px[c, 0] = (0, 0, 0, 0)          # black but fully transparent: not drawn, not burned
    rgba.save(tmp_path / "t.png")
    assert np.array_equal(burned(tmp_path / "t.png") > 0, intended())
    pal = page("RGB", (255, 255, 255), (0, 0, 0)).convert("P")
    pal.save(tmp_path / "p.png")
    assert np.array_equal(burned(tmp_path / "p.png") > 0, intended())


def test_sixteen_bit_gradient_keeps_its_levels(tmp_path):
    # A 16-bit ramp 0…65535 across 256 columns: after the threshold at 128 exactly the
    # darker half burns (an 8-bit clip at 255 would burn only the first three columns).
    ramp = np.tile(np.linspace(0, 65535, 256).astype(np.uint16), (4, 1))
    Image.frombytes("I;16", (256, 4), ramp.astype("<u2").tobytes()).save(tmp_path / "ramp.png")
    img = read_image(tmp_path / "ramp.png")
    assert img.pixels.dtype == np.uint16 and img.pixels.max() == 65535
    job = image_to_job(img.pixels, mode="zigzag", beam_mm=0.1, pixel_mm=0.1, resample="nearest")
    count, _ = burn_map(job.moves, ramp.shape, 0.1)
    gray8 = ramp.astype(float) * 255 / 65535
    assert np.array_equal(count > 0, gray8 < 128)
    assert (count > 0).sum(axis=1).tolist() == [128] * 4


def test_truncated_and_foreign_files_are_named(tmp_path):
    page("L", 255, 0).save(tmp_path / "ok.png")
    data = (tmp_path / "ok.png").read_bytes()
    (tmp_path / "cut.png").write_bytes(data[: len(data) // 2])
    with pytest.raises(RasterError, match=r"cut.png: the image data cannot be decoded"):
        read_image(tmp_path / "cut.png")
    (tmp_path / "notes.png").write_text("G1 X1\n")
    with pytest.raises(RasterError, match="notes.png: not an image file"):
        read_image(tmp_path / "notes.png")
