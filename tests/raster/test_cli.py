"""``labkit img2gcode`` end to end: files written, report printed, G-code parses back to the job."""

import numpy as np
import pytest
from PIL import Image
from skimage import data

from labkit.cli import main
from labkit.gcode import parse_file
from labkit.raster import burn_map


@pytest.fixture
def horse_png(tmp_path):
    path = tmp_path / "horse.png"
    Image.fromarray(data.horse().astype(np.uint8) * 255).save(path, dpi=(254, 254))
    return path


@pytest.mark.parametrize("mode", ["zigzag", "spiral", "edges", "gray", "dither"])
def test_img2gcode_modes(tmp_path, horse_png, capsys, mode):
    out = tmp_path / f"{mode}.gcode"
    assert main(["img2gcode", str(horse_png), "-o", str(out), "--mode", mode, "--beam", "0.4",
                 "--width", "40"]) == 0
    text = capsys.readouterr().out
    assert f"mode                             {mode}" in text
    lines = out.read_text().count("\n")
    assert f"G-code lines                     {lines}" in text
    assert (tmp_path / f"{mode}.png").stat().st_size > 10_000
    moves = parse_file(out)
    count, _ = burn_map(moves, (82, 100), 0.4, tol_mm=1e-3)   # 40 mm / 0.4 = 100 columns
    assert count.max() == 1 and count.sum() > 0


def test_img2gcode_uses_the_file_dpi(tmp_path, horse_png, capsys):
    out = tmp_path / "h.gcode"
    assert main(["img2gcode", str(horse_png), "-o", str(out), "--beam", "0.5", "--preview", "none"]) == 0
    text = capsys.readouterr().out
    # 400 px at 254 dpi = 40 mm → 80 pixels of 0.5 mm
    assert "80 × 66 px at 0.5 mm" in text and not (tmp_path / "h.png").exists()


def test_img2gcode_errors(tmp_path, capsys):
    bad = tmp_path / "bad.png"
    bad.write_text("not an image")
    assert main(["img2gcode", str(bad), "-o", str(tmp_path / "x.gcode")]) == 1
    assert "not an image file" in capsys.readouterr().err
    assert main(["img2gcode", str(tmp_path / "missing.png"), "-o", str(tmp_path / "x.gcode")]) == 1
    assert "missing.png: no such file; expected an existing image file" in capsys.readouterr().err
