"""Image files as a viewer shows them (issue 27): EXIF orientation applied, transparency of
every kind never burned in any mode, non-square pixel density kept.

The samples are in data/images (made by Pillow, data/images/make_real_world.py). Each test
checks the file first carries what it claims (the EXIF tag, the tRNS key, the densities),
so a sample that lost it would fail here instead of passing vacuously."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image, ImageOps

from labkit.raster import burn_map, image_to_job, read_image, to_gray
from labkit.raster.color import blank_mask

IMAGES = Path(__file__).resolve().parents[2] / "data" / "images"
ORIENTATION = 0x0112


@pytest.fixture
def run_cli(capsys):
    """``labkit ARGS`` in this process: (exit code, stdout, stderr)."""
    from labkit.cli import main

    def run(argv):
        code = main(argv)
        captured = capsys.readouterr()
        return code, captured.out, captured.err

    return run


# ----------------------------------------------------------------------------- orientation

# EXIF orientation → how the stored pixels are turned for display, by hand: np.rot90 turns
# counter-clockwise, so 6 ("rotate 90° clockwise to view") is k = -1, 8 is k = 1, 3 is k = 2.
TURNS = {"phone_orientation_3.jpg": (3, 2), "phone_orientation_6.jpg": (6, -1),
         "phone_orientation_8.webp": (8, 1)}


@pytest.mark.parametrize("name", sorted(TURNS))
def test_exif_orientation_is_applied_as_a_viewer_shows_it(name):
    orientation, k = TURNS[name]
    with Image.open(IMAGES / name) as im:
        assert im.getexif()[ORIENTATION] == orientation          # the sample carries the tag
        stored = np.asarray(im.convert("RGB"))
        viewer = np.asarray(ImageOps.exif_transpose(im).convert("RGB"))
    assert stored.shape == (40, 60, 3)
    got = read_image(IMAGES / name).pixels
    assert np.array_equal(got, viewer)                           # Pillow's own transpose
    assert np.array_equal(got, np.rot90(stored, k))              # and the hand-turned array
    # A quarter turn makes the landscape card portrait.
    assert got.shape[:2] == ((60, 40) if k in (1, -1) else (40, 60))


def test_the_black_corner_lands_where_the_viewer_shows_it():
    """Hand-worked: the camera stored a black block at its top-left; turned clockwise (6)
    it is top-right, turned counter-clockwise (8) bottom-left, upside down (3) bottom-right."""
    def dark_corner(name):
        g = to_gray(read_image(IMAGES / name).pixels)
        rows, cols = g.shape
        corners = {"top-left": g[:8, :8], "top-right": g[:8, cols - 8:],
                   "bottom-left": g[rows - 8:, :8], "bottom-right": g[rows - 8:, cols - 8:]}
        return [k for k, v in corners.items() if v.mean() < 40]

    assert dark_corner("phone_orientation_6.jpg") == ["top-right"]
    assert dark_corner("phone_orientation_8.webp") == ["bottom-left"]
    assert dark_corner("phone_orientation_3.jpg") == ["bottom-right"]


def test_a_turned_photo_job_swaps_width_and_height(tmp_path, run_cli):
    out = tmp_path / "o6.gcode"
    code, stdout, _ = run_cli(["img2gcode", str(IMAGES / "phone_orientation_6.jpg"), "-o", str(out),
                               "--dpi", "254", "--preview", "none"])
    assert code == 0
    # 40 × 60 px after the turn at 254 dpi (0.1 mm a pixel): 4 mm wide, 6 mm tall.
    assert "job size 4.0 × 6.0 mm" in stdout
    assert "40 × 60 px at 0.1 mm" in stdout


def test_a_quarter_turn_swaps_the_two_densities(tmp_path):
    """A file 200 dpi across and 100 dpi down, turned a quarter: 100 across, 200 down."""
    path = tmp_path / "turned.jpg"
    exif = Image.Exif()
    exif[ORIENTATION] = 6
    Image.fromarray(np.full((40, 60), 200, np.uint8)).save(path, dpi=(200, 100), exif=exif.tobytes())
    img = read_image(path)
    assert img.pixels.shape == (60, 40)
    assert img.dpi == pytest.approx(100.0) and img.pixel_aspect == pytest.approx(0.5)


def test_an_unturned_file_is_read_as_stored():
    with Image.open(IMAGES / "heart.png") as im:
        assert ORIENTATION not in im.getexif()
        stored = np.asarray(im)
    assert np.array_equal(read_image(IMAGES / "heart.png").pixels, stored)


# ----------------------------------------------------------------------------- transparency

# Every sample is the same picture (data/images/make_real_world.py): the left 16 columns
# transparent with a dark colour stored under them; on the right, on white, a black and a
# mid-gray square.
TRANSPARENT = ["transparent_alpha.png", "transparent_rgb_key.png", "transparent_gray_key.png",
               "transparent_gray16_key.png", "transparent_palette.png"]
MODES = ["zigzag", "spiral", "edges", "gray", "dither"]


def _card():
    img = np.full((30, 40), 255, np.uint8)
    img[4:14, 20:30] = 0
    img[17:27, 24:36] = 128
    blank = np.zeros((30, 40), bool)
    blank[:, :16] = True
    return img, blank


def _burns(job):
    count, power = burn_map(job.moves, job.report.shape, job.report.pixel_mm)
    return count, power


@pytest.mark.parametrize("name", TRANSPARENT)
def test_the_samples_store_a_dark_colour_under_the_transparency(name):
    """Without the transparency the left part would burn in every mode: it is dark."""
    card, blank = _card()
    with Image.open(IMAGES / name) as im:
        assert im.mode in ("RGBA", "RGB", "L", "I;16", "I", "P")
        assert im.mode == "RGBA" or "transparency" in im.info        # tRNS present
        stored = np.asarray(im.convert("RGB") if im.mode == "P" else im)
    under = to_gray(stored[:, :, :3] if stored.ndim == 3 else stored)
    assert (under[blank] < 64).all()                  # dark: 60 of 255 or black
    assert np.allclose(under[~blank], card[~blank])   # the picture itself
    assert np.array_equal(read_image(IMAGES / name).blank, blank)


def _stored_colours(img):
    """The file's colours without its transparency (alpha channel dropped)."""
    return img.pixels[:, :, :-1] if img.pixels.shape[-1] in (2, 4) else img.pixels


