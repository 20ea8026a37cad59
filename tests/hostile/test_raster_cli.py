"""Hostile options and files for ``labkit img2gcode`` (issue 9): each gets its named error,
never a wrong program with exit 0, a traceback, a hang or all the memory."""

from __future__ import annotations

import os

import numpy as np
import pytest
from PIL import Image

from labkit.gcode import parse
from labkit.toolpath import MoveKind


@pytest.fixture
def square(tmp_path):
    """A 20 × 20 px page at 25.4 dpi (20 × 20 mm), a black 10 × 10 px square in it."""
    im = Image.new("L", (20, 20), 255)
    im.paste(0, (5, 5, 15, 15))
    path = tmp_path / "square.png"
    im.save(path, dpi=(25.4, 25.4))
    return path


@pytest.mark.parametrize("option,value,message", [
    ("--power", "inf", "argument --power: 'inf' is not a finite number >= 0"),
    ("--power", "nan", "argument --power: 'nan' is not a finite number >= 0"),
    ("--s-max", "-1", "argument --s-max: '-1' is not a finite number > 0"),
    ("--beam", "0", "argument --beam: '0' is not a finite number > 0"),
    ("--width", "-5", "argument --width: '-5' is not a finite number > 0"),
    ("--gamma", "inf", "argument --gamma: 'inf' is not a finite number > 0"),
    ("--max-power", "2", "argument --max-power: '2' is not a finite number >= 0 and <= 1"),
])
def test_numeric_options_are_checked_by_name(square, tmp_path, run_labkit, option, value, message):
    r = run_labkit(["img2gcode", square, "-o", tmp_path / "out.gcode", option, value], time_s=60)
    assert r.code == 2 and message in r.stderr
    assert not (tmp_path / "out.gcode").exists()


def test_power_above_s_max_is_refused(square, tmp_path, run_labkit):
    r = run_labkit(["img2gcode", square, "-o", tmp_path / "o.gcode", "--power", "5000"], time_s=60)
    assert r.code == 1 and "--power 5000 is above --s-max 1000" in r.stderr
    assert not (tmp_path / "o.gcode").exists()


def test_a_450_megapixel_job_is_refused_before_resampling(square, tmp_path, run_labkit):
    r = run_labkit(["img2gcode", square, "-o", tmp_path / "o.gcode", "--width", "3000",
                    "--beam", "0.1", "--force"], time_s=60, memory_mb=300)
    assert r.code == 1
    assert "too much work: 900,000,000 pixels (budget 200,000,000)" in r.stderr
    assert "--width/--height/--dpi" in r.stderr


def test_a_job_larger_than_the_machine_is_refused_unless_forced(square, tmp_path, run_labkit):
    """3 m wide on a 300 × 400 mm machine: refused before any work; --machine names another
    machine; --force writes it with a warning."""
    out = tmp_path / "o.gcode"
    r = run_labkit(["img2gcode", square, "-o", out, "--width", "3000", "--beam", "2"], time_s=60)
    assert r.code == 1 and not out.exists()
    assert ("the engraving is 3000.0 × 3000.0 mm, larger than the travel of cbr40-laser "
            "(300 × 400 mm) along X, Y; scale it down, or force it (--force)") in r.stderr
    r = run_labkit(["img2gcode", square, "-o", out, "--width", "350", "--beam", "2"], time_s=60)
    assert r.code == 1 and "350.0 × 350.0 mm, larger than the travel of cbr40-laser (300 × 400 mm) along X;" in r.stderr
    r = run_labkit(["img2gcode", square, "-o", out, "--width", "350", "--beam", "2",
                    "--machine", "grbl-diode"], time_s=60)           # 400 × 400 mm: it fits
    assert r.code == 0 and out.exists() and "warning" not in r.stderr
    out.unlink()
    r = run_labkit(["img2gcode", square, "-o", out, "--width", "3000", "--beam", "2", "--force"],
                   time_s=60)
    assert r.code == 0 and out.exists()
    assert "warning: the engraving is 3000.0 × 3000.0 mm" in r.stderr and "(written anyway: --force)" in r.stderr


