"""Dose model against a numerical time integral; fits recover generating parameters; inversion."""

import numpy as np
import pytest
from scipy import integrate

from labkit.errors import InputError
from labkit.laser.models import (cross_validate, cut_probability, dose_width, empirical_width, fit_cut_through,
                                 fit_dose, fit_empirical, fit_power_law, lateral_fluence, power_band,
                                 power_for_width, power_law_width, speed_for_width, threshold_ratio)


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


@pytest.mark.parametrize("maker", ["dose", "power_law", "empirical"])
def test_inverse_design_round_trips(maker):
    p, v = _grid()
    if maker == "dose":
        f = fit_dose(p, v, dose_width(p, v, 0.1, 300.0))
    elif maker == "empirical":
        f = fit_empirical(p, v, dose_width(p, v, 0.1, 100.0))
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


def _curved(p, v):
    """Widths that grow faster above ~2000 mW, like [CBR40] figure 10 (made up: ln W quadratic in ln P)."""
    prm = dict(degree=2, ln_p0=np.log(1500.0), ln_v0=np.log(800.0), c00=np.log(0.15), c10=0.5, c01=-0.45,
               c20=0.6, c11=0.0, c02=0.05)
    return prm, empirical_width(p, v, prm)


def test_fit_empirical_recovers_a_curved_surface_and_cross_validation_prefers_it():
    p, v = _grid()
    prm, w = _curved(p, v)
    f = fit_empirical(p, v, w)
    # the centres differ from the generator's, so compare the surface, not the coefficients
    assert f.width(p, v) == pytest.approx(w, rel=1e-9)
    rng = np.random.default_rng(11)
    noisy = w * np.exp(rng.normal(0, 0.02, w.shape))
    cv = cross_validate(p, v, noisy)
    assert min(cv, key=cv.get) == "empirical"
    assert cv["empirical"] < 0.5 * min(cv["dose"], cv["power_law"])
    # and on dose-model data the dose model wins
    wd = dose_width(p, v, 0.12, 200.0)
    cv = cross_validate(p, v, np.where(wd > 0, wd + rng.normal(0, 0.003, wd.shape), 0.0))
    assert min(cv, key=cv.get) == "dose"


def test_cut_through_logistic_finds_the_ratio_even_when_the_classes_separate():
    p, v = _grid()
    ratio = 1.7
    cut = p / v > ratio
    m = fit_cut_through(p, v, cut)
    assert m["b1"] > 0
    # separated data: the 50 % point lies between the last uncut and the first cut ratio
    r = p / v
    assert r[~cut].max() <= m["ratio50_mw_per_mm_min"] <= r[cut].min()
    assert ((cut_probability(m, p, v) > 0.5) == cut).all()
    # overlapping classes drawn from a known logistic: slope and midpoint recovered
    rng = np.random.default_rng(2)
    pp, vv = rng.uniform(300, 2500, 4000), rng.uniform(300, 1500, 4000)
    truth = 1 / (1 + np.exp(-(4.0 * np.log(pp / vv / ratio))))
    m = fit_cut_through(pp, vv, rng.random(4000) < truth)
    assert m["b1"] == pytest.approx(4.0, rel=0.15)
    assert m["ratio50_mw_per_mm_min"] == pytest.approx(ratio, rel=0.05)


def test_power_band_matches_refits_of_resampled_data():
    """The delta-method band against the spread of powers from fits to fresh noisy data sets."""
    p, v = _grid()
    w = dose_width(p, v, 0.12, 200.0)
    rng = np.random.default_rng(8)
    sd = 0.004
    powers, widths = [], []
    for _ in range(300):
        f = fit_dose(p, v, np.where(w > 0, w + rng.normal(0, sd, w.shape), 0.0))
        powers.append(float(power_for_width(f, 0.2, 600.0)))
        widths.append(power_band(f, 0.2, 600.0))
    spread = np.std(powers)
    half = np.median([(hi - lo) / 2 for _, lo, hi in widths])
    assert half / 1.96 == pytest.approx(spread, rel=0.2)
    true_power = float(power_for_width(fit_dose(p, v, w), 0.2, 600.0))
    hits = np.mean([lo <= true_power <= hi for _, lo, hi in widths])
    assert 0.9 <= hits <= 0.99


def _near_threshold_grid():
    """Lines from just above the no-cut boundary (1.02 ×) to 1.6 × its power/speed ratio."""
    v, k = np.meshgrid(np.linspace(300, 1500, 7), np.linspace(1.02, 1.6, 8))
    return (k * threshold_ratio(0.12, 200.0) * v).ravel(), v.ravel()


def test_fit_dose_on_lines_crowding_the_threshold():
    # Liu's line W² against ln(P/v) gives the start; with its intercept's sign wrong the fit used
    # to stall at F_th ≈ 800 with infinite intervals on exactly these data
    p, v = _near_threshold_grid()
    f = fit_dose(p, v, dose_width(p, v, 0.12, 200.0))
    assert [f.params["w0_mm"], f.params["fth_mj_mm2"]] == pytest.approx([0.12, 200.0], rel=1e-6)
    assert np.all(np.isfinite(f.cov))


@pytest.mark.parametrize("layout", ["spanning", "near threshold"])
def test_dose_intervals_cover_at_their_stated_rate(layout):
    """95 % intervals over 1000 noisy data sets: the documented rate (94.1-95.1 %), binomial SE 0.7 %."""
    p, v = _grid() if layout == "spanning" else _near_threshold_grid()
    w = dose_width(p, v, 0.12, 200.0)
    rng = np.random.default_rng(21)
    hits = np.zeros(2)
    for _ in range(1000):
        noisy = w + rng.normal(0, 0.006, w.shape)
        f = fit_dose(p, v, np.where((w > 0) & (noisy > 0), noisy, 0.0))
        hits += [f.ci["w0_mm"][0] <= 0.12 <= f.ci["w0_mm"][1],
                 f.ci["fth_mj_mm2"][0] <= 200.0 <= f.ci["fth_mj_mm2"][1]]
    assert np.all((0.925 <= hits / 1000) & (hits / 1000 <= 0.97)), hits / 1000


def test_data_that_do_not_fix_both_dose_parameters_are_refused():
    # one power/speed ratio repeated: the width is the same everywhere, w0 and F_th trade off freely
    p = np.array([1000.0, 2000.0, 3000.0, 4000.0])
    with pytest.raises(InputError):
        fit_dose(p, p / 2, np.full(4, 0.15))


def test_cut_through_fit_is_the_optimum_to_the_last_digits():
    """Logistic regression with an unpenalised intercept: at the optimum the predicted
    probabilities sum to the number of lines cut (the intercept's score equation), so a
    speed derived from the fit does not wobble with the optimiser's stopping point."""
    rng = np.random.default_rng(5)
    p, v = rng.uniform(300, 2500, 60), rng.uniform(300, 1500, 60)
    cut = rng.random(60) < 1 / (1 + np.exp(-3.0 * np.log(p / v / 1.5)))
    m = fit_cut_through(p, v, cut)
    assert abs(cut_probability(m, p, v).sum() - cut.sum()) < 1e-8
    # the same data in another order: the same coefficients to ~1e-12
    order = rng.permutation(60)
    m2 = fit_cut_through(p[order], v[order], cut[order])
    assert m2["b0"] == pytest.approx(m["b0"], rel=1e-10) and m2["b1"] == pytest.approx(m["b1"], rel=1e-10)