@pytest.mark.parametrize("name", TRANSPARENT)
@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("invert", [False, True])
def test_transparency_is_never_burned_and_the_rest_burns_as_on_white(name, mode, invert):
    """The reference is the picture a viewer shows on white: the file's colours with its
    transparent part painted white, opaque. Burns there agree pixel for pixel; the
    transparent part gets nothing, even inverted (white would become black)."""
    _, blank = _card()
    img = read_image(IMAGES / name)
    stored = _stored_colours(img)
    on_white = stored.copy()
    on_white[blank] = np.iinfo(stored.dtype).max
    settings = dict(mode=mode, beam_mm=0.1, pixel_mm=0.1, invert=invert, edge_threshold=100.0)
    count, power = _burns(image_to_job(img, **settings))
    ref_count, ref_power = _burns(image_to_job(on_white, **settings))
    assert count[blank].sum() == 0 and power[blank].sum() == 0
    assert ref_count[~blank].sum() > 0                          # the check is not vacuous
    assert np.array_equal(count[~blank], ref_count[~blank])
    assert np.array_equal(power[~blank], ref_power[~blank])
    # Before, the job burned there: the stored dark colour (transparency ignored) or, for
    # alpha composited onto white and inverted, white turned black.
    stored_count = _burns(image_to_job(stored, **settings))[0]
    assert stored_count[blank].sum() + (ref_count[blank].sum() if invert else 0) > 0


@pytest.mark.parametrize("mode", MODES)
def test_transparency_survives_resampling(mode):
    """At twice the size (bicubic) the transparent part stays unburned, away from its
    border by one beam pixel (where resampling mixes the two sides)."""
    _, blank = _card()
    job = image_to_job(read_image(IMAGES / "transparent_rgb_key.png"), mode=mode, beam_mm=0.05,
                       pixel_mm=0.1, invert=True, edge_threshold=100.0)
    count, _ = _burns(job)
    assert count.shape == (60, 80)
    assert count[:, :31].sum() == 0 and count[:, 33:].sum() > 0


def test_the_16_bit_key_is_exact():
    """A 16-bit gray tRNS key marks only the pixels of exactly that value (not its 8-bit
    neighbours): one unit above the key is opaque."""
    key = 15420
    values = np.array([[key, key + 1, key - 1, 0]], np.uint16)
    blank = blank_mask(_read_saved(values, transparency=key).pixels)
    assert blank.tolist() == [[True, False, False, False]]


def _read_saved(arr, **options):
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "image.png"
        Image.fromarray(arr).save(path, **options)
        return read_image(path)


