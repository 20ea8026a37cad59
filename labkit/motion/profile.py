"""Speed profile of a block: ramp up, cruise at the peak, ramp down ([CBR40] §K).

A block of length L (mm) is entered at speed v_e and left at v_x (mm/s) and
may not exceed its cap v_c. [CBR40] profiles a block with a first-order
polynomial: the step rate rises by a constant number of Hz per step while
accelerating and falls by a constant number of Hz per step while
decelerating. Per step of the driver axis, Hz per step is the same number as
(mm/s) per mm, so in path units the speed is linear in distance:

    v(s) = min(v_e + A·s,  v_c,  v_x + D·(L − s))          (law ``"linear"``)

with A, D the slopes (1/s). If the two ramps meet below the cap the peak
drops to where they meet ([CBR40] fig. 13); when entry and exit differ enough
the meeting point leaves the block and the profile is a single ramp up or
down ([CBR40] fig. 14) — the min of three lines does all of this at once.
GRBL and most modern controllers accelerate at a constant a (mm/s²) instead,
v² linear in distance (law ``"accel"``):

    v(s) = min(sqrt(v_e² + 2a·s),  v_c,  sqrt(v_x² + 2d·(L − s)))

Time follows by integrating ds/v: a linear ramp from v0 to v1 takes
ln(v1/v0)/A (so it needs v0 > 0: the motors start at a start rate), a
constant-acceleration ramp (v1 − v0)/a.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from labkit._array import ColumnTable, scalar_or_array
from labkit.errors import MotionError
from labkit.motion import _ramp

__all__ = ["RAMP_LAWS", "Profiles", "block_profiles", "reach_speed", "ramp_distance", "ramp_time"]

#: Ramp law names → codes used in the kernels.
RAMP_LAWS = {"linear": _ramp.LINEAR, "accel": _ramp.ACCEL}

#: Relative slack allowed when checking that a profile is feasible (rounding of the planner).
_FEASIBLE_RTOL = 1e-9


def _law(law: str) -> int:
    try:
        return RAMP_LAWS[law]
    except KeyError:
        raise MotionError(f"ramp law must be one of {sorted(RAMP_LAWS)}, got {law!r}") from None


def reach_speed(v0_mm_s, distance_mm, slope, law="linear"):
    """Speed reached after ramping over ``distance_mm`` from ``v0_mm_s``.

    Parameters
    ----------
    v0_mm_s : float or array
        Starting speed, mm/s.
    distance_mm : float or array
        Ramp length, mm.
    slope : float or array
        Hz per step (= 1/s) for ``"linear"``, mm/s² for ``"accel"``.
    law : {"linear", "accel"}

    Examples
    --------
    >>> reach_speed(1.0, 0.5, 40)            # [CBR40]'s law: +40 mm/s per mm
    21.0
    >>> reach_speed(0.0, 0.5, 500, "accel")  # v² = 2·a·d
    22.360679774997898
    """
    return scalar_or_array(_ramp.reach(np.asarray(v0_mm_s, float), np.asarray(distance_mm, float),
                                       np.asarray(slope, float), _law(law)))


def ramp_distance(v0_mm_s, v1_mm_s, slope, law="linear"):
    """Distance (mm) a ramp between two speeds takes (v0 ≤ v1, mm/s).

    >>> ramp_distance(1.0, 21.0, 40)
    0.5
    """
    return scalar_or_array(_ramp.ramp_distance(np.asarray(v0_mm_s, float), np.asarray(v1_mm_s, float),
                                               np.asarray(slope, float), _law(law)))


def ramp_time(v0_mm_s, v1_mm_s, slope, law="linear"):
    """Time (s) a ramp between two speeds takes (v0 ≤ v1, mm/s; v0 > 0 for ``"linear"``).

    >>> round(ramp_time(1.0, 21.0, 40), 6)    # ln(21)/40
    0.076113
    >>> ramp_time(0.0, 20.0, 500, "accel")
    0.04
    """
    return scalar_or_array(_ramp.ramp_time(np.asarray(v0_mm_s, float), np.asarray(v1_mm_s, float),
                                           np.asarray(slope, float), _law(law)))


@dataclass(frozen=True)
class Profiles(ColumnTable):
    """Speed profiles of n blocks as columns (all speeds mm/s, distances mm, times s).

    Attributes
    ----------
    law : str
        ``"linear"`` ([CBR40]) or ``"accel"`` (constant acceleration).
    length_mm, entry_mm_s, peak_mm_s, exit_mm_s, cap_mm_s : ndarray
        Block length, speeds at entry, top, exit, and the cap the block may not exceed.
    up, down : ndarray
        Ramp slopes (Hz per step for linear, mm/s² for accel).
    accel_mm, cruise_mm, decel_mm : ndarray
        Lengths of the three phases (sum = length).
    accel_s, cruise_s, decel_s : ndarray
        Durations of the three phases.
    """

    law: str
    length_mm: np.ndarray
    entry_mm_s: np.ndarray
    peak_mm_s: np.ndarray
    exit_mm_s: np.ndarray
    cap_mm_s: np.ndarray
    up: np.ndarray
    down: np.ndarray
    accel_mm: np.ndarray
    cruise_mm: np.ndarray
    decel_mm: np.ndarray
    accel_s: np.ndarray
    cruise_s: np.ndarray
    decel_s: np.ndarray

    @property
    def time_s(self) -> np.ndarray:
        """Duration of each block, s."""
        return self.accel_s + self.cruise_s + self.decel_s

    @property
    def shape_name(self) -> np.ndarray:
        """Per block: ``"trapezoid"``, ``"triangle"`` (peak lowered), ``"accel"``, ``"decel"``,
        ``"cruise"`` or ``"empty"``."""
        out = np.full(len(self), "trapezoid", dtype=object)
        has_a = self.accel_mm > 0
        has_c = self.cruise_mm > 0
        has_d = self.decel_mm > 0
        out[has_a & ~has_c & has_d] = "triangle"
        out[has_a & ~has_c & ~has_d] = "accel"
        out[~has_a & ~has_c & has_d] = "decel"
        out[~has_a & has_c & ~has_d] = "cruise"
        out[~has_a & ~has_c & ~has_d] = "empty"
        return out

    def speed_at(self, i: int, s_mm):
        """Speed (mm/s) of block ``i`` at distance ``s_mm`` from its start (the min of three curves)."""
        s = np.clip(np.asarray(s_mm, float), 0.0, self.length_mm[i])
        law = RAMP_LAWS[self.law]
        v = np.minimum(np.minimum(_ramp.reach(self.entry_mm_s[i], s, self.up[i], law), self.peak_mm_s[i]),
                       _ramp.reach(self.exit_mm_s[i], self.length_mm[i] - s, self.down[i], law))
        return scalar_or_array(v)

    def sample(self, i, t_s):
        """Distance (mm) and speed (mm/s) of block ``i`` at times ``t_s`` (s) from its start.

        ``i`` may be an array of block indices of the same shape as ``t_s``.
        """
        t = np.clip(np.asarray(t_s, float), 0.0, self.time_s[i])
        ve, vp, vx = self.entry_mm_s[i], self.peak_mm_s[i], self.exit_mm_s[i]
        a, d = self.up[i], self.down[i]
        ta, tc = self.accel_s[i], self.cruise_s[i]
        t2 = np.clip(t - ta - tc, 0.0, None)           # time spent decelerating
        t1 = np.clip(t, None, ta)                      # time spent accelerating
        if self.law == "linear":
            v_up = ve * np.exp(a * t1)
            s_up = ve * np.expm1(a * t1) / a
            v_dn = vp * np.exp(-d * t2)
            s_dn = -vp * np.expm1(-d * t2) / d
        else:
            v_up = ve + a * t1
            s_up = ve * t1 + 0.5 * a * t1 * t1
            v_dn = vp - d * t2
            s_dn = vp * t2 - 0.5 * d * t2 * t2
        cruise_t = np.clip(t - ta, 0.0, tc)
        s = np.where(t <= ta, s_up, self.accel_mm[i] + vp * cruise_t + s_dn)
        v = np.where(t <= ta, v_up, np.where(t <= ta + tc, vp, v_dn))
        return scalar_or_array(s), scalar_or_array(v)


def block_profiles(length_mm, entry_mm_s, cap_mm_s, exit_mm_s, up, down, law="linear") -> Profiles:
    """Profile blocks from their entry, cap and exit speeds ([CBR40] §K).

    Parameters
    ----------
    length_mm : float or array
        Block lengths, mm (> 0).
    entry_mm_s, cap_mm_s, exit_mm_s : float or array
        Entry speed, highest allowed speed and exit speed, mm/s
        (0 < entry, exit ≤ cap for ``"linear"``; ≥ 0 for ``"accel"``).
    up, down : float or array
        Acceleration and deceleration slopes: Hz per step for ``"linear"``,
        mm/s² for ``"accel"`` (> 0).
    law : {"linear", "accel"}

    Returns
    -------
    Profiles

    Raises
    ------
    MotionError
        If a speed or slope is out of range, or the exit cannot be reached
        from the entry within the block (or the reverse) — the planner's
        job, reported with the block index.

    Notes
    -----
    The peak is min(cap, v*) where v* is the speed at which the rising ramp
    from the entry meets the falling ramp into the exit; the phase lengths
    follow from the ramp distances and the cruise takes the rest.

    Examples
    --------
    A 10 mm block from and to 1 mm/s with a 25 mm/s cap and 40 Hz/step
    slopes: 0.6 mm up, 8.8 mm at 25 mm/s, 0.6 mm down.

    >>> p = block_profiles(10.0, 1.0, 25.0, 1.0, 40, 40)
    >>> [round(float(x), 6) for x in (p.accel_mm[0], p.cruise_mm[0], p.peak_mm_s[0])]
    [0.6, 8.8, 25.0]

    A 0.5 mm block cannot reach the cap: the ramps meet at 11 mm/s (triangle).

    >>> p = block_profiles(0.5, 1.0, 25.0, 1.0, 40, 40)
    >>> round(float(p.peak_mm_s[0]), 9), p.shape_name[0]
    (11.0, 'triangle')
    """
    law_code = _law(law)
    arrays = np.broadcast_arrays(*(np.atleast_1d(np.asarray(v, dtype=float)) for v in
                                   (length_mm, entry_mm_s, cap_mm_s, exit_mm_s, up, down)))
    L, ve, vc, vx, a, d = (np.array(x, dtype=float) for x in arrays)
    _check_inputs(L, ve, vc, vx, a, d, law)
    s_meet, v_meet = _ramp.meet(ve, vx, L, a, d, law_code)
    tol = _FEASIBLE_RTOL * np.maximum(L, 1.0)
    bad = (s_meet < -tol) | (s_meet > L + tol)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        which = "exit" if s_meet[i] > L[i] else "entry"
        raise MotionError(f"block {i}: {which} speed cannot be reached within {L[i]:g} mm "
                          f"(entry {ve[i]:g} mm/s, exit {vx[i]:g} mm/s, slopes {a[i]:g}/{d[i]:g})")
    peak = np.minimum(vc, np.maximum(v_meet, np.maximum(ve, vx)))
    acc = np.clip(_ramp.ramp_distance(ve, peak, a, law_code), 0.0, None)
    dec = np.clip(_ramp.ramp_distance(vx, peak, d, law_code), 0.0, None)
    over = acc + dec - L            # rounding: the ramps may overlap by a few ulps
    fix = over > 0
    acc = np.where(fix, np.clip(s_meet, 0.0, L), acc)
    dec = np.where(fix, L - acc, dec)
    cru = np.clip(L - acc - dec, 0.0, None)
    with np.errstate(divide="ignore", invalid="ignore"):
        ta = np.where(acc > 0, _ramp.ramp_time(ve, peak, a, law_code), 0.0)
        td = np.where(dec > 0, _ramp.ramp_time(vx, peak, d, law_code), 0.0)
        tc = np.where(cru > 0, cru / peak, 0.0)
    return Profiles(law=law, length_mm=L, entry_mm_s=ve, peak_mm_s=peak, exit_mm_s=vx, cap_mm_s=vc,
                    up=a, down=d, accel_mm=acc, cruise_mm=cru, decel_mm=dec,
                    accel_s=ta, cruise_s=tc, decel_s=td)


def _check_inputs(L, ve, vc, vx, a, d, law):
    low = 0.0 if law == "accel" else np.nextafter(0.0, 1.0)
    checks = [
        ("length_mm", L > 0, "> 0 mm"),
        ("up", a > 0, "> 0"),
        ("down", d > 0, "> 0"),
        ("cap_mm_s", vc > 0, "> 0 mm/s"),
        ("entry_mm_s", (ve >= low) & (ve <= vc * (1 + _FEASIBLE_RTOL)),
         f"in {'[0' if law == 'accel' else '(0'}, cap] mm/s"),
        ("exit_mm_s", (vx >= low) & (vx <= vc * (1 + _FEASIBLE_RTOL)),
         f"in {'[0' if law == 'accel' else '(0'}, cap] mm/s"),
    ]
    for name, ok, allowed in checks:
        ok = ok & np.isfinite(L) if name == "length_mm" else ok
        if not np.all(ok):
            i = int(np.flatnonzero(~ok)[0])
            value = {"length_mm": L, "up": a, "down": d, "cap_mm_s": vc,
                     "entry_mm_s": ve, "exit_mm_s": vx}[name][i]
            raise MotionError(f"block {i}: {name} must be {allowed}, got {float(value)!r}")
