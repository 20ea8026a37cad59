"""Block speed profiles: closed forms checked by independent quadrature and by hand."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import quad
from scipy.optimize import brentq

from labkit.errors import MotionError
from labkit.motion.profile import block_profiles, ramp_distance, ramp_time, reach_speed


def _random_feasible(rng, law):
    L = rng.uniform(0.01, 50.0)
    up, down = rng.uniform(5, 200, 2) if law == "linear" else rng.uniform(50, 5000, 2)
    cap = rng.uniform(1.0, 60.0)
    lo = 1e-3 if law == "linear" else 0.0
    ve = rng.uniform(lo, cap)
    vx = rng.uniform(lo, cap)
    # make the pair reachable within L
    vx = min(vx, reach_speed(ve, L, up, law))
    ve = min(ve, reach_speed(vx, L, down, law))
    return L, ve, cap, vx, up, down


@pytest.mark.parametrize("law", ["linear", "accel"])
def test_distance_under_speed_curve_equals_length(law):
    rng = np.random.default_rng(5 if law == "linear" else 6)
    for _ in range(300):
        L, ve, cap, vx, up, down = _random_feasible(rng, law)
        p = block_profiles(L, ve, cap, vx, up, down, law)
        ta, tc, td = p.accel_s[0], p.cruise_s[0], p.decel_s[0]
        # integrate v(t) piecewise with adaptive quadrature (independent of the distance formulas)
        area = 0.0
        for lo, hi in ((0, ta), (ta, ta + tc), (ta + tc, ta + tc + td)):
            if hi > lo:
                area += quad(lambda t: float(p.sample(0, t)[1]), lo, hi, epsabs=0, epsrel=1e-13)[0]
        assert area == pytest.approx(L, rel=1e-9, abs=1e-12)
        # time from the closed forms = integral of ds / v(s)
        t_num = sum(quad(lambda s: 1.0 / float(p.speed_at(0, s)), a, b, epsabs=0, epsrel=1e-12)[0]
                    for a, b in ((0, p.accel_mm[0]), (p.accel_mm[0], p.accel_mm[0] + p.cruise_mm[0]),
                                 (p.accel_mm[0] + p.cruise_mm[0], L)) if b > a)
        assert p.time_s[0] == pytest.approx(t_num, rel=1e-9)
        # limits: never above the cap; entry and exit honoured
        assert p.peak_mm_s[0] <= cap * (1 + 1e-12)
        s, v = p.sample(0, np.linspace(0, p.time_s[0], 200))
        assert np.all(v <= cap * (1 + 1e-12)) and np.all(np.diff(s) >= -1e-12)
        assert v[0] == pytest.approx(ve, abs=1e-9) and v[-1] == pytest.approx(vx, rel=1e-7, abs=1e-9)


def test_peak_lowered_where_the_ramps_meet_cbr40_fig13():
    # 2 mm from and to 1 mm/s, cap 100 mm/s, slopes 40 and 60 Hz/step: the ramps meet where
    # 1 + 40 s = 1 + 60 (2 − s) -> s = 1.2 mm, v = 49 mm/s (found here by root finding).
    p = block_profiles(2.0, 1.0, 100.0, 1.0, 40, 60)
    s_star = brentq(lambda s: (1 + 40 * s) - (1 + 60 * (2 - s)), 0, 2)
    assert p.peak_mm_s[0] == pytest.approx(1 + 40 * s_star, rel=1e-12)
    assert p.accel_mm[0] == pytest.approx(s_star, rel=1e-12)
    assert p.cruise_mm[0] == 0 and p.shape_name[0] == "triangle"


def test_accel_only_and_decel_only_cbr40_fig14():
    up = block_profiles(1.0, 2.0, 100.0, 42.0, 40, 40)          # 2 + 40·1 = 42: ramp up only
    assert up.shape_name[0] == "accel" and up.peak_mm_s[0] == pytest.approx(42.0)
    down = block_profiles(1.0, 42.0, 100.0, 2.0, 40, 40)
    assert down.shape_name[0] == "decel"
    cruise = block_profiles(1.0, 10.0, 10.0, 10.0, 40, 40)
    assert cruise.shape_name[0] == "cruise" and cruise.time_s[0] == pytest.approx(0.1)
    trap = block_profiles(10.0, 1.0, 20.0, 1.0, 40, 40)
    assert trap.shape_name[0] == "trapezoid"


def test_constant_acceleration_closed_forms_by_hand():
    # 0 → 20 mm/s at 500 mm/s²: 0.04 s over 0.4 mm; a 2 mm block cruises 1.2 mm for 0.06 s.
    p = block_profiles(2.0, 0.0, 20.0, 0.0, 500.0, 500.0, "accel")
    assert (p.accel_mm[0], p.cruise_mm[0], p.decel_mm[0]) == pytest.approx((0.4, 1.2, 0.4))
    assert p.time_s[0] == pytest.approx(0.04 + 0.06 + 0.04)
    assert ramp_time(0.0, 20.0, 500.0, "accel") == pytest.approx(0.04)
    assert ramp_distance(0.0, 20.0, 500.0, "accel") == pytest.approx(0.4)


@settings(max_examples=200, deadline=None)
@given(st.floats(0.1, 30), st.floats(1, 200), st.floats(0.01, 10))
def test_linear_ramp_time_is_log_ratio(v0, slope, d):
    v1 = reach_speed(v0, d, slope)
    assert v1 == pytest.approx(v0 + slope * d)
    assert ramp_time(v0, v1, slope) == pytest.approx(math.log(v1 / v0) / slope)
    assert ramp_distance(v0, v1, slope) == pytest.approx(d)


@pytest.mark.parametrize("args,law,match", [
    ((1.0, 5.0, 50.0, 46.0, 40, 40), "linear", "block 0: exit speed cannot be reached"),
    ((1.0, 46.0, 50.0, 5.0, 40, 40), "linear", "block 0: entry speed cannot be reached"),
    ((0.0, 1.0, 10.0, 1.0, 40, 40), "linear", "length_mm must be > 0 mm"),
    ((1.0, 0.0, 10.0, 1.0, 40, 40), "linear", r"entry_mm_s must be in \(0, cap\]"),
    ((1.0, 11.0, 10.0, 1.0, 40, 40), "linear", "entry_mm_s must be in"),
    ((1.0, 1.0, 10.0, -1.0, 40, 40), "accel", r"exit_mm_s must be in \[0, cap\]"),
    ((1.0, 1.0, 10.0, 1.0, 0, 40), "linear", "up must be > 0"),
    ((1.0, 1.0, 10.0, 1.0, 40, -2), "linear", "down must be > 0"),
    ((1.0, 1.0, 0.0, 1.0, 40, 40), "linear", "cap_mm_s must be > 0"),
    ((1.0, 1.0, 10.0, 1.0, 40, 40), "cubic", "ramp law must be one of"),
])
def test_profile_errors(args, law, match):
    with pytest.raises(MotionError, match=match):
        block_profiles(*args, law=law)
