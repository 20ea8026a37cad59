"""Scan-offset (ghosting) calibration: how far backward scan lines land from forward ones.

A laser switches late: the beam follows its commanded power a time ``t_delay`` behind, so a
line burned in +X at speed v lands ``v · t_delay`` further right than commanded, and one burned in
−X as far to the left. In a bidirectional raster the two halves of every edge part by
``2 · v · t_delay`` — the doubled, ghosted edges of fast photo engravings.

The test pattern is the cut-width grid (:func:`labkit.laser.patterns.grid_pattern`: one power,
the speeds as columns, its corner crosses and engraved numbers) with every second row burned
in −X; its scan registers with :func:`labkit.laser.measure.register`. Each line's centre (the
midpoint of its two end edges along X) is measured on a profile along it, and for each speed the
offset is the mean, over forward/backward row pairs, of forward centre − backward centre, with
the standard error of that mean. A straight line ``offset = k · v + c`` is fitted (weighted least
squares; v in mm/s, k in s): ``k`` is twice the beam delay, ``c`` a fixed misalignment (backlash).

:func:`apply_scan_offset` moves every backward row of a raster job by the offset at its feed, so
both directions land where the forward rows do.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from labkit.errors import InputError
from labkit.laser._calibration import read_document, registered_scan, save_document
from labkit.laser.patterns import GridPattern, grid_pattern
from labkit.toolpath.moves import MoveKind, Moves

__all__ = ["ScanOffset", "scan_offset_pattern", "measure_scan_offset", "fit_scan_offset",
           "apply_scan_offset", "load_scan_offset", "SCAN_OFFSET_FORMAT"]

SCAN_OFFSET_FORMAT = "labkit-scan-offset"
_VERSION = 1


def scan_offset_pattern(speeds_mm_min, *, power_mw: float, pairs: int = 3, line_mm: float = 8.0,
                        pitch_mm: float = 1.0, overscan_mm: float | None = None, machine=None,
                        label_mm: float = 2.0, s_max: float = 1000.0) -> GridPattern:
    """Bidirectional test lines: per speed ``pairs`` rows burned in +X, each followed by one in −X.

    Parameters
    ----------
    speeds_mm_min : array_like
        Scanning feeds, mm/min (the columns).
    power_mw : float
        Optical power of every line, mW.
    pairs : int
        Forward/backward row pairs (>= 2: the spread of their offsets is the uncertainty).
    line_mm, pitch_mm : float
        Line length and row spacing, mm.
    overscan_mm : float, optional
        Beam-off run before and after each line, mm; default what the machine needs to reach
        the fastest speed (v² / 2a, plus 20 %), so every line burns at its speed.
    machine : MachineSpec, optional
        For the default overscan and the power at full S (default CBR40).
    label_mm : float
        Height of the engraved numbers, mm.
    s_max : float
        S meaning full power.

    Returns
    -------
    GridPattern
        Its layout has ``kind`` ``"scan-offset"`` and each line a ``direction`` (``"+X"`` or ``"-X"``).
    """
    from labkit.motion.spec import CBR40

    m = CBR40 if machine is None else machine
    if int(pairs) != pairs or pairs < 2:
        raise InputError(f"pairs must be a whole number >= 2, got {pairs!r}")
    speeds = np.asarray(speeds_mm_min, float)
    if speeds.ndim != 1 or len(speeds) < 2 or not np.all(np.isfinite(speeds) & (speeds > 0)):
        raise InputError(f"need at least two speeds > 0 mm/min to fit a delay, got {speeds_mm_min!r}")
    if speeds.max() > float(m.max_rate_mm_min[0]):
        raise InputError(f"speed {speeds.max():g} mm/min is above the machine's X rate "
                         f"({float(m.max_rate_mm_min[0]):g} mm/min): the line would burn slower than its label")
    if overscan_mm is None:
        v = speeds.max() / 60.0
        overscan_mm = math.ceil(1.2 * v * v / (2 * float(m.accel_mm_s2[0])) * 10) / 10 + 0.5
    g = grid_pattern([power_mw], speeds, line_mm=line_mm, pitch_mm=pitch_mm, overscan_mm=overscan_mm,
                     gap_mm=2 * overscan_mm, repeats=2 * int(pairs), label_mm=label_mm,
                     max_power_mw=m.laser_max_power_mw, s_max=s_max)
    layout = g.layout
    backward_y = {ln["y_mm"] for ln in layout["lines"] if ln["repeat"] % 2}
    for ln in layout["lines"]:
        ln["direction"] = "-X" if ln["repeat"] % 2 else "+X"
    x_lo, x_hi = -overscan_mm, max(ln["x1_mm"] for ln in layout["lines"]) + overscan_mm
    mv = g.moves
    cut = mv.kind != MoveKind.RAPID
    starts, ends = mv.start[cut, :2].copy(), mv.end[cut, :2].copy()
    feed, power = mv.feed_mm_min[cut], mv.s_word[cut]
    # the grid's lines (and their overscans) on a backward row: traced the other way, right to left
    on_row = (np.isin(starts[:, 1], list(backward_y)) & (starts[:, 1] == ends[:, 1])
              & (np.minimum(starts[:, 0], ends[:, 0]) >= x_lo - 1e-9)
              & (np.maximum(starts[:, 0], ends[:, 0]) <= x_hi + 1e-9))
    order = np.arange(len(starts))
    for y in backward_y:
        idx = np.flatnonzero(on_row & (starts[:, 1] == y))
        order[idx] = idx[::-1]
    starts[on_row], ends[on_row] = ends[on_row].copy(), starts[on_row].copy()
    moves = Moves.from_cuts(starts[order], ends[order], feed_mm_min=feed[order], s_word=power[order],
                            laser=int(mv.laser[cut][0]), s_max=s_max)
    layout.update(kind="scan-offset", direction="bidirectional", pairs=int(pairs))
    return GridPattern(moves=moves, layout=layout)


def _centre_along(img, tf, x0, x1, y, half_width_mm, px_mm):
    """Centre (mm) of a dark line between x0 and x1 at y, from its two end edges on a profile
    averaged across the line; NaN when no clear line is seen."""
    xs = np.arange(x0 - 1.5, x1 + 1.5, px_mm / 4)
    across = np.linspace(-half_width_mm, half_width_mm, 5)
    from scipy import ndimage

    pts = np.array([[x, -(y + a)] for a in across for x in xs])
    cr = tf(pts)
    prof = ndimage.map_coordinates(img, [cr[:, 1], cr[:, 0]], order=1, mode="nearest")
    prof = prof.reshape(len(across), len(xs)).mean(axis=0)
    inside = (xs > x0 + 0.25 * (x1 - x0)) & (xs < x1 - 0.25 * (x1 - x0))
    outside = (xs < x0 - 0.5) | (xs > x1 + 0.5)
    dark, paper = np.median(prof[inside]), np.median(prof[outside])
    if not paper - dark > 0.1:
        return math.nan
    level = (paper + dark) / 2
    below = prof < level
    i, j = np.flatnonzero(below)[[0, -1]]
    if i == 0 or j == len(xs) - 1:
        return math.nan
    # linear interpolation of each crossing
    left = xs[i - 1] + (prof[i - 1] - level) / (prof[i - 1] - prof[i]) * (xs[i] - xs[i - 1])
    right = xs[j] + (prof[j] - level) / (prof[j] - prof[j + 1]) * (xs[j + 1] - xs[j])
    return (left + right) / 2


def measure_scan_offset(image, layout: dict) -> pd.DataFrame:
    """Offset between forward and backward lines at each speed of a scanned scan-offset pattern.

    Parameters
    ----------
    image : ndarray
        Grey scan, 0…1 (paper light, burn dark), any turn on the scanner.
    layout : dict
        The pattern's layout (:func:`scan_offset_pattern`).

    Returns
    -------
    DataFrame
        One row per speed: ``speed_mm_min``, ``offset_mm`` (forward − backward line centre,
        mean over the row pairs), ``offset_sd_mm`` (standard error of that mean) and ``pairs``
        (pairs measured).

    Raises
    ------
    InputError
        When the layout is not a scan-offset pattern, the scan does not register, or a speed
        has fewer than two pairs with both lines seen.
    """
    img, tf, layout = registered_scan(image, layout, kind="scan-offset", maker="labkit raster-test scan-offset")
    px_mm = 1.0 / tf.scale
    half = min(0.25 * float(layout["pitch_mm"]), 2 * px_mm)
    rows = []
    for ln in layout["lines"]:
        if ln.get("direction") not in ("+X", "-X"):
            raise InputError(f"layout: a line has direction {ln.get('direction')!r}; expected '+X' or '-X'")
        rows.append(dict(col=ln["col"], pair=ln["repeat"] // 2, direction=ln["direction"],
                         speed_mm_min=ln["speed_mm_min"],
                         centre_mm=_centre_along(img, tf, ln["x0_mm"], ln["x1_mm"], ln["y_mm"], half, px_mm)))
    df = pd.DataFrame(rows)
    fwd = df[df.direction == "+X"].set_index(["col", "pair"])
    bwd = df[df.direction == "-X"].set_index(["col", "pair"])
    pairs = fwd.assign(offset_mm=fwd.centre_mm - bwd.centre_mm.reindex(fwd.index)).dropna(subset=["offset_mm"])
    out = []
    for col, d in pairs.groupby(level="col"):
        if len(d) < 2:
            raise InputError(f"speed {d.speed_mm_min.iloc[0]:g} mm/min: {len(d)} line pair(s) seen in the scan; "
                             "expected at least two (is the pattern burned and the scan sharp?)")
        out.append(dict(speed_mm_min=float(d.speed_mm_min.iloc[0]), offset_mm=float(d.offset_mm.mean()),
                        offset_sd_mm=float(d.offset_mm.std(ddof=1) / math.sqrt(len(d))), pairs=len(d)))
    if len(out) < 2:
        raise InputError(f"{len(out)} speed(s) measured; expected at least two to fit a delay")
    return pd.DataFrame(out).sort_values("speed_mm_min", ignore_index=True)


@dataclass(frozen=True)
class ScanOffset:
    """Offset of backward scan lines against forward ones: ``offset = slope · v + intercept``.

    Attributes
    ----------
    slope_s : float
        Offset per speed, s (mm per mm/s): twice the beam delay.
    intercept_mm : float
        Offset at zero speed, mm (a fixed misalignment).
    slope_sd_s, intercept_sd_mm : float
        Their standard uncertainties.
    measured : dict
        The measurements fitted (speed_mm_min, offset_mm, offset_sd_mm lists).
    """

    slope_s: float
    intercept_mm: float
    slope_sd_s: float = math.nan
    intercept_sd_mm: float = math.nan
    measured: dict | None = None

    @property
    def beam_delay_s(self) -> float:
        """The beam's switching delay, s (half the slope: each direction lands v · delay off)."""
        return self.slope_s / 2

    def offset_mm(self, feed_mm_min):
        """Forward − backward line offset at a feed (mm/min), mm."""
        return self.slope_s * np.asarray(feed_mm_min, float) / 60.0 + self.intercept_mm

    def to_dict(self) -> dict:
        return dict(format=SCAN_OFFSET_FORMAT, version=_VERSION, slope_s=self.slope_s,
                    intercept_mm=self.intercept_mm, slope_sd_s=self.slope_sd_s,
                    intercept_sd_mm=self.intercept_sd_mm, beam_delay_s=self.beam_delay_s,
                    model="offset_mm = slope_s * speed_mm_s + intercept_mm (forward - backward line centre)",
                    measured=self.measured or {})

    def save(self, path) -> None:
        """Write the model as JSON (whole or not at all)."""
        save_document(path, self.to_dict())


