"""Ramp-law arithmetic shared by the vectorised profile code and the planner kernels.

Each function is plain Python on numbers that also works element-wise on numpy
arrays; the ``*_nb`` twins are the same source compiled with numba for the
sequential planner loops. ``law`` is :data:`LINEAR` ([CBR40]: speed rises
linearly with distance, slope in Hz per step = 1/s) or :data:`ACCEL`
(constant acceleration: speed² rises linearly with distance, slope in mm/s²).
"""

from __future__ import annotations

import numpy as np

from labkit._jit import jit

LINEAR = 0
ACCEL = 1


def reach(v0, d, slope, law):
    """Speed after ramping over distance ``d`` (mm) from ``v0`` (mm/s)."""
    if law == LINEAR:
        return v0 + slope * d
    return np.sqrt(v0 * v0 + 2.0 * slope * d)


def ramp_distance(v0, v1, slope, law):
    """Distance (mm) to ramp between speeds v0 ≤ v1 (mm/s)."""
    if law == LINEAR:
        return (v1 - v0) / slope
    return (v1 * v1 - v0 * v0) / (2.0 * slope)


def ramp_time(v0, v1, slope, law):
    """Time (s) to ramp between speeds 0 < v0 ≤ v1 (linear law) or 0 ≤ v0 ≤ v1 (accel law)."""
    if law == LINEAR:
        return np.log(v1 / v0) / slope
    return (v1 - v0) / slope


def meet(v_entry, v_exit, length, up, down, law):
    """Where the rising ramp from the entry meets the falling ramp to the exit.

    Returns (distance from the block start in mm, speed there in mm/s). The
    distance falls outside [0, length] when the exit (entry) speed cannot be
    reached from the entry (exit) within the block.
    """
    if law == LINEAR:
        s = (v_exit - v_entry + down * length) / (up + down)
        return s, v_entry + up * s
    s = (v_exit * v_exit - v_entry * v_entry + 2.0 * down * length) / (2.0 * (up + down))
    return s, np.sqrt(np.maximum(v_entry * v_entry + 2.0 * up * s, 0.0))


reach_nb = jit(reach)
