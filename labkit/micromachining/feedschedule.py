"""Feed-rate scheduling from the chip volume ([MicroCAM] ch. 3.2–3.4).

Off-line: the chip volume V_c at every position of the path
(:func:`~labkit.micromachining.chipvolume.chip_volumes`) sets the feed per tooth there,

    f_t,opt = f_t,max − (f_t,max − f_t,min) · (V_c − V_c,min) / (V_c,max − V_c,min)   (eq. 3.2)

so the feed rises where the chip is small (air, partial immersion) and falls to f_t,min
where it is largest (full immersion). [MicroCAM] compares two ways to write it back:

- **one feed per position**: every step becomes its own block with the smoothed
  (moving-average) feed — many short blocks. On the ALIO stage the measured feed fell
  linearly with the block length below 0.4 mm at 3 mm/s (fig. 3-20), so this program
  ran *slower* than the original (+10 s on the 0.794 mm pocket);
- **one feed per original block**: the average chip volume of each block sets its feed;
  the block count is unchanged, and the pocket ran 13 % faster with 28 % lower force.

Consecutive steps of one block whose feeds round to the same F are merged, so the first
variant has as many blocks as the feed actually changes. Machining time comes from
:func:`labkit.motion.plan` (acceleration, junction speeds) with an optional floor of
``block_time_s`` per block — the controller's block-processing time that makes the
measured feed proportional to block length (0.4 mm / 3 mm/s ≈ 0.133 s on [MicroCAM]'s
controller).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from labkit.errors import GeometryError
from labkit.micromachining.chipvolume import ChipVolumes, ZMap, chip_volumes
from labkit.motion.spec import CBR40, MachineSpec
from labkit.toolpath.moves import MoveKind, Moves

__all__ = ["MICRO_MILL", "optimal_feed_per_tooth", "moving_average", "FeedSchedule", "schedule_feeds",
           "machining_time_s", "SEED_BLOCK_TIME_S"]

#: An illustrative precision micro-milling stage (not a specific product): 0.2 µm per step
#: as [MicroCAM]'s ALIO stages, 20 mm/s, 500 mm/s² — for :func:`labkit.motion.plan`.
MICRO_MILL = CBR40.replace(name="micro-mill", steps_per_mm=(5000.0,) * 3, max_rate_mm_min=(1200.0,) * 3,
                           accel_mm_s2=(500.0,) * 3, travel_mm=(100.0,) * 3, junction_deviation_mm=0.001,
                           step_pulse_us=1.0,
                           description="illustrative precision micro-milling stage, 0.2 µm steps")

#: Block-processing time that matches [MicroCAM] fig. 3-20: 0.4 mm blocks just reach 3 mm/s.
SEED_BLOCK_TIME_S = 0.4 / 3.0


def optimal_feed_per_tooth(volume, ft_min_mm: float, ft_max_mm: float) -> np.ndarray:
    """[MicroCAM] eq. 3.2: the feed per tooth for each chip volume, mm.

    With V_c constant along the path (no information) every position gets f_t,min.

    >>> optimal_feed_per_tooth([0.0, 5.0, 10.0], 0.001, 0.0015).tolist()
    [0.0015, 0.00125, 0.001]
    """
    v = np.asarray(volume, float)
    if not (0 < ft_min_mm <= ft_max_mm and math.isfinite(ft_max_mm)):
        raise GeometryError(f"need 0 < ft_min_mm <= ft_max_mm, got {ft_min_mm!r}, {ft_max_mm!r}")
    lo, hi = float(v.min()), float(v.max())
    if hi == lo:
        return np.full(v.shape, float(ft_min_mm))
    return ft_max_mm - (ft_max_mm - ft_min_mm) * (v - lo) / (hi - lo)


def moving_average(x, window: int) -> np.ndarray:
    """Centred moving average over ``window`` samples (odd); near the ends, over those there are.

    >>> moving_average([0, 0, 3, 0, 0], 3).tolist()
    [0.0, 1.0, 1.0, 1.0, 0.0]
    """
    x = np.asarray(x, float)
    if int(window) != window or window < 1 or window % 2 == 0:
        raise GeometryError(f"window must be an odd whole number >= 1, got {window!r}")
    h = int(window) // 2
    c = np.concatenate([[0.0], np.cumsum(x)])
    i = np.arange(len(x))
    lo = np.maximum(0, i - h)
    hi = np.minimum(len(x), i + h + 1)
    return (c[hi] - c[lo]) / (hi - lo)


def machining_time_s(moves: Moves, machine: MachineSpec | str = MICRO_MILL, *, block_time_s: float = 0.0) -> float:
    """Job time from :func:`labkit.motion.plan` (junction deviation, constant acceleration),
    each motion block taking at least ``block_time_s`` (a controller's block-processing time), s."""
    from labkit.motion import plan

    p = plan(moves, machine, planner="junction", law="accel")
    t = p.block_time_s
    if block_time_s > 0:
        t = t.copy()
        t[p.motion] = np.maximum(t[p.motion], block_time_s)
    return float(t.sum())


@dataclass
class FeedSchedule:
    """The chip volume, the scheduled feeds and the two rewritten programs.

    Attributes
    ----------
    chips : ChipVolumes
    ft_position_mm : ndarray (k,)
        Eq. 3.2 per position, smoothed by the moving average, mm/tooth.
    ft_block_mm : ndarray (n,)
        Eq. 3.2 on each block's mean chip volume, mm/tooth (NaN for rapids, dwells).
    per_position, per_block : Moves
        The two rewritten programs (feed per position; feed per original block).
    original : Moves
    """

    chips: ChipVolumes
    ft_position_mm: np.ndarray
    ft_block_mm: np.ndarray
    per_position: Moves
    per_block: Moves
    original: Moves

    def times_s(self, machine: MachineSpec | str = MICRO_MILL, *, block_time_s: float = 0.0) -> dict:
        """Machining time of the original and both variants, s."""
        return {name: machining_time_s(m, machine, block_time_s=block_time_s)
                for name, m in (("original", self.original), ("per_position", self.per_position),
                                ("per_block", self.per_block))}


def _per_position_moves(moves: Moves, chips: ChipVolumes, feed_mm_min: np.ndarray, decimals: int) -> Moves:
    """Each feed move cut at its step positions, consecutive pieces of equal (rounded) feed merged."""
    rows = {name: [] for name in Moves.column_names()}
    first = np.searchsorted(chips.move, np.arange(len(moves)))
    last = np.searchsorted(chips.move, np.arange(len(moves)), side="right")
    f_round = np.round(feed_mm_min, decimals)

    def add(i, start, end, feed):
        for name in Moves.column_names():
            rows[name].append(getattr(moves, name)[i])
        rows["start"][-1] = start
        rows["end"][-1] = end
        rows["feed_mm_min"][-1] = feed

    for i in range(len(moves)):
        k0, k1 = first[i], last[i]
        if not moves.is_feed[i] or k1 == k0:
            add(i, moves.start[i], moves.end[i], moves.feed_mm_min[i])
            continue
        pos = chips.xyz[k0:k1].copy()
        pos[-1] = moves.end[i]                       # the block ends exactly where it did
        fk = f_round[k0:k1]
        change = np.flatnonzero(fk[1:] != fk[:-1])   # piece j ends at position j
        ends = np.append(change, k1 - k0 - 1)
        start = moves.start[i]
        for e in ends:
            add(i, start, pos[e], fk[e])
            start = pos[e]
    cols = {name: np.array(v) for name, v in rows.items()}
    return Moves(source=moves.source, s_max=moves.s_max, **cols)


def schedule_feeds(moves: Moves, workpiece: ZMap, *, tool_diameter_mm: float, rpm: float, teeth: int,
                   ft_min_mm: float, ft_max_mm: float, scale: float = 10.0, window: int = 5,
                   feed_decimals: int = 0) -> FeedSchedule:
    """Chip volume along the program, eq. 3.2, and both rewritten programs.

    Parameters
    ----------
    moves : Moves
        The parsed program.
    workpiece : ZMap
        The stock (not changed).
    tool_diameter_mm, rpm, teeth
        Flat-end mill diameter (mm), spindle speed (rev/min), flutes.
    ft_min_mm, ft_max_mm : float
        Feed per tooth range, mm ([MicroCAM]: 1 and 1.5 µm for Al6061: above 1.5 × the
        minimum chip thickness 0.3 r_e, below the vibration limit).
    scale : float
        Steps of scale × f_t along the path.
    window : int
        Moving-average window, positions (odd).
    feed_decimals : int
        F is rounded to this many decimals (mm/min) before neighbouring pieces are merged.

    Returns
    -------
    FeedSchedule

    Examples
    --------
    A slot (full immersion) then a pass beside it (half immersion): with two blocks they
    take the two ends of the range; the per-block program keeps its block count:

    >>> from labkit.gcode import parse
    >>> prog = parse("G0 X-1 Y0 Z-0.05\\nG1 X6 F120\\nG0 X-1 Y0.5\\nG1 X6")
    >>> stock = ZMap.stock((0, -1), (5, 1.5), top_z=0, bottom_z=-1, cell_mm=0.01)
    >>> s = schedule_feeds(prog, stock, tool_diameter_mm=1.0, rpm=60_000, teeth=2,
    ...                    ft_min_mm=0.001, ft_max_mm=0.0015, scale=20)
    >>> (s.per_block.feed_mm_min[[1, 3]] / 120).round(2).tolist()
    [1.0, 1.5]
    >>> len(s.per_block) == len(prog) < len(s.per_position)
    True
    """
    chips = chip_volumes(moves, workpiece, tool_diameter_mm=tool_diameter_mm, rpm=rpm, teeth=teeth,
                         scale=scale)
    v = chips.per_tooth_mm3
    ft_pos = moving_average(optimal_feed_per_tooth(v, ft_min_mm, ft_max_mm), window)
    # one feed per block from its mean chip volume
    n = len(moves)
    counts = np.bincount(chips.move, minlength=n)
    mean_v = np.bincount(chips.move, weights=v, minlength=n)
    has = counts > 0
    ft_block = np.full(n, np.nan)
    ft_block[has] = optimal_feed_per_tooth(mean_v[has] / counts[has], ft_min_mm, ft_max_mm)
    per_block = moves.copy()
    per_block.feed_mm_min[has] = ft_block[has] * rpm * teeth
    per_position = _per_position_moves(moves, chips, ft_pos * rpm * teeth, feed_decimals)
    return FeedSchedule(chips, ft_pos, ft_block, per_position, per_block, moves)
