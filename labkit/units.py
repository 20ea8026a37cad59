"""Unit conversions used across labkit.

Lengths are millimetres inside labkit, feeds mm/min, times seconds, laser
power either the controller's S value, milliwatts or a duty fraction 0…1.
This module is the one home of the S ↔ duty ↔ mW conversions; the laser's power at
full duty is stated once, in the machine description
(``laser_max_power_mw`` of :mod:`labkit.motion.spec` and its TOML files), and passed in.

>>> inch_to_mm(1.0)
25.4
>>> mm_min_to_mm_s(1500.0)
25.0
>>> s_to_mw(500, s_max=1000, max_power_mw=2500)
1250.0
>>> round(s_to_duty(255, s_max=255), 3)
1.0
"""

from __future__ import annotations

import numpy as np

from labkit._array import scalar_or_array

__all__ = [
    "MM_PER_INCH",
    "inch_to_mm",
    "mm_to_inch",
    "mm_min_to_mm_s",
    "mm_s_to_mm_min",
    "s_to_duty",
    "duty_to_s",
    "s_to_mw",
    "mw_to_s",
    "s_to_percent",
    "s_within",
    "S_MAX_RTOL",
]

MM_PER_INCH = 25.4


def inch_to_mm(value):
    """Inches → millimetres (exact: 1 in = 25.4 mm)."""
    return np.multiply(value, MM_PER_INCH) if isinstance(value, np.ndarray) else value * MM_PER_INCH


def mm_to_inch(value):
    """Millimetres → inches."""
    return np.divide(value, MM_PER_INCH) if isinstance(value, np.ndarray) else value / MM_PER_INCH


def mm_min_to_mm_s(feed_mm_min):
    """Feed in mm/min → speed in mm/s."""
    return feed_mm_min / 60.0


def mm_s_to_mm_min(speed_mm_s):
    """Speed in mm/s → feed in mm/min."""
    return speed_mm_s * 60.0


def _check_s_max(s_max):
    if not s_max > 0:
        raise ValueError(f"s_max must be > 0 (the S value of full power), got {s_max!r}")


#: Relative slack above ``s_max`` that still counts as full power: an S written back with six
#: significant digits, or scaled between dialects, may land a rounding above it.
S_MAX_RTOL = 1e-6


def s_within(s, s_max, *, positive: bool = False):
    """Whether power word S lies within the laser's range: the one test of S against ``s_max``.

    Every check of an S against full power (the writer, the job builders, the Dobot,
    the test pulse, the commands' ``--power``) asks this and words its own refusal.

    Parameters
    ----------
    s : float or array
        Power word S.
    s_max : float
        S of full power (GRBL ``$30``), > 0.
    positive : bool
        Require S > 0 (a power that burns) instead of S ≥ 0.

    Returns
    -------
    bool or ndarray of bool
        False for NaN, for S above ``s_max · (1 + S_MAX_RTOL)`` and below the floor.

    >>> s_within(1000, 1000), s_within(1000.0005, 1000), s_within(1001, 1000), s_within(float("nan"), 1000)
    (True, True, False, False)
    >>> s_within(0, 255), s_within(0, 255, positive=True)
    (True, False)
    """
    v = np.asarray(s, dtype=float)
    ok = ((v > 0) if positive else (v >= 0)) & (v <= float(s_max) * (1.0 + S_MAX_RTOL))
    return bool(ok) if ok.ndim == 0 else ok


def s_to_duty(s, *, s_max=1000.0):
    """Controller power S → duty fraction 0…1, clipped.

    Parameters
    ----------
    s : float or array
        Power word S as programmed.
    s_max : float
        S value meaning full power (GRBL ``$30``, default 1000; [DobotLaser]'s
        Dobot PWM uses 255, so S′ = S·100/255 percent).
    """
    _check_s_max(s_max)
    return scalar_or_array(np.clip(np.asarray(s, dtype=float) / s_max, 0.0, 1.0))


def duty_to_s(duty, *, s_max=1000.0):
    """Duty fraction 0…1 → power word S (clipped to 0…s_max)."""
    _check_s_max(s_max)
    return scalar_or_array(np.clip(np.asarray(duty, dtype=float), 0.0, 1.0) * s_max)


def s_to_percent(s, *, s_max=1000.0):
    """Power word S → duty in percent ([DobotLaser]: S′ = S·100/255 with s_max=255)."""
    return s_to_duty(s, s_max=s_max) * 100.0


def s_to_mw(s, *, s_max=1000.0, max_power_mw):
    """Power word S → optical power in mW, linear up to ``max_power_mw``.

    ``max_power_mw`` is the machine description's ``laser_max_power_mw`` (mW at full duty).
    """
    return s_to_duty(s, s_max=s_max) * max_power_mw


def mw_to_s(power_mw, *, s_max=1000.0, max_power_mw):
    """Optical power in mW → power word S (clipped)."""
    if not max_power_mw > 0:
        raise ValueError(f"max_power_mw must be > 0, got {max_power_mw!r}")
    return duty_to_s(np.asarray(power_mw, dtype=float) / max_power_mw, s_max=s_max)
