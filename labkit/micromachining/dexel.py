"""Ploughing in micro flat-end milling on a dual-dexel workpiece ([MicroCAM] ch. 5).

The 2-D workpiece is two perpendicular families of line segments, *dexels*: lines along X
at y = y0 + (k + ½)·R and lines along Y at x = x0 + (k + ½)·R, R the resolution, each
holding the intervals where material is. The cutter is a circle of radius r moved along
the program in steps of the feed per tooth times a scale factor S (eq. 5.1,
f_t = f / (RPM · N) · S). At every step each dexel that enters the circle is trimmed at
its exact intersections with it (the chord x = c_x ± √(r² − (y − c_y)²)); what is cut
away is the chip of that step.

**Uncut chip thickness.** A removed piece of a dexel runs from the new cutting edge (its
end on the circle) back to the surface the previous steps left. Where the two bounding
curves are locally parallel (as two circles one feed apart are), the thickness normal to
the edge is the piece's length times |n·d|, n the circle's normal at the edge end and d
the dexel's direction. Each family measures the part of the chip where its direction is
closer to the normal — exactly: the X dexels own the part of the chip where
|x − c_x| ≥ |y − c_y| seen from the cutter centre, the Y dexels the rest, each piece clipped
at the two diagonals — so the two families share the chip without counting any of it twice,
and each measures its thickness where its lines cross the edge steeply (the reason for two
families).

The thickness estimate assumes the two curves locally parallel; near the crescent's tips
they are not, and the ploughed share comes out low by about 0.2 × (step / r) (0.011 at a
step of 0.05 r, 0.003 at 0.0125 r: measured in the tests).

**Ploughing.** Below the minimum chip thickness T_min the edge ploughs instead of
cutting ([MicroCAM]: T_min ≈ 0.3 r_e for Al6061, r_e the edge radius). A piece whose
thickness per tooth (its thickness / S) is below T_min is ploughing area; summed per step
and along the path it is the ploughing area the seed compares with the measured forces.
For a full-immersion slot the chip is the crescent h(ψ) = f·cos ψ, and the ploughed share
of it is 1 − √(1 − (T_min / f)²) — the closed form the tests check.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from labkit.errors import GeometryError
from labkit.micromachining.chipvolume import _check_spindle, tool_positions
from labkit.toolpath.moves import Moves

__all__ = ["DualDexel", "Chip", "PloughResult", "plough", "crescent_area_mm2", "slot_plough_share"]


def crescent_area_mm2(radius_mm: float, step_mm: float) -> float:
    """Area a circle of radius r uncovers when it moves by s: πr² minus the lens of overlap, mm².

    >>> round(crescent_area_mm2(1.0, 0.001), 9)              # ≈ 2·r·s for s ≪ r
    0.002
    """
    r, s = float(radius_mm), float(step_mm)
    if s >= 2 * r:
        return math.pi * r * r
    lens = 2 * r * r * math.acos(s / (2 * r)) - 0.5 * s * math.sqrt(4 * r * r - s * s)
    return math.pi * r * r - lens


def slot_plough_share(feed_per_tooth_mm: float, min_chip_mm: float, radius_mm: float | None = None) -> float:
    """Share of a full-slot chip thinner than T_min.

    To first order in f/r the chip is h(ψ) = f·cos ψ and the share is 1 − √(1 − (T/f)²).
    With ``radius_mm`` the crescent is taken exactly: at angle ψ from the feed direction
    the new edge lies h(ψ) = r + f·cos ψ − √(r² − f²·sin²ψ) from the previous surface, and
    the share is the area where h < T over the whole crescent (area element h·(r − h/2)),
    integrated numerically.

    >>> slot_plough_share(0.001, 0.0006)                      # f = 1 µm, T_min = 0.6 µm
    0.2
    >>> round(slot_plough_share(0.02, 0.012, 0.4), 4)          # f/r = 0.05: nearly the same
    0.1996
    """
    f, t = float(feed_per_tooth_mm), float(min_chip_mm)
    if radius_mm is None:
        q = min(1.0, t / f)
        return 1.0 - math.sqrt(1.0 - q * q)
    r = float(radius_mm)
    psi = np.linspace(-math.pi / 2, math.pi / 2, 200_001)
    h = r + f * np.cos(psi) - np.sqrt(r * r - (f * np.sin(psi)) ** 2)
    da = h * (r - h / 2)
    return float(da[h < t].sum() / da.sum())


@dataclass
class Chip:
    """What one step removed: per removed piece its family (0 = X dexel, 1 = Y dexel), its
    ends ``(x0, y0, x1, y1)``, its thickness normal to the cutting edge (mm) and the length
    of it in the family's share of the chip (mm)."""

    family: np.ndarray
    ends: np.ndarray
    thickness_mm: np.ndarray
    owned_mm: np.ndarray


