"""Blocks: the executable units a controller plans and runs ([CBR40] §H).

The parser turns each motion of a program into a *block*: where it starts
and ends in steps, how many ticks of the step timer it takes, its length and
direction, the highest speed it may run at and the laser power it asks for.
Blocks wait in a first-in first-out buffer (:class:`BlockFifo`) between the
parser/planner and the runner, as in [CBR40]'s firmware and GRBL's planner
buffer.

Conventions (what the firmware must reproduce)
----------------------------------------------
- Positions in steps are ``llround(mm × steps_per_mm)`` in IEEE double
  (:func:`to_steps`), rounding halves away from zero, from the *programmed*
  end point of each move; a block starts where the previous one ended, so
  rounding never accumulates.
- A line's length is that of its rounded step displacement
  (Δsteps / steps_per_mm, as GRBL does), so speed ↔ step rate is exact.
  An arc's length is the programmed one, |sweep|·r (with the helix).
- A move that rounds to no step at all makes no block (GRBL drops them too).
- Speeds: the cap of a block is the programmed feed limited by every axis'
  maximum rate along the block's direction, min_i(v_max,i / |u_i|) (arcs: by
  the slowest of their axes and by the centripetal limit sqrt(a·r)); rapids
  run at the axis limit. The acceleration along a line is
  min_i(a_i / |u_i|) (GRBL); along an arc the smallest of its axes'.
- The rest speed of a block is the path speed at which its driver axis steps
  at the machine's start rate, start_rate_hz × L / N (or the cap if lower); a
  plan with constant acceleration on a machine whose planner rests at zero
  (GRBL, ``MachineSpec.rest_at_zero``) sets it to 0 (:meth:`Blocks.with_rest`).
- Power: S / s_max × laser maximum (mW) while the beam burns (M3/M4 with
  S > 0 on a feed move), else 0; the power/speed ratio of [CBR40] §IV is
  that power over the programmed speed (mW per mm/s).
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, fields, replace

import numpy as np

from labkit._array import ColumnTable
from labkit.errors import MotionError
from labkit.motion.bresenham import arc_lattice_points, direction_bits
from labkit.motion.spec import MachineSpec, load_machine
from labkit.toolpath.moves import PLANE_AXES, LaserMode, MoveKind, Moves, check_moves

__all__ = ["BlockKind", "Blocks", "BlockFifo", "build_blocks", "to_steps", "expand_arcs"]


class BlockKind(enum.IntEnum):
    """What a block does."""

    LINE = 1    #: straight motion (G0, G1, or a chord of a cut-up arc)
    ARC = 2     #: circular (helical) motion walked by the octant Bresenham (G2/G3)
    DWELL = 4   #: wait in place (G4): a full stop, no steps


def to_steps(mm, steps_per_mm):
    """Millimetres → whole steps: ``llround(mm × steps_per_mm)`` (halves away from zero).

    Examples
    --------
    >>> to_steps([0.0, 1.0, -0.000234375], 6400 / 3).tolist()   # -0.5 step rounds to -1
    [0, 2133, -1]
    """
    x = np.asarray(mm, dtype=float) * np.asarray(steps_per_mm, dtype=float)
    return (np.sign(x) * np.floor(np.abs(x) + 0.5)).astype(np.int64)


@dataclass(frozen=True)
class Blocks(ColumnTable):
    """Blocks as numpy columns, one row per block in program order.

    Attributes
    ----------
    kind : int8
        :class:`BlockKind`.
    rapid : bool
        G0 (laser off, axis-limited speed).
    move, line : int
        Row of the source :class:`~labkit.toolpath.Moves` and its 1-based source line.
    start_steps, end_steps : int64, (n, 3)
        Absolute positions in steps.
    ticks : int64
        Step-timer ticks N of the block (driver steps; arcs: length of the octant walk).
    length_mm : float
        Path length, mm.
    unit_in, unit_out : float, (n, 3)
        Direction of travel at the start and the end (equal for lines).
    centre_mm : float, (n, 3)
        Arc centre (NaN for lines).
    radius_mm, sweep_rad : float
        Arc radius and signed sweep (CCW > 0); 0 for lines.
    plane : int8
        17, 18, 19 (arcs).
    feed_mm_s : float
        Programmed speed (inf for rapids).
    limit_mm_s : float
        Machine limit along the block (axis rates, centripetal).
    cap_mm_s : float
        min(feed, limit): the block's nominal speed.
    accel_mm_s2 : float
        Acceleration along the block.
    rest_mm_s : float
        Rest speed, the speed the planner starts and stops the block at: the
        driver at the machine's start rate (≤ cap), or 0 (:meth:`with_rest`).
    laser_mode : int8
        0 off, 3 M3 constant, 4 M4 dynamic.
    power_mw : float
        Programmed optical power, mW (0 when the beam is off).
    dwell_s : float
        Dwell time (DWELL blocks).
    """

    kind: np.ndarray
    rapid: np.ndarray
    move: np.ndarray
    line: np.ndarray
    start_steps: np.ndarray
    end_steps: np.ndarray
    ticks: np.ndarray
    length_mm: np.ndarray
    unit_in: np.ndarray
    unit_out: np.ndarray
    centre_mm: np.ndarray
    radius_mm: np.ndarray
    sweep_rad: np.ndarray
    plane: np.ndarray
    feed_mm_s: np.ndarray
    limit_mm_s: np.ndarray
    cap_mm_s: np.ndarray
    accel_mm_s2: np.ndarray
    rest_mm_s: np.ndarray
    laser_mode: np.ndarray
    power_mw: np.ndarray
    dwell_s: np.ndarray

    @property
    def steps(self) -> np.ndarray:
        """Net displacement in steps per axis, (n, 3)."""
        return self.end_steps - self.start_steps

    def speed_at_rate(self, rate_hz) -> np.ndarray:
        """Path speed (mm/s) at which each block's driver axis steps at ``rate_hz`` (Hz), at
        most its cap; 0 for a block of no tick. At the machine's ``start_rate_hz`` it is the
        slowest speed the step timer runs the block at (a planned speed below it runs at it)."""
        return _rest_mm_s(self.length_mm, self.ticks, self.cap_mm_s, rate_hz)

    def with_rest(self, machine: MachineSpec, law: str) -> "Blocks":
        """The blocks with the rest speed ``machine``'s planner starts and stops them at
        under the ramp ``law`` (``"linear"`` or ``"accel"``): the driver at
        :meth:`MachineSpec.rest_rate_hz` (0 on GRBL with constant acceleration). Blocks
        built for ``machine`` rest at its start rate already: those come back as they are."""
        rate = machine.rest_rate_hz(law)
        if rate == machine.start_rate_hz:
            return self
        return replace(self, rest_mm_s=self.speed_at_rate(rate))

    @property
    def dir_bits(self) -> np.ndarray:
        """Direction bits of the net displacement (bit i: axis i negative); arcs turn
        within the block, so their bits only describe start → end."""
        return direction_bits(self.steps)

    @property
    def is_motion(self) -> np.ndarray:
        """Blocks that move (lines and arcs)."""
        return self.kind != BlockKind.DWELL

    @property
    def laser_on(self) -> np.ndarray:
        """Blocks during which the beam burns."""
        return self.power_mw > 0

    @property
    def power_ratio(self) -> np.ndarray:
        """[CBR40]'s power/speed ratio: programmed power / programmed speed, mW per mm/s."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(self.laser_on, self.power_mw / self.feed_mm_s, 0.0)

    def to_dataframe(self):
        """The columns as a pandas DataFrame (XYZ columns split)."""
        import pandas as pd

        data = {}
        for f in fields(self):
            col = getattr(self, f.name)
            if col.ndim == 2:
                for i, ax in enumerate("xyz"):
                    data[f"{f.name}_{ax}"] = col[:, i]
            else:
                data[f.name] = col
        data["kind"] = [BlockKind(k).name for k in self.kind]
        return pd.DataFrame(data)


