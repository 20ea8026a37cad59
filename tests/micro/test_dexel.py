"""Dual-dexel ploughing ([MicroCAM] ch. 5): removed area against shapely's exact swept area,
chip and ploughing against the closed forms of a full slot."""

import math

import numpy as np
import pytest
import shapely

from labkit.cli import main
from labkit.errors import GeometryError
from labkit.gcode import parse
from labkit.micromachining.dexel import DualDexel, crescent_area_mm2, plough, slot_plough_share

D, RPM, TEETH = 0.8, 60_000, 2


def _exact_removed(prog_text, lower, upper, r):
    """Stock ∩ (the path, densely sampled, buffered by r): the exact swept area to ~1e-7."""
    m = parse(prog_text)
    from labkit.micromachining.chipvolume import tool_positions
    pts, _, _ = tool_positions(m, np.full(len(m), 0.001))
    start = m.start[np.flatnonzero(m.is_feed)[0], :2]
    path = shapely.LineString(np.vstack([start, pts[:, :2]]))
    return shapely.box(*lower, *upper).intersection(path.buffer(r, quad_segs=512)).area


@pytest.mark.parametrize("prog", [
    "G0 X0.6 Y1.1\nG1 X2.4 Y0.8 F120",                        # a slot starting inside the stock
    "G0 X2.2 Y1\nG2 X1 Y2.2 I-1.2 J0 F120",                    # a quarter circle leaving the stock
])
def test_removed_area_converges_to_shapelys_swept_area(prog):
    lower, upper = (0, 0), (3, 2)
    exact = _exact_removed(prog, lower, upper, D / 2)
    errors = []
    for res in (0.04, 0.02, 0.01, 0.005):
        out = plough(parse(prog), lower, upper, resolution_mm=res, tool_diameter_mm=D, rpm=RPM,
                     teeth=TEETH, scale=20)
        errors.append(abs(out.removed_dual_mm2 / exact - 1))
        # the dexels left plus the removed area are the stock
        left = out.workpiece.areas_mm2()
        assert left[0] + out.removed_mm2[0] == pytest.approx(6.0, rel=1e-12)
    assert errors[-1] < 5e-4
    assert errors[-1] < errors[0] / 2


@pytest.mark.parametrize("t_over_f", [0.3, 0.6, 0.9])
def test_full_slot_ploughing_share_matches_the_crescent(t_over_f):
    ft = 0.001
    prog = parse("G0 X-1 Y1\nG1 X3 F120")
    res = plough(prog, (0, 0), (2, 2), resolution_mm=0.002, tool_diameter_mm=D, rpm=RPM, teeth=TEETH,
                 min_chip_mm=t_over_f * ft, scale=20)
    steady = (res.xyz[:, 0] > 0.6) & (res.xyz[:, 0] < 1.4)
    share = res.plough_mm2[steady].sum() / res.chip_mm2[steady].sum()
    step = 20 * ft                      # the scaled step; T_min scales with it
    exact = slot_plough_share(step, t_over_f * step, D / 2)
    assert share == pytest.approx(exact, abs=0.015)
    assert share == pytest.approx(slot_plough_share(ft, t_over_f * ft), abs=0.02)      # first order
    # each step's chip is the crescent the circle uncovers, shared by the two families exactly
    assert res.chip_mm2[steady].mean() == pytest.approx(crescent_area_mm2(D / 2, step), rel=1e-3)
    # ploughing sits at the ends of the crescent, |ψ| > acos(T/f) from the feed direction:
    # on a slot along y = 1, |y − 1| = r·sin ψ > r·√(1 − (T/f)²)
    pts = res.plough_points[(res.plough_points[:, 0] > 0.8) & (res.plough_points[:, 0] < 1.2)]
    assert len(pts)
    assert np.all(np.abs(pts[:, 1] - 1.0) >= D / 2 * math.sqrt(1 - t_over_f ** 2) - 0.004)


def test_ploughing_share_converges_as_the_step_shrinks():
    gaps = []
    for scale, res in ((20, 0.002), (10, 0.001), (5, 0.0005)):
        out = plough(parse("G0 X0.5 Y1\nG1 X1.5 F120"), (0, 0), (2, 2), resolution_mm=res, tool_diameter_mm=D,
                     rpm=RPM, teeth=TEETH, min_chip_mm=0.0006, scale=scale)
        st = (out.xyz[:, 0] > 0.95) & (out.xyz[:, 0] < 1.4)
        step = 0.001 * scale
        gaps.append(slot_plough_share(step, 0.6 * step, D / 2) - out.plough_mm2[st].sum() / out.chip_mm2[st].sum())
    assert all(0 < b < 0.6 * a for a, b in zip(gaps, gaps[1:]))
    assert gaps[-1] < 0.004


def test_ploughing_rises_as_the_feed_falls():
    shares = []
    for feed in (60, 84, 96, 120, 240):        # 0.5, 0.7, 0.8, 1, 2 µm/tooth; T_min = 0.6 µm
        res = plough(parse(f"G0 X-1 Y1\nG1 X3 F{feed}"), (0, 0), (2, 2), resolution_mm=0.002,
                     tool_diameter_mm=D, rpm=RPM, teeth=TEETH, edge_radius_mm=0.002,
                     scale=10 * 120 / feed)     # the same 0.01 mm step for every feed
        st = (res.xyz[:, 0] > 0.6) & (res.xyz[:, 0] < 1.4)
        shares.append(res.plough_mm2[st].sum() / res.chip_mm2[st].sum())
        assert shares[-1] == pytest.approx(slot_plough_share(feed / 120_000, 0.0006), abs=0.01)
    assert shares[0] == pytest.approx(1.0)                  # f < T_min: all of the chip ploughs
    assert all(b < a for a, b in zip(shares, shares[1:]))


def test_dexel_errors():
    with pytest.raises(GeometryError, match="resolution_mm"):
        DualDexel((0, 0), (1, 1), 0)
    with pytest.raises(GeometryError, match="upper > lower"):
        DualDexel((0, 0), (0, 1), 0.1)
    with pytest.raises(GeometryError, match="min_chip_mm"):
        plough(parse("G1 X1 F10"), (0, 0), (1, 1), resolution_mm=0.1, tool_diameter_mm=0.5, rpm=1000,
               teeth=2, min_chip_mm=-1)


def test_plough_command(tmp_path, capsys):
    src = tmp_path / "slot.gcode"
    src.write_text("G0 X-1 Y1\nG1 X3 F120\n")
    csv = tmp_path / "steps.csv"
    assert main(["plough", str(src), "--tool-d", "0.8", "--teeth", "2", "--rpm", "60000",
                 "--resolution", "0.004", "--min-chip", "0.0006", "--scale", "20",
                 "--stock", "0", "0", "2", "2", "--csv", str(csv)]) == 0
    out = capsys.readouterr().out
    assert "ploughing" in out and "removed" in out
    rows = csv.read_text().splitlines()
    assert rows[0].startswith("x_mm,y_mm") and len(rows) > 10