def test_output_never_overwrites_the_image(square, run_labkit):
    before = square.read_bytes()
    r = run_labkit(["img2gcode", square, "-o", square], time_s=60)
    assert r.code == 1 and "is also the input file" in r.stderr
    assert square.read_bytes() == before


def test_fifo_and_text_files_give_one_line(tmp_path, run_labkit):
    fifo = tmp_path / "pipe.png"
    os.mkfifo(fifo)
    r = run_labkit(["img2gcode", fifo, "-o", tmp_path / "o.gcode"], time_s=30)
    assert r.code == 1 and "not a regular file (a FIFO" in r.stderr
    (tmp_path / "job.png").write_text("G1 X1\n")
    r = run_labkit(["img2gcode", tmp_path / "job.png", "-o", tmp_path / "o.gcode"], time_s=60)
    assert r.code == 1 and "job.png: not an image file" in r.stderr


def test_edges_of_an_upscaled_image_are_cut(square, tmp_path, run_labkit):
    # 1 px = 1 mm, beam 0.1 mm: the image is upscaled 10×; the program used to be empty.
    out = tmp_path / "edges.gcode"
    r = run_labkit(["img2gcode", square, "-o", out, "--mode", "edges", "--preview", "none"],
                   time_s=120)
    assert r.code == 0, r.stderr
    moves = parse(out.read_text())
    cuts = moves.laser_on
    xy = np.concatenate([moves.start[cuts, :2], moves.end[cuts, :2]])
    # every cut lies on the square's outline (5…15 mm): Sobel marks the two pixels either
    # side of a step, whose centres lie 0.05 and 0.15 mm from it; paths turn at pixel
    # corners, at most 0.25 mm away
    inside = np.minimum.reduce([abs(xy[:, 0] - 5), abs(xy[:, 0] - 15),
                                abs(xy[:, 1] - 5), abs(xy[:, 1] - 15)])
    assert cuts.sum() > 20 and inside.max() <= 0.25 + 1e-9


def test_a_blank_page_is_an_error_not_an_empty_program(tmp_path, run_labkit):
    Image.new("L", (10, 10), 255).save(tmp_path / "blank.png")
    r = run_labkit(["img2gcode", tmp_path / "blank.png", "-o", tmp_path / "o.gcode"], time_s=60)
    assert r.code == 1 and "nothing to burn in mode zigzag" in r.stderr
    assert not (tmp_path / "o.gcode").exists()


def test_travel_beam_off_keeps_every_rapid_dark(square, tmp_path, run_labkit):
    out = tmp_path / "t.gcode"
    r = run_labkit(["img2gcode", square, "-o", out, "--travel-beam-off", "--preview", "none",
                    "--beam", "1"], time_s=60)
    assert r.code == 0, r.stderr
    text = out.read_text()
    moves = parse(text)
    rapids = moves.kind == MoveKind.RAPID
    assert rapids.any() and (moves.laser[rapids] == 0).all()
    assert "job size 20.0 × 20.0 mm from the file's resolution (25.4 dpi)" in r.stdout


def test_default_preview_never_overwrites_the_image(tmp_path, run_labkit):
    """img2gcode photo.png -o photo.gcode: the default preview (OUTPUT with .png) would be
    the image itself; it goes to photo.preview.png and the image is untouched."""
    from PIL import Image

    image = tmp_path / "photo.png"
    Image.fromarray(np.tile(np.arange(0, 256, 16, dtype=np.uint8), (16, 1))).save(image, dpi=(254, 254))
    before = image.read_bytes()
    r = run_labkit(["img2gcode", image, "-o", tmp_path / "photo.gcode"], time_s=60)
    assert r.code == 0, r.stderr
    assert image.read_bytes() == before and (tmp_path / "photo.preview.png").exists()
    r = run_labkit(["img2gcode", image, "-o", tmp_path / "other.gcode", "--preview", image], time_s=60)
    assert r.code == 1 and image.read_bytes() == before and not (tmp_path / "other.gcode").exists()
