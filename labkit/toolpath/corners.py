"""Constant-velocity corner loops ([MicroCAM] §6.1.3.1).

A controller must slow down at a sharp corner and at the two ends of a cut;
a beam that keeps burning meanwhile leaves more energy there. [MicroCAM]'s CAM
keeps the feed constant wherever the laser burns by letting the head run on
past every non-tangent corner along a detour with the laser off, and come
back onto the next segment already at full speed:

- turn angle θ below 45°: both segments are *extended* beyond the corner by
  e = ρ·tan(θ/2) and joined by a circular arc tangent to both extensions —
  a loop of 360° − θ around the outside of the corner. The radius ρ = v²/a
  lets the head drive the loop at the feed v with centripetal acceleration
  a, so the speed never changes.
- θ of 45° or more: a triangular loop. Circle C1 of radius r1 around the
  corner Int1 cuts the forward extension of the incoming segment at P1 and
  the backward extension of the outgoing one at P2; the head goes
  Int1 → P1 → P2 → Int1 with both corners P1 and P2 filleted at |L1|/5.
  [MicroCAM] takes r1 = max(TA, TD)·Feed with TA, TD the acceleration and
  deceleration times; for a = v/TA that is v²/a.
- Cut ends (the seed's start and end loops): a laser-off lead-in before the
  first cut of a chain and a lead-out after its last one, each the ramp
  distance ½·v·TA = v²/(2a).

Two decisions the seed leaves open: the fillet radius r1/5 is shrunk where
it would overrun the loop (θ near 45° or near 180°), and r1 is enlarged
where the straight part before a fillet is too short to slow down to the
fillet's speed sqrt(a·ρ) (with 2 % to spare for rounding to steps) — so that
the slowing happens on the loop, never on the cut.
"""

from __future__ import annotations

import math

import numpy as np

from labkit.errors import GeometryError
from labkit.toolpath.moves import LaserMode, MoveKind, Moves

__all__ = ["add_corner_loops", "turn_angles", "CornerLoopReport"]

#: Slack on the enlarged r1 of a triangular loop, for the rounding of its short sides to steps.
_MARGIN = 1.02

_COLS = Moves.column_names()      # every column, so a new one is carried through


class CornerLoopReport(dict):
    """Counts of what :func:`add_corner_loops` added: ``arc_loops``, ``triangle_loops``,
    ``leads`` (lead-ins plus lead-outs) and ``added_length_mm``."""


def turn_angles(d_in, d_out):
    """Turn angle (rad, 0…π) and side (+1 left, −1 right, 0 straight) between directions.

    >>> a, side = turn_angles([1, 0], [0, 1])
    >>> round(math.degrees(a), 6), side
    (90.0, 1)
    """
    d_in = np.asarray(d_in, float)
    d_out = np.asarray(d_out, float)
    cross = d_in[..., 0] * d_out[..., 1] - d_in[..., 1] * d_out[..., 0]
    dot = (d_in[..., :2] * d_out[..., :2]).sum(axis=-1)
    ang = np.arctan2(np.abs(cross), dot)
    side = np.sign(cross).astype(int)
    if np.ndim(ang) == 0:
        return float(ang), int(side)
    return ang, side


def _right(d):
    return np.array([d[1], -d[0]])


class _Builder:
    """Collects output rows; every added row is a laser-off feed move."""

    def __init__(self, moves: Moves):
        self.src = moves
        self.rows: list[dict] = []
        self.added = 0.0

    def copy_row(self, i, **changes):
        row = {c: np.array(getattr(self.src, c)[i], copy=True) for c in _COLS}
        row.update({k: np.asarray(v) for k, v in changes.items()})
        self.rows.append(row)

    def detour(self, template, kind, start2, end2, centre2=None, length=0.0):
        z = self.src.start[template, 2]
        row = {c: np.array(getattr(self.src, c)[template], copy=True) for c in _COLS}
        row["kind"] = np.asarray(kind, np.int8)
        row["start"] = np.array([start2[0], start2[1], z])
        row["end"] = np.array([end2[0], end2[1], z])
        row["centre"] = (np.full(3, np.nan) if centre2 is None
                         else np.array([centre2[0], centre2[1], z]))
        row["plane"] = np.asarray(17, np.int8)
        row["laser"] = np.asarray(LaserMode.OFF, np.int8)
        self.rows.append(row)
        self.added += length

    def build(self) -> Moves:
        cols = {c: np.array([r[c] for r in self.rows]) for c in _COLS}
        return Moves(source=self.src.source, s_max=self.src.s_max, records=(), **cols)


