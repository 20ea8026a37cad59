"""Chip volume along a micro-milling toolpath on a z-map workpiece ([MicroCAM] ch. 3.1).

[MicroCAM] divides every segment of the parsed program into steps of the feed per tooth

    f_t = f / (RPM · teeth)                                        (eq. 3.1)

(times a scale factor, to have fewer steps), moves the cutter to each step and measures
the volume it removes there — the chip volume V_c — by Boolean operations on a voxel /
solid model. Here the workpiece is a *z-map*: a grid of square cells over XY, each
holding the height of the material's top. A flat-end mill of radius R with its tip at
height z removes, from every cell whose centre lies within R of its axis, the material
above z. The volume removed at a step is exact for the grid; its error against the true
solid is of the order of (perimeter of the cut × cell size × depth) and falls linearly
with the cell size (measured in the tests against closed forms: a full slot, a circular
pocket and the steady half-immersion chip a_e · a_p · f_t).

The sequential kernel is compiled with numba; ``NUMBA_DISABLE_JIT=1`` runs it as Python.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from labkit._jit import jit
from labkit.errors import GeometryError
from labkit.toolpath.moves import MoveKind, Moves

__all__ = ["ZMap", "ChipVolumes", "feed_per_tooth_mm", "tool_positions", "chip_volumes", "stock_extent"]


def feed_per_tooth_mm(feed_mm_min, rpm: float, teeth: int):
    """Feed per tooth f_t = f / (RPM · teeth), mm ([MicroCAM] eq. 3.1, f in mm/min).

    >>> feed_per_tooth_mm(120.0, 60_000, 2)          # 2 mm/s at 60 000 rpm, two flutes: 1 µm
    0.001
    """
    _check_spindle(rpm, teeth)
    out = np.asarray(feed_mm_min, float) / (rpm * teeth)
    return float(out) if out.ndim == 0 else out


def _check_spindle(rpm, teeth):
    if not (math.isfinite(rpm) and rpm > 0 and int(teeth) == teeth and teeth >= 1):
        raise GeometryError(f"rpm must be > 0 and teeth a whole number >= 1, got {rpm!r}, {teeth!r}")


@jit
def _cut_disc(h, x0, y0, cell, cx, cy, r, z, bottom):
    """Lower every cell whose centre is within r of (cx, cy) to z (not below bottom);
    return the volume removed, mm³."""
    ny, nx = h.shape
    target = max(z, bottom)
    j0 = max(0, int(math.floor((cx - r - x0) / cell)))
    j1 = min(nx - 1, int(math.floor((cx + r - x0) / cell)))
    i0 = max(0, int(math.floor((cy - r - y0) / cell)))
    i1 = min(ny - 1, int(math.floor((cy + r - y0) / cell)))
    r2 = r * r
    removed = 0.0
    for i in range(i0, i1 + 1):
        yc = y0 + (i + 0.5) * cell - cy
        for j in range(j0, j1 + 1):
            xc = x0 + (j + 0.5) * cell - cx
            if xc * xc + yc * yc <= r2 and h[i, j] > target:
                removed += h[i, j] - target
                h[i, j] = target
    return removed * cell * cell


@jit
def _cut_path(h, x0, y0, cell, xs, ys, zs, r, bottom):
    out = np.empty(len(xs))
    for k in range(len(xs)):
        out[k] = _cut_disc(h, x0, y0, cell, xs[k], ys[k], r, zs[k], bottom)
    return out


@dataclass
class ZMap:
    """A workpiece as a height field: ``height[i, j]`` is the top of the material over the
    cell with lower-left corner (x0 + j·cell, y0 + i·cell), mm.

    Examples
    --------
    >>> stock = ZMap.stock((0, 0), (10, 4), top_z=0.0, bottom_z=-1.0, cell_mm=0.01)
    >>> stock.height.shape, round(stock.volume_mm3(), 9)
    ((400, 1000), 40.0)
    >>> round(stock.cut(5.0, 2.0, -0.1, radius_mm=1.0), 2)  # a 2 mm plunge 0.1 deep: π/10
    0.31
    """

    x0: float
    y0: float
    cell_mm: float
    height: np.ndarray
    bottom_z: float

    @classmethod
    def stock(cls, lower, upper, *, top_z: float = 0.0, bottom_z: float = -1.0,
              cell_mm: float = 0.005) -> "ZMap":
        """A rectangular block: XY from ``lower`` to ``upper`` (mm), Z from bottom to top."""
        (xa, ya), (xb, yb) = lower, upper
        if not (cell_mm > 0 and math.isfinite(cell_mm)):
            raise GeometryError(f"cell_mm must be a finite number > 0 mm, got {cell_mm!r}")
        if not (xb > xa and yb > ya and top_z > bottom_z):
            raise GeometryError(f"stock needs upper > lower and top_z > bottom_z, got {lower}, {upper}, "
                                f"{top_z}, {bottom_z}")
        nx = int(round((xb - xa) / cell_mm))
        ny = int(round((yb - ya) / cell_mm))
        from labkit.budget import check_budget

        check_budget("pixels", nx * ny, cause=f"a {xb - xa:g} × {yb - ya:g} mm stock at {cell_mm:g} mm cells",
                     option="--cell")
        return cls(float(xa), float(ya), float(cell_mm), np.full((ny, nx), float(top_z)), float(bottom_z))

    def copy(self) -> "ZMap":
        return ZMap(self.x0, self.y0, self.cell_mm, self.height.copy(), self.bottom_z)

    def volume_mm3(self) -> float:
        """Material left, mm³."""
        return float((self.height - self.bottom_z).sum() * self.cell_mm ** 2)

    def cut(self, x: float, y: float, z: float, *, radius_mm: float) -> float:
        """Put a flat-end mill's tip at (x, y, z); return the volume it removes, mm³."""
        return float(_cut_disc(self.height, self.x0, self.y0, self.cell_mm, float(x), float(y),
                               float(radius_mm), float(z), self.bottom_z))

    def cut_path(self, xyz: np.ndarray, *, radius_mm: float) -> np.ndarray:
        """Cut at every position of ``xyz`` (n, 3) in turn; the volume removed at each, mm³."""
        xyz = np.ascontiguousarray(xyz, float)
        return _cut_path(self.height, self.x0, self.y0, self.cell_mm, xyz[:, 0].copy(),
                         xyz[:, 1].copy(), xyz[:, 2].copy(), float(radius_mm), self.bottom_z)


