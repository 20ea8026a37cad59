"""Plan a program: blocks → look-ahead → speed profiles → laser power → times.

:func:`plan` runs the whole chain of a controller's planner on a
:class:`~labkit.toolpath.Moves` program and returns a :class:`Plan`: every
block with its entry, peak and exit speed, its duration and power, the super
blocks, and the job summary (time, speeds, laser-on time). The step-level
view (timer periods and the step pulse train) is in :mod:`labkit.motion.timer`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from labkit.errors import MotionError
from labkit.motion.blocks import BlockKind, Blocks, build_blocks
from labkit.motion.power import laser_power_mw
from labkit.motion.planner import PLANNERS, Lookahead, lookahead
from labkit.motion.spec import MachineSpec, load_machine
from labkit.motion import _ramp
from labkit.motion.profile import RAMP_LAWS, Profiles, block_profiles
from labkit.toolpath.moves import Moves

__all__ = ["Plan", "PlanSummary", "plan", "default_law"]


def default_law(planner: str) -> str:
    """The ramp law a planner uses unless told: [CBR40]'s linear ramps for its MBLA
    modes, constant acceleration for GRBL's junction planner.

    >>> default_law("hq"), default_law("junction")
    ('linear', 'accel')
    """
    if planner not in PLANNERS:
        raise MotionError(f"planner must be one of {', '.join(PLANNERS)}, got {planner!r}")
    return "accel" if planner == "junction" else "linear"


@dataclass(frozen=True)
class PlanSummary:
    """Figures of a planned job (times s, speeds mm/s, lengths mm)."""

    planner: str
    law: str
    buffer_blocks: int
    blocks: int
    motion_blocks: int
    super_blocks: int
    job_time_s: float
    motion_time_s: float
    dwell_time_s: float
    laser_on_time_s: float
    cut_length_mm: float
    travel_length_mm: float
    peak_speed_mm_s: float
    mean_speed_mm_s: float
    junctions_over_limit: int

    def as_dict(self) -> dict:
        """Plain dict (for JSON)."""
        return dict(self.__dict__)


@dataclass(frozen=True)
class Plan:
    """A planned program.

    Attributes
    ----------
    machine : MachineSpec
    blocks : Blocks
        All blocks, dwells included.
    motion : ndarray of int
        Indices (into ``blocks``) of the motion blocks, in order.
    lookahead : Lookahead
        Junction speeds and super blocks of the motion blocks.
    profiles : Profiles
        Speed profile of each motion block.
    sync_lines : ndarray of int
        Source lines at which the motion was made to stop because the controller empties
        its planner there (``plan``'s ``sync_lines``); empty when none were given.
    """

    machine: MachineSpec
    blocks: Blocks
    motion: np.ndarray
    lookahead: Lookahead
    profiles: Profiles
    sync_lines: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))

    @property
    def planner(self) -> str:
        return self.lookahead.planner

    @property
    def law(self) -> str:
        return self.lookahead.law

    @property
    def block_time_s(self) -> np.ndarray:
        """Duration of every block (profiles for motion, dwell times for dwells), s."""
        t = self.blocks.dwell_s.astype(float).copy()
        t[self.motion] = self.profiles.time_s
        return t

    @property
    def block_start_s(self) -> np.ndarray:
        """Time at which every block starts, s (the job starts at 0)."""
        t = self.block_time_s
        return np.concatenate([[0.0], np.cumsum(t)[:-1]]) if len(t) else t

    @property
    def job_time_s(self) -> float:
        """Total time: the sum of every block's profile time and the dwells, s."""
        return float(self.block_time_s.sum())

    def summary(self) -> PlanSummary:
        """Job figures: time, blocks, super blocks, peak and mean speed, laser-on time."""
        b = self.blocks[self.motion]
        p = self.profiles
        t = p.time_s
        on = b.laser_on
        motion_t = float(t.sum())
        length = float(p.length_mm.sum())
        return PlanSummary(
            planner=self.planner, law=self.law, buffer_blocks=self.lookahead.buffer_blocks,
            blocks=len(self.blocks), motion_blocks=len(self.motion),
            super_blocks=self.lookahead.n_super_blocks, job_time_s=self.job_time_s,
            motion_time_s=motion_t, dwell_time_s=float(self.blocks.dwell_s.sum()),
            laser_on_time_s=float(t[on].sum()), cut_length_mm=float(p.length_mm[on].sum()),
            travel_length_mm=float(p.length_mm[~on].sum()),
            peak_speed_mm_s=float(p.peak_mm_s.max()) if len(p) else 0.0,
            mean_speed_mm_s=length / motion_t if motion_t > 0 else 0.0,
            junctions_over_limit=int(self.lookahead.over_limit.sum()),
        )

    def trace(self):
        """One row per block: source line, kind, length, entry/peak/exit speed, power, times.

        Returns a pandas DataFrame with columns ``block, line, kind, super_block,
        length_mm, entry_mm_s, peak_mm_s, exit_mm_s, cap_mm_s, power_mw, laser,
        start_s, time_s`` (speeds 0 and super block −1 on dwells).
        """
        import pandas as pd

        n = len(self.blocks)
        cols = {name: np.zeros(n) for name in ("entry_mm_s", "peak_mm_s", "exit_mm_s", "cap_mm_s")}
        for name in cols:
            cols[name][self.motion] = getattr(self.profiles, name)
        sb = np.full(n, -1, np.int64)
        sb[self.motion] = self.lookahead.super_block
        return pd.DataFrame({
            "block": np.arange(n), "line": self.blocks.line,
            "kind": [("RAPID" if r else BlockKind(k).name) for k, r in zip(self.blocks.kind, self.blocks.rapid)],
            "super_block": sb, "length_mm": self.blocks.length_mm, **cols,
            "power_mw": self.blocks.power_mw, "laser": self.blocks.laser_mode,
            "start_s": self.block_start_s, "time_s": self.block_time_s,
        })

    def burn_profile(self, step_mm: float = 0.01):
        """Speed, power and dose along the burned path, sampled every ``step_mm`` of it.

        Parameters
        ----------
        step_mm : float
            Sample spacing along the burning blocks, mm (> 0); samples sit in
            the middle of equal pieces of each block.

        Returns
        -------
        dict of ndarray
            ``distance_mm`` (along the burned path only), ``speed_mm_s``,
            ``power_mw``, ``dose_mj_per_mm`` (power / speed), ``feed_mm_s``
            (programmed) and ``block``.
        """
        if not step_mm > 0:
            raise MotionError(f"step_mm must be > 0 mm, got {step_mm!r}")
        b = self.blocks[self.motion]
        on = np.flatnonzero(b.laser_on)
        p = self.profiles
        L = p.length_mm[on]
        n = np.maximum(1, np.ceil(L / step_mm).astype(np.int64))
        j = np.repeat(on, n)
        k = np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)
        s = (k + 0.5) * p.length_mm[j] / np.repeat(n, n)
        law = RAMP_LAWS[self.law]
        v = np.minimum(np.minimum(_ramp.reach(p.entry_mm_s[j], s, p.up[j], law), p.peak_mm_s[j]),
                       _ramp.reach(p.exit_mm_s[j], p.length_mm[j] - s, p.down[j], law))
        power = np.asarray(laser_power_mw(v, mode=b.laser_mode[j], power_mw=b.power_mw[j],
                                          feed_mm_s=b.feed_mm_s[j],
                                          max_power_mw=self.machine.laser_max_power_mw))
        start = np.concatenate([[0.0], np.cumsum(L)[:-1]]) if len(L) else np.zeros(0)
        return {"distance_mm": np.repeat(start, n) + s, "speed_mm_s": v, "power_mw": power,
                "dose_mj_per_mm": power / v, "feed_mm_s": b.feed_mm_s[j], "block": self.motion[j]}

    def sample(self, n: int = 2000):
        """Sample the motion uniformly in time for plots.

        Parameters
        ----------
        n : int
            Number of samples over the whole job (≥ 2); in plans of up to 4n
            blocks every block also gets its start and end, so short blocks
            are not lost.

        Returns
        -------
        dict of ndarray
            ``time_s``, ``distance_mm`` (along the path), ``speed_mm_s``,
            ``power_mw`` (instantaneous, per the block's laser mode) and
            ``block`` (index into ``blocks``).
        """
        if not (isinstance(n, (int, np.integer)) and n >= 2):
            raise MotionError(f"n must be an integer >= 2 samples, got {n!r}")
        if len(self.blocks) == 0:
            z = np.zeros(n)
            return {"time_s": z, "distance_mm": z.copy(), "speed_mm_s": z.copy(), "power_mw": z.copy(),
                    "block": np.zeros(n, np.int64)}
        start = self.block_start_s
        times = self.block_time_s
        total = self.job_time_s
        grid = np.linspace(0.0, total, n)
        if len(start) <= 4 * n:        # small plans: every block's ends too
            grid = np.concatenate([grid, start, start + times])
        t_all = np.unique(grid)
        blk = np.clip(np.searchsorted(start, t_all, side="right") - 1, 0, max(len(start) - 1, 0))
        dist0 = np.zeros(len(self.blocks))
        dist0[1:] = np.cumsum(self.blocks.length_mm)[:-1]
        pos = np.full(len(self.blocks), -1)
        pos[self.motion] = np.arange(len(self.motion))
        s = dist0[blk].copy()
        v = np.zeros_like(t_all)
        moving = pos[blk] >= 0
        if moving.any():
            ss, vv = self.profiles.sample(pos[blk[moving]], t_all[moving] - start[blk[moving]])
            s[moving] += ss
            v[moving] = vv
        b = self.blocks
        power = laser_power_mw(v, mode=b.laser_mode[blk], power_mw=b.power_mw[blk],
                               feed_mm_s=np.where(np.isfinite(b.feed_mm_s[blk]), b.feed_mm_s[blk], 1.0),
                               max_power_mw=self.machine.laser_max_power_mw)
        return {"time_s": t_all, "distance_mm": s, "speed_mm_s": v, "power_mw": np.asarray(power),
                "block": blk}