class BlockFifo:
    """A fixed-capacity first-in first-out ring buffer, as the firmware keeps its blocks.

    The parser/planner pushes at the head, the runner pops at the tail; when
    the buffer is full the parser waits (here: :meth:`push` raises).

    Parameters
    ----------
    capacity : int
        Slots (≥ 1).

    Examples
    --------
    >>> f = BlockFifo(2)
    >>> f.push(10); f.push(11); f.full
    True
    >>> f.pop(), list(f), len(f)
    (10, [11], 1)
    """

    def __init__(self, capacity: int):
        if not (isinstance(capacity, (int, np.integer)) and capacity >= 1):
            raise MotionError(f"capacity must be an integer >= 1 slot, got {capacity!r}")
        self._slots = [None] * int(capacity)
        self._tail = 0     # oldest item
        self._count = 0

    @property
    def capacity(self) -> int:
        return len(self._slots)

    @property
    def full(self) -> bool:
        return self._count == len(self._slots)

    @property
    def empty(self) -> bool:
        return self._count == 0

    def __len__(self) -> int:
        return self._count

    def push(self, item) -> None:
        """Append at the head; raises :class:`MotionError` when full."""
        if self.full:
            raise MotionError(f"block buffer full ({self.capacity} blocks): pop before pushing")
        self._slots[(self._tail + self._count) % len(self._slots)] = item
        self._count += 1

    def pop(self):
        """Remove and return the oldest item; raises :class:`MotionError` when empty."""
        if self.empty:
            raise MotionError("block buffer empty: nothing to pop")
        item = self._slots[self._tail]
        self._slots[self._tail] = None
        self._tail = (self._tail + 1) % len(self._slots)
        self._count -= 1
        return item

    def __getitem__(self, i: int):
        """Item ``i`` counted from the oldest (0)."""
        if not 0 <= i < self._count:
            raise IndexError(f"buffer index {i} out of range (holds {self._count})")
        return self._slots[(self._tail + i) % len(self._slots)]

    def __iter__(self):
        return (self[i] for i in range(self._count))


