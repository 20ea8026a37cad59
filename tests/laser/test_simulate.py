"""The virtual material against the closed-form line width, M3/M4 through a stop, and the scan workflow."""

import dataclasses

import numpy as np
import pytest

from labkit.errors import InputError
from labkit.laser.measure import measure_lines
from labkit.laser.models import dose_width
from labkit.laser.patterns import grid_pattern
from labkit.laser.simulate import simulate_burn
from labkit.motion.spec import CBR40
from labkit.toolpath import MovesBuilder
from labkit.units import mw_to_s

W0, FTH = 0.05, 150.0
# a slow machine (100 mm/s²) so the ramps are millimetres long and many beam radii
SLOW = dataclasses.replace(CBR40, accel_mm_s2=(100.0,) * 3)


def _program(mode, *, corner=True, power_mw=1000.0, feed=1200.0, length=6.0):
    b = MovesBuilder(feed_mm_min=feed, s_word=mw_to_s(power_mw, max_power_mw=2500), laser=mode)
    b.rapid(x=0, y=0)
    b.line(x=length)
    if corner:
        b.dwell(0)            # a dwell between two moves: the head stops at the corner
        b.line(y=6)
    return b.build()


@pytest.mark.parametrize("power_mw, feed", [(1000.0, 1200.0), (2000.0, 600.0), (400.0, 1500.0)])
def test_straight_line_at_constant_speed_matches_the_closed_form(power_mw, feed):
    burn = simulate_burn(_program(3, corner=False, power_mw=power_mw, feed=feed, length=12.0), w0_mm=W0, fth_mj_mm2=FTH,
                         machine=SLOW)
    df = burn.line_widths()
    cruise = df[np.isclose(df.speed_mm_s, feed / 60.0)]
    # stations within 3 w0 of the ramps still get some of the slower head's dose: leave them out
    cruise = cruise[(cruise.along_mm > cruise.along_mm.min() + 3 * W0) & (cruise.along_mm < cruise.along_mm.max() - 3 * W0)]
    assert len(cruise) > 20
    expected = dose_width(power_mw, feed, W0, FTH)
    assert expected > 0
    # the simulated grid is w0/8; the widths agree to a hundredth of that
    assert cruise.width_mm.to_numpy() == pytest.approx(expected, abs=burn.pixel_mm / 100)


def test_m4_keeps_the_width_through_a_stop_and_go_corner_where_m3_does_not():
    widths = {}
    for mode in (3, 4):
        burn = simulate_burn(_program(mode), w0_mm=W0, fth_mj_mm2=FTH, machine=SLOW)
        df = burn.line_widths(skip_mm=4 * W0)        # away from the corner's own overlap
        widths[mode] = df
    cruise = dose_width(1000.0, 1200.0, W0, FTH)
    m3, m4 = widths[3], widths[4]
    assert m3.speed_mm_s.min() < 0.4 * 20.0           # the stations reach deep into the ramps
    # M4: power ∝ speed keeps energy per mm, so the width stays the cruise width everywhere
    assert m4.width_mm.to_numpy() == pytest.approx(cruise, abs=1e-4)
    # M3: constant power over a slowing head widens the line towards the stop
    assert m3.width_mm.max() > 1.25 * cruise
    # and where the speed changes slowly the width is the closed form at the local speed
    slow = m3[m3.speed_mm_s < 15]
    local = dose_width(1000.0, 60.0 * slow.speed_mm_s.to_numpy(), W0, FTH)
    assert slow.width_mm.to_numpy() == pytest.approx(local, rel=0.02)


def test_simulated_grid_scanned_and_measured_gives_the_closed_form_widths():
    g = grid_pattern([800.0, 1600.0, 2400.0], [300.0, 900.0, 1500.0], label_mm=0)
    w0, fth = 0.12, 200.0
    burn = simulate_burn(g.moves, w0_mm=w0, fth_mj_mm2=fth, pixel_mm=0.03)
    dpi = 400
    img = burn.scan(dpi=dpi, rotation_deg=-3.0, noise=0.02, blur_px=0.8, seed=4)
    df = measure_lines(img, g.layout, dpi=dpi)
    expected = dose_width(df.power_mw.to_numpy(), df.speed_mm_min.to_numpy(), w0, fth)
    assert (df.burned.to_numpy() == (expected > 0)).all()
    assert np.abs(df.width_mm.to_numpy() - expected).max() < 25.4 / dpi


def test_bad_parameters_are_named():
    with pytest.raises(InputError, match="w0_mm"):
        simulate_burn(_program(3), w0_mm=0.0, fth_mj_mm2=FTH)
    burn = simulate_burn(_program(3, corner=False), w0_mm=W0, fth_mj_mm2=FTH)
    with pytest.raises(InputError, match="finer"):
        burn.scan(dpi=10_000)


def _short_segment_arc(mode):
    """Three quarters of a 3 mm circle as 36 lines of 0.39 mm: the short blocks of CAM output."""
    b = MovesBuilder(feed_mm_min=1800.0, s_word=mw_to_s(1000.0, max_power_mw=2500), laser=mode)
    angle = np.linspace(0.0, 1.5 * np.pi, 37)
    b.rapid(x=3.0, y=0.0)
    for a in angle[1:]:
        b.line(x=3.0 * np.cos(a), y=3.0 * np.sin(a))
    return b.build()


def test_the_planner_mode_changes_m3_widths_on_short_blocks_and_m4_keeps_them():
    """[CBR40]'s MBLA modes plan different speeds over short blocks; under M3 the burn follows
    the speed (wider where the head is slower), under M4 it does not."""
    cruise = dose_width(1000.0, 1800.0, W0, FTH)
    m3, m4 = {}, {}
    for planner in ("fast", "hq", "junction"):
        m3[planner] = simulate_burn(_short_segment_arc(3), w0_mm=W0, fth_mj_mm2=FTH, machine=SLOW,
                                    planner=planner).line_widths()
        m4[planner] = simulate_burn(_short_segment_arc(4), w0_mm=W0, fth_mj_mm2=FTH, machine=SLOW,
                                    planner=planner).line_widths()
    speed = {k: df.speed_mm_s.mean() for k, df in m3.items()}
    width = {k: df.width_mm.mean() for k, df in m3.items()}
    assert speed["hq"] < 0.5 * speed["fast"]                 # the modes really plan differently here
    assert width["hq"] > 1.3 * width["fast"]                  # and M3 burns that difference
    # slower mean speed, wider mean line: the order of the widths is the reverse of the speeds'
    assert sorted(width, key=width.get) == sorted(speed, key=speed.get, reverse=True)
    for planner, df in m3.items():
        # mostly the closed form at the local speed (the speed changes within a beam radius
        # at the block joints, where the dose also comes from the neighbouring speeds)
        local = dose_width(1000.0, 60.0 * df.speed_mm_s.to_numpy(), W0, FTH)
        assert np.median(np.abs(df.width_mm.to_numpy() / local - 1.0)) < 0.02
        # M4 holds the energy per mm whatever the planner does (away from the path's two
        # ends, which lack the dose of the path beyond them)
        w = m4[planner]
        inner = (np.hypot(w.x_mm - 3.0, w.y_mm) > 3 * W0) & (np.hypot(w.x_mm, w.y_mm + 3.0) > 3 * W0)
        assert w.width_mm[inner].to_numpy() == pytest.approx(cruise, rel=0.01)
