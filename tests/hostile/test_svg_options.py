"""Hostile options for ``labkit svg2gcode`` / ``dxf2gcode`` (issue 9): each gets its named
error — never a negative or too-large S, a diamond for a circle, a truncated pass count, a
work bomb or an overwritten drawing."""

from __future__ import annotations

import os

import pytest

from labkit.gcode import parse
from labkit.toolpath import MoveKind

SVG = ('<svg xmlns="http://www.w3.org/2000/svg" width="40mm" height="40mm" viewBox="0 0 40 40">'
       '<circle cx="20" cy="20" r="15" fill="none" stroke="#000" stroke-width="0.2"/>'
       '<rect x="2" y="2" width="8" height="8" fill="none" stroke="#f00" stroke-width="0.2"/></svg>')


@pytest.fixture
def drawing(tmp_path):
    path = tmp_path / "art.svg"
    path.write_text(SVG)
    return path


@pytest.mark.parametrize("option,value,message", [
    ("--power", "inf", "argument --power: 'inf' is not a finite number >= 0"),
    ("--power", "-5", "argument --power: '-5' is not a finite number >= 0"),
    ("--s-max", "-1", "argument --s-max: '-1' is not a finite number > 0"),
    ("--s-max", "nan", "argument --s-max: 'nan' is not a finite number > 0"),
    ("--tol", "inf", "argument --tol: 'inf' is not a finite number >= 0.0001 and <= 10"),
    ("--tol", "1e-12", "argument --tol: '1e-12' is not a finite number >= 0.0001 and <= 10"),
    ("--passes", "2.5", "argument --passes: '2.5' is not a whole number >= 1"),
    ("--feed", "0", "argument --feed: '0' is not a finite number >= 1 and <= 1e+06"),
    ("--feed", "1e-9", "argument --feed: '1e-9' is not a finite number >= 1 and <= 1e+06"),
    ("--kerf", "7e13", "argument --kerf: '7e13' is not a finite number >= 0 and <= 10"),
    ("--fill-spacing", "-1", "argument --fill-spacing: '-1' is not a finite number > 0"),
])
def test_numeric_options_are_checked_by_name(drawing, tmp_path, run_labkit, option, value, message):
    r = run_labkit(["svg2gcode", drawing, "-o", tmp_path / "o.gcode", option, value], time_s=60)
    assert r.code == 2 and message in r.stderr
    assert not (tmp_path / "o.gcode").exists()


def test_power_above_s_max_is_refused(drawing, tmp_path, run_labkit):
    r = run_labkit(["svg2gcode", drawing, "-o", tmp_path / "o.gcode", "--power", "5000"], time_s=60)
    assert r.code == 1 and "--power: power S5000 is above --s-max 1000" in r.stderr
    r = run_labkit(["svg2gcode", drawing, "-o", tmp_path / "o.gcode", "--layer", "#ff0000:600:1200"],
                   time_s=60)
    assert r.code == 1 and "--layer #ff0000: power S1200 is above --s-max 1000" in r.stderr
    assert not (tmp_path / "o.gcode").exists()


@pytest.mark.parametrize("layer,message", [
    ("#ff0000:600:500:2.5", "PASSES 2.5 must be a whole number >= 1"),
    ("#ff0000:600:inf", "POWER inf must be a finite number >= 0"),
    ("#ff0000:-600:500", "FEED -600 must be a finite number > 0"),
])
def test_layer_fields_are_checked_not_truncated(drawing, tmp_path, run_labkit, layer, message):
    r = run_labkit(["svg2gcode", drawing, "-o", tmp_path / "o.gcode", "--layer", layer], time_s=60)
    assert r.code == 1 and message in r.stderr


def test_work_bombs_are_refused_before_the_work(drawing, tmp_path, run_labkit):
    r = run_labkit(["svg2gcode", drawing, "-o", tmp_path / "o.gcode", "--passes", "1000000"],
                   time_s=60, memory_mb=400)
    assert r.code == 1 and "moves (budget 20,000,000)" in r.stderr and "--passes" in r.stderr
    r = run_labkit(["svg2gcode", drawing, "-o", tmp_path / "o.gcode", "--fill", "--fill-spacing", "1e-5"],
                   time_s=60, memory_mb=400)
    assert r.code == 1 and "hatch lines (budget 1,000,000) from hatching 2 closed shape(s)" in r.stderr


def test_output_never_overwrites_the_drawing(drawing, run_labkit):
    r = run_labkit(["svg2gcode", drawing, "-o", drawing], time_s=60)
    assert r.code == 1 and "is also the input file" in r.stderr
    assert drawing.read_text() == SVG


def test_fifo_input_is_refused_without_hanging(tmp_path, run_labkit):
    fifo = tmp_path / "art.svg"
    os.mkfifo(fifo)
    r = run_labkit(["svg2gcode", fifo, "-o", tmp_path / "o.gcode"], time_s=30)
    assert r.code == 1 and "not a regular file (a FIFO" in r.stderr
    r = run_labkit(["dxf2gcode", fifo, "-o", tmp_path / "o.gcode"], time_s=30)
    assert r.code == 1 and "not a regular file (a FIFO" in r.stderr


def test_the_largest_tolerance_still_cuts_a_circle_not_a_diamond(drawing, tmp_path, run_labkit):
    out = tmp_path / "o.gcode"
    r = run_labkit(["svg2gcode", drawing, "-o", out, "--tol", "10", "--arcs"], time_s=60)
    assert r.code == 0, r.stderr
    moves = parse(out.read_text())
    assert (moves.kind == MoveKind.ARC_CW).sum() + (moves.kind == MoveKind.ARC_CCW).sum() >= 1


def test_travel_beam_off_keeps_every_rapid_dark(drawing, tmp_path, run_labkit):
    out = tmp_path / "o.gcode"
    r = run_labkit(["svg2gcode", drawing, "-o", out, "--travel-beam-off"], time_s=60)
    assert r.code == 0, r.stderr
    moves = parse(out.read_text())
    rapids = moves.kind == MoveKind.RAPID
    assert rapids.any() and (moves.laser[rapids] == 0).all()
