"""The virtual material: a Gaussian spot's dose integrated along a planned motion, thresholded.

A beam of power P(t) and 1/e² radius w0 at position X(t) leaves at point x the fluence

    F(x) = ∫ 2·P(t) / (π·w0²) · exp(−2·|x − X(t)|² / w0²) dt      (mJ/mm² for mW, mm, s),

and the material burns where F reaches its threshold F_th. The motion is
:func:`labkit.motion.pipeline.plan`'s — its speed profiles, ramps and junctions —
and the power at each instant follows the block's laser mode (M3 constant, M4
scaled by speed, :func:`labkit.motion.power.laser_power_mw`). The integral is a
sum over instants spaced closely enough in time that the spot moves at most a
tenth of w0 between them (a sampled Gaussian sums to its integral to far below
a part in a million at that spacing), each evaluated exactly on the pixels
within 3.5·w0.

On a straight line at constant speed this is the closed form of
:func:`labkit.laser.models.dose_width`; where the head slows — at a corner, a
line's ends — M3 leaves more energy per millimetre and the line widens, while
M4 keeps the power/speed ratio and the width ([CBR40] §IV).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from scipy import ndimage

from labkit.errors import InputError
from labkit.motion.pipeline import Plan, plan
from labkit.toolpath.moves import Moves, check_moves

__all__ = ["Burn", "simulate_burn", "beam_positions"]

_MM_PER_INCH = 25.4
_REACH = 3.5            # the spot is evaluated within this many w0 (exp(−2·3.5²) ≈ 2e-11)


def beam_positions(p: Plan, n: int):
    """Time samples of a plan with the beam's XY position, speed and power.

    Parameters
    ----------
    p : Plan
        A plan whose motion blocks are straight lines (plan arcs with ``arc_tol_mm``).
    n : int
        Samples over the whole job, uniform in time (block ends added).

    Returns
    -------
    dict of ndarray
        ``time_s``, ``x_mm``, ``y_mm``, ``speed_mm_s``, ``power_mw``, ``block`` and
        ``along_mm`` (distance from the start of its block).
    """
    s = p.sample(int(max(n, 2)))
    b = p.blocks
    if len(p.motion) and np.isfinite(b.centre_mm[p.motion]).any():
        raise InputError("the burn simulation follows straight blocks only; plan arcs as chords (arc_tol_mm)")
    spm = np.asarray(p.machine.steps_per_mm, float)
    start = b.start_steps / spm
    dist0 = np.concatenate([[0.0], np.cumsum(b.length_mm)[:-1]])
    blk = s["block"]
    along = np.clip(s["distance_mm"] - dist0[blk], 0.0, b.length_mm[blk])
    pos = start[blk] + b.unit_in[blk] * along[:, None]
    return {"time_s": s["time_s"], "x_mm": pos[:, 0], "y_mm": pos[:, 1], "speed_mm_s": s["speed_mm_s"],
            "power_mw": s["power_mw"], "block": blk, "along_mm": along}


@dataclass
class Burn:
    """A simulated burn: the fluence on a pixel grid and what it burned.

    Attributes
    ----------
    fluence : ndarray, (rows, cols)
        mJ/mm²; row 0 at ``y_mm[0]`` (y grows with the row index: flip for an image).
    x_mm, y_mm : ndarray
        Pixel centres, mm.
    w0_mm, fth_mj_mm2 : float
        Beam radius and threshold.
    plan : Plan
        The motion that was burned.
    samples : dict
        The instants summed (:func:`beam_positions`).
    """

    fluence: np.ndarray
    x_mm: np.ndarray
    y_mm: np.ndarray
    w0_mm: float
    fth_mj_mm2: float
    plan: Plan
    samples: dict = field(repr=False, default_factory=dict)

    @property
    def pixel_mm(self) -> float:
        return float(self.x_mm[1] - self.x_mm[0])

    @property
    def burned(self) -> np.ndarray:
        """Pixels whose fluence reaches the threshold."""
        return self.fluence >= self.fth_mj_mm2

    @property
    def coverage(self) -> np.ndarray:
        """Burned share of each pixel, 0…1: the threshold edge placed inside the pixel from the
        fluence and its gradient (linear across the pixel), so edges are not rounded to whole pixels."""
        gy, gx = np.gradient(self.fluence, self.pixel_mm)
        slope = np.hypot(gx, gy) * self.pixel_mm            # fluence change across one pixel
        with np.errstate(divide="ignore", invalid="ignore"):
            c = np.where(slope > 0, 0.5 + (self.fluence - self.fth_mj_mm2) / slope,
                         (self.fluence >= self.fth_mj_mm2).astype(float))
        return np.clip(c, 0.0, 1.0)

    @property
    def extent(self):
        """(left, right, bottom, top) in mm for ``imshow(..., origin="lower")``."""
        h = self.pixel_mm / 2
        return (self.x_mm[0] - h, self.x_mm[-1] + h, self.y_mm[0] - h, self.y_mm[-1] + h)

    def fluence_at(self, x_mm, y_mm):
        """Fluence at arbitrary points (cubic spline of the pixel grid), mJ/mm²."""
        c = (np.asarray(x_mm, float) - self.x_mm[0]) / self.pixel_mm
        r = (np.asarray(y_mm, float) - self.y_mm[0]) / self.pixel_mm
        return ndimage.map_coordinates(self.fluence, [r, c], order=3, mode="nearest")

    def line_widths(self, station_mm: float | None = None, *, skip_mm: float = 0.0) -> pd.DataFrame:
        """Burned width across every burning block, at stations along it.

        The width at a station is the distance between the two threshold
        crossings on the perpendicular (linear interpolation of the fluence
        between samples a tenth of a pixel apart).

        Parameters
        ----------
        station_mm : float, optional
            Spacing of the stations along each block, mm (default w0 / 2).
        skip_mm : float
            Stations closer than this to a block's ends are left out, mm.

        Returns
        -------
        DataFrame
            ``block``, ``line`` (source line), ``along_mm``, ``x_mm``, ``y_mm``,
            ``speed_mm_s``, ``power_mw`` (the head's at that point) and ``width_mm``.
        """
        step = self.w0_mm / 2 if station_mm is None else float(station_mm)
        if not step > 0:
            raise InputError(f"station_mm must be > 0, got {station_mm!r}")
        p = self.plan
        b = p.blocks
        samples = self.samples
        spm = np.asarray(p.machine.steps_per_mm, float)
        half = 3.0 * self.w0_mm + 2 * self.pixel_mm
        across = np.arange(-half, half + 1e-12, self.pixel_mm / 10)
        rows = []
        for k in p.motion[b.laser_on[p.motion]]:
            L = float(b.length_mm[k])
            s = np.arange(skip_mm + step / 2, L - skip_mm, step)
            if not len(s):
                continue
            u = b.unit_in[k, :2]
            normal = np.array([-u[1], u[0]])
            c = b.start_steps[k, :2] / spm[:2] + s[:, None] * u
            pts = c[:, None, :] + across[None, :, None] * normal
            f = self.fluence_at(pts[..., 0], pts[..., 1])
            mine = samples["block"] == k
            v = np.interp(s, samples["along_mm"][mine], samples["speed_mm_s"][mine])
            pw = np.interp(s, samples["along_mm"][mine], samples["power_mw"][mine])
            rows.append(pd.DataFrame({"block": k, "line": b.line[k], "along_mm": s, "x_mm": c[:, 0],
                                      "y_mm": c[:, 1], "speed_mm_s": v, "power_mw": pw,
                                      "width_mm": _crossing_width(across, f, self.fth_mj_mm2)}))
        cols = ["block", "line", "along_mm", "x_mm", "y_mm", "speed_mm_s", "power_mw", "width_mm"]
        return pd.concat(rows, ignore_index=True) if rows else pd.DataFrame(columns=cols)

    def scan(self, *, dpi: float = 600.0, rotation_deg: float = 0.0, margin_mm: float = 2.0, noise: float = 0.0,
             blur_px: float = 0.0, seed: int = 0) -> np.ndarray:
        """The burned piece as a grey scan (paper 0.9, burn 0.1; rows down, y up) at ``dpi``.

        Each scan pixel takes the burned share (:attr:`coverage`) of the simulation
        pixels it covers (their pixel must be at most the scan's); the piece lies
        ``rotation_deg`` counter-clockwise on the scanner, with ``margin_mm`` of paper
        round the simulated area; then optional blur and noise as
        :func:`labkit.laser.measure.render_scan`.
        """
        px = _MM_PER_INCH / dpi
        if px < self.pixel_mm * 0.999:
            raise InputError(f"the scan's pixel ({px:.4f} mm at {dpi:g} dpi) is finer than the simulation's "
                             f"({self.pixel_mm:.4f} mm); simulate with a smaller pixel_mm")
        dark = ndimage.uniform_filter(self.coverage, size=max(1, int(round(px / self.pixel_mm))))
        x_lo, x_hi, y_lo, y_hi = self.extent
        cx, cy = (x_lo + x_hi) / 2, (y_lo + y_hi) / 2
        t = np.deg2rad(rotation_deg)
        w, h = x_hi - x_lo, y_hi - y_lo
        # the rotated piece's bounding box, plus the margin
        half_w = (abs(np.cos(t)) * w + abs(np.sin(t)) * h) / 2 + margin_mm
        half_h = (abs(np.sin(t)) * w + abs(np.cos(t)) * h) / 2 + margin_mm
        u = np.arange(-half_w + px / 2, half_w, px)
        v = np.arange(half_h - px / 2, -half_h, -px)          # rows go down, y up
        U, V = np.meshgrid(u, v)
        # scan frame → piece frame: undo the piece's rotation
        X = cx + np.cos(t) * U + np.sin(t) * V
        Y = cy - np.sin(t) * U + np.cos(t) * V
        d = ndimage.map_coordinates(dark, [(Y - self.y_mm[0]) / self.pixel_mm, (X - self.x_mm[0]) / self.pixel_mm],
                                    order=1, mode="constant", cval=0.0)
        img = 0.9 - 0.8 * np.clip(d, 0, 1)
        if blur_px > 0:
            img = ndimage.gaussian_filter(img, blur_px)
        if noise > 0:
            img = img + np.random.default_rng(seed).normal(0, noise, img.shape)
        return np.clip(img, 0, 1)


def _crossing_width(u, f, threshold):
    """Distance between the outermost threshold crossings of each profile row (0 where none)."""
    above = f >= threshold
    out = np.zeros(len(f))
    for i, (row, a) in enumerate(zip(f, above)):
        idx = np.flatnonzero(a)
        if not len(idx):
            continue
        j0, j1 = idx[0], idx[-1]
        if j0 == 0 or j1 == len(u) - 1:
            out[i] = np.nan          # the burn runs past the profile: not a line
            continue
        left = u[j0 - 1] + (threshold - row[j0 - 1]) / (row[j0] - row[j0 - 1]) * (u[j0] - u[j0 - 1])
        right = u[j1] + (threshold - row[j1]) / (row[j1 + 1] - row[j1]) * (u[j1 + 1] - u[j1])
        out[i] = right - left
    return out


def simulate_burn(moves: Moves | Plan, *, w0_mm: float, fth_mj_mm2: float, pixel_mm: float | None = None,
                  machine=None, planner: str = "junction", law: str | None = None,
                  arc_tol_mm: float = 0.002, margin_mm: float | None = None, max_pixels: int = 40_000_000,
                  beam_delay_s: float = 0.0) -> Burn:
    """Burn a program into the virtual material.

    Parameters
    ----------
    moves : Moves or Plan
        The program, or a plan of it (its arcs as chords).
    w0_mm : float
        1/e² beam radius, mm.
    fth_mj_mm2 : float
        Threshold fluence of the material, mJ/mm².
    pixel_mm : float, optional
        Grid spacing, mm (default w0 / 8).
    machine, planner, law, arc_tol_mm
        Passed to :func:`labkit.motion.pipeline.plan` when ``moves`` is a program.
    margin_mm : float, optional
        Paper around the burned path, mm (default 4·w0).
    max_pixels : int
        Refuse grids larger than this.
    beam_delay_s : float
        The beam follows its commanded power this late, s (>= 0): the power at each instant
        is the one commanded ``beam_delay_s`` before (to the nearest earlier sample) — the
        late switching that misaligns bidirectional scan lines.

    Returns
    -------
    Burn
    """
    for name, value in (("w0_mm", w0_mm), ("fth_mj_mm2", fth_mj_mm2)):
        if not (np.isfinite(value) and value > 0):
            raise InputError(f"{name} must be > 0, got {value!r}")
    if not isinstance(moves, Plan):
        check_moves(moves, error=InputError)
    p = moves if isinstance(moves, Plan) else plan(moves, machine, planner=planner, law=law, arc_tol_mm=arc_tol_mm)
    pixel = w0_mm / 8 if pixel_mm is None else float(pixel_mm)
    if not pixel > 0:
        raise InputError(f"pixel_mm must be > 0, got {pixel_mm!r}")
    vmax = float(p.profiles.peak_mm_s.max()) if len(p.motion) else 1.0
    # the spot moves at most w0/10 between instants at the top speed
    n = int(np.ceil(p.job_time_s * vmax / (w0_mm / 10))) + 2
    if n > 50_000_000:
        raise InputError(f"the job needs {n:,} time samples at w0 = {w0_mm:g} mm; simulate a smaller part of it")
    s = beam_positions(p, n)
    t = s["time_s"]
    if not (np.isfinite(beam_delay_s) and beam_delay_s >= 0):
        raise InputError(f"beam_delay_s must be >= 0, got {beam_delay_s!r}")
    if beam_delay_s > 0:
        k = np.searchsorted(t, t - beam_delay_s, side="right") - 1
        s = dict(s, power_mw=np.where(k >= 0, s["power_mw"][np.maximum(k, 0)], 0.0))
    # trapezoid weights: each instant carries half the interval to either neighbour
    dt = np.diff(t, prepend=t[0]) / 2 + np.diff(t, append=t[-1]) / 2
    energy = s["power_mw"] * dt                       # mJ per instant
    on = energy > 0
    margin = 4 * w0_mm if margin_mm is None else float(margin_mm)
    if on.any():
        x_lo, x_hi = s["x_mm"][on].min() - margin, s["x_mm"][on].max() + margin
        y_lo, y_hi = s["y_mm"][on].min() - margin, s["y_mm"][on].max() + margin
    else:
        x_lo = x_hi = y_lo = y_hi = 0.0
    nx, ny = int(np.ceil((x_hi - x_lo) / pixel)) + 1, int(np.ceil((y_hi - y_lo) / pixel)) + 1
    if nx * ny > max_pixels:
        raise InputError(f"the burn grid would have {nx * ny:,} pixels (> {max_pixels:,}); use a larger pixel_mm")
    xs, ys = x_lo + pixel * np.arange(nx), y_lo + pixel * np.arange(ny)
    fluence = np.zeros(ny * nx)
    reach = int(np.ceil(_REACH * w0_mm / pixel))
    off = np.arange(-reach, reach + 1)
    peak = 2.0 / (np.pi * w0_mm ** 2)
    xe, ye, ee = s["x_mm"][on], s["y_mm"][on], energy[on]
    chunk = max(1, 2_000_000 // len(off) ** 2)
    for a in range(0, len(ee), chunk):
        x, y, e = xe[a:a + chunk], ye[a:a + chunk], ee[a:a + chunk]
        ci = np.rint((x - x_lo) / pixel).astype(np.int64)[:, None, None] + off[None, None, :]
        ri = np.rint((y - y_lo) / pixel).astype(np.int64)[:, None, None] + off[None, :, None]
        dx = xs[np.clip(ci, 0, nx - 1)] - x[:, None, None]
        dy = ys[np.clip(ri, 0, ny - 1)] - y[:, None, None]
        val = e[:, None, None] * peak * np.exp(-2.0 * (dx ** 2 + dy ** 2) / w0_mm ** 2)
        ok = (ci >= 0) & (ci < nx) & (ri >= 0) & (ri < ny)
        flat = np.broadcast_to(ri * nx + ci, val.shape)[ok]
        fluence += np.bincount(flat, weights=val[ok], minlength=ny * nx)
    return Burn(fluence.reshape(ny, nx), xs, ys, float(w0_mm), float(fth_mj_mm2), p, s)
