"""Cut width against power and speed: the Gaussian line-dose model and an empirical power law.

Dose model. A Gaussian beam of 1/e² radius ``w0`` and power ``P`` moving at ``v``
leaves, at lateral distance ``y`` from its track, the fluence (energy per area)

    F(y) = sqrt(2/π) · P / (v · w0) · exp(−2 y² / w0²),

so the material burns (F above a threshold ``F_th``) over the width

    W = w0 · sqrt(2 · ln(F_peak / F_th)),   F_peak = sqrt(2/π) · P / (v · w0),

and nothing burns where P / v is below ``F_th · w0 · sqrt(π/2)`` — the no-cut
region of [CBR40] figure 10. W² is linear in ln(P / v) with slope 2·w0² (Liu's
method for a moving beam). The power/speed ratio P / v is [CBR40] §IV's
quantity, so a fixed width is a fixed ratio in this model. [CBR40] reports
widths that grow faster than this above about 2000 mW; the empirical model
``W = a · P^b · v^c`` is there to follow such data.

Units: power mW, speed mm/min, widths and radii mm, fluence mJ/mm².
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import optimize, stats

from labkit.errors import InputError
from labkit.units import mm_min_to_mm_s

__all__ = ["peak_fluence", "lateral_fluence", "dose_width", "threshold_ratio", "Fit",
           "fit_dose", "fit_power_law", "power_law_width", "power_for_width", "speed_for_width"]

_GAUSS = np.sqrt(2.0 / np.pi)


def peak_fluence(power_mw, speed_mm_min, w0_mm):
    """Peak fluence on the track of a moving Gaussian beam, mJ/mm².

    Parameters
    ----------
    power_mw : float or array
        Optical power, mW.
    speed_mm_min : float or array
        Speed, mm/min.
    w0_mm : float
        1/e² beam radius, mm.

    Examples
    --------
    1000 mW at 600 mm/min (10 mm/s) with w0 = 0.1 mm: sqrt(2/π)·1000/(10·0.1).

    >>> round(float(peak_fluence(1000, 600, 0.1)), 3)
    797.885
    """
    return _GAUSS * np.asarray(power_mw, float) / (mm_min_to_mm_s(np.asarray(speed_mm_min, float)) * w0_mm)


def lateral_fluence(y_mm, power_mw, speed_mm_min, w0_mm):
    """Fluence at lateral offset ``y_mm`` from the track, mJ/mm² (closed form of the time integral)."""
    y = np.asarray(y_mm, float)
    return peak_fluence(power_mw, speed_mm_min, w0_mm) * np.exp(-2.0 * y ** 2 / w0_mm ** 2)


def dose_width(power_mw, speed_mm_min, w0_mm, fth_mj_mm2):
    """Burned width of the dose model, mm (0 where the peak fluence is below threshold).

    Parameters
    ----------
    power_mw, speed_mm_min : float or array
        Power (mW) and speed (mm/min); broadcast together.
    w0_mm : float
        1/e² beam radius, mm.
    fth_mj_mm2 : float
        Threshold fluence, mJ/mm².

    Examples
    --------
    At F_peak = e·F_th the width is w0·sqrt(2).

    >>> f = float(peak_fluence(1000, 600, 0.1)) / np.e
    >>> round(float(dose_width(1000, 600, 0.1, f)) / 0.1, 6)
    1.414214
    """
    ratio = peak_fluence(power_mw, speed_mm_min, w0_mm) / fth_mj_mm2
    return w0_mm * np.sqrt(2.0 * np.log(np.maximum(ratio, 1.0)))


def threshold_ratio(w0_mm, fth_mj_mm2):
    """The power/speed ratio below which nothing burns, mW per mm/min."""
    # F_peak = F_th  ⇔  P / v_mm_s = F_th · w0 / sqrt(2/π); v in mm/min is 60 × mm/s
    return fth_mj_mm2 * w0_mm / _GAUSS / 60.0


@dataclass
class Fit:
    """A fitted model: parameters, their confidence intervals, and fit quality.

    Attributes
    ----------
    model : str
        ``"dose"`` (params ``w0_mm``, ``fth_mj_mm2``) or ``"power_law"``
        (params ``a``, ``b``, ``c`` of W = a·P^b·v^c).
    params : dict
    ci : dict
        Name → (low, high) at ``level`` (from the covariance, t distribution;
        the dose model's threshold interval is mapped from its log).
    level : float
    rmse_mm : float
        Root-mean-square width residual, mm.
    n : int
        Points used (burned lines only).
    """

    model: str
    params: dict
    ci: dict
    level: float
    rmse_mm: float
    n: int

    def width(self, power_mw, speed_mm_min):
        """Predicted width, mm."""
        if self.model == "dose":
            return dose_width(power_mw, speed_mm_min, self.params["w0_mm"], self.params["fth_mj_mm2"])
        return power_law_width(power_mw, speed_mm_min, self.params["a"], self.params["b"], self.params["c"])

    def to_dict(self) -> dict:
        return dict(model=self.model, params=self.params, ci={k: list(v) for k, v in self.ci.items()},
                    level=self.level, rmse_mm=self.rmse_mm, n=self.n)


def _data(power_mw, speed_mm_min, width_mm, k):
    p, v, w = (np.asarray(a, float).ravel() for a in (power_mw, speed_mm_min, width_mm))
    if not (len(p) == len(v) == len(w)):
        raise InputError(f"power, speed and width differ in length: {len(p)}, {len(v)}, {len(w)}")
    if not np.all(np.isfinite(p) & (p > 0) & np.isfinite(v) & (v > 0)):
        raise InputError("powers and speeds must be finite and > 0")
    burned = np.isfinite(w) & (w > 0)
    if burned.sum() <= k:
        raise InputError(f"need more than {k} burned lines (width > 0) to fit, got {int(burned.sum())}")
    return p[burned], v[burned], w[burned]


def _intervals(names, values, cov, dof, level):
    t = stats.t.ppf(0.5 + level / 2.0, dof)
    err = np.sqrt(np.diag(cov)) * t
    return {n: (float(x - e), float(x + e)) for n, x, e in zip(names, values, err)}


def fit_dose(power_mw, speed_mm_min, width_mm, *, level: float = 0.95) -> Fit:
    """Fit w0 and the threshold fluence of the dose model to measured widths.

    Lines that did not burn (width 0 or NaN) are left out. The starting point
    is the straight line W² = 2·w0²·ln(P/v) + b (Liu's plot); the final fit is
    least squares on W with :func:`scipy.optimize.curve_fit`.

    Parameters
    ----------
    power_mw, speed_mm_min, width_mm : array_like
        Power (mW), speed (mm/min) and burned width (mm) of each line.
    level : float
        Confidence level of the intervals.

    Returns
    -------
    Fit
    """
    p, v, w = _data(power_mw, speed_mm_min, width_mm, 2)
    x = np.log(p / v)
    slope, icpt = np.polyfit(x, w ** 2, 1)
    if not slope > 0:
        raise InputError("widths do not grow with power/speed: the dose model does not apply")
    w0 = np.sqrt(slope / 2.0)
    # W² = slope·(ln(P/v) + ln(sqrt(2/π)/(w0/60)) − ln F_th): solve the intercept for F_th
    ln_fth = np.log(_GAUSS * 60.0 / w0) + icpt / slope

    def model(pv, w0_, ln_fth_):
        return dose_width(pv[0], pv[1], abs(w0_), np.exp(ln_fth_))

    popt, pcov = optimize.curve_fit(model, np.vstack([p, v]), w, p0=[w0, ln_fth])
    popt[0] = abs(popt[0])
    ci = _intervals(["w0_mm", "ln_fth"], popt, pcov, len(w) - 2, level)
    ci["fth_mj_mm2"] = tuple(float(np.exp(b)) for b in ci.pop("ln_fth"))
    params = dict(w0_mm=float(popt[0]), fth_mj_mm2=float(np.exp(popt[1])))
    res = w - model(np.vstack([p, v]), *popt)
    return Fit("dose", params, ci, level, float(np.sqrt(np.mean(res ** 2))), len(w))


def power_law_width(power_mw, speed_mm_min, a, b, c):
    """Empirical width a·P^b·v^c, mm (P in mW, v in mm/min)."""
    return a * np.asarray(power_mw, float) ** b * np.asarray(speed_mm_min, float) ** c


def fit_power_law(power_mw, speed_mm_min, width_mm, *, level: float = 0.95) -> Fit:
    """Fit W = a·P^b·v^c to burned widths (start from the log-linear fit, finish with curve_fit).

    Parameters
    ----------
    power_mw, speed_mm_min, width_mm : array_like
        Power (mW), speed (mm/min) and width (mm); lines with width 0 or NaN are left out.
    level : float
        Confidence level of the intervals.

    Returns
    -------
    Fit
    """
    p, v, w = _data(power_mw, speed_mm_min, width_mm, 3)
    design = np.column_stack([np.ones_like(p), np.log(p), np.log(v)])
    (ln_a, b, c), *_ = np.linalg.lstsq(design, np.log(w), rcond=None)

    def model(pv, a_, b_, c_):
        return power_law_width(pv[0], pv[1], a_, b_, c_)

    popt, pcov = optimize.curve_fit(model, np.vstack([p, v]), w, p0=[np.exp(ln_a), b, c])
    ci = _intervals(["a", "b", "c"], popt, pcov, len(w) - 3, level)
    res = w - model(np.vstack([p, v]), *popt)
    return Fit("power_law", dict(a=float(popt[0]), b=float(popt[1]), c=float(popt[2])), ci, level,
               float(np.sqrt(np.mean(res ** 2))), len(w))


def _check_width(width_mm):
    w = np.asarray(width_mm, float)
    if not np.all(np.isfinite(w) & (w > 0)):
        raise InputError(f"width_mm must be finite and > 0, got {width_mm!r}")
    return w


def power_for_width(fit: Fit, width_mm, speed_mm_min):
    """Power (mW) that gives ``width_mm`` at ``speed_mm_min`` according to ``fit``.

    Examples
    --------
    >>> f = Fit("dose", dict(w0_mm=0.1, fth_mj_mm2=300.0), {}, 0.95, 0.0, 0)
    >>> p = power_for_width(f, 0.12, 600)
    >>> round(float(f.width(p, 600)), 9)
    0.12
    """
    w, v = _check_width(width_mm), np.asarray(speed_mm_min, float)
    if fit.model == "dose":
        w0, fth = fit.params["w0_mm"], fit.params["fth_mj_mm2"]
        # invert W = w0·sqrt(2 ln(F_peak/F_th)) for F_peak, then F_peak for P
        f_peak = fth * np.exp(w ** 2 / (2.0 * w0 ** 2))
        return f_peak * mm_min_to_mm_s(v) * w0 / _GAUSS
    a, b, c = fit.params["a"], fit.params["b"], fit.params["c"]
    return (w / (a * v ** c)) ** (1.0 / b)


def speed_for_width(fit: Fit, width_mm, power_mw):
    """Speed (mm/min) that gives ``width_mm`` at ``power_mw`` according to ``fit``."""
    w, p = _check_width(width_mm), np.asarray(power_mw, float)
    if fit.model == "dose":
        w0, fth = fit.params["w0_mm"], fit.params["fth_mj_mm2"]
        f_peak = fth * np.exp(w ** 2 / (2.0 * w0 ** 2))
        return 60.0 * _GAUSS * p / (f_peak * w0)
    a, b, c = fit.params["a"], fit.params["b"], fit.params["c"]
    return (w / (a * p ** b)) ** (1.0 / c)