def expand_arcs(moves: Moves, tol_mm: float) -> Moves:
    """Replace every arc by chords, as GRBL does (``$12`` tolerance).

    Each arc becomes ``grbl_segments(r, sweep, tol_mm)`` lines of equal angle
    (the helix axis moves linearly), keeping the arc's feed, power, laser
    and source line.

    Examples
    --------
    >>> from labkit.toolpath import MovesBuilder
    >>> b = MovesBuilder(feed_mm_min=600)
    >>> b.arc_ccw(x=0, y=0, i=5, j=0)              # full circle, r = 5 mm
    >>> len(expand_arcs(b.build(), 0.01))          # floor(½·2π·5 / sqrt(0.01·9.99))
    49
    """
    from labkit.geometry.circle import arc_chord_points, grbl_segments

    if not tol_mm > 0:
        raise MotionError(f"tol_mm must be > 0 mm, got {tol_mm!r}")
    arc = moves.is_arc
    if not arc.any():
        return moves
    sweep = moves.sweep_rad()[arc]
    radius = moves.radius_mm()[arc]
    arcs = np.flatnonzero(arc)
    counts = np.atleast_1d(grbl_segments(radius, sweep, tol_mm)).astype(np.int64)
    axes = np.array([PLANE_AXES[17], PLANE_AXES[18], PLANE_AXES[19]])[moves.plane[arcs].astype(int) - 17]
    pts, owner, _ = arc_chord_points(moves.start[arcs], moves.end[arcs], moves.centre[arcs], axes,
                                     radius, sweep, counts)
    # each arc's points after the first are its chords' ends; every row keeps its move's
    # feed, power, laser and source line
    first = np.cumsum(counts + 1) - (counts + 1)
    chord_end = np.ones(len(pts), bool)
    chord_end[first] = False
    per_row = np.ones(len(moves), np.int64)
    per_row[arcs] = counts
    source_row = np.repeat(np.arange(len(moves)), per_row)
    merged = {k: v[source_row] for k, v in moves.columns().items()}
    is_chord = np.repeat(arc, per_row)
    merged["kind"][is_chord] = MoveKind.LINE
    merged["end"][is_chord] = pts[chord_end]
    merged["start"][is_chord] = pts[np.flatnonzero(chord_end) - 1]
    merged["centre"][is_chord] = np.nan
    return Moves(source=moves.source, s_max=moves.s_max, **merged)


def _axis_limit(values, unit):
    """min_i(values_i / |u_i|) over the axes the direction uses (GRBL's limit_value_by_axis_maximum)."""
    with np.errstate(divide="ignore"):
        per_axis = np.where(np.abs(unit) > 1e-12, np.asarray(values) / np.abs(unit), np.inf)
    return per_axis.min(axis=-1)