def stock_extent(moves: Moves, tool_diameter_mm: float, stock=None):
    """The stock's XY corners: ``stock`` = (xmin, ymin, xmax, ymax) if given, else the cutting
    moves' extent plus the tool radius (everything the cutter touches), mm.

    >>> from labkit.gcode import parse
    >>> stock_extent(parse("G0 X1 Y1\\nG1 X3 F60"), 1.0)
    ((0.5, 0.5), (3.5, 1.5))
    """
    if stock is not None:
        return (float(stock[0]), float(stock[1])), (float(stock[2]), float(stock[3]))
    cut = moves[moves.is_feed]
    if not len(cut):
        raise GeometryError(f"{moves.source or 'the program'}: no feed moves (G1/G2/G3) to cut with")
    lo, hi = cut.bounds()
    r = tool_diameter_mm / 2
    return (float(lo[0] - r), float(lo[1] - r)), (float(hi[0] + r), float(hi[1] + r))


def tool_positions(moves: Moves, step_of_move_mm: np.ndarray, *, rapids: bool = False):
    """Points along every feed move (and rapid, if asked) at (at most) the given spacing,
    lines and XY arcs.

    Parameters
    ----------
    moves : Moves
    step_of_move_mm : ndarray, shape (n,)
        Largest spacing per move, mm (ignored for rapids and dwells).

    Returns
    -------
    xyz : ndarray, shape (k, 3)
        Positions after each step (the end of every feed move included), mm.
    move : ndarray of int, shape (k,)
        Index of the move each position belongs to.
    step_mm : ndarray, shape (k,)
        Path length from the previous position, mm.

    Examples
    --------
    >>> from labkit.toolpath import MovesBuilder
    >>> b = MovesBuilder(feed_mm_min=60); b.line(x=1.0)
    >>> xyz, move, step = tool_positions(b.build(), np.array([0.3]))
    >>> xyz[:, 0].round(3).tolist(), step.round(3).tolist()
    ([0.25, 0.5, 0.75, 1.0], [0.25, 0.25, 0.25, 0.25])
    """
    pts, idx, steps = [], [], []
    lengths = moves.lengths_mm()
    sweeps = moves.sweep_rad()
    for i in np.flatnonzero(moves.is_motion if rapids else moves.is_feed):
        L = float(lengths[i])
        if L <= 0:
            continue
        n = max(1, math.ceil(L / float(step_of_move_mm[i]) - 1e-9))
        f = np.arange(1, n + 1) / n
        a, b = moves.start[i], moves.end[i]
        if moves.kind[i] in (MoveKind.LINE, MoveKind.RAPID):
            p = a + f[:, None] * (b - a)
        else:
            if moves.plane[i] != 17:
                raise GeometryError(f"move {i} (line {int(moves.line[i])}): arcs in the XY plane only "
                                    f"(G17), got G{int(moves.plane[i])}")
            c = moves.centre[i]
            r = math.hypot(a[0] - c[0], a[1] - c[1])
            a0 = math.atan2(a[1] - c[1], a[0] - c[0])
            ang = a0 + f * sweeps[i]
            p = np.c_[c[0] + r * np.cos(ang), c[1] + r * np.sin(ang), a[2] + f * (b[2] - a[2])]
        pts.append(p)
        idx.append(np.full(n, i))
        steps.append(np.full(n, L / n))
    if not pts or not moves.is_feed.any():
        raise GeometryError("the program has no feed moves (G1/G2/G3) to cut with")
    return np.vstack(pts), np.concatenate(idx), np.concatenate(steps)