def _arc(b, t, start, end, centre, clockwise, sweep_abs, radius):
    if np.allclose(start, end, rtol=0.0, atol=1e-12) and sweep_abs < math.pi:
        return
    b.detour(t, MoveKind.ARC_CW if clockwise else MoveKind.ARC_CCW, start, end, centre,
             length=radius * sweep_abs)


def _line(b, t, start, end):
    length = float(np.hypot(*(np.asarray(end) - start)))
    if length > 1e-12:
        b.detour(t, MoveKind.LINE, start, end, length=length)


def add_corner_loops(moves: Moves, *, accel_mm_s2: float, split_deg: float = 45.0,
                     min_turn_deg: float = 1.0, junction_deviation_mm: float | None = None,
                     leads: bool = True, fillet_ratio: float = 0.2) -> tuple[Moves, CornerLoopReport]:
    """Add laser-off loops at sharp corners (and lead-ins/outs) so cuts run at constant feed.

    Parameters
    ----------
    moves : Moves
        A program whose cuts are straight burning G1 moves in the XY plane.
    accel_mm_s2 : float
        Machine acceleration a (mm/s², > 0): sets ρ = r1 = v²/a and the leads v²/(2a).
    split_deg : float
        Turns below this get the tangent-arc loop, the others the triangular
        loop ([MicroCAM]: 45°), in (0, 180).
    min_turn_deg : float
        Turns below this count as tangent and get no loop, ≥ 0.
    junction_deviation_mm : float, optional
        If given, corners that a junction-deviation controller (GRBL ``$11``)
        passes at full feed get no loop either: GRBL's v_j² =
        a·δ·sin(φ/2)/(1 − sin(φ/2)) ≥ v², with φ = π − turn (useful for
        polylines that approximate curves). By default every corner above
        ``min_turn_deg`` gets one, as in [MicroCAM].
    leads : bool
        Add a lead-in before and a lead-out after every chain of cuts.
    fillet_ratio : float
        Fillet radius of the triangular loop as a fraction of r1 (seed: 1/5), in (0, 1].

    Returns
    -------
    moves : Moves
        The program with the detours (laser off, feed = the cut's feed).
    report : CornerLoopReport
        What was added.

    Raises
    ------
    GeometryError
        Out-of-range arguments.

    Examples
    --------
    A square corner at 1200 mm/min (20 mm/s) with a = 500 mm/s²: a triangular
    loop with r1 = 0.8 mm, and a 0.4 mm lead at each end.

    >>> from labkit.toolpath import MovesBuilder
    >>> b = MovesBuilder(feed_mm_min=1200, s_word=500, laser=LaserMode.CONSTANT)
    >>> b.line(x=10); b.line(y=10)
    >>> looped, rep = add_corner_loops(b.build(), accel_mm_s2=500)
    >>> rep["triangle_loops"], rep["arc_loops"], rep["leads"], int(looped.laser_on.sum())
    (1, 0, 2, 2)
    """
    if not accel_mm_s2 > 0:
        raise GeometryError(f"accel_mm_s2 must be > 0 mm/s², got {accel_mm_s2!r}")
    if not 0 < split_deg < 180:
        raise GeometryError(f"split_deg must be in (0, 180) degrees, got {split_deg!r}")
    if not 0 <= min_turn_deg < split_deg:
        raise GeometryError(f"min_turn_deg must be in [0, split_deg), got {min_turn_deg!r}")
    if not 0 < fillet_ratio <= 1:
        raise GeometryError(f"fillet_ratio must be in (0, 1], got {fillet_ratio!r}")
    n = len(moves)
    cut = (moves.kind == MoveKind.LINE) & moves.laser_on
    cut &= np.abs(moves.end[:, 2] - moves.start[:, 2]) < 1e-12
    length = np.linalg.norm(moves.end - moves.start, axis=1)
    cut &= length > 1e-12
    joined = np.zeros(n, bool)       # joined[i]: cut i continues cut i−1 at the same point
    joined[1:] = cut[1:] & cut[:-1] & (np.linalg.norm(moves.start[1:] - moves.end[:-1], axis=1) < 1e-9)
    with np.errstate(invalid="ignore", divide="ignore"):
        d = np.where(length[:, None] > 0, (moves.end - moves.start) / length[:, None], 0.0)[:, :2]
    v = moves.feed_mm_min / 60.0
    b = _Builder(moves)
    report = CornerLoopReport(arc_loops=0, triangle_loops=0, leads=0, added_length_mm=0.0)
    split = math.radians(split_deg)
    min_turn = math.radians(min_turn_deg)
    pending_shift = None     # where the move after a lead-out must start from
    for i in range(n):
        chain_start = cut[i] and not joined[i]
        chain_end = cut[i] and not (i + 1 < n and joined[i + 1])
        lead = v[i] ** 2 / (2 * accel_mm_s2) if cut[i] else 0.0
        if pending_shift is not None:
            # the previous chain ended with a lead-out: this move starts there
            if moves.kind[i] == MoveKind.RAPID or not cut[i] and moves.kind[i] == MoveKind.LINE:
                b.copy_row(i, start=np.append(pending_shift, moves.start[i, 2]))
                pending_shift = None
                continue
            _line(b, i, pending_shift, moves.start[i, :2])
            pending_shift = None
        if leads and chain_start:
            p0 = moves.start[i, :2]
            lead_start = p0 - lead * d[i]
            prev = b.rows[-1] if b.rows else None
            if prev is not None and int(prev["kind"]) == MoveKind.RAPID and np.allclose(prev["end"][:2], p0):
                prev["end"] = np.append(lead_start, prev["end"][2])
            else:
                _line(b, i, p0, lead_start)
            _line(b, i, lead_start, p0)
            report["leads"] += 1
        b.copy_row(i)
        if cut[i] and i + 1 < n and joined[i + 1]:
            theta, side = turn_angles(d[i], d[i + 1])
            vel = max(v[i], v[i + 1])
            if junction_deviation_mm is not None and theta < math.pi - 1e-12:
                sh = math.cos(theta / 2)       # sin of half GRBL's angle, which is π − turn
                if accel_mm_s2 * junction_deviation_mm * sh / (1 - sh) >= vel * vel:
                    theta = 0.0        # passed at full feed: no loop
            if theta >= min_turn and side != 0 or theta > math.pi - 1e-12:
                _loop(b, i, moves.end[i, :2], d[i], d[i + 1], theta, side, vel, accel_mm_s2,
                      split, fillet_ratio, report)
        if leads and chain_end:
            p1 = moves.end[i, :2]
            _line(b, i, p1, p1 + lead * d[i])
            report["leads"] += 1
            pending_shift = p1 + lead * d[i]
    report["added_length_mm"] = b.added
    return b.build(), report