def plan(moves: Moves | Blocks, machine: MachineSpec | str | None = None, *, planner: str = "junction",
         buffer_blocks: int | None = None, law: str | None = None,
         arc_tol_mm: float | None = None, sync_lines=None) -> Plan:
    """Plan a program the way a controller would.

    Parameters
    ----------
    moves : Moves or Blocks
        The program (or blocks already built for this machine).
    machine : MachineSpec, str or None
        Machine or name of a description in ``labkit/motion/machines/`` (default CBR-40).
    planner : {"junction", "fast", "normal", "hq"}
        GRBL's junction deviation, or [CBR40]'s MBLA modes.
    buffer_blocks : int, optional
        Look-ahead depth; default the machine's ``buffer_blocks``.
    law : {"linear", "accel"}, optional
        Ramp law; default :func:`default_law` of the planner. ``"linear"``
        ramps by the machine's ``accel_hz_per_step``/``decel_hz_per_step``,
        ``"accel"`` by each block's acceleration (mm/s²).
    arc_tol_mm : float, optional
        Cut arcs into chords (GRBL ``$12``); default one block per arc.
    sync_lines : sequence of int, optional
        Source lines at which the controller waits for its planner to empty before it goes
        on (every line GRBL syncs on: laser, coolant, offsets and probes,
        :func:`labkit.gcode.grbl_sync_lines`): the motion stops at the junction before the
        first block of that line or after it. A dwell, a pause (M0, M1), a program end (M2,
        M30) and a probe move (before and after it) always stop it.

    Returns
    -------
    Plan

    Examples
    --------
    A 10 mm cut at 1200 mm/min (20 mm/s) on the CBR-40 with [CBR40]'s linear
    ramps of 40 Hz per step from the 1 kHz start rate (0.46875 mm/s): each
    ramp takes ln(20/0.46875)/40 = 0.093835 s over (20 − 0.46875)/40 =
    0.488281 mm, the 9.023438 mm between at 20 mm/s take 0.451172 s.

    >>> from labkit.toolpath import MovesBuilder
    >>> b = MovesBuilder(feed_mm_min=1200)
    >>> b.line(x=10)
    >>> p = plan(b.build(), planner="hq")
    >>> s = p.summary()
    >>> s.blocks, s.super_blocks, round(s.peak_speed_mm_s, 3), round(s.job_time_s, 4)
    (1, 1, 20.0, 0.6388)
    """
    m = load_machine(machine)
    blocks = moves if isinstance(moves, Blocks) else build_blocks(moves, m, arc_tol_mm=arc_tol_mm)
    law = default_law(planner) if law is None else law
    if law not in RAMP_LAWS:
        raise MotionError(f"ramp law must be one of {sorted(RAMP_LAWS)}, got {law!r}")
    blocks = blocks.with_rest(m, law)       # GRBL's planner rests at 0, the others at the start rate
    depth = m.buffer_blocks if buffer_blocks is None else buffer_blocks
    motion = np.flatnonzero(blocks.is_motion)
    mb = blocks[motion]
    # a dwell between two motion blocks forces a stop at that junction
    stop = np.zeros(len(motion) + 1, bool)
    if len(motion):
        dwell_before = np.cumsum(~blocks.is_motion)[motion]
        stop[1:-1] = dwell_before[1:] != dwell_before[:-1]
    sync = np.zeros(0, np.int64) if sync_lines is None else np.unique(np.asarray(sync_lines, np.int64))
    if len(sync) and len(motion):
        # the first motion block at or after each such line starts from rest
        k = np.searchsorted(np.asarray(mb.line, np.int64), sync, side="left")
        stop[k[(k > 0) & (k < len(motion))]] = True
    if isinstance(moves, Moves) and len(motion):
        # a pause, a program end, a probe: the first motion block after the record's place
        # (Record.index: the moves before it; a probe also after its own move) starts from rest
        cuts = [r.index for r in moves.records if r.kind in ("pause", "optional_pause", "end")]
        cuts += [r.index + k for r in moves.records if r.kind == "probe" for k in (0, 1)]
        if cuts:
            k = np.searchsorted(np.asarray(blocks.move[motion], np.int64), np.asarray(cuts), side="left")
            stop[k[(k > 0) & (k < len(motion))]] = True
    if law == "linear":
        up = np.full(len(mb), float(m.accel_hz_per_step))
        down = np.full(len(mb), float(m.decel_hz_per_step))
    else:
        up = down = mb.accel_mm_s2
    la = lookahead(mb, planner=planner, law=law, buffer_blocks=depth,
                   junction_deviation_mm=m.junction_deviation_mm, axis_accel_mm_s2=m.accel_mm_s2,
                   up=up, down=down, stop_before=stop)
    if len(mb):
        floor = np.minimum(mb.rest_mm_s, la.cap_mm_s)
        prof = block_profiles(mb.length_mm, np.maximum(la.speed_mm_s[:-1], floor), la.cap_mm_s,
                              np.maximum(la.speed_mm_s[1:], floor), up, down, law)
    else:
        prof = block_profiles(np.ones(0), np.ones(0), np.ones(0), np.ones(0), np.ones(0), np.ones(0), law)
    return Plan(machine=m, blocks=blocks, motion=motion, lookahead=la, profiles=prof, sync_lines=sync)