class DualDexel:
    """A rectangular 2-D workpiece as X and Y dexels at ``resolution_mm``.

    Examples
    --------
    >>> w = DualDexel((0, 0), (4, 2), 0.01)
    >>> [round(a, 9) for a in w.areas_mm2()]
    [8.0, 8.0]
    >>> chip = w.cut(2.0, 1.0, 0.5)                              # a plunge: a disc of r = 0.5
    >>> [round(a / (math.pi / 4) - 1, 4) for a in w.removed_mm2(chip)]   # X and Y family vs π r²
    [0.0, 0.0]
    """

    def __init__(self, lower, upper, resolution_mm: float):
        (xa, ya), (xb, yb) = lower, upper
        if not (math.isfinite(resolution_mm) and resolution_mm > 0):
            raise GeometryError(f"resolution_mm must be a finite number > 0 mm, got {resolution_mm!r}")
        if not (xb > xa and yb > ya):
            raise GeometryError(f"the stock needs upper > lower, got {lower}, {upper}")
        from labkit.budget import check_budget

        nx = int(round((xb - xa) / resolution_mm))
        ny = int(round((yb - ya) / resolution_mm))
        check_budget("elements", nx + ny, cause=f"dexels at {resolution_mm:g} mm", option="--resolution")
        self.lower = (float(xa), float(ya))
        self.upper = (float(xb), float(yb))
        self.resolution_mm = float(resolution_mm)
        #: per family the line positions (y of X dexels, x of Y dexels) and their intervals
        self.position = [ya + (np.arange(ny) + 0.5) * resolution_mm, xa + (np.arange(nx) + 0.5) * resolution_mm]
        self.intervals = [[[(float(xa), float(xb))] for _ in range(ny)],
                          [[(float(ya), float(yb))] for _ in range(nx)]]

    def areas_mm2(self) -> tuple[float, float]:
        """Material area as the X family and as the Y family see it, mm²."""
        return tuple(self.resolution_mm * sum(b - a for line in fam for a, b in line)
                     for fam in self.intervals)

    def removed_mm2(self, chip: Chip) -> tuple[float, float]:
        """Area of a chip as each family measures it alone, mm²."""
        length = np.hypot(chip.ends[:, 2] - chip.ends[:, 0], chip.ends[:, 3] - chip.ends[:, 1])
        return tuple(float(length[chip.family == f].sum() * self.resolution_mm) for f in (0, 1))

    def segments(self, family: int) -> np.ndarray:
        """Every material interval of a family as ``(x0, y0, x1, y1)`` rows (for drawing)."""
        rows = []
        for pos, line in zip(self.position[family], self.intervals[family]):
            for a, b in line:
                rows.append((a, pos, b, pos) if family == 0 else (pos, a, pos, b))
        return np.array(rows).reshape(-1, 4)

    def cut(self, cx: float, cy: float, r: float) -> Chip:
        """Trim every dexel at the circle of radius ``r`` around (cx, cy); return what went."""
        fam_out, ends, thick, owned = [], [], [], []
        for f in (0, 1):
            along, across = (cx, cy) if f == 0 else (cy, cx)
            pos = self.position[f]
            k0 = int(np.searchsorted(pos, across - r))
            k1 = int(np.searchsorted(pos, across + r, side="right"))
            for k in range(k0, k1):
                dy = pos[k] - across
                w2 = r * r - dy * dy
                if w2 <= 0:
                    continue
                w = math.sqrt(w2)
                u, v = along - w, along + w
                line = self.intervals[f][k]
                if not line or line[-1][1] <= u or line[0][0] >= v:
                    continue
                kept = []
                for a, b in line:
                    if b <= u or a >= v:
                        kept.append((a, b))
                        continue
                    if a < u:
                        kept.append((a, u))
                    if b > v:
                        kept.append((v, b))
                    p, q = max(a, u), min(b, v)
                    if q <= p:
                        continue
                    # the end on the circle is the cutting edge (both ends: the same |normal|;
                    # neither — an island inside the circle — the nearer one); the normal there
                    edge = v if q == v else u if p == u else (p if p - u < v - q else q)
                    n_along = (edge - along) / r
                    fam_out.append(f)
                    ends.append((p, pos[k], q, pos[k]) if f == 0 else (pos[k], p, pos[k], q))
                    thick.append((q - p) * abs(n_along))
                    # the share: |along − c| >= |across − c|, i.e. outside (c − |dy|, c + |dy|)
                    lo_, hi_ = along - abs(dy), along + abs(dy)
                    owned.append(max(0.0, min(q, lo_) - p) + max(0.0, q - max(p, hi_)))
                self.intervals[f][k] = kept
        return Chip(np.array(fam_out, np.int8), np.array(ends, float).reshape(-1, 4),
                    np.array(thick, float), np.array(owned, float))