def _loop(b, t, corner, d1, d2, theta, side, v, a, split, fillet_ratio, report):
    """Append the detour at one corner (laser off), from the corner back to the corner."""
    clockwise = side >= 0          # left corners loop clockwise around the outside
    if theta < split:
        rho = v * v / a
        e = rho * math.tan(theta / 2)
        p_a = corner + e * d1
        p_b = corner - e * d2
        normal = _right(d1) if clockwise else -_right(d1)
        centre = p_a + rho * normal
        _line(b, t, corner, p_a)
        _arc(b, t, p_a, p_b, centre, clockwise, 2 * math.pi - theta, rho)
        _line(b, t, p_b, corner)
        report["arc_loops"] += 1
        return
    # triangular loop: fillet radius c·r1, r1 enlarged so the head can slow to the fillet speed
    half = theta / 4
    cot = 1.0 / math.tan(half) if half > 0 else math.inf
    c = min(fillet_ratio, math.cos(theta / 2) * math.tan(half))
    kappa = max(1.0, _MARGIN / (2.0 - 2.0 * c * cot + c))
    r1 = kappa * v * v / a
    p1 = corner + r1 * d1
    p2 = corner - r1 * d2
    chord = p2 - p1
    span = float(np.hypot(*chord))
    report["triangle_loops"] += 1
    if c * r1 < 1e-6:              # (nearly) a full reversal: fillets vanish, go out and back
        _line(b, t, corner, p1)
        _line(b, t, p1, p2)
        _line(b, t, p2, corner)
        return
    w = chord / span
    rf = c * r1
    tl = rf * cot                     # tangent length of each fillet from its corner
    a1, b1 = p1 - tl * d1, p1 + tl * w
    a2, b2 = p2 - tl * w, p2 + tl * d2
    turn = math.pi - theta / 2        # each fillet turns this much
    n1 = _right(d1) if clockwise else -_right(d1)
    n2 = _right(w) if clockwise else -_right(w)
    _line(b, t, corner, a1)
    _arc(b, t, a1, b1, a1 + rf * n1, clockwise, turn, rf)
    _line(b, t, b1, a2)
    _arc(b, t, a2, b2, a2 + rf * n2, clockwise, turn, rf)
    _line(b, t, b2, corner)
