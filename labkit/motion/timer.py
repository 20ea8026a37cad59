"""Step timing: from planned speeds to timer periods and the step pulse train ([CBR40] §IV).

The runner drives the motors with a hardware timer: each time it overflows,
an interrupt pulses the step pins (5 µs on [CBR40]) and loads the period
of the next tick. [CBR40] sets the period register from the wanted step
rate (``motorFreq``):

    Period = Timer_clk / (motorFreq · (Prescaler + 1)) − 1

so a tick lasts (Period + 1)·(Prescaler + 1) timer clock cycles. The
register holds an integer; labkit rounds the division *up*, so a tick is
never shorter than asked and the motors never run faster than planned (the
tick is at most one timer count longer: at 54 972 Hz on 48 MHz, 0.1 %).

Integer semantics (what the firmware must reproduce)
----------------------------------------------------
Each motion block becomes a :class:`StepBlocks` row of integers: N ticks,
step rates of the driver axis in whole Hz at entry, peak and exit, a floor,
and the two ramp slopes. For a block of length L (mm) and N ticks, a path
speed v (mm/s) is the driver rate floor(v · N / L) Hz, raised to the floor
f_min = min(start_rate_hz, floor(cap · N / L)) and at least 1. Tick k = 0 … N−1
then runs at

    linear law ([CBR40], slopes A, D in Hz per step):
        f_k = max(f_min, min(f_e + A·k,  f_p,  f_x + D·(N − 1 − k)))
    constant-acceleration law (slopes α, δ in steps/s², floor(a · N / L), ≥ 1):
        f_k = max(f_min, min(isqrt(f_e² + 2α·k),  f_p,  isqrt(f_x² + 2δ·(N − 1 − k))))

— the block's speed profile evaluated at the start of the tick, so the first
tick of a block runs at its entry rate and the last at its exit rate. The
period register is ``P_k = ceil(Timer_clk / (f_k · (Prescaler + 1))) − 1``
(in integers: ``(Timer_clk + q − 1) // q − 1`` with q = f_k·(Prescaler + 1)),
the tick lasts ``(P_k + 1)·(Prescaler + 1)`` clock
cycles, and the step pulse of tick k fires at its end. A dwell lasts
round(dwell_s · Timer_clk) cycles. Times are kept as integer clock cycles
from the start of the job.

The laser follows the same ticks ([CBR40] §IV, ratio = power / speed with
the speed as a step rate): with f_feed = floor(feed · N / L) the programmed
rate, an M4 block burns min(P_max, P · f_k / f_feed) mW during tick k, an M3
block P, a dark block 0 (IEEE double: one multiply and one divide).

Because every tick runs at the rate of its start, the step-timed job is a
little slower than the continuous profiles (:attr:`Plan.job_time_s`): about
half a tick at the start rate per ramp from or to rest (more where the planner
rests at 0, ``MachineSpec.rest_at_zero``: the first tick still runs at f_min).
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from labkit._array import ColumnTable, scalar_or_array
from labkit.errors import MotionError
from labkit.motion.blocks import BlockKind
from labkit.motion.bresenham import arc_lattice_points, lines_points
from labkit.toolpath.moves import PLANE_AXES

__all__ = ["timer_period", "tick_cycles", "StepBlocks", "step_blocks", "tick_rates",
           "block_periods", "block_points", "tick_power_mw", "StepTrace", "step_trace", "iter_step_chunks", "isqrt"]


def timer_period(freq_hz, *, timer_clock_hz: int = 48_000_000, prescaler: int = 0):
    """Period register for a step rate: ceil(Timer_clk / (f·(Prescaler + 1))) − 1.

    Parameters
    ----------
    freq_hz : int or array of int
        Step rate, Hz (≥ 1).
    timer_clock_hz : int
        Timer input clock ([CBR40]: 48 MHz).
    prescaler : int
        Prescaler register (the timer counts every Prescaler + 1 cycles).

    Examples
    --------
    The CBR-40's top rate, 54 972 Hz, at 48 MHz without prescaler: 48e6 / 54 972
    = 873.17 cycles, rounded up to 874 (the motor runs at 54 920 Hz, not faster):

    >>> timer_period(54972)
    873
    >>> timer_period([1000, 2000], prescaler=47)        # 1 MHz ticks
    [999, 499]
    """
    f = np.asarray(freq_hz)
    if f.dtype.kind not in "iu" or np.any(f < 1):
        raise MotionError(f"freq_hz must be whole Hz >= 1, got {np.asarray(freq_hz).tolist()!r}")
    if not (isinstance(prescaler, (int, np.integer)) and prescaler >= 0):
        raise MotionError(f"prescaler must be an integer >= 0, got {prescaler!r}")
    q = f.astype(np.int64) * (prescaler + 1)
    out = (timer_clock_hz + q - 1) // q - 1
    if np.any(q > timer_clock_hz):
        raise MotionError(f"step rate above the timer's counting rate "
                          f"({timer_clock_hz / (prescaler + 1):g} Hz)")
    return out.tolist() if out.ndim else int(out)


def tick_cycles(period, *, prescaler: int = 0):
    """Timer clock cycles one tick lasts: (period + 1)·(prescaler + 1).

    >>> tick_cycles(873)          # 874 cycles of 48 MHz = 18.21 µs, i.e. 54 920 Hz
    874
    """
    return scalar_or_array((np.asarray(period, np.int64) + 1) * (prescaler + 1))


def isqrt(x):
    """Integer square root of non-negative int64 values (floor), element-wise.

    >>> isqrt([0, 1, 15, 16, 10**12 - 1]).tolist()
    [0, 1, 3, 4, 999999]
    """
    x = np.asarray(x, np.int64)
    r = np.floor(np.sqrt(x.astype(float))).astype(np.int64)
    r = np.where(r * r > x, r - 1, r)
    r = np.where((r + 1) * (r + 1) <= x, r + 1, r)
    return r


@dataclass(frozen=True)
class StepBlocks(ColumnTable):
    """The integer blocks the runner executes (one row per block of the plan).

    Attributes
    ----------
    law : str
        ``"linear"`` or ``"accel"``.
    block : int64
        Index into the plan's blocks.
    ticks : int64
        N; 0 for dwells.
    f_entry, f_peak, f_exit, f_min : int64
        Driver step rates, Hz.
    up, down : int64
        Slopes: Hz per step (linear) or steps/s² (accel).
    dwell_cycles : int64
        Timer clock cycles of a dwell (0 for motion).
    f_feed : int64
        Programmed driver rate, Hz (0 for rapids and dwells): [CBR40]'s
        power/speed ratio is ``power_mw / f_feed``.
    laser : int64
        0 off, 3 M3, 4 M4.
    power_mw : float64
        Programmed power, mW.
    """

    law: str
    block: np.ndarray
    ticks: np.ndarray
    f_entry: np.ndarray
    f_peak: np.ndarray
    f_exit: np.ndarray
    f_min: np.ndarray
    up: np.ndarray
    down: np.ndarray
    dwell_cycles: np.ndarray
    f_feed: np.ndarray
    laser: np.ndarray
    power_mw: np.ndarray

    def row(self, i: int) -> dict:
        """Row ``i`` as a dict of Python ints (and the law)."""
        out = {}
        for f in fields(self):
            v = getattr(self, f.name)
            out[f.name] = v if f.name == "law" else (float(v[i]) if f.name == "power_mw" else int(v[i]))
        return out


def step_blocks(plan) -> StepBlocks:
    """Quantise a :class:`~labkit.motion.pipeline.Plan` into integer step blocks (see the module notes).

    Examples
    --------
    >>> from labkit.toolpath import MovesBuilder
    >>> from labkit.motion.pipeline import plan
    >>> b = MovesBuilder(feed_mm_min=1200)
    >>> b.line(x=1)
    >>> sb = step_blocks(plan(b.build(), planner="hq"))
    >>> {k: sb.row(0)[k] for k in ("ticks", "f_entry", "f_peak", "f_exit", "f_min", "up")}
    {'ticks': 2133, 'f_entry': 1000, 'f_peak': 42666, 'f_exit': 1000, 'f_min': 1000, 'up': 40}
    """
    blocks = plan.blocks
    m = plan.machine
    n = len(blocks)
    z = np.zeros(n, np.int64)
    f_e, f_p, f_x, f_min, up, down = (z.copy() for _ in range(6))
    mot = plan.motion
    b = blocks[mot]
    p = plan.profiles
    scale = b.ticks / b.length_mm                       # ticks per mm
    fm = np.maximum(1, np.minimum(m.start_rate_hz, np.floor(b.cap_mm_s * scale))).astype(np.int64)

    def rate(v):
        return np.maximum(fm, np.floor(v * scale + 1e-9).astype(np.int64))

    f_e[mot], f_p[mot], f_x[mot], f_min[mot] = rate(p.entry_mm_s), rate(p.peak_mm_s), rate(p.exit_mm_s), fm
    if plan.law == "linear":
        up[mot] = m.accel_hz_per_step
        down[mot] = m.decel_hz_per_step
    else:
        up[mot] = np.maximum(1, np.floor(p.up * scale)).astype(np.int64)
        down[mot] = np.maximum(1, np.floor(p.down * scale)).astype(np.int64)
    ticks = np.where(blocks.is_motion, blocks.ticks, 0).astype(np.int64)
    dwell = np.where(blocks.kind == BlockKind.DWELL,
                     np.floor(blocks.dwell_s * m.timer_clock_hz + 0.5), 0).astype(np.int64)
    f_feed = z.copy()
    feed = np.where(np.isfinite(b.feed_mm_s), b.feed_mm_s, 0.0)
    f_feed[mot] = np.floor(feed * scale + 1e-9).astype(np.int64)
    return StepBlocks(law=plan.law, block=np.arange(n, dtype=np.int64), ticks=ticks, f_entry=f_e,
                      f_peak=f_p, f_exit=f_x, f_min=f_min, up=up, down=down, dwell_cycles=dwell,
                      f_feed=f_feed, laser=blocks.laser_mode.astype(np.int64),
                      power_mw=blocks.power_mw.astype(float))


def tick_rates(ticks, f_entry, f_peak, f_exit, f_min, up, down, law="linear"):
    """Step rate (Hz, int64) of every tick of one block (module notes give the formula).

    Examples
    --------
    Ten ticks from 1000 Hz up by 100 Hz per step to a 1300 Hz peak and back to 1100 Hz:

    >>> tick_rates(10, 1000, 1300, 1100, 1000, 100, 100).tolist()
    [1000, 1100, 1200, 1300, 1300, 1300, 1300, 1300, 1200, 1100]
    """
    if law not in ("linear", "accel"):
        raise MotionError(f"ramp law must be 'linear' or 'accel', got {law!r}")
    k = np.arange(int(ticks), dtype=np.int64)
    back = int(ticks) - 1 - k
    if law == "linear":
        rise = f_entry + up * k
        fall = f_exit + down * back
    else:
        rise = isqrt(f_entry * f_entry + 2 * up * k)
        fall = isqrt(f_exit * f_exit + 2 * down * back)
    return np.maximum(f_min, np.minimum(np.minimum(rise, f_peak), fall))


def tick_power_mw(row: dict, rates, *, max_power_mw: float) -> np.ndarray:
    """Laser power (mW) during each tick of a :class:`StepBlocks` row at step rates ``rates``.

    >>> row = {"laser": 4, "power_mw": 1000.0, "f_feed": 1000}
    >>> tick_power_mw(row, np.array([500, 1000, 4000]), max_power_mw=2500.0).tolist()
    [500.0, 1000.0, 2500.0]
    """
    rates = np.asarray(rates)
    if row["laser"] == 4 and row["f_feed"] > 0:
        return np.minimum(max_power_mw, row["power_mw"] * rates / row["f_feed"])
    if row["laser"] == 3:
        return np.full(len(rates), min(row["power_mw"], max_power_mw))
    return np.zeros(len(rates))


def block_periods(row: dict, *, timer_clock_hz: int, prescaler: int) -> np.ndarray:
    """Period register value of every tick of one :class:`StepBlocks` row."""
    f = tick_rates(row["ticks"], row["f_entry"], row["f_peak"], row["f_exit"], row["f_min"],
                   row["up"], row["down"], row["law"])
    return np.asarray(timer_period(f, timer_clock_hz=timer_clock_hz, prescaler=prescaler)
                      if len(f) else np.zeros(0, np.int64), dtype=np.int64)


@dataclass(frozen=True)
class StepTrace(ColumnTable):
    """The step pulse train: one row per tick.

    Attributes
    ----------
    cycle : int64
        Timer clock cycles from the job start to the tick's step pulse.
    time_s : float64
        The same in seconds.
    block, line : int
        Block index and source line.
    step : int8, (n, 3)
        −1, 0, +1 per axis.
    period : int64
        Period register of the tick.
    power_mw : float64
        Laser power during the tick.
    """

    cycle: np.ndarray
    time_s: np.ndarray
    block: np.ndarray
    line: np.ndarray
    step: np.ndarray
    period: np.ndarray
    power_mw: np.ndarray

    @property
    def dir_bits(self) -> np.ndarray:
        """Bit i set when axis i steps in the negative direction on that tick."""
        return ((self.step < 0).astype(np.int64) << np.arange(3)).sum(axis=1)

    def to_dataframe(self):
        """Columns ``time_s, cycle, block, line, x, y, z, dir, period, power_mw``."""
        import pandas as pd

        return pd.DataFrame({"time_s": self.time_s, "cycle": self.cycle, "block": self.block,
                             "line": self.line, "x": self.step[:, 0], "y": self.step[:, 1],
                             "z": self.step[:, 2], "dir": self.dir_bits, "period": self.period,
                             "power_mw": self.power_mw})


def iter_step_chunks(plan, *, max_ticks: int = 1_000_000):
    """Yield :class:`StepTrace` pieces of about ``max_ticks`` ticks, in order (for big jobs)."""
    m = plan.machine
    spm = np.asarray(m.steps_per_mm)
    sb = step_blocks(plan)
    blocks = plan.blocks
    clock = 0
    parts: list[tuple] = []
    size = 0
    for i in range(len(blocks)):
        row = sb.row(i)
        if blocks.kind[i] == BlockKind.DWELL:
            clock += row["dwell_cycles"]
            continue
        pts = block_points(blocks, i, spm)
        rates = tick_rates(row["ticks"], row["f_entry"], row["f_peak"], row["f_exit"], row["f_min"],
                           row["up"], row["down"], row["law"])
        per = np.asarray(timer_period(rates, timer_clock_hz=m.timer_clock_hz, prescaler=m.prescaler),
                         dtype=np.int64)
        cyc = clock + np.cumsum((per + 1) * (m.prescaler + 1))
        clock = int(cyc[-1])
        parts.append((cyc, np.full(len(per), i), np.full(len(per), blocks.line[i]),
                      np.diff(pts, axis=0).astype(np.int8), per,
                      tick_power_mw(row, rates, max_power_mw=m.laser_max_power_mw)))
        size += len(per)
        if size >= max_ticks:
            yield _join(parts, m.timer_clock_hz)
            parts, size = [], 0
    if parts or size == 0:
        yield _join(parts, m.timer_clock_hz)


def _join(parts, clock_hz) -> StepTrace:
    if not parts:
        e = np.zeros(0, np.int64)
        return StepTrace(e, e.astype(float), e, e.astype(np.int32), np.zeros((0, 3), np.int8), e,
                         e.astype(float))
    cyc, blk, line, step, per, pw = (np.concatenate(x) for x in zip(*parts))
    return StepTrace(cycle=cyc.astype(np.int64), time_s=cyc / clock_hz, block=blk.astype(np.int64),
                     line=line.astype(np.int32), step=step, period=per.astype(np.int64),
                     power_mw=pw.astype(float))


def step_trace(plan) -> StepTrace:
    """The whole job's step pulse train (every tick: time, steps, direction, period).

    Examples
    --------
    >>> from labkit.toolpath import MovesBuilder
    >>> from labkit.motion.pipeline import plan
    >>> b = MovesBuilder(feed_mm_min=600)
    >>> b.line(x=0.003, y=-0.001)          # 6.4 and -2.13 steps: a (6, -2) step line
    >>> tr = step_trace(plan(b.build(), planner="hq"))
    >>> tr.step[:, :2].tolist(), tr.dir_bits.tolist()
    ([[1, 0], [1, -1], [1, 0], [1, 0], [1, -1], [1, 0]], [0, 2, 0, 0, 2, 0])

    The first tick runs at the 1 kHz start rate (48 000 cycles of 48 MHz), the
    second at 1040 Hz: 48e6 / 1040 = 46 153.8, rounded up to 46 154 cycles.

    >>> tr.cycle[:2].tolist(), tr.period[:2].tolist()
    ([48000, 94154], [47999, 46153])
    """
    parts = list(iter_step_chunks(plan, max_ticks=2 ** 62))
    return parts[0] if len(parts) == 1 else StepTrace.concat(parts)


def block_points(blocks, i: int, steps_per_mm) -> np.ndarray:
    """Lattice points (ticks + 1, 3) of motion block ``i``: its Bresenham line, or its
    octant arc with the helix axis spread over the ticks by the line rule.

    The arc is walked exactly as :func:`~labkit.motion.blocks.build_blocks` counted it.
    """
    s = blocks.start_steps[i]
    e = blocks.end_steps[i]
    if blocks.kind[i] == BlockKind.LINE:
        return lines_points(s[None, :], e[None, :])[0]
    a0, a1, lin = PLANE_AXES[int(blocks.plane[i])]
    spm = np.asarray(steps_per_mm, float)
    c = blocks.centre_mm[i]
    plane = arc_lattice_points(s[[a0, a1]], e[[a0, a1]], c[[a0, a1]] * spm[a0],
                       clockwise=blocks.sweep_rad[i] < 0, radius=blocks.radius_mm[i] * spm[a0],
                       sweep_rad=blocks.sweep_rad[i])
    n = len(plane) - 1
    pts = np.empty((n + 1, 3), np.int64)
    pts[:, a0] = plane[:, 0]
    pts[:, a1] = plane[:, 1]
    h = int(e[lin] - s[lin])
    k = np.arange(n + 1)
    pts[:, lin] = s[lin] + np.sign(h) * ((2 * k * abs(h) + n) // (2 * max(n, 1)))
    return pts
