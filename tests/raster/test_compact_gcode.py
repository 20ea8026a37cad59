"""Compact raster G-code (issue 30 §3) burns what the spaced, absolute text burns.

Both texts of one job are read back by the parser and burned by ``coverage.burn_map`` (the
independent check of every raster mode): the same moves, the same pixels at the same S, and
that S is the job's target. The photo is data/images/photo_500x450_72dpi.jpg (a camera
photo, public domain), cropped so the test stays small.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from labkit.gcode import emit, parse
from labkit.raster.coverage import burn_map
from labkit.raster.engrave import image_to_job, raster_program
from labkit.raster.io import read_image

PHOTO = Path(__file__).resolve().parents[2] / "data" / "images" / "photo_500x450_72dpi.jpg"


@pytest.fixture(scope="module")
def crop():
    """A 48 × 64 px crop of the photo holding a face's edge (dark, mid and light grays)."""
    return np.ascontiguousarray(read_image(PHOTO).pixels[120:168, 200:264])


@pytest.mark.parametrize("mode", ["gray", "dither"])
@pytest.mark.parametrize("pitch", [0.1, 0.127])
def test_compact_burns_what_the_spaced_text_burns(crop, mode, pitch):
    job = image_to_job(crop, mode=mode, beam_mm=pitch, pixel_mm=pitch, feed_mm_min=6000.0,
                       skip_white_mm=0.5, overscan_mm=1.0, white_level=230.0)
    spaced, compact = emit(job.moves), emit(job.moves, compact=True)
    assert len(compact) < len(spaced)      # the ratio on whole jobs: benchmarks/bench_raster_gcode.py
    a, b = parse(spaced), parse(compact)
    assert a.diagnostics == () and b.diagnostics == ()
    np.testing.assert_array_equal(a.kind, b.kind)
    np.testing.assert_allclose(a.end, b.end, atol=1e-9)
    np.testing.assert_array_equal(a.s_word, b.s_word)
    np.testing.assert_array_equal(a.laser_on, b.laser_on)
    tol = 1e-6 if pitch == 0.1 else 1e-3     # 0.127 mm: centres at 0.0635 k, written to 1 µm
    count_a, power_a = burn_map(a, job.target.shape, pitch, tol_mm=tol)
    count_b, power_b = burn_map(b, job.target.shape, pitch, tol_mm=tol)
    np.testing.assert_array_equal(count_a, count_b)
    np.testing.assert_array_equal(power_a, power_b)
    burned = job.target > 0
    assert burned.sum() > 500 and not burned.all()      # white gaps crossed and skipped too
    np.testing.assert_array_equal(count_b, burned.astype(int))
    np.testing.assert_array_equal(power_b[burned], job.target[burned])


def test_numbers_have_the_decimals_the_pitch_needs(crop):
    """At 0.1 mm, X is at pixel edges (one decimal) and Y at row centres (two): no more."""
    text = raster_program(crop, feed_mm_min=6000.0, pitch_mm=0.1, mode="gray")
    body = text.split("M5\n", 1)[1]
    xs = re.findall(r"X(-?\d*\.?\d*)", body)
    ys = re.findall(r"Y(-?\d*\.?\d*)", body)
    assert xs and ys
    assert max(len(v.partition(".")[2]) for v in xs) == 1
    assert max(len(v.partition(".")[2]) for v in ys) == 2
    assert " " not in body and "(" not in body and ";" not in body     # no spaces, no comments


def test_img2gcode_writes_compact_unless_asked(tmp_path, capsys):
    from PIL import Image

    from labkit.cli import main

    def run_cli(argv):
        code = main(argv)
        captured = capsys.readouterr()
        return code, captured.out, captured.err

    png = tmp_path / "crop.png"
    Image.fromarray(np.asarray(read_image(PHOTO).pixels[120:168, 200:264])).save(png, dpi=(254, 254))
    texts = {}
    for extra in ([], ["--readable"], ["--dialect", "marlin"]):
        out = tmp_path / f"{len(extra)}{''.join(extra)}.gcode"
        code, _, err = run_cli(["img2gcode", str(png), "-o", str(out), "--mode", "gray", "--preview", "none",
                                *extra])
        assert code == 0, err
        texts[" ".join(extra)] = out.read_text()
    compact, readable = texts[""], texts["--readable"]
    assert "G91" in compact and "G91" not in readable and "G1 X" in readable
    assert "G1 X" in texts["--dialect marlin"]           # Marlin: the spaced form
    a, b = parse(readable), parse(compact)
    np.testing.assert_allclose(a.end, b.end, atol=1e-9)
    np.testing.assert_array_equal(a.s_word, b.s_word)
    # every header line fits a counting sender's view of GRBL's line buffer
    assert max(len(line) for line in compact.splitlines()) <= 79


def test_the_labkit_firmware_runs_the_compact_text_as_labkit_plans_it(tmp_path, capsys):
    """The firmware's host simulator traces the compact program step for step as ``labkit steps``
    does (its own tools/sim_trace check: every tick's time, steps, direction and power), and
    the readable text of the same job takes exactly as many ticks: relative moves, words
    without spaces and numbers without a leading 0 are read by the firmware as by labkit."""
    import importlib.util
    import subprocess

    root = Path(__file__).resolve().parents[2]
    build = subprocess.run(["make", "-C", str(root / "firmware"), "sim"], capture_output=True, text=True)
    assert build.returncode == 0, build.stdout + build.stderr
    spec = importlib.util.spec_from_file_location("sim_trace", root / "firmware" / "tests" / "sim_trace.py")
    sim_trace = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(sim_trace)
    strip = np.ascontiguousarray(read_image(PHOTO).pixels[130:134, 100:250])     # 4 rows, 15 mm
    ticks = {}
    for compact in (True, False):
        text = raster_program(strip, feed_mm_min=1500, pitch_mm=0.1, mode="gray", overscan_mm=1.0,
                              compact=compact)
        assert ("G91" in text) == compact
        job = tmp_path / f"{compact}.gcode"
        job.write_text(text, "ascii")
        assert sim_trace.main(["sim_trace", str(root / "firmware/build/host/labkit-fw-sim"), str(job)]) == 0
        out = capsys.readouterr().out
        assert "sim_trace: identical" in out, out
        ticks[compact] = int(out.split(" simulator ticks")[0].rsplit(" ", 1)[1])
    assert ticks[True] == ticks[False] > 10_000