def test_gray_mode_of_the_issue_file_no_longer_burns_the_key(tmp_path, run_cli):
    """The issue's case: gray mode burned an RGB PNG's colour-key area (there at ~39 %).
    The whole command, read back from the G-code text."""
    from labkit.gcode import parse

    _, blank = _card()
    out = tmp_path / "key.gcode"
    code, _, _ = run_cli(["img2gcode", str(IMAGES / "transparent_rgb_key.png"), "-o", str(out),
                          "--mode", "gray", "--dpi", "254", "--preview", "none"])
    assert code == 0
    count, power = burn_map(parse(out.read_text()), (30, 40), 0.1)
    assert count[blank].sum() == 0 and count[~blank].sum() > 0


# ----------------------------------------------------------------------------- pixel density

@pytest.mark.parametrize("name", ["density_200x100.jpg", "density_200x100.png"])
def test_non_square_pixels_keep_the_true_aspect(name, tmp_path, run_cli):
    """60 × 40 px at 200 dpi across and 100 dpi down: 7.62 mm × 10.16 mm, and the square
    the file holds (20 × 20 px, 2.54 × 5.08 mm as stored) is engraved as it is shown."""
    with Image.open(IMAGES / name) as im:
        assert [round(d) for d in im.info["dpi"]] == [200, 100]
    img = read_image(IMAGES / name)
    assert img.dpi == pytest.approx(200, rel=1e-4) and img.pixel_aspect == pytest.approx(2.0)
    out = tmp_path / "d.gcode"
    code, stdout, _ = run_cli(["img2gcode", str(IMAGES / name), "-o", str(out), "--preview", "none"])
    assert code == 0
    assert "job size 7.6 × 10.2 mm" in stdout and "200 dpi across, 100 dpi down" in stdout
    job = image_to_job(img, mode="zigzag", beam_mm=0.1, dpi=img.dpi)
    assert job.report.shape == (102, 76)
    rows, cols = np.nonzero(job.target)
    # the dark rectangle: 20 px = 2.54 mm across, 20 px = 5.08 mm down (2.54 if the density
    # were ignored), within two beam pixels (bicubic upscaling rings at each edge)
    assert abs((cols.max() - cols.min() + 1) * 0.1 - 2.54) <= 0.2
    assert abs((rows.max() - rows.min() + 1) * 0.1 - 5.08) <= 0.2
    # --width keeps the aspect too: 30 mm across → 40 mm down
    code, stdout, _ = run_cli(["img2gcode", str(IMAGES / name), "-o", str(out), "--width", "30",
                               "--preview", "none", "--force"])
    assert code == 0 and "job size 30.0 × 40.0 mm" in stdout


def test_a_unitless_density_is_an_aspect(tmp_path):
    """JFIF may state densities without a unit: only the pixels' aspect. Pillow writes
    JFIF densities in dpi only, so the header of a Pillow JPEG is patched here by hand
    (JFIF 1.02: units 0, Xdensity 3, Ydensity 1)."""
    path = tmp_path / "aspect.jpg"
    Image.fromarray(np.full((10, 10), 255, np.uint8)).save(path)
    raw = bytearray(path.read_bytes())
    at = raw.index(b"JFIF\0") + 7                  # version (2 bytes), then units, Xdensity, Ydensity
    raw[at:at + 5] = bytes([0, 0, 3, 0, 1])        # unit 0: 3 : 1
    path.write_bytes(bytes(raw))
    img = read_image(path)
    assert img.dpi is None and img.pixel_aspect == pytest.approx(3.0)


@pytest.mark.parametrize("kind", ["palette", "rgb key", "gray16 key"])
def test_a_turned_file_keeps_its_transparency_in_place(kind, tmp_path):
    """Orientation and transparency together: the blank part turns with the picture."""
    exif = Image.Exif()
    exif[ORIENTATION] = 6
    rgb = np.full((4, 6, 3), 200, np.uint8)
    rgb[:, :2] = 60
    blank = np.zeros((4, 6), bool)
    blank[:, :2] = True
    path = tmp_path / "turned.png"
    if kind == "palette":
        im = Image.fromarray(rgb).convert("P")
        im.save(path, transparency=im.getpixel((0, 0)), exif=exif.tobytes())
    elif kind == "rgb key":
        Image.fromarray(rgb).save(path, transparency=(60, 60, 60), exif=exif.tobytes())
    else:
        Image.fromarray(rgb[:, :, 0].astype(np.uint16) * 257).save(path, transparency=60 * 257,
                                                                   exif=exif.tobytes())
    img = read_image(path)
    assert img.pixels.shape[:2] == (6, 4)
    assert np.array_equal(img.blank, np.rot90(blank, -1))
