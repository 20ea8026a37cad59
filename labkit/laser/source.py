"""The laser source itself ([CBR40] §F): I–V and P–I curves, threshold current, slope efficiency.

A semiconductor laser emits almost nothing below its threshold current I_th
and, above it, optical power rising linearly with current:

    P = η_s · (I − I_th)   for I > I_th,   0 below,

with η_s the slope efficiency (W/A = mW/mA). Electrically it is a diode with
a series resistance, V ≈ V_0 + R_s · I once it conducts. The
electrical-to-optical (wall-plug) efficiency is P / (I · V).

[CBR40] sold as 2500 mW measured about 963.65 mW (over a 20 nm band round
445 nm, the sensor only up to 90 % of full power): :func:`label_ratio` is why
a laboratory characterises the source rather than trusting its label.

Units: current A, voltage V, optical power mW.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import optimize, stats

from labkit.errors import InputError

__all__ = ["SourceFit", "fit_source", "read_source_csv", "label_ratio", "synthetic_source_curves",
           "CBR40_MEASURED_MW", "CBR40_NOMINAL_MW"]

#: [CBR40] §F: optical power measured (20 nm band) and the laser's nominal power, mW.
CBR40_MEASURED_MW = 963.65
CBR40_NOMINAL_MW = 2500.0



def label_ratio(measured_mw: float = CBR40_MEASURED_MW, nominal_mw: float = CBR40_NOMINAL_MW) -> float:
    """Measured over nominal optical power.

    Examples
    --------
    [CBR40]'s diode gave about 38.5 % of its label.

    >>> round(label_ratio(), 4)
    0.3855
    """
    if not (nominal_mw > 0 and measured_mw >= 0):
        raise InputError(f"powers must be >= 0 (nominal > 0), got {measured_mw!r} and {nominal_mw!r}")
    return float(measured_mw) / float(nominal_mw)


@dataclass
class SourceFit:
    """Fitted characteristics of a laser source.

    Attributes
    ----------
    threshold_a : float
        Threshold current I_th, A.
    slope_w_per_a : float
        Slope efficiency η_s, W/A (= mW/mA).
    ci : dict
        ``threshold_a`` and ``slope_w_per_a`` → (low, high) at ``level``.
    level : float
    v0_v, series_ohm : float or None
        Turn-on voltage and series resistance of V = V_0 + R_s·I above threshold (None without voltages).
    efficiency : ndarray or None
        P / (I·V) at each reading (NaN at I = 0).
    peak_efficiency : float or None
        Its largest value.
    max_optical_mw : float
        Largest optical power measured.
    """

    threshold_a: float
    slope_w_per_a: float
    ci: dict
    level: float
    v0_v: float | None
    series_ohm: float | None
    efficiency: np.ndarray | None
    peak_efficiency: float | None
    max_optical_mw: float

    def power_mw(self, current_a):
        """Optical power of the fitted P–I line, mW."""
        return 1000.0 * self.slope_w_per_a * np.maximum(np.asarray(current_a, float) - self.threshold_a, 0.0)

    def current_for_power(self, power_mw):
        """Current that gives ``power_mw`` on the fitted line, A."""
        return self.threshold_a + np.asarray(power_mw, float) / (1000.0 * self.slope_w_per_a)


def fit_source(current_a, optical_mw, voltage_v=None, *, level: float = 0.95) -> SourceFit:
    """Fit threshold current and slope efficiency (and the I–V line, if voltages are given).

    The P–I fit is least squares of the hinge P = η_s·max(I − I_th, 0) over
    all readings, started from the straight line through the readings above
    a fifth of the largest power (whose zero crossing is the textbook
    threshold estimate). Intervals from the covariance, t distribution.

    Parameters
    ----------
    current_a, optical_mw : array_like
        Drive current (A) and optical power (mW) of each reading.
    voltage_v : array_like, optional
        Voltage across the laser (V).
    level : float
        Confidence level.

    Returns
    -------
    SourceFit
    """
    i = np.asarray(current_a, float).ravel()
    p = np.asarray(optical_mw, float).ravel()
    if len(i) != len(p):
        raise InputError(f"current and optical power differ in length: {len(i)} and {len(p)}")
    if not (np.all(np.isfinite(i)) and np.all(np.isfinite(p)) and np.all(i >= 0)):
        raise InputError("currents must be finite and >= 0, optical powers finite")
    lasing = p > 0.2 * p.max() if len(p) else np.zeros(0, bool)
    if lasing.sum() < 2 or len(i) < 4:
        raise InputError(f"need at least 4 readings, 2 of them above a fifth of the largest power; got {len(i)}")
    slope, icpt = np.polyfit(i[lasing], p[lasing], 1)
    if not slope > 0:
        raise InputError("optical power does not grow with current: no lasing threshold to fit")

    def hinge(x, ith, eta):
        return eta * np.maximum(x - ith, 0.0)

    popt, pcov = optimize.curve_fit(hinge, i, p, p0=[-icpt / slope, slope])
    t = stats.t.ppf(0.5 + level / 2.0, max(len(i) - 2, 1))
    err = t * np.sqrt(np.diag(pcov))
    ci = {"threshold_a": (float(popt[0] - err[0]), float(popt[0] + err[0])),
          "slope_w_per_a": (float((popt[1] - err[1]) / 1000.0), float((popt[1] + err[1]) / 1000.0))}
    v0 = rs = eff = peak = None
    if voltage_v is not None:
        v = np.asarray(voltage_v, float).ravel()
        if len(v) != len(i) or not np.all(np.isfinite(v)):
            raise InputError("voltages must be finite, one per current reading")
        above = i > popt[0]
        if above.sum() >= 2:
            rs, v0 = (float(a) for a in np.polyfit(i[above], v[above], 1))
        with np.errstate(divide="ignore", invalid="ignore"):
            eff = np.where(i * v > 0, p / 1000.0 / (i * v), np.nan)
        peak = float(np.nanmax(eff)) if np.isfinite(eff).any() else None
    return SourceFit(float(popt[0]), float(popt[1] / 1000.0), ci, level, v0, rs, eff, peak, float(p.max()))


def read_source_csv(path):
    """A source CSV (``current_a``, ``optical_mw``, optional ``voltage_v``; leading ``#`` lines are comments).

    Raises
    ------
    InputError
        A required column is missing (named) or holds something other than numbers.
    """
    from labkit.laser.measure import read_table

    return read_table(path, ("current_a", "optical_mw"), optional=("voltage_v",), what="laser source CSV")


def synthetic_source_curves(*, threshold_a: float = 0.30, slope_w_per_a: float = 1.15, max_current_a: float = 1.14,
                            readings: int = 20, v_thermal_n: float = 0.10, saturation_a: float = 1e-12,
                            series_ohm: float = 0.9, noise_mw: float = 5.0, noise_v: float = 0.01,
                            seed: int = 0):
    """Made-up I–V–P readings of a blue diode laser (a SYNTHETIC stand-in, not a measurement).

    Optical power is the hinge with Gaussian noise; voltage the diode law
    V = n·V_T·ln(1 + I/I_s) + R_s·I with noise. The defaults put the largest
    reading near [CBR40]'s measured 963.65 mW; nothing else about them comes
    from that laser.

    Returns
    -------
    dict of ndarray
        ``current_a``, ``voltage_v``, ``optical_mw``.
    """
    rng = np.random.default_rng(seed)
    i = np.linspace(0.0, max_current_a, readings)
    v = v_thermal_n * np.log1p(i / saturation_a) + series_ohm * i + rng.normal(0, noise_v, readings)
    p = 1000.0 * slope_w_per_a * np.maximum(i - threshold_a, 0.0) + rng.normal(0, noise_mw, readings)
    return {"current_a": i, "voltage_v": np.maximum(v, 0.0), "optical_mw": np.maximum(p, 0.0)}
