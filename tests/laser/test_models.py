"""Dose model against a numerical time integral; fits recover generating parameters; inversion."""

import numpy as np
import pytest
from scipy import integrate

from labkit.errors import InputError
from labkit.laser.models import (dose_width, fit_dose, fit_power_law, lateral_fluence, power_for_width,
                                 power_law_width, speed_for_width, threshold_ratio)


def _intensity(x, y, p_mw, w0):
    """Gaussian beam irradiance, mW/mm², 1/e² radius w0 (textbook form, written independently)."""
    return 2.0 * p_mw / (np.pi * w0 ** 2) * np.exp(-2.0 * (x ** 2 + y ** 2) / w0 ** 2)


@pytest.mark.parametrize("y", [0.0, 0.03, 0.1])
def test_lateral_fluence_is_the_time_integral_of_the_moving_spot(y):
    p, v_min, w0 = 1500.0, 900.0, 0.08
    v = v_min / 60.0
    numeric, _ = integrate.quad(lambda t: _intensity(v * t, y, p, w0), -1.0, 1.0, points=[0.0])
    assert lateral_fluence(y, p, v_min, w0) == pytest.approx(numeric, rel=1e-7)


def test_dose_width_is_where_the_numerical_fluence_crosses_threshold():
    p, v_min, w0, fth = 2000.0, 600.0, 0.1, 250.0
    v = v_min / 60.0

    def excess(y):
        f, _ = integrate.quad(lambda t: _intensity(v * t, y, p, w0), -1.0, 1.0, points=[0.0])
        return f - fth

    from scipy.optimize import brentq
    half = brentq(excess, 0.0, 1.0, xtol=1e-12)
    assert dose_width(p, v_min, w0, fth) == pytest.approx(2 * half, rel=1e-7)
    # below the threshold ratio nothing burns; just above it something does
    r = threshold_ratio(w0, fth)
    assert dose_width(0.99 * r * v_min, v_min, w0, fth) == 0.0
    assert dose_width(1.01 * r * v_min, v_min, w0, fth) > 0.0


def _grid():
    p, v = np.meshgrid(np.linspace(400, 2500, 8), np.linspace(300, 1500, 7))
    return p.ravel(), v.ravel()


def test_fit_dose_recovers_generating_parameters():
    p, v = _grid()
    w = dose_width(p, v, 0.12, 200.0)
    assert (w == 0).any() and (w > 0).sum() > 10     # the grid spans the no-cut region
    exact = fit_dose(p, v, w)
    assert exact.params["w0_mm"] == pytest.approx(0.12, rel=1e-6)
    assert exact.params["fth_mj_mm2"] == pytest.approx(200.0, rel=1e-6)
    rng = np.random.default_rng(4)
    noisy = fit_dose(p, v, np.where(w > 0, w + rng.normal(0, 0.003, w.shape), 0.0))
    assert noisy.params["w0_mm"] == pytest.approx(0.12, rel=0.05)
    assert noisy.params["fth_mj_mm2"] == pytest.approx(200.0, rel=0.05)
    lo, hi = noisy.ci["w0_mm"]
    assert lo < noisy.params["w0_mm"] < hi


def test_fit_power_law_recovers_generating_parameters():
    p, v = _grid()
    w = power_law_width(p, v, 0.05, 0.6, -0.4)
    f = fit_power_law(p, v, w)
    assert [f.params[k] for k in "abc"] == pytest.approx([0.05, 0.6, -0.4], rel=1e-6)
    rng = np.random.default_rng(7)
    # coverage: the 95 % interval on b holds the truth in most of 200 noisy repeats
    hits = 0
    for _ in range(200):
        g = fit_power_law(p, v, w + rng.normal(0, 0.004, w.shape))
        lo, hi = g.ci["b"]
        hits += lo <= 0.6 <= hi
    assert 0.88 <= hits / 200 <= 0.99


@pytest.mark.parametrize("maker", ["dose", "power_law"])
def test_inverse_design_round_trips(maker):
    p, v = _grid()
    if maker == "dose":
        f = fit_dose(p, v, dose_width(p, v, 0.1, 300.0))
    else:
        f = fit_power_law(p, v, power_law_width(p, v, 0.05, 0.6, -0.4))
    speeds = np.array([300.0, 700.0, 1500.0])
    power = power_for_width(f, 0.2, speeds)
    assert f.width(power, speeds) == pytest.approx(0.2, rel=1e-9)
    assert speed_for_width(f, 0.2, power) == pytest.approx(speeds, rel=1e-9)
    with pytest.raises(InputError):
        power_for_width(f, 0.0, 600.0)


def test_too_few_burned_lines_is_a_named_error():
    with pytest.raises(InputError, match="burned"):
        fit_dose([100, 200, 300], [600, 600, 600], [0.0, 0.0, 0.1])