def fit_scan_offset(speed_mm_min, offset_mm, offset_sd_mm=None) -> ScanOffset:
    """Fit ``offset = slope · v + intercept`` by weighted least squares.

    Parameters
    ----------
    speed_mm_min : array_like
        Feeds, mm/min (at least two distinct).
    offset_mm : array_like
        Measured forward − backward offsets, mm.
    offset_sd_mm : array_like, optional
        Their standard uncertainties, mm (weights 1/sd²; default equal weights, and the
        parameters' uncertainties from the residuals).

    Returns
    -------
    ScanOffset

    Examples
    --------
    >>> f = fit_scan_offset([600, 1200, 2400], [0.02, 0.04, 0.08])
    >>> round(f.slope_s, 6), round(f.beam_delay_s * 1e3, 3), round(f.intercept_mm, 6) + 0.0
    (0.002, 1.0, 0.0)
    """
    v = np.asarray(speed_mm_min, float) / 60.0
    y = np.asarray(offset_mm, float)
    if v.ndim != 1 or y.shape != v.shape or len(np.unique(v)) < 2:
        raise InputError("need offsets at two or more distinct speeds to fit a delay")
    if not (np.all(np.isfinite(v)) and np.all(np.isfinite(y))):
        raise InputError("speeds and offsets must be finite")
    sd = None if offset_sd_mm is None else np.asarray(offset_sd_mm, float)
    if sd is not None and not (sd.shape == v.shape and np.all(np.isfinite(sd))):
        raise InputError("offset_sd_mm must hold one finite uncertainty per speed")
    a = np.column_stack([v, np.ones_like(v)])
    if sd is None or np.any(sd <= 0):
        w = np.ones_like(v)
    else:
        # a floor keeps one suspiciously exact point from taking all the weight
        w = 1.0 / np.maximum(sd, 0.1 * np.median(sd)) ** 2
    aw = a * w[:, None]
    cov = np.linalg.inv(a.T @ aw)
    p = cov @ (aw.T @ y)
    resid = y - a @ p
    dof = len(v) - 2
    if dof > 0:
        # scaled by the residuals (the stated uncertainties may be too small or too large)
        cov = cov * float(resid @ (w * resid)) / dof
    sds = np.sqrt(np.diag(cov)) if dof > 0 or sd is not None else np.full(2, math.nan)
    measured = dict(speed_mm_min=(v * 60).tolist(), offset_mm=y.tolist(),
                    offset_sd_mm=None if sd is None else sd.tolist())
    return ScanOffset(float(p[0]), float(p[1]), float(sds[0]), float(sds[1]), measured)


