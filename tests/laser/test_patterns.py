"""Test grids: steps, layout against the G-code read back, overscan at constant speed, job time."""

import json

import numpy as np
import pytest

from labkit.errors import InputError
from labkit.gcode.reader import parse
from labkit.laser.patterns import grid_pattern, steps, stroke_digits, write_pattern
from labkit.toolpath import MoveKind


def test_steps_linear_and_geometric_spacing():
    lin = steps(300, 1500, 7)
    assert np.allclose(np.diff(lin), (1500 - 300) / 6)
    geo = steps(100, 2500, 6, scale="geometric")
    ratio = (2500 / 100) ** (1 / 5)
    assert np.allclose(geo[1:] / geo[:-1], ratio)
    assert geo[0] == pytest.approx(100) and geo[-1] == pytest.approx(2500)
    with pytest.raises(InputError):
        steps(0, 10, 3, scale="geometric")
    with pytest.raises(InputError):
        steps(1, 10, 0)


@pytest.mark.parametrize("dialect", ["grbl", "marlin", "labkit-fw"])
def test_gcode_burns_exactly_the_layout_lines(dialect):
    powers, speeds = [500.0, 1250.0, 2500.0], [300.0, 900.0]
    g = grid_pattern(powers, speeds, line_mm=8, overscan_mm=2, gap_mm=5, repeats=2,
                     label_mm=0, fiducial_mm=0)
    back = parse(g.gcode(dialect), dialect=dialect)
    on = np.flatnonzero((back.kind == MoveKind.LINE) & (back.s_word > 0))
    # every burning move is one layout line, at S = P/2500·1000 and the programmed feed
    assert len(on) == len(powers) * len(speeds) * 2
    lines = sorted(g.layout["lines"], key=lambda d: (d["y_mm"], d["x0_mm"]))
    got = sorted(on, key=lambda k: (back.start[k, 1], back.start[k, 0]))
    for d, k in zip(lines, got):
        assert back.start[k, :2] == pytest.approx([d["x0_mm"], d["y_mm"]], abs=1e-3)
        assert back.end[k, :2] == pytest.approx([d["x1_mm"], d["y_mm"]], abs=1e-3)
        assert back.feed_mm_min[k] == pytest.approx(d["speed_mm_min"])
        assert back.s_word[k] * 2500 / back.s_max == pytest.approx(d["power_mw"], rel=1e-3)
        # the approach is a beam-off move on the same row at the same feed, overscan long
        prev = k - 1
        while back.kind[prev] != MoveKind.LINE:
            prev -= 1
        assert back.s_word[prev] == 0
        assert back.end[prev, :2] == pytest.approx(back.start[k, :2], abs=1e-3)
        assert back.end[prev, 0] - back.start[prev, 0] == pytest.approx(2.0, abs=1e-3)
        assert back.feed_mm_min[prev] == pytest.approx(d["speed_mm_min"])


def test_passes_repeat_each_burn():
    g = grid_pattern([1000.0], [600.0], passes=3, label_mm=0, fiducial_mm=0)
    burn = (g.moves.kind == MoveKind.LINE) & (g.moves.s_word > 0)
    assert burn.sum() == 3


def test_job_time_at_least_cut_length_over_feed():
    g = grid_pattern([1000.0, 2000.0], [300.0, 1200.0], label_mm=0, fiducial_mm=0)
    m = g.moves
    cut = m.kind == MoveKind.LINE
    length = np.linalg.norm(m.end[cut] - m.start[cut], axis=1)
    lower = float(np.sum(length / (m.feed_mm_min[cut] / 60.0)))
    t = g.job_time_s()
    # ramps only add time; travel adds more, but not more than the cuts at these sizes
    assert lower < t < 2.5 * lower


def test_stroke_font_digits_stay_in_their_cell():
    polys = stroke_digits("0123456789", x_mm=1.0, y_mm=2.0, height_mm=4.0)
    pts = np.vstack(polys)
    assert pts[:, 1].min() == pytest.approx(2.0) and pts[:, 1].max() == pytest.approx(6.0)
    assert pts[:, 0].min() == pytest.approx(1.0) and pts[:, 0].max() == pytest.approx(1.0 + 27 + 2)
    with pytest.raises(InputError):
        stroke_digits("1a", x_mm=0, y_mm=0, height_mm=1)


def test_labels_and_fiducials_burn_outside_the_lines(tmp_path):
    g = grid_pattern([800.0, 1600.0], [300.0, 600.0, 1200.0])
    assert len(g.layout["fiducials_mm"]) == 4
    fx = np.array(g.layout["fiducials_mm"])
    xs = [d["x0_mm"] for d in g.layout["lines"]] + [d["x1_mm"] for d in g.layout["lines"]]
    ys = [d["y_mm"] for d in g.layout["lines"]]
    inside = ((fx[:, 0] > min(xs)) & (fx[:, 0] < max(xs)) & (fx[:, 1] > min(ys)) & (fx[:, 1] < max(ys)))
    assert not inside.any()
    path = write_pattern(tmp_path / "grid.gcode", g, dialect="marlin")
    data = json.loads(path.read_text())
    assert data["gcode"] == "grid.gcode" and data["dialect"] == "marlin"
    assert len(data["lines"]) == 6
    assert (tmp_path / "grid.gcode").read_text().count("M3") > 0


@pytest.mark.parametrize("kw", [dict(powers_mw=[0.0]), dict(speeds_mm_min=[-5.0]),
                                dict(powers_mw=[3000.0]), dict(overscan_mm=5.0, gap_mm=4.0),
                                dict(repeats=0), dict(line_mm=float("nan"))])
def test_bad_parameters_are_named(kw):
    args = dict(powers_mw=[1000.0], speeds_mm_min=[600.0])
    args.update(kw)
    with pytest.raises(InputError, match=next(iter(kw)).split("_")[0]):
        grid_pattern(**args)
