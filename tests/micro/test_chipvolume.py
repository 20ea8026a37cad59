"""Chip volume on the z-map ([MicroCAM] ch. 3.1) against closed forms; feed scheduling (eq. 3.2,
ch. 3.4) against hand-worked cases and the seed's qualitative results."""

import math

import numpy as np
import pytest

from labkit.cli import main
from labkit.errors import GeometryError
from labkit.gcode import emit, parse, parse_file
from labkit.micromachining.chipvolume import ZMap, chip_volumes, feed_per_tooth_mm
from labkit.micromachining.feedschedule import (SEED_BLOCK_TIME_S, moving_average, optimal_feed_per_tooth,
                                                schedule_feeds)
from labkit.toolpath import patterns

D, RPM, TEETH = 0.794, 60_000, 2


def _slot_volume(cell):
    prog = parse("G0 X-1 Y2 Z-0.05\nG1 X6 F120")             # across the whole 5 mm stock
    stock = ZMap.stock((0, 0), (5, 4), top_z=0, bottom_z=-1, cell_mm=cell)
    cv = chip_volumes(prog, stock, tool_diameter_mm=D, rpm=RPM, teeth=TEETH, scale=20)
    return cv.volume_mm3.sum()


def test_full_slot_volume_converges_to_width_times_depth_times_length():
    exact = D * 0.05 * 5.0
    errors = [abs(_slot_volume(c) / exact - 1) for c in (0.02, 0.01, 0.005)]
    assert errors[-1] < 0.01
    assert errors[2] < errors[0]


def test_circular_pocket_volume_is_the_swept_annulus():
    rho, depth = 1.0, 0.03
    prog = parse(f"G0 X{2 + rho} Y2 Z0.1\nG1 Z-{depth} F120\nG2 X{2 + rho} Y2 I-{rho} J0")
    stock = ZMap.stock((0, 0), (4, 4), top_z=0, bottom_z=-1, cell_mm=0.004)
    cv = chip_volumes(prog, stock, tool_diameter_mm=D, rpm=RPM, teeth=TEETH, scale=20)
    exact = 4 * math.pi * rho * (D / 2) * depth                # π((ρ+R)² − (ρ−R)²) · depth
    assert cv.volume_mm3.sum() == pytest.approx(exact, rel=0.01)
    assert cv.workpiece.volume_mm3() == pytest.approx(stock.volume_mm3() - cv.volume_mm3.sum(), rel=1e-12)


@pytest.mark.parametrize("ae_frac", [1.0, 0.5, 0.25])
def test_steady_chip_per_tooth_is_ae_times_ap_times_ft(ae_frac):
    R, ap = D / 2, 0.05
    ae = 2 * R * ae_frac
    # first pass a slot at y = 2; the second, offset so that it engages ae of new material
    y2 = 2 + ae if ae_frac < 1 else 2
    first = "G0 X-1 Y2 Z-0.05\nG1 X6 F120\nG0 Z1\n" if ae_frac < 1 else ""
    prog = parse(first + f"G0 X-1 Y{y2}\nG0 Z-0.05\nG1 X6 F120")
    stock = ZMap.stock((0, 0), (5, 4), top_z=0, bottom_z=-1, cell_mm=0.003)
    cv = chip_volumes(prog, stock, tool_diameter_mm=D, rpm=RPM, teeth=TEETH, scale=10)
    last = cv.move == cv.move.max()
    steady = cv.per_tooth_mm3[last & (cv.xyz[:, 0] > 1.5) & (cv.xyz[:, 0] < 3.5)]
    ft = feed_per_tooth_mm(120, RPM, TEETH)
    assert ft == pytest.approx(0.001)
    assert steady.mean() == pytest.approx(ae * ap * ft, rel=0.02)


def test_equation_3_2_and_the_moving_average():
    assert optimal_feed_per_tooth([2.0, 4.0, 3.0], 1.0, 1.5).tolist() == [1.5, 1.0, 1.25]
    assert optimal_feed_per_tooth([7.0, 7.0], 1.0, 1.5).tolist() == [1.0, 1.0]
    x = np.random.default_rng(3).normal(size=50)
    assert np.allclose(moving_average(x, 7)[3:-3], np.convolve(x, np.ones(7) / 7, mode="valid"))
    with pytest.raises(GeometryError, match="odd"):
        moving_average(x, 4)
    with pytest.raises(GeometryError, match="ft_min_mm"):
        optimal_feed_per_tooth(x, 0.002, 0.001)