@dataclass
class PloughResult:
    """Chip and ploughing along a path.

    Attributes
    ----------
    xyz : ndarray (k, 3)
        Cutter positions (mm).
    move : ndarray (k,)
        Source move of each position.
    chip_mm2 : ndarray (k,)
        Chip area of each step (the two families' owned shares), mm².
    plough_mm2 : ndarray (k,)
        Ploughing area of each step, mm².
    removed_mm2 : (float, float)
        Total area removed as the X and the Y family measure it, mm².
    plough_points : ndarray (m, 2)
        Edge points of the ploughing pieces (the ploughing map), mm.
    workpiece : DualDexel
        The workpiece after the cut.
    """

    xyz: np.ndarray
    move: np.ndarray
    chip_mm2: np.ndarray
    plough_mm2: np.ndarray
    removed_mm2: tuple
    plough_points: np.ndarray
    workpiece: DualDexel = field(repr=False)

    @property
    def removed_dual_mm2(self) -> float:
        """The dual-dexel estimate of the removed area: the mean of the two families, mm²."""
        return 0.5 * (self.removed_mm2[0] + self.removed_mm2[1])


def plough(moves: Moves, lower, upper, *, resolution_mm: float, tool_diameter_mm: float, rpm: float,
           teeth: int, min_chip_mm: float | None = None, edge_radius_mm: float = 0.002,
           scale: float = 10.0) -> PloughResult:
    """Simulate a program on a dual-dexel stock; chip and ploughing area at every step.

    Parameters
    ----------
    moves : Moves
        The parsed program (XY lines and arcs; Z is ignored — a 2-D cut: only feed moves
        cut, rapids pass above the work).
    lower, upper : (x, y)
        Stock corners, mm.
    resolution_mm : float
        Dexel spacing R, mm.
    tool_diameter_mm, rpm, teeth
        Mill diameter (mm), spindle speed (rev/min), flutes.
    min_chip_mm : float, optional
        Minimum chip thickness T_min per tooth, mm; default 0.3 × ``edge_radius_mm``.
    edge_radius_mm : float
        Cutting-edge radius r_e, mm ([MicroCAM]: 2 µm typical).
    scale : float
        Steps of ``scale`` × f_t (eq. 5.1's SF); thicknesses are divided by it before
        they are compared with T_min.

    Returns
    -------
    PloughResult

    Examples
    --------
    A full slot at 1 µm/tooth with T_min = 0.6 µm ploughs 20 % of its chip; the dexels
    measure 19 % with steps of 20 teeth (the thickness estimate is first order in the
    step / radius, 0.05 here; the gap halves with the step):

    >>> from labkit.gcode import parse
    >>> prog = parse("G0 X-1 Y1\\nG1 X3 F120")
    >>> res = plough(prog, (0, 0), (2, 2), resolution_mm=0.002, tool_diameter_mm=0.8, rpm=60_000,
    ...              teeth=2, min_chip_mm=0.0006, scale=20)
    >>> steady = (res.xyz[:, 0] > 0.6) & (res.xyz[:, 0] < 1.4)
    >>> round(float(res.plough_mm2[steady].sum() / res.chip_mm2[steady].sum()), 2)
    0.19
    """
    _check_spindle(rpm, teeth)
    if not (tool_diameter_mm > 0 and scale > 0):
        raise GeometryError(f"tool_diameter_mm and scale must be > 0, got {tool_diameter_mm!r}, {scale!r}")
    t_min = 0.3 * edge_radius_mm if min_chip_mm is None else float(min_chip_mm)
    if not t_min >= 0:
        raise GeometryError(f"min_chip_mm must be >= 0 mm, got {min_chip_mm!r}")
    feed = np.nan_to_num(moves.feed_mm_min, nan=0.0)
    if np.any(moves.is_feed & ~(feed > 0)):
        raise GeometryError("a feed move has no feed rate (F); expected F > 0 on every cutting move")
    ft = np.where(feed > 0, feed, 1.0) / (rpm * teeth)
    wp = DualDexel(lower, upper, resolution_mm)
    # a 2-D cut: rapids run above the work and remove nothing; a feed move's first step
    # into material is a plunge (its chip is the whole disc)
    step = np.maximum(scale * ft, 1e-6)
    xyz, move, _ = tool_positions(moves, step)
    feed_idx = np.flatnonzero(moves.is_feed)
    entries = [i for i in feed_idx if i == 0 or not moves.is_feed[i - 1]]
    at = np.searchsorted(move, entries)                   # the plunge before each entry's first step
    xyz = np.insert(xyz, at, moves.start[entries], axis=0)
    move = np.insert(move, at, entries)
    from labkit.budget import check_budget

    check_budget("segments", len(xyz), cause=f"steps of {scale:g} × f_t", option="--scale")
    r = tool_diameter_mm / 2
    chip_a = np.zeros(len(xyz))
    plough_a = np.zeros(len(xyz))
    removed = [0.0, 0.0]
    points = []
    for k, (x, y, _) in enumerate(xyz):
        chip = wp.cut(x, y, r)
        if not len(chip.family):
            continue
        length = np.hypot(chip.ends[:, 2] - chip.ends[:, 0], chip.ends[:, 3] - chip.ends[:, 1])
        for f in (0, 1):
            removed[f] += float(length[chip.family == f].sum()) * resolution_mm
        area = chip.owned_mm * resolution_mm
        thin = (chip.owned_mm > 0) & (chip.thickness_mm / scale < t_min)
        chip_a[k] = area.sum()
        plough_a[k] = area[thin].sum()
        if thin.any():
            points.append(0.5 * (chip.ends[thin, :2] + chip.ends[thin, 2:]))
    return PloughResult(xyz, move, chip_a, plough_a, tuple(removed),
                        np.vstack(points) if points else np.zeros((0, 2)), wp)
