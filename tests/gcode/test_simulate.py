"""Envelope check, lengths and time estimates against hand counts and pygcode."""

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from labkit.errors import BoundsError
from labkit.gcode import parse, parse_file
from labkit.gcode.simulate import Envelope, check_bounds, summarize

from ._pygcode_peer import positions_by_line

JSDC = Path(__file__).resolve().parents[2] / "data" / "gcode" / "cncjs" / "jsdc-laser.gcode"


def test_summary_by_hand():
    text = "G0 X30 Y40\nM3 S500\nG1 X60 F600\nG2 X60 Y20 I0 J-10\nG4 P2\nM5\nG1 X0 Y0"
    s = summarize(parse(text), rapid_mm_min=3000)
    half_circle = math.pi * 10
    assert s.cut_length_mm == pytest.approx(30 + half_circle)
    back = math.hypot(60, 20)
    assert s.travel_length_mm == pytest.approx(50 + back)
    assert s.laser_on_time_s == pytest.approx((30 + half_circle) / 10)
    assert s.dwell_time_s == 2
    assert s.estimated_time_s == pytest.approx(50 / 50 + (30 + half_circle + back) / 10 + 2)
    assert s.counts == {"rapid": 1, "line": 2, "arc_cw": 1, "arc_ccw": 0, "dwell": 1}
    assert s.cut_bounds == [[30, 20, 0], [70, 40, 0]]    # the arc bulges to X70
    assert s.to_dict()["bounds"] == [[0, 0, 0], [70, 40, 0]]
    assert "cut length      61.416 mm" in s.format()


def test_cut_length_of_a_real_job_matches_pygcode_positions():
    text = JSDC.read_text()
    positions, _ = positions_by_line(text)
    moves = parse(text)
    # Independent count: walk the file, track M3/M5/S ourselves, sum segments while burning.
    burning, power, total, prev = False, 0.0, 0.0, np.zeros(3)
    for k, raw in enumerate(text.splitlines()):
        code = raw.split(";")[0].upper()
        if "M3" in code.split() or code.startswith("M3"):
            burning = True
        if "M5" in code.split():
            burning = False
        for word in code.split():
            if word.startswith("S"):
                power = float(word[1:])
        pos = positions[k]
        if burning and power > 0 and code.startswith("G1"):
            total += float(np.linalg.norm(pos - prev))
        prev = pos
    assert summarize(moves).cut_length_mm == pytest.approx(total, rel=1e-12)


def test_envelope_check_finds_the_first_offending_line_and_arc_bulges():
    with pytest.raises(BoundsError, match="Y reaches 20 mm, the limit is 15 mm") as info:
        check_bounds(parse("G0 X10 Y10\nG2 X30 Y10 I10 J0 F600\nG0 X500"), Envelope.from_size(100, 15))
    assert info.value.line == 2 and info.value.code == 102
    with pytest.raises(BoundsError, match="X reaches -1 mm, the limit is 0 mm"):
        check_bounds(parse("G0 X5\nG0 X-1"), Envelope.from_size(10, 10))
    check_bounds(parse("G0 X10 Y10\nG1 X0 Y0 F10"), Envelope.from_size(10, 10))   # on the edge is in


def test_envelope_error_quotes_the_source_line(tmp_path):
    path = tmp_path / "far.gcode"
    path.write_text("G0 X1\n(move)\nG0 X900 Y2\n")
    with pytest.raises(BoundsError) as info:
        check_bounds(parse_file(path), Envelope.from_size(400, 400))
    assert info.value.text == "G0 X900 Y2" and info.value.filename == str(path)
    assert str(info.value).startswith(f"{path}:3:1: error 102")


def test_bad_arguments():
    with pytest.raises(ValueError, match="y_mm must be > 0 mm"):
        Envelope.from_size(10, 0)
    with pytest.raises(ValueError, match="rapid_mm_min must be > 0"):
        summarize(parse("G0 X1"), rapid_mm_min=0)


@given(st.floats(1, 50), st.floats(0, 2 * math.pi), st.floats(0.01, 2 * math.pi), st.booleans())
def test_arc_bounds_contain_dense_samples_and_touch_them(r, a0, turn, cw):
    start = np.array([r * math.cos(a0), r * math.sin(a0)])
    a1 = a0 - turn if cw else a0 + turn
    end = np.array([r * math.cos(a1), r * math.sin(a1)])
    m = parse(f"G0 X{start[0]:.9f} Y{start[1]:.9f}\n"
              f"G{2 if cw else 3} X{end[0]:.9f} Y{end[1]:.9f} I{-start[0]:.9f} J{-start[1]:.9f} F100")
    box = m[1:].bounds()
    t = np.linspace(0, 1, 20001)
    sweep = m.sweep_rad()[1]
    ang = math.atan2(start[1], start[0]) + sweep * t
    pts = np.c_[r * np.cos(ang), r * np.sin(ang)]
    assert (pts.min(axis=0) >= box[0, :2] - 1e-6).all() and (pts.max(axis=0) <= box[1, :2] + 1e-6).all()
    np.testing.assert_allclose(pts.min(axis=0), box[0, :2], atol=1e-5 * r)
    np.testing.assert_allclose(pts.max(axis=0), box[1, :2], atol=1e-5 * r)


def test_raster_and_gcode_summaries_are_one_type_and_agree():
    from labkit.gcode.simulate import JobSummary
    from labkit.raster.engrave import summarize as raster_summarize
    from labkit.toolpath import Moves

    m = Moves.from_cuts([[0, 0], [5, 0], [5, 3]], [[3, 0], [9, 0], [0, 3]], feed_mm_min=600,
                        s_word=800)
    r = raster_summarize(m, feed_mm_min=600, rapid_mm_min=3000)
    g = summarize(m, rapid_mm_min=3000)
    assert type(r) is JobSummary and r == g
    # Hand count: cuts 3 + 4 + 5 mm at 600 mm/min, rapids 2 + 5 mm at 3000 mm/min.
    assert r.cut_length_mm == 12.0 and r.cut_moves == 3 and r.counts["rapid"] == 2
    assert r.estimated_time_s == pytest.approx(12 / 10 + 7 / 50)