def build_blocks(moves: Moves, machine: MachineSpec | str | None = None, *,
                 arc_tol_mm: float | None = None) -> Blocks:
    """Turn a program into blocks for ``machine``.

    Parameters
    ----------
    moves : Moves
        The program (absolute mm; feeds in mm/min).
    machine : MachineSpec, str or None
        Machine or the name of a description in ``labkit/motion/machines/``
        (default :data:`~labkit.motion.CBR40`).
    arc_tol_mm : float, optional
        Cut arcs into chords at this tolerance first (GRBL ``$12``). By
        default each arc is one block walked by the octant Bresenham
        ([CBR40] §J), which needs equal steps/mm on the arc's two axes.

    Returns
    -------
    Blocks

    Raises
    ------
    MotionError
        A feed move with no feed rate, a move that does not start where the
        previous one ended, an arc whose end is off its circle (GRBL's
        0.005 mm and 0.1 % rule), an arc on axes with different steps/mm, or
        a helix whose linear axis needs more steps than the arc has ticks —
        each naming the source line.

    Examples
    --------
    >>> from labkit.toolpath import MovesBuilder, LaserMode
    >>> b = MovesBuilder(feed_mm_min=600, s_word=400, laser=LaserMode.DYNAMIC)
    >>> b.line(x=3, y=4)
    >>> blk = build_blocks(b.build())
    >>> blk.steps[0].tolist(), int(blk.ticks[0]), round(float(blk.length_mm[0]), 6)
    ([6400, 8533, 0], 8533, 4.999875)
    >>> float(blk.cap_mm_s[0]), float(blk.power_mw[0]), float(blk.power_ratio[0])
    (10.0, 1000.0, 100.0)
    """
    m = load_machine(machine)
    check_moves(moves, error=MotionError)
    if arc_tol_mm is not None:
        moves = expand_arcs(moves, arc_tol_mm)
    n = len(moves)
    spm = np.asarray(m.steps_per_mm)
    if n == 0:
        return _empty_blocks()
    # chain positions: every move starts where the previous one ended
    gap = np.linalg.norm(moves.start[1:] - moves.end[:-1], axis=1)
    if np.any(gap > 1e-6):
        i = int(np.flatnonzero(gap > 1e-6)[0]) + 1
        raise MotionError(f"move {i} (line {moves.line[i]}) starts at {moves.start[i].tolist()} mm "
                          f"but the previous move ended at {moves.end[i - 1].tolist()} mm")
    end_steps = to_steps(moves.end, spm)
    start_steps = np.vstack([to_steps(moves.start[:1], spm), end_steps[:-1]])
    feed = moves.feed_mm_min / 60.0
    missing = moves.is_feed & ~(feed > 0)
    if missing.any():
        i = int(np.flatnonzero(missing)[0])
        raise MotionError(f"move {i} (line {moves.line[i]}): no feed rate in effect "
                          f"(F must be set > 0 before G1/G2/G3), got {moves.feed_mm_min[i]!r} mm/min")
    rapid = moves.kind == MoveKind.RAPID
    feed = np.where(rapid, np.inf, feed)

    kind = np.where(moves.is_arc, BlockKind.ARC, BlockKind.LINE).astype(np.int8)
    kind[moves.kind == MoveKind.DWELL] = BlockKind.DWELL
    delta = (end_steps - start_steps).astype(float) / spm
    length = np.linalg.norm(delta, axis=1)
    ticks = np.abs(end_steps - start_steps).max(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        unit = np.where(length[:, None] > 0, delta / length[:, None], 0.0)
    unit_in = unit.copy()
    unit_out = unit.copy()
    vmax = m.max_rate_mm_s
    amax = np.asarray(m.accel_mm_s2)
    limit = _axis_limit(vmax, unit)
    accel = _axis_limit(amax, unit)
    radius = np.zeros(n)
    sweep = np.zeros(n)
    centre = np.full((n, 3), np.nan)

    all_sweeps = moves.sweep_rad()
    all_radii = moves.radius_mm()
    for i in np.flatnonzero(moves.is_arc):
        a0, a1, lin = PLANE_AXES[int(moves.plane[i])]
        if not math.isclose(spm[a0], spm[a1], rel_tol=1e-12):
            raise MotionError(f"move {i} (line {moves.line[i]}): an arc needs equal steps/mm on "
                              f"its axes ({spm[a0]:g} vs {spm[a1]:g}); give arc_tol_mm to cut it into lines")
        sw = float(all_sweeps[i])
        r = float(all_radii[i])
        c = moves.centre[i]
        r_end = math.hypot(moves.end[i, a0] - c[a0], moves.end[i, a1] - c[a1])
        if abs(r_end - r) > 0.005 and abs(r_end - r) > 0.001 * r:
            raise MotionError(f"move {i} (line {moves.line[i]}): arc radius {r:g} mm at the start but "
                              f"{r_end:g} mm at the end (GRBL allows 0.005 mm and 0.1 %)")
        pts = arc_lattice_points(start_steps[i, [a0, a1]], end_steps[i, [a0, a1]], c[[a0, a1]] * spm[a0],
                         clockwise=moves.kind[i] == MoveKind.ARC_CW, radius=r * spm[a0], sweep_rad=sw)
        n_ticks = len(pts) - 1
        h = int(end_steps[i, lin] - start_steps[i, lin])
        if abs(h) > n_ticks:
            raise MotionError(f"move {i} (line {moves.line[i]}): helix rises {abs(h)} steps over an arc "
                              f"of {n_ticks} ticks; give arc_tol_mm to cut it into lines")
        ticks[i] = n_ticks
        radius[i] = r
        sweep[i] = sw
        centre[i] = c
        arc_len = abs(sw) * r
        rise = (end_steps[i, lin] - start_steps[i, lin]) / spm[lin]
        length[i] = math.hypot(arc_len, rise)
        for tgt, point in ((unit_in, moves.start[i]), (unit_out, moves.end[i])):
            rx, ry = point[a0] - c[a0], point[a1] - c[a1]
            t = np.array([-ry, rx]) * np.sign(sw) / max(math.hypot(rx, ry), 1e-300)
            tgt[i] = 0.0
            tgt[i, a0] = t[0] * arc_len / length[i]
            tgt[i, a1] = t[1] * arc_len / length[i]
            tgt[i, lin] = rise / length[i]
        axes = [a0, a1] + ([lin] if h else [])
        limit[i] = min(min(vmax[axes]), math.sqrt(min(amax[[a0, a1]]) * r))
        accel[i] = min(amax[axes])

    cap = np.minimum(feed, limit)
    rest = _rest_mm_s(length, ticks, cap, m.start_rate_hz)
    burning = moves.laser_on
    power = moves.power_mw(m.laser_max_power_mw)
    keep = (ticks > 0) | (kind == BlockKind.DWELL)
    dwell = np.where(kind == BlockKind.DWELL, moves.dwell_s, 0.0)
    zero = kind == BlockKind.DWELL
    for arr in (length, limit, cap, accel, rest):
        arr[zero] = 0.0
    return Blocks(kind=kind[keep], rapid=rapid[keep], move=np.flatnonzero(keep).astype(np.int64),
                  line=moves.line[keep].astype(np.int32), start_steps=start_steps[keep],
                  end_steps=end_steps[keep], ticks=ticks[keep].astype(np.int64), length_mm=length[keep],
                  unit_in=unit_in[keep], unit_out=unit_out[keep], centre_mm=centre[keep],
                  radius_mm=radius[keep], sweep_rad=sweep[keep], plane=moves.plane[keep].astype(np.int8),
                  feed_mm_s=feed[keep], limit_mm_s=limit[keep], cap_mm_s=cap[keep],
                  accel_mm_s2=accel[keep], rest_mm_s=rest[keep],
                  laser_mode=np.where(burning, moves.laser, LaserMode.OFF)[keep].astype(np.int8),
                  power_mw=power[keep], dwell_s=dwell[keep])


def _rest_mm_s(length_mm, ticks, cap_mm_s, rate_hz: int) -> np.ndarray:
    """Path speed (mm/s) at which a block's driver steps at ``rate_hz``, at most its cap;
    0 for a block of no tick."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(ticks > 0, np.minimum(rate_hz * length_mm / np.maximum(ticks, 1), cap_mm_s), 0.0)


def _empty_blocks() -> Blocks:
    z = np.zeros(0)
    z3 = np.zeros((0, 3))
    return Blocks(kind=np.zeros(0, np.int8), rapid=np.zeros(0, bool), move=np.zeros(0, np.int64),
                  line=np.zeros(0, np.int32), start_steps=np.zeros((0, 3), np.int64),
                  end_steps=np.zeros((0, 3), np.int64), ticks=np.zeros(0, np.int64), length_mm=z,
                  unit_in=z3, unit_out=z3, centre_mm=z3, radius_mm=z, sweep_rad=z,
                  plane=np.zeros(0, np.int8), feed_mm_s=z, limit_mm_s=z, cap_mm_s=z, accel_mm_s2=z,
                  rest_mm_s=z, laser_mode=np.zeros(0, np.int8), power_mw=z, dwell_s=z)
