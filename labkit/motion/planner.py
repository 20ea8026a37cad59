"""Look-ahead: the speeds at which consecutive blocks meet.

Two families of planners decide the speed at every junction (the exit of one
block = the entry of the next):

[CBR40]'s multi-block look-ahead (MBLA, §L)
    Consecutive blocks join into a *super block* that is profiled as one
    motion: it starts and ends at rest, and inside it the blocks pass into
    each other without stopping. A super block ends at a change between
    rapid and feed motion, at a dwell, and when it holds ``buffer_blocks``
    blocks. The three modes differ in what may join and how fast:

    ``"hq"`` (high quality)
        only blocks of the same direction join (straight runs, e.g. the
        power steps of one raster row); each keeps its own speed.
    ``"normal"``
        any consecutive blocks join, whatever their direction; each keeps
        its own speed (at a junction the slower block's speed).
    ``"fast"``
        any consecutive blocks join and all take the highest speed found in
        the super block (within each block's machine limits): one
        acceleration and one deceleration for the whole set.

    Corners inside ``"normal"`` and ``"fast"`` super blocks are passed
    without slowing — [CBR40]'s printing errors. :func:`junction_speed_caps`
    says how fast each corner could safely be taken; :class:`Lookahead`
    counts the junctions planned faster than that.

GRBL's junction-deviation planner (``"junction"``)
    Every junction gets the speed at which a circle tangent to both blocks,
    ``junction_deviation_mm`` away from the corner, is driven at the
    machine's acceleration: v² = a·δ·sin(θ/2)/(1 − sin(θ/2)) (θ the angle
    between the two directions as GRBL measures it). A backward pass makes
    every block able to stop by the end of the buffer, a forward pass
    limits what acceleration can reach; with a buffer of N blocks the
    planner sees the running block and N − 1 more.

Simplification (stated, not hidden): a block's exit speed is fixed when it
starts running, with the buffer full; GRBL can also raise the exit of the
running block when new blocks arrive during it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from labkit.errors import MotionError
from labkit.motion import _planner as K
from labkit.motion.blocks import BlockKind, Blocks
from labkit.motion.profile import RAMP_LAWS

__all__ = ["PLANNERS", "Lookahead", "junction_speed_caps", "lookahead", "SAME_DIRECTION_COS"]

#: Planner names: GRBL's junction deviation, then [CBR40]'s three MBLA modes.
PLANNERS = ("junction", "fast", "normal", "hq")

#: Two blocks run "in the same direction" (high-quality MBLA) when cos(angle) ≥ this.
SAME_DIRECTION_COS = 1.0 - 1e-9


def junction_speed_caps(unit_prev, unit_next, accel_mm_s2, deviation_mm):
    """GRBL's junction speed limit between two directions.

    Parameters
    ----------
    unit_prev, unit_next : array_like, shape (..., 3)
        Unit direction at the end of the first block and the start of the second.
    accel_mm_s2 : float or sequence of 3 floats
        Axis accelerations; the junction uses the limit along u_next − u_prev.
    deviation_mm : float
        Junction deviation δ (GRBL ``$11``), mm.

    Returns
    -------
    ndarray
        Speed limit at each junction, mm/s (inf for a straight continuation,
        0 for a full reversal).

    Notes
    -----
    With cos θ = −u_prev·u_next (GRBL's sign) and sin(θ/2) = sqrt((1 − cos θ)/2),
    the junction is driven like a circle of radius R = δ·sin(θ/2)/(1 − sin(θ/2))
    at centripetal acceleration a: v² = a·R (GRBL 1.1 planner.c, junction deviation).

    Examples
    --------
    A right angle with a = 500 mm/s² on both axes and δ = 0.01 mm:
    a along (−1, 1)/√2 is 500·√2 = 707.1, R = 0.01·0.7071/0.2929 = 0.024142 mm,
    v = sqrt(707.1 · 0.024142) = 4.1317 mm/s.

    >>> v = junction_speed_caps([1, 0, 0], [0, 1, 0], 500.0, 0.01)
    >>> round(float(v), 4)
    4.1317
    """
    up = np.asarray(unit_prev, float)
    un = np.asarray(unit_next, float)
    cos_theta = -(up * un).sum(axis=-1)
    j = un - up
    norm = np.linalg.norm(j, axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        j = np.where(norm > 0, j / norm, 0.0)
        per_axis = np.where(np.abs(j) > 1e-12, np.asarray(accel_mm_s2, float) / np.abs(j), np.inf)
    a = per_axis.min(axis=-1)
    sin_half = np.sqrt(np.clip(0.5 * (1.0 - cos_theta), 0.0, 1.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        v = np.sqrt(a * deviation_mm * sin_half / (1.0 - sin_half))
    v = np.where(cos_theta > 0.999999, 0.0, v)
    v = np.where(cos_theta < -0.999999, np.inf, v)
    return v


@dataclass(frozen=True)
class Lookahead:
    """Planned junction speeds of n motion blocks.

    Attributes
    ----------
    planner : str
        One of :data:`PLANNERS`.
    law : str
        Ramp law (``"linear"`` or ``"accel"``).
    buffer_blocks : int
        Buffer depth / super block size.
    speed_mm_s : ndarray (n + 1,)
        Speed at each junction: ``speed_mm_s[k]`` enters block k, ``speed_mm_s[k + 1]`` leaves it.
    cap_mm_s : ndarray (n,)
        Cap each block was planned with (``"fast"`` raises it to the super block's top speed).
    junction_cap_mm_s, junction_rest_mm_s : ndarray (n + 1,)
        The planner's cap and the rest speed at each junction.
    safe_mm_s : ndarray (n + 1,)
        GRBL's junction-deviation limit at each junction (for comparing planners).
    super_block : ndarray (n,)
        Super block of each block (MBLA), or for ``"junction"`` the run between full stops.
    """

    planner: str
    law: str
    buffer_blocks: int
    speed_mm_s: np.ndarray
    cap_mm_s: np.ndarray
    junction_cap_mm_s: np.ndarray
    junction_rest_mm_s: np.ndarray
    safe_mm_s: np.ndarray
    super_block: np.ndarray

    @property
    def n_super_blocks(self) -> int:
        """Number of super blocks (runs from rest to rest)."""
        return int(self.super_block.max() + 1) if len(self.super_block) else 0

    @property
    def over_limit(self) -> np.ndarray:
        """Junctions planned faster than GRBL's junction-deviation limit (interior only;
        the rest speed, which the motors may always start and stop at, counts as safe)."""
        limit = np.maximum(self.safe_mm_s, self.junction_rest_mm_s)
        out = self.speed_mm_s > limit * (1 + 1e-9) + 1e-12
        out[[0, -1]] = False
        return out


def lookahead(blocks: Blocks, *, planner: str = "junction", law: str = "accel",
              buffer_blocks: int = 16, junction_deviation_mm: float = 0.01,
              axis_accel_mm_s2=(500.0, 500.0, 500.0), up=None, down=None,
              stop_before=None) -> Lookahead:
    """Plan the junction speeds of motion blocks.

    Parameters
    ----------
    blocks : Blocks
        Motion blocks only (no dwells), in order.
    planner : {"junction", "fast", "normal", "hq"}
    law : {"linear", "accel"}
        Ramp law of the profiles (see :mod:`labkit.motion.profile`).
    buffer_blocks : int
        Look-ahead depth (≥ 1): GRBL's planner buffer, or the largest super block.
    junction_deviation_mm : float
        GRBL ``$11`` (mm), for the junction planner and for :attr:`Lookahead.safe_mm_s`.
    axis_accel_mm_s2 : sequence of 3 floats
        Axis accelerations for junction speeds.
    up, down : array_like, optional
        Ramp slopes per block (Hz per step or mm/s²); default the blocks'
        accelerations.
    stop_before : array of bool (n + 1,), optional
        Junctions where the machine must stop (dwells); the two ends always stop.

    Returns
    -------
    Lookahead

    Examples
    --------
    Two collinear 10 mm cuts at 20 mm/s, then a right turn: high quality joins
    the first two only, normal all three.

    >>> from labkit.toolpath import MovesBuilder
    >>> from labkit.motion.blocks import build_blocks
    >>> b = MovesBuilder(feed_mm_min=1200)
    >>> for x, y in [(10, 0), (20, 0), (20, 10)]:
    ...     b.line(x=x, y=y)
    >>> blk = build_blocks(b.build())
    >>> lookahead(blk, planner="hq").super_block.tolist()
    [0, 0, 1]
    >>> lookahead(blk, planner="normal").super_block.tolist()
    [0, 0, 0]
    """
    if planner not in PLANNERS:
        raise MotionError(f"planner must be one of {', '.join(PLANNERS)}, got {planner!r}")
    if law not in RAMP_LAWS:
        raise MotionError(f"ramp law must be one of {sorted(RAMP_LAWS)}, got {law!r}")
    if not (isinstance(buffer_blocks, (int, np.integer)) and buffer_blocks >= 1):
        raise MotionError(f"buffer_blocks must be an integer >= 1 block, got {buffer_blocks!r}")
    if np.any(blocks.kind == BlockKind.DWELL):
        raise MotionError("lookahead plans motion blocks only: drop dwells and pass stop_before")
    n = len(blocks)
    up = np.broadcast_to(np.asarray(blocks.accel_mm_s2 if up is None else up, float), (n,))
    down = np.broadcast_to(np.asarray(blocks.accel_mm_s2 if down is None else down, float), (n,))
    stops = np.zeros(n + 1, bool) if stop_before is None else np.asarray(stop_before, bool).copy()
    if stops.shape != (n + 1,):
        raise MotionError(f"stop_before must have n + 1 = {n + 1} entries, got {stops.shape}")
    if n == 0:
        e = np.zeros(0)
        return Lookahead(planner, law, int(buffer_blocks), np.zeros(1), e, np.zeros(1), np.zeros(1),
                         np.zeros(1), np.zeros(0, np.int64))
    stops[[0, -1]] = True
    dwell_stop = stops.copy()          # the stops asked for (dwells), before super-block breaks
    cap = blocks.cap_mm_s.astype(float)
    rest = blocks.rest_mm_s
    safe = np.empty(n + 1)
    safe[[0, -1]] = 0.0
    safe[1:-1] = junction_speed_caps(blocks.unit_out[:-1], blocks.unit_in[1:], axis_accel_mm_s2,
                                     junction_deviation_mm)

    if planner == "junction":
        jcap = np.empty(n + 1)
        jcap[1:-1] = np.minimum(safe[1:-1], np.minimum(cap[:-1], cap[1:]))
        window = int(buffer_blocks)
        group = None
    else:
        breaks = np.zeros(n, bool)
        breaks[1:] = (blocks.rapid[1:] != blocks.rapid[:-1]) | stops[1:-1]
        same = np.zeros(n, bool)
        lines = blocks.kind == BlockKind.LINE
        same[1:] = (((blocks.unit_out[:-1] * blocks.unit_in[1:]).sum(axis=1) >= SAME_DIRECTION_COS)
                    & lines[1:] & lines[:-1])
        group = K.group_blocks(breaks, same, int(buffer_blocks), planner == "hq")
        if planner == "fast":
            top = np.full(group[-1] + 1, 0.0)
            np.maximum.at(top, group, cap)
            cap = np.minimum(top[group], blocks.limit_mm_s)
        jcap = np.empty(n + 1)
        jcap[1:-1] = np.minimum(cap[:-1], cap[1:])
        stops[1:-1] |= group[1:] != group[:-1]
        window = int(buffer_blocks)    # a super block never holds more: the window reaches its end
    jrest = np.empty(n + 1)
    jrest[0] = rest[0]
    jrest[-1] = rest[-1]
    # a stop without a dwell is passed at the larger rest speed (both blocks may start and
    # stop there); across a dwell the machine stands still, so each side ramps from and to
    # its own rest speed, as from the start of a job (GRBL waits for the moves to end at G4)
    pair = np.where(dwell_stop[1:-1], np.minimum(rest[:-1], rest[1:]),
                    np.maximum(rest[:-1], rest[1:]))
    jrest[1:-1] = np.minimum(pair, np.minimum(cap[:-1], cap[1:]))
    jcap = np.where(stops, jrest, np.maximum(jcap, jrest))
    v = K.windowed_passes(blocks.length_mm.astype(float), np.ascontiguousarray(up),
                          np.ascontiguousarray(down), jcap, jrest, rest.astype(float),
                          np.minimum(rest, cap).astype(float), window,
                          RAMP_LAWS[law])
    if group is None:   # runs between full stops
        stopped = v <= jrest * (1 + 1e-12)      # junction 0 always is
        group = np.cumsum(stopped[:-1]) - 1
    return Lookahead(planner=planner, law=law, buffer_blocks=int(buffer_blocks), speed_mm_s=v,
                     cap_mm_s=cap, junction_cap_mm_s=jcap, junction_rest_mm_s=jrest,
                     safe_mm_s=safe, super_block=group.astype(np.int64))