def load_scan_offset(path) -> ScanOffset:
    """Read a scan-offset model written by :meth:`ScanOffset.save`, or a clear :class:`InputError`."""
    doc = read_document(path, what="scan-offset model", format=SCAN_OFFSET_FORMAT, version=_VERSION,
                        maker="labkit raster-test measure-offset")
    vals = {}
    for key in ("slope_s", "intercept_mm"):
        v = doc.get(key)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise InputError(f"{path}: {key} is {v!r}; expected a finite number")
        vals[key] = float(v)
    return ScanOffset(vals["slope_s"], vals["intercept_mm"], float(doc.get("slope_sd_s") or math.nan),
                      float(doc.get("intercept_sd_mm") or math.nan), doc.get("measured"))


def apply_scan_offset(moves: Moves, model: ScanOffset, *, tol_mm: float = 1e-6) -> Moves:
    """A raster job with each backward (−X) row moved by the model's offset at its feed.

    A row is the set of moves at one Y; it is backward when its burning moves run in −X.
    Every point on such a row — the moves along it, the ends of the moves that enter and
    leave it — moves by ``model.offset_mm(feed)`` in +X, so the row stays one contiguous
    pass and lands where the forward rows do.

    Parameters
    ----------
    moves : Moves
        A row-scanned job (``img2gcode`` gray, dither or zig-zag along X).
    model : ScanOffset
    tol_mm : float
        Two Y values closer than this are one row, mm.

    Returns
    -------
    Moves
        A copy; forward rows unchanged.
    """
    out = moves.copy()
    if not len(out):
        return out
    burn = out.laser_on & (np.abs(out.end[:, 1] - out.start[:, 1]) <= tol_mm)
    dx = out.end[:, 0] - out.start[:, 0]
    back = burn & (dx < 0)
    if not back.any():
        along_y = out.laser_on & (np.abs(dx) <= tol_mm) & (out.end[:, 1] < out.start[:, 1] - tol_mm)
        if along_y.any():
            raise InputError("the job scans along Y (columns); the scan offset is measured and applied along X: "
                             "engrave it in rows (img2gcode --axis rows)")
        return out
    key = lambda y: np.rint(np.asarray(y) / tol_mm).astype(np.int64)      # noqa: E731 - one rounding for both ends
    rows, first = np.unique(key(out.start[back, 1]), return_index=True)
    feed = out.feed_mm_min[back][first]
    if burn[dx > 0].any() and np.isin(key(out.start[burn & (dx > 0), 1]), rows).any():
        raise InputError("a row burns in both directions; the scan offset applies to rows scanned one way")
    shift = dict(zip(rows.tolist(), np.asarray(model.offset_mm(feed), float).tolist()))
    for col in (out.start, out.end):
        k = key(col[:, 1])
        hit = np.isin(k, rows)
        col[hit, 0] += np.array([shift[v] for v in k[hit].tolist()])
    return out