@pytest.fixture(scope="module")
def pocket():
    """A square-spiral pocket from the centre out: the first leg is a full slot."""
    moves, _ = patterns.square_spiral((2, 2), 3.0, 0.5, z_mm=-0.05, feed_mm_min=120, loops=False)
    stock = ZMap.stock((0, 0), (4, 4), top_z=0, bottom_z=-1, cell_mm=0.005)
    return moves, schedule_feeds(moves, stock, tool_diameter_mm=D, rpm=RPM, teeth=TEETH,
                                 ft_min_mm=0.001, ft_max_mm=0.0015, scale=10, window=5, feed_decimals=2)


def test_feed_rises_where_the_chip_volume_falls(pocket):
    moves, s = pocket
    v = s.chips.per_tooth_mm3
    assert np.corrcoef(v, s.ft_position_mm)[0, 1] < -0.5
    # the first leg (full immersion) is the slowest block
    cut = np.flatnonzero(moves.is_feed)
    assert np.nanargmin(s.ft_block_mm) == cut[0]
    assert s.ft_position_mm.min() >= 0.001 - 1e-12 and s.ft_position_mm.max() <= 0.0015 + 1e-12


def test_both_variants_trace_the_same_path(pocket):
    moves, s = pocket
    assert len(s.per_block) == len(moves)                                  # block count kept
    assert len(s.per_position) > len(moves)
    for variant in (s.per_block, s.per_position):
        assert variant.lengths_mm().sum() == pytest.approx(moves.lengths_mm().sum(), rel=1e-12)
        back = parse(emit(variant))
        assert np.allclose(back.end[-1], moves.end[-1], atol=1e-3)
        assert np.allclose(back.feed_mm_min[back.is_feed], variant.feed_mm_min[variant.is_feed], atol=0.01)
    # every original block end is still a block end of the per-position program
    ends = {tuple(np.round(p, 9)) for p in s.per_position.end}
    assert all(tuple(np.round(p, 9)) in ends for p in moves.end)


def test_times_reproduce_the_seeds_comparison(pocket):
    moves, s = pocket
    t = s.times_s()
    assert t["per_block"] < t["original"]                     # higher feeds where the chip is thin
    slow = s.times_s(block_time_s=SEED_BLOCK_TIME_S)
    assert slow["per_position"] > slow["per_block"]           # many short blocks lose the gain


def test_errors_are_named():
    stock = ZMap.stock((0, 0), (1, 1), top_z=0, bottom_z=-1, cell_mm=0.01)
    with pytest.raises(GeometryError, match="rpm"):
        chip_volumes(parse("G1 X1 F10"), stock, tool_diameter_mm=1, rpm=0, teeth=2)
    with pytest.raises(GeometryError, match="XY plane"):
        chip_volumes(parse("G18 G2 X1 Z1 I0.5 K0.5 F10"), stock, tool_diameter_mm=1, rpm=1000, teeth=2)
    with pytest.raises(GeometryError, match="no feed moves"):
        chip_volumes(parse("G0 X1"), stock, tool_diameter_mm=1, rpm=1000, teeth=2)
    with pytest.raises(GeometryError, match="stock"):
        ZMap.stock((0, 0), (0, 1))


def test_millfeed_command(tmp_path, capsys):
    moves, _ = patterns.square_spiral((2, 2), 3.0, 0.5, z_mm=-0.05, feed_mm_min=120, loops=False)
    src = tmp_path / "pocket.gcode"
    src.write_text(emit(moves))
    out = tmp_path / "opt.gcode"
    argv = ["millfeed", str(src), "--tool-d", "0.794", "--teeth", "2", "--rpm", "60000",
            "--ft-min", "0.001", "--ft-max", "0.0015", "--stock", "0", "0", "4", "4", "-o", str(out)]
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "per block" in text and "time" in text
    assert len(parse_file(str(out))) == len(parse(src.read_text()))
    assert main(argv[:-2] + ["--per-position", "-o", str(out)]) == 0
    assert len(parse_file(str(out))) > len(moves)
    bad = [a if a not in ("0.001", "0.0015") else {"0.001": "0.002", "0.0015": "0.001"}[a] for a in argv]
    assert main(bad) == 1
    assert "ft_min" in capsys.readouterr().err
