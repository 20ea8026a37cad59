"""Laser power that follows speed ([CBR40] §IV) and GRBL's M3/M4 laser modes.

While a block accelerates and decelerates, a beam at constant power leaves
more energy per millimetre where the head is slow: corners and line ends
burn darker. [CBR40] keeps the cut uniform by holding the ratio of laser
power to speed: the planner computes, per block, ratio = programmed power /
programmed speed, and the runner sets the power to ratio × instantaneous
speed — capped at the laser's maximum (2500 mW on [CBR40]'s diode), so the
ratio fails where the speed exceeds the one it was computed for.

GRBL's laser mode (``$32=1``) offers both behaviours: ``M3`` keeps the
programmed power whatever the speed, ``M4`` scales it by current speed /
programmed speed — [CBR40]'s rule (GRBL never exceeds the programmed speed,
so its cap is the programmed power).
"""

from __future__ import annotations

import numpy as np

from labkit._array import scalar_or_array
from labkit.errors import MotionError
from labkit.toolpath.moves import LaserMode

__all__ = ["power_ratio", "laser_power_mw", "dose_mj_per_mm", "dose_uniformity"]


def power_ratio(power_mw, speed):
    """[CBR40]'s power/speed ratio: programmed power over programmed speed.

    Parameters
    ----------
    power_mw : float or array
        Programmed power, mW.
    speed : float or array
        Programmed speed in any unit (> 0): mm/s gives mW per mm/s, a step
        rate in Hz gives mW per Hz as in [CBR40].

    Examples
    --------
    [CBR40]'s example: 1000 mW at a 1000 Hz step rate gives a ratio of 1.

    >>> power_ratio(1000.0, 1000.0)
    1.0
    """
    speed = np.asarray(speed, float)
    if np.any(~(speed > 0)):
        raise MotionError(f"speed must be > 0 to form a power/speed ratio, got {speed.min()!r}")
    return scalar_or_array(np.asarray(power_mw, float) / speed)


def laser_power_mw(speed_mm_s, *, mode, power_mw, feed_mm_s, max_power_mw):
    """Instantaneous laser power at a speed, for M3, M4 or off.

    Parameters
    ----------
    speed_mm_s : float or array
        Instantaneous speed, mm/s.
    mode : LaserMode or int or array
        0 off (M5), 3 constant (M3), 4 dynamic (M4, [CBR40]).
    power_mw : float or array
        Programmed power, mW.
    feed_mm_s : float or array
        Programmed speed the ratio was formed with, mm/s.
    max_power_mw : float
        Laser maximum, mW (the cap of the dynamic mode).

    Returns
    -------
    float or ndarray
        Power, mW: M3 → ``power_mw`` (0 when stopped); M4 → min(ratio × speed,
        ``max_power_mw``); off → 0.

    Examples
    --------
    >>> laser_power_mw([0.0, 5.0, 10.0, 40.0], mode=4, power_mw=1000, feed_mm_s=10,
    ...                max_power_mw=2500).tolist()
    [0.0, 500.0, 1000.0, 2500.0]
    >>> laser_power_mw([0.0, 5.0, 10.0], mode=LaserMode.CONSTANT, power_mw=1000, feed_mm_s=10,
    ...                max_power_mw=2500).tolist()
    [0.0, 1000.0, 1000.0]
    """
    if not max_power_mw > 0:
        raise MotionError(f"max_power_mw must be > 0 mW, got {max_power_mw!r}")
    v = np.asarray(speed_mm_s, float)
    mode = np.asarray(mode)
    valid = np.isin(mode, [LaserMode.OFF, LaserMode.CONSTANT, LaserMode.DYNAMIC])
    if not np.all(valid):
        raise MotionError(f"laser mode must be 0 (off), 3 (M3) or 4 (M4), got {np.asarray(mode)[~valid].ravel()[0]!r}")
    p = np.asarray(power_mw, float)
    f = np.asarray(feed_mm_s, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        dynamic = np.minimum(np.where(f > 0, p / f, 0.0) * v, max_power_mw)
    constant = np.where(v > 0, np.minimum(p, max_power_mw), 0.0)
    out = np.where(mode == LaserMode.DYNAMIC, dynamic, np.where(mode == LaserMode.CONSTANT, constant, 0.0))
    return scalar_or_array(np.where(v > 0, out, 0.0))


def dose_mj_per_mm(power_mw, speed_mm_s):
    """Energy left per millimetre of path: power / speed (mW per mm/s = mJ/mm).

    The quantity the power/speed ratio keeps constant; NaN where the head stands.

    >>> dose_mj_per_mm([1000.0, 1000.0], [10.0, 5.0]).tolist()
    [100.0, 200.0]
    """
    v = np.asarray(speed_mm_s, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return scalar_or_array(np.where(v > 0, np.asarray(power_mw, float) / v, np.nan))


def dose_uniformity(dose_mj_per_mm, speed_mm_s=None, feed_mm_s=None) -> dict:
    """How even a cut is: statistics of the dose sampled evenly along the burned path.

    Parameters
    ----------
    dose_mj_per_mm : array
        Dose samples at equal spacing along the path (e.g. from
        :meth:`~labkit.motion.pipeline.Plan.burn_profile`).
    speed_mm_s, feed_mm_s : array, optional
        Speed and programmed speed at the same samples, for the slow fraction.

    Returns
    -------
    dict
        ``cv`` (standard deviation / mean), ``max_over_mean``, ``min_over_mean``
        and, with speeds, ``slow_fraction``: the share of the burned length
        run below 99 % of the programmed speed.

    Examples
    --------
    >>> dose_uniformity([100.0, 100.0, 200.0, 100.0])["max_over_mean"]
    1.6
    """
    d = np.asarray(dose_mj_per_mm, float)
    if d.size == 0:
        raise MotionError("no dose samples: nothing burns")
    mean = float(d.mean())
    out = {"cv": float(d.std() / mean), "max_over_mean": float(d.max() / mean),
           "min_over_mean": float(d.min() / mean)}
    if speed_mm_s is not None and feed_mm_s is not None:
        out["slow_fraction"] = float(np.mean(np.asarray(speed_mm_s) < 0.99 * np.asarray(feed_mm_s)))
    return out
