"""Tone-response calibration: how dark the material gets at each S, and the S for a wanted gray.

A gray engraving maps a pixel's darkness linearly to S (:func:`labkit.raster.engrave.power_map`),
but a material darkens with S along its own curve — slowly at first, then saturating — so a
photo's mid-grays come out wrong. The calibration burns a *step wedge*: patches of parallel lines
at increasing S (a one-column :func:`labkit.laser.patterns.grid_pattern`, so its scan registers on
the same corner crosses and engraved numbers as the cut-width grid), measures each patch's mean
darkness and its spread in the scan, and fits a monotone curve S → darkness.

The fit: the patch means are first made non-decreasing by isotonic regression (pool adjacent
violators, weighted by the pixels measured; a few lines of numpy, as scikit-learn is not a
dependency), then joined by a monotone cubic (PCHIP, :class:`scipy.interpolate.PchipInterpolator`).
PCHIP keeps the sign of the data's slope between knots, so the curve never overshoots or turns
back, and it can be inverted: :meth:`ToneCurve.s_for` is the S that gives a wanted darkness.
:meth:`ToneCurve.correct_gray` rewrites an image's grays so that the linear power map then asks
for those S values.

Darkness is ``1 − scan / paper``: 0 on unburned material, the scan's paper level measured beside
the patches (where the head runs on with the beam off).

``labkit raster-test measure-tone -o TONE.json`` (:meth:`ToneCurve.save`) writes the curve in
this format (version 2)::

    {
      "format": "labkit-tone-curve",      # exactly this
      "version": 2,                       # 1 named the knots' S "power_s"; both are read
      "s_max": 1000.0, "feed_mm_min": 3000.0, "line_interval_mm": 0.1,   # null: not known
      "s_word": [0.0, 62.5, …],           # the knots' S, increasing from 0
      "darkness": [0.0, 0.04, …],         # the knots' darkness, non-decreasing
      "measured": […], "spread": […],     # each patch's mean darkness and spread (null: none)
      "fit": "isotonic (pool adjacent violators) then PCHIP"
    }
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy import ndimage
from scipy.interpolate import PchipInterpolator

from labkit.errors import InputError
from labkit.laser._calibration import read_document, registered_scan, save_document
from labkit.laser.patterns import GridPattern, grid_pattern
from labkit.units import s_within

__all__ = ["ToneCurve", "wedge_pattern", "measure_wedge", "fit_tone", "isotonic", "load_tone", "TONE_FORMAT",
           "TONE_VERSION"]

TONE_FORMAT = "labkit-tone-curve"
#: The tone curve's version (2: the knots' S is ``s_word``; version 1 named it ``power_s``).
TONE_VERSION = 2


def wedge_pattern(steps: int = 16, *, s_max: float = 1000.0, machine=None,
                  speed_mm_min: float | None = None, line_interval_mm: float = 0.1, patch_mm: float = 8.0,
                  patch_lines: int = 30, overscan_mm: float = 3.0, label_mm: float = 2.0) -> GridPattern:
    """A gray step wedge: ``steps`` patches of parallel lines, S rising evenly to ``s_max``.

    Parameters
    ----------
    steps : int
        Number of patches (>= 2); patch k (1-based) burns at S = s_max · k / steps.
    s_max : float
        S meaning full power.
    machine : MachineSpec, optional
        Its power at full S and X rate (default CBR40).
    speed_mm_min : float, optional
        Scanning feed, mm/min (the feed the engravings will use; default 3000 or the
        machine's X rate if lower). A feed above the machine's rate is refused.
    line_interval_mm : float
        Distance between the lines of a patch, mm (the engraving's pixel pitch).
    patch_mm : float
        Patch width (line length), mm.
    patch_lines : int
        Lines per patch (patch height = patch_lines · line_interval_mm).
    overscan_mm : float
        Beam-off run before and after each line, mm.
    label_mm : float
        Height of the engraved step numbers, mm.

    Returns
    -------
    GridPattern
        Its layout has ``kind`` ``"tone-wedge"`` and ``steps``.
    """
    if int(steps) != steps or steps < 2:
        raise InputError(f"steps must be a whole number >= 2, got {steps!r}")
    if int(patch_lines) != patch_lines or patch_lines < 3:
        raise InputError(f"patch_lines must be a whole number >= 3, got {patch_lines!r}")
    from labkit.motion.spec import CBR40

    m = CBR40 if machine is None else machine
    max_power_mw = m.laser_max_power_mw
    rate = float(m.max_rate_mm_min[0])
    speed_mm_min = min(3000.0, rate) if speed_mm_min is None else float(speed_mm_min)
    if speed_mm_min > rate:
        raise InputError(f"feed {speed_mm_min:g} mm/min is above the machine's X rate ({rate:g} mm/min): "
                         "the wedge would burn slower than the engraving")
    powers = max_power_mw * np.arange(1, int(steps) + 1) / int(steps)
    g = grid_pattern(powers, [speed_mm_min], line_mm=patch_mm, pitch_mm=line_interval_mm,
                     overscan_mm=overscan_mm, gap_mm=2 * overscan_mm, repeats=int(patch_lines),
                     label_mm=label_mm, max_power_mw=max_power_mw, s_max=s_max)
    g.layout.update(kind="tone-wedge", steps=int(steps))
    return g


def _sample(img, tf, x_mm, y_mm):
    """Scan values at layout points (mm, y up), bilinear."""
    cr = tf(np.column_stack([np.ravel(x_mm), -np.ravel(y_mm)]))
    return ndimage.map_coordinates(img, [cr[:, 1], cr[:, 0]], order=1, mode="nearest")


def measure_wedge(image, layout: dict, *, trim_mm: float | None = None) -> pd.DataFrame:
    """Mean darkness and its spread in each patch of a scanned step wedge.

    Parameters
    ----------
    image : ndarray
        The scan, as :func:`labkit.laser.scanoffset.measure_scan_offset` takes it.
    layout : dict
        The wedge's layout (:func:`wedge_pattern`).
    trim_mm : float, optional
        Margin left out inside each patch's edges, mm (default two line intervals):
        the edges blur into the paper and the neighbour.

    Returns
    -------
    DataFrame
        ``step``, ``s_word``, ``power_mw``, ``darkness`` (mean of 1 − scan/paper over the
        patch), ``darkness_sd`` (its spread over the patch's pixels), ``pixels`` and
        ``paper`` (the scan's paper level).

    Raises
    ------
    InputError
        When the layout is not a step wedge, the scan does not register, or the paper
        beside the patches is not lighter than the darkest patch.
    """
    img, tf, layout = registered_scan(image, layout, kind="tone-wedge", maker="labkit raster-test wedge")
    px_mm = 1.0 / tf.scale
    lines = pd.DataFrame(layout["lines"])
    pitch = float(layout["pitch_mm"])
    trim = 2 * pitch if trim_mm is None else float(trim_mm)
    x0, x1 = float(lines.x0_mm.min()), float(lines.x1_mm.max())
    over = float(layout.get("overscan_mm", 0.0))
    if over < 4 * px_mm:
        raise InputError(f"layout: overscan_mm {over:g} leaves no paper beside the patches to measure "
                         f"(need at least 4 scan pixels, {4 * px_mm:.3f} mm)")
    y_lo, y_hi = float(lines.y_mm.min()), float(lines.y_mm.max())
    ys = np.arange(y_lo, y_hi, px_mm)
    # paper: the beam-off run right of the patches, away from the line ends
    xs = np.arange(x1 + 2 * px_mm, x1 + over - px_mm, px_mm)
    X, Y = np.meshgrid(xs, ys)
    paper = float(np.median(_sample(img, tf, X, Y)))
    rows = []
    for (row_power, s), patch in lines.groupby(["power_mw", "s_word"], sort=True):
        py0, py1 = patch.y_mm.min() - pitch / 2 + trim, patch.y_mm.max() + pitch / 2 - trim
        px0, px1 = patch.x0_mm.min() + trim, patch.x1_mm.max() - trim
        if not (py1 > py0 and px1 > px0):
            raise InputError(f"layout: the patch at S {s:g} is smaller than twice trim_mm ({trim:g} mm)")
        X, Y = np.meshgrid(np.arange(px0, px1, px_mm), np.arange(py0, py1, px_mm))
        d = 1.0 - _sample(img, tf, X, Y) / paper
        rows.append(dict(s_word=float(s), power_mw=float(row_power), darkness=float(d.mean()),
                         darkness_sd=float(d.std(ddof=1)), pixels=int(d.size), paper=paper))
    df = pd.DataFrame(rows).sort_values("s_word", ignore_index=True)
    df.insert(0, "step", np.arange(1, len(df) + 1))
    if not df.darkness.max() > 0:
        raise InputError("no patch is darker than the paper beside the wedge; expected a scan of the burned "
                         "wedge (paper light, burn dark)")
    return df


def isotonic(y, weights=None) -> np.ndarray:
    """The non-decreasing sequence nearest to ``y`` in weighted least squares (pool adjacent violators).

    Parameters
    ----------
    y : array_like, 1-D
    weights : array_like, optional
        Positive weight of each value (default 1).

    Returns
    -------
    ndarray

    Examples
    --------
    >>> isotonic([1.0, 3.0, 2.0, 4.0]).tolist()
    [1.0, 2.5, 2.5, 4.0]
    """
    y = np.asarray(y, float)
    w = np.ones_like(y) if weights is None else np.asarray(weights, float)
    if y.ndim != 1 or w.shape != y.shape or not (np.all(np.isfinite(y)) and np.all(w > 0)):
        raise InputError("isotonic needs a 1-D finite sequence and as many positive weights")
    means, wsum, count = [], [], []
    for v, wt in zip(y, w):
        means.append(v)
        wsum.append(wt)
        count.append(1)
        # merge the last two blocks while they decrease
        while len(means) > 1 and means[-2] > means[-1]:
            m2, w2, c2 = means.pop(), wsum.pop(), count.pop()
            means[-1] = (means[-1] * wsum[-1] + m2 * w2) / (wsum[-1] + w2)
            wsum[-1] += w2
            count[-1] += c2
    return np.repeat(means, count)


@dataclass(frozen=True)
class ToneCurve:
    """A material's darkness against S: monotone knots joined by PCHIP.

    Attributes
    ----------
    s_word : ndarray
        Knots' S, increasing, starting at 0 (unburned).
    darkness : ndarray
        Knots' darkness, non-decreasing (0 … 1: 1 − scan / paper).
    measured, spread : ndarray
        The patches' measured mean darkness and spread (without the S = 0 knot).
    s_max : float
        S meaning full power.
    feed_mm_min, line_interval_mm : float
        The wedge's scanning feed (mm/min) and line interval (mm): the curve holds for
        engravings at these (NaN: not known).
    """

    s_word: np.ndarray
    darkness: np.ndarray
    measured: np.ndarray
    spread: np.ndarray
    s_max: float
    feed_mm_min: float = math.nan
    line_interval_mm: float = math.nan

    @property
    def _curve(self):
        return PchipInterpolator(self.s_word, self.darkness, extrapolate=False)

    def darkness_at(self, s_word):
        """Darkness the material shows at ``s_word`` (clipped to the measured S range)."""
        s = np.clip(np.asarray(s_word, float), self.s_word[0], self.s_word[-1])
        return self._curve(s)

    def s_for(self, darkness):
        """The lowest S giving ``darkness`` (clipped to the curve's range): the curve inverted."""
        s = np.linspace(self.s_word[0], self.s_word[-1], 4097)
        d = np.maximum.accumulate(self._curve(s))
        first = np.concatenate([[True], np.diff(d) > 0])     # flat stretches: their lowest S
        return np.interp(np.asarray(darkness, float), d[first], s[first])

    def correct_gray(self, gray, *, s_max: float, min_power: float = 0.0, max_power: float = 1.0,
                     white_level: float = 255.0) -> np.ndarray:
        """Grays that make the linear power map burn the wanted tones.

        A pixel's wanted darkness is its share ``1 − g/255`` of the range the material shows
        between the lightest and darkest power (``min_power``, ``max_power`` of ``s_max``); the
        curve gives the S for it, and the gray returned is the one
        :func:`labkit.raster.engrave.power_map` maps to that S. Pixels at or above
        ``white_level`` stay as they are (not burned).

        Parameters
        ----------
        gray : ndarray
            labkit gray, 0…255.
        s_max : float
            S meaning full power in the job (may differ from the wedge's: S is scaled).
        min_power, max_power : float
            Fractions of full power for the lightest and darkest pixel.
        white_level : float
            Gray at and above which a pixel is not burned.

        Returns
        -------
        ndarray
            Corrected gray, 0…255.
        """
        g = np.asarray(gray, float)
        if max_power <= min_power:
            return g.copy()
        scale = self.s_max / float(s_max)        # job S → wedge S
        lo, hi = s_max * min_power * scale, s_max * max_power * scale
        d_lo, d_hi = self.darkness_at(lo), self.darkness_at(hi)
        if not d_hi > d_lo:
            raise InputError(f"the tone curve is flat between S {lo:g} and {hi:g} (darkness {float(d_lo):.3f}); "
                             "no gray can be shown there: widen --min-power/--max-power")
        wanted = d_lo + (1.0 - np.clip(g, 0, 255) / 255.0) * (d_hi - d_lo)
        s = self.s_for(wanted) / scale
        dark = np.clip((s / s_max - min_power) / (max_power - min_power), 0.0, 1.0)
        out = 255.0 * (1.0 - dark)
        white = g >= white_level
        # a burned pixel stays burned: just under the white level
        out = np.where(white, g, np.minimum(out, np.nextafter(white_level, 0)))
        return out

    def to_dict(self) -> dict:
        def known(x):          # JSON has no NaN: unknown is null
            return None if not math.isfinite(x) else float(x)

        return dict(format=TONE_FORMAT, version=TONE_VERSION, s_max=self.s_max,
                    feed_mm_min=known(self.feed_mm_min), line_interval_mm=known(self.line_interval_mm),
                    s_word=self.s_word.tolist(), darkness=self.darkness.tolist(),
                    measured=self.measured.tolist(), spread=[known(x) for x in self.spread],
                    fit="isotonic (pool adjacent violators) then PCHIP")

    def save(self, path) -> None:
        """Write the curve as JSON (whole or not at all)."""
        save_document(path, self.to_dict())


def fit_tone(s_word, darkness, *, spread=None, weights=None, s_max: float = 1000.0,
             feed_mm_min: float = math.nan, line_interval_mm: float = math.nan) -> ToneCurve:
    """Fit a monotone tone curve to measured patches.

    Parameters
    ----------
    s_word : array_like
        Each patch's S (> 0, distinct).
    darkness : array_like
        Each patch's mean darkness (1 − scan / paper).
    spread : array_like, optional
        Each patch's darkness spread (kept in the curve for the record).
    weights : array_like, optional
        Weight of each patch in the isotonic step (e.g. pixels measured).
    s_max : float
        S meaning full power.
    feed_mm_min, line_interval_mm : float, optional
        The wedge's feed (mm/min) and line interval (mm), kept with the curve.

    Returns
    -------
    ToneCurve
        Knots at S = 0 (darkness 0, the unburned material) and at each patch.

    Examples
    --------
    >>> c = fit_tone([250, 500, 750, 1000], [0.2, 0.5, 0.45, 0.8])
    >>> c.darkness.round(3).tolist()
    [0.0, 0.2, 0.475, 0.475, 0.8]
    """
    s = np.asarray(s_word, float)
    d = np.asarray(darkness, float)
    if s.ndim != 1 or d.shape != s.shape or len(s) < 2:
        raise InputError(f"need at least two patches with one darkness each, got {s.shape} S and {d.shape} darkness")
    if not (np.all(np.isfinite(s)) and np.all(np.isfinite(d)) and np.all(s > 0)):
        raise InputError("patch S must be finite and > 0 and darkness finite")
    if not (math.isfinite(s_max) and s_max > 0 and s_within(s.max(), s_max)):
        raise InputError(f"s_max must be > 0 and at least the highest patch S ({s.max():g}), got {s_max!r}")
    order = np.argsort(s)
    s, d = s[order], d[order]
    if np.any(np.diff(s) <= 0):
        raise InputError("two patches have the same S; expected distinct S per patch")
    sd = np.full_like(d, np.nan) if spread is None else np.asarray(spread, float)[order]
    w = None if weights is None else np.asarray(weights, float)[order]
    knots_d = np.concatenate([[0.0], isotonic(np.maximum(d, 0.0), w)])
    return ToneCurve(np.concatenate([[0.0], s]), knots_d, d, sd, float(s_max), float(feed_mm_min),
                     float(line_interval_mm))


def load_tone(path) -> ToneCurve:
    """Read a tone curve written by :meth:`ToneCurve.save` (version 2, or 1), or a clear
    :class:`InputError`."""
    doc = read_document(path, what="tone curve", format=TONE_FORMAT, version=(1, TONE_VERSION),
                        maker="labkit raster-test measure-tone")
    s_key = "s_word" if doc["version"] == TONE_VERSION else "power_s"      # version 1's name
    try:
        s = np.asarray(doc[s_key], float)
        d = np.asarray(doc["darkness"], float)
        s_max = float(doc["s_max"])
        measured = np.asarray(doc.get("measured", d[1:]), float)
        spread = np.array([math.nan if x is None else x for x in doc.get("spread") or [None] * (len(d) - 1)], float)
        feed, interval = (math.nan if doc.get(k) is None else float(doc[k]) for k in ("feed_mm_min", "line_interval_mm"))
    except (KeyError, TypeError, ValueError) as exc:
        raise InputError(f"{path}: {s_key}, darkness and s_max must be numbers ({exc})") from None
    if s.ndim != 1 or d.shape != s.shape or len(s) < 2:
        raise InputError(f"{path}: {s_key} and darkness must be lists of the same length >= 2")
    if not (np.all(np.isfinite(s)) and np.all(np.isfinite(d)) and np.all(np.diff(s) > 0)
            and np.all(np.diff(d) >= 0) and s[0] >= 0):
        raise InputError(f"{path}: expected {s_key} increasing from >= 0 and darkness non-decreasing, "
                         "all finite")
    if not (math.isfinite(s_max) and s_max > 0):
        raise InputError(f"{path}: s_max must be > 0, got {s_max!r}")
    return ToneCurve(s, d, measured, spread, s_max, feed, interval)