@dataclass
class ChipVolumes:
    """Chip volume along a toolpath.

    Attributes
    ----------
    xyz : ndarray (k, 3)
        Cutter positions, mm.
    move : ndarray (k,)
        Index of the source move of each position.
    step_mm : ndarray (k,)
        Path length of each step, mm.
    volume_mm3 : ndarray (k,)
        Volume removed in each step, mm³.
    per_tooth_mm3 : ndarray (k,)
        The same as the volume one tooth removes at the move's nominal feed per tooth:
        volume / step × f_t, mm³ (what the feed schedule compares).
    feed_per_tooth_mm : ndarray (k,)
        Nominal f_t of each position's move, mm.
    workpiece : ZMap
        The workpiece after the cut.
    """

    xyz: np.ndarray
    move: np.ndarray
    step_mm: np.ndarray
    volume_mm3: np.ndarray
    per_tooth_mm3: np.ndarray
    feed_per_tooth_mm: np.ndarray
    workpiece: ZMap


def chip_volumes(moves: Moves, workpiece: ZMap, *, tool_diameter_mm: float, rpm: float, teeth: int,
                 scale: float = 10.0) -> ChipVolumes:
    """Walk a program in steps of scale × f_t and record the chip volume at every step.

    Parameters
    ----------
    moves : Moves
        The parsed program (lines and XY arcs). Rapids remove what they pass through
        without counting it as a chip.
    workpiece : ZMap
        The stock; it is not changed (a copy is cut and returned).
    tool_diameter_mm : float
        Flat-end mill diameter, mm.
    rpm : float
        Spindle speed, rev/min.
    teeth : int
        Number of flutes.
    scale : float
        [MicroCAM]'s chip-load scale factor: steps of scale × f_t (≥ 1: fewer steps).

    Returns
    -------
    ChipVolumes

    Examples
    --------
    A 2 mm full slot 0.1 mm deep at 1 µm/tooth: each tooth takes 2 × 0.1 × 0.001 mm³:

    >>> from labkit.gcode import parse
    >>> prog = parse("G0 X-2 Y0 Z-0.1\\nG1 X8 F120")
    >>> stock = ZMap.stock((0, -2), (10, 2), top_z=0, bottom_z=-1, cell_mm=0.005)
    >>> cv = chip_volumes(prog, stock, tool_diameter_mm=2.0, rpm=60_000, teeth=2, scale=50)
    >>> steady = cv.per_tooth_mm3[(cv.xyz[:, 0] > 2) & (cv.xyz[:, 0] < 7)]
    >>> bool(abs(steady.mean() / (2 * 0.1 * 0.001) - 1) < 0.01)
    True
    """
    if not (tool_diameter_mm > 0 and scale > 0):
        raise GeometryError(f"tool_diameter_mm and scale must be > 0, got {tool_diameter_mm!r}, {scale!r}")
    _check_spindle(rpm, teeth)
    feed = np.nan_to_num(moves.feed_mm_min, nan=0.0)
    if np.any(moves.is_feed & ~(feed > 0)):
        raise GeometryError("a feed move has no feed rate (F); expected F > 0 on every cutting move")
    ft = np.where(feed > 0, feed, 1.0) / (rpm * teeth)
    # rapids take steps of a cell; they remove what they pass through (a rapid into the
    # material is a crash on a machine) but make no chip, so an entry does not count as one
    step = np.where(moves.is_feed, np.maximum(scale * ft, workpiece.cell_mm / 4), workpiece.cell_mm)
    xyz, move, step_mm = tool_positions(moves, step, rapids=True)
    from labkit.budget import check_budget

    check_budget("segments", len(xyz), cause=f"steps of {scale:g} × f_t", option="--scale")
    wp = workpiece.copy()
    vol = wp.cut_path(xyz, radius_mm=tool_diameter_mm / 2)
    keep = moves.is_feed[move]
    xyz, move, step_mm, vol = xyz[keep], move[keep], step_mm[keep], vol[keep]
    ftk = ft[move]
    return ChipVolumes(xyz, move, step_mm, vol, vol / step_mm * ftk, ftk, wp)
