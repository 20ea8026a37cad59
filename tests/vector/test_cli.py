"""The svg2gcode / dxf2gcode commands end to end: files written, summary printed, G-code parses back."""

import os

import pytest

from labkit.cli import main
from labkit.errors import GeometryError
from labkit.commands.vector import parse_layer_option
from labkit.gcode import parse
from labkit.geometry import total_length
from labkit.vector import read_svg

DATA = os.path.join(os.path.dirname(__file__), "..", "..", "data")
SVG = os.path.join(DATA, "svg", "labkit", "transforms.svg")
DXF = os.path.join(DATA, "dxf", "parts_mm.dxf")


@pytest.mark.parametrize("arcs", [False, True])
def test_svg2gcode(tmp_path, capsys, arcs):
    out = tmp_path / "job.gcode"
    png = tmp_path / "job.png"
    argv = ["svg2gcode", SVG, "-o", str(out), "--tol", "0.01", "--feed", "900", "--power", "700",
            "--preview", str(png), "--layer", "#ff0000:300:1000:2"] + (["--arcs"] if arcs else [])
    assert main(argv) == 0
    text = capsys.readouterr().out
    for key in ("segments", "G-code lines", "cut length", "travel length", "max deviation", "estimated time"):
        assert key in text
    moves = parse(out.read_text())
    assert moves.is_arc.any() == arcs
    drawing = read_svg(SVG, tol_mm=0.01)
    red = sum(p.length_mm for p in drawing.paths if p.layer == "#ff0000")
    cut = moves.lengths_mm()[moves.laser_on].sum()
    assert cut == pytest.approx(total_length(drawing.paths) + red, rel=2e-3)   # red cut twice
    assert set(moves.feed_mm_min[moves.laser_on]) == {300.0, 900.0}
    assert png.stat().st_size > 1000


def test_dxf2gcode_with_fill_and_kerf(tmp_path, capsys):
    out = tmp_path / "parts.gcode"
    assert main(["dxf2gcode", DXF, "-o", str(out), "--fill", "--fill-spacing", "1", "--kerf", "0.2",
                 "--arcs"]) == 0
    text = capsys.readouterr().out
    assert "skipped         TEXT#" in text
    moves = parse(out.read_text())
    assert moves.laser_on.sum() > 100


def test_errors_are_one_line(tmp_path, capsys):
    assert main(["svg2gcode", str(tmp_path / "none.svg"), "-o", str(tmp_path / "x.gcode")]) == 1
    assert "none.svg: no such file; expected an existing SVG file" in capsys.readouterr().err
    assert main(["svg2gcode", SVG, "-o", str(tmp_path / "x.gcode"), "--layer", "red"]) == 1
    assert "expected NAME:FEED:POWER" in capsys.readouterr().err
    with pytest.raises(SystemExit) as stop:             # argparse: usage error, status 2
        main(["svg2gcode", SVG, "-o", str(tmp_path / "x.gcode"), "--tol", "0"])
    assert stop.value.code == 2
    assert "argument --tol: '0' is not a finite number >= 0.0001 and <= 10" in capsys.readouterr().err


def test_layer_option():
    name, s = parse_layer_option("a:b:100:200:3:0.5")
    assert (name, s.feed_mm_min, s.s_word, s.passes, s.z_step_mm) == ("a:b", 100, 200, 3, 0.5)
    with pytest.raises(GeometryError, match="expected NAME:FEED:POWER"):
        parse_layer_option("100:200")
