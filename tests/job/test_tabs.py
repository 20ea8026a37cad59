"""Tabs and perforation on a job's cut and score layers, checked geometrically: the gaps' lengths
and where they lie against the corners (worked by hand on rectangles), and with shapely that the
sheet is still one piece when tabs hold the part (three pieces without them)."""

import numpy as np
import pytest
import shapely

from labkit.errors import InputError
from labkit.gcode.reader import parse
from labkit.jobfile import compose_job, perforation_gaps, read_job, split_at_gaps, tab_gaps
from labkit.cli import main

SVG = """<svg xmlns="http://www.w3.org/2000/svg" width="60mm" height="40mm" viewBox="0 0 60 40">
<rect id="outline" x="10" y="10" width="40" height="20" fill="none" stroke="#000000"/>
<rect id="hole" x="20" y="15" width="5" height="5" fill="none" stroke="#000000"/>
<path id="fold" d="M 30 12 L 30 28" fill="none" stroke="#ff0000"/>
</svg>"""                                                    # written by hand

JOB = """format = "labkit-job"
version = 1
machine = "cbr40-laser"
[[layer]]
source = "part.svg"
operation = "{op}"
select = ["{colour}"]
power_mw = 2000.0
speed_mm_min = 300.0
{extra}
"""


def _compose(tmp_path, op="cut", colour="#000000", extra=""):
    (tmp_path / "part.svg").write_text(SVG)
    p = tmp_path / "job.toml"
    p.write_text(JOB.format(op=op, colour=colour, extra=extra))
    return compose_job(read_job(p)).moves


def _burned_segments(moves):
    on = moves.laser_on
    return moves.start[on][:, :2], moves.end[on][:, :2]


def test_tabs_slide_clear_of_corners():
    rect = np.array([[0, 0], [10, 0], [10, 30], [0, 30], [0, 0]], float)   # corners at s = 0, 10, 40, 50
    gaps = tab_gaps(rect, 4, 2.0)
    # evenly: centres 10, 30, 50, 70 — two on corners; they move to the nearest centre 3 mm clear (13, 53)
    assert [round(a, 6) for a, _ in gaps] == [12.0, 29.0, 52.0, 69.0]
    assert all(b - a == pytest.approx(2.0) for a, b in gaps)
    corners = np.array([0, 10, 40, 50, 80])
    for a, b in gaps:
        assert np.min(np.abs(corners - (a + b) / 2)) >= 3.0 - 1e-9


def test_split_and_perforation_by_hand():
    line = np.array([[0, 0], [10, 0]], float)
    pieces = split_at_gaps(line, perforation_gaps(line, 2.0, 1.0), closed=False)
    assert [p[:, 0].tolist() for p in pieces] == [[0, 2], [3, 5], [6, 8], [9, 10]]
    square = np.array([[0, 0], [4, 0], [4, 4], [0, 4], [0, 0]], float)
    pieces = split_at_gaps(square, [(1.0, 2.0), (15.0, 15.5)], closed=True)
    # from the end of the first gap round to the next, and from there past the start to the first gap
    assert pieces[0][0].tolist() == [2.0, 0.0] and pieces[0][-1].tolist() == [0.0, 1.0]   # s = 15 on the left side
    assert pieces[1][0].tolist() == [0.0, 0.5] and pieces[1][-1].tolist() == [1.0, 0.0]
    assert sum(float(np.hypot(*np.diff(p, axis=0).T).sum()) for p in pieces) == pytest.approx(16 - 1.5)


def test_tabs_keep_the_sheet_one_piece(tmp_path):
    starts, ends = _burned_segments(_compose(tmp_path, extra="tabs = 2\ntab_mm = 1.5"))
    # the outline (120 mm) and the hole (20 mm), each less two 1.5 mm tabs
    # (the SVG reader's coordinates carry 1e-5 mm of float rounding)
    assert float(np.hypot(*(ends - starts).T).sum()) == pytest.approx(140 - 4 * 1.5, abs=1e-3)
    sheet = shapely.box(0, 0, 60, 40)
    kerf = shapely.union_all([shapely.LineString([a, b]).buffer(0.05) for a, b in zip(starts, ends)])
    assert len(getattr(sheet.difference(kerf), "geoms", [sheet.difference(kerf)])) == 1
    # every gap lies clear of the rectangles' corners: the burned ends that bound a gap
    corners = np.array([[10, 10], [50, 10], [50, 30], [10, 30], [20, 20], [25, 20], [25, 25], [20, 25]])
    gap_ends = [e for e, s2 in zip(ends[:-1], starts[1:]) if np.hypot(*(s2 - e)) > 1e-6]
    assert len(gap_ends) >= 3
    for e in gap_ends:
        assert np.min(np.hypot(*(corners - e).T)) >= 1.5 - 1e-3      # one tab length, within the reader's rounding


def test_without_tabs_the_part_and_the_hole_fall_out(tmp_path):
    starts, ends = _burned_segments(_compose(tmp_path))
    sheet = shapely.box(0, 0, 60, 40)
    kerf = shapely.union_all([shapely.LineString([a, b]).buffer(0.05) for a, b in zip(starts, ends)])
    assert len(sheet.difference(kerf).geoms) == 3              # the frame, the part, the hole's scrap


def test_perforated_score(tmp_path):
    moves = _compose(tmp_path, op="score", colour="#ff0000", extra="perforate = [3.0, 1.0]")
    starts, ends = _burned_segments(moves)
    # the 16 mm fold line: cut 3, skip 1 → four dashes of 3 mm
    assert np.round(np.hypot(*(ends - starts).T), 3).tolist() == [3.0, 3.0, 3.0, 3.0]
    # cut upwards from y 12 (40 − 28, flipped) or downwards from 28: the order chooses the direction
    assert sorted(np.round(starts[:, 1], 3).tolist()) in ([12.0, 16.0, 20.0, 24.0], [16.0, 20.0, 24.0, 28.0])


@pytest.mark.parametrize("extra, op, match", [
    ("tabs = 2\nperforate = [1.0, 1.0]", "cut", "tabs and perforate together"),
    ("tabs = 40\ntab_mm = 1.0", "cut", r"40 × 1 mm do not fit on a shape 20 mm round"),
    ("tabs = 0", "cut", "tabs = 0; expected a whole number >= 1"),
    ("perforate = [1.0]", "score", r"perforate = \[1.0\]; expected \[x, y\]"),
])
def test_bad_tab_options(tmp_path, extra, op, match):
    with pytest.raises(InputError, match=match):
        _compose(tmp_path, op=op, colour="#000000" if op == "cut" else "#ff0000", extra=extra)


def test_tabs_only_on_cut_and_score(tmp_path, capsys):
    from PIL import Image

    Image.fromarray(np.zeros((4, 4), np.uint8)).save(tmp_path / "dot.png")
    p = tmp_path / "job.toml"
    p.write_text('format = "labkit-job"\nversion = 1\nmachine = "cbr40-laser"\n[[layer]]\nsource = "dot.png"\n'
                 'operation = "image"\npower_mw = 100.0\nspeed_mm_min = 600.0\ntabs = 2\n')
    assert main(["job", str(p), "-o", str(tmp_path / "o.gcode")]) == 1
    assert "tabs and perforate are for cut and score layers, not image" in capsys.readouterr().err
