"""Power × speed test grids for cut-width characterisation ([CBR40] figure 10).

Each grid cell is one straight line burned at one (power, speed). The head runs
``overscan_mm`` before and after every line with the beam at S0 so that the
burned part is traced at the programmed speed, not while accelerating (where a
constant-power beam over-burns, [CBR40] §IV). Rows are powers, columns speeds;
the row and column numbers are engraved with a tiny stroke font so a scan can
be read by eye, and four corner crosses give measurement something to register
on. The crosses form a rectangle, which looks the same turned 180°; the numbers
(rows on the left, columns on top) do not, and tell measurement which way up
the piece lay on the scanner (:func:`labkit.laser.measure.register`). The layout (where every line is, its power and speed) is saved as JSON
next to the G-code (version 2)::

    {"version": 2, "units": "mm", "direction": "+X", "powers_mw": [...], "speeds_mm_min": [...],
     "pitch_mm": 2.0, "fiducial_mm": 2.0, "fiducials_mm": [[x, y], ...], "labels": [...], ...,
     "lines": [{"row": 0, "col": 0, "repeat": 0, "power_mw": 500.0, "s_word": 200.0,
                "speed_mm_min": 300.0, "x0_mm": 0.0, "x1_mm": 10.0, "y_mm": 0.0, "passes": 1}, ...]}

Version 1 named a line's S word ``power_s``; :func:`labkit.laser.measure.check_layout` reads both
and gives every reader the version 2 form.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from labkit.errors import InputError
from labkit.gcode.writer import emit
from labkit.motion.pipeline import plan
from labkit.toolpath.moves import Moves
from labkit.units import mw_to_s

__all__ = ["GridPattern", "grid_pattern", "steps", "stroke_digits", "write_pattern"]

#: The layout JSON's version (2: a line's S word is ``s_word``; 1 named it ``power_s``).
LAYOUT_VERSION = 2

# Digits as polylines on a 2 × 4 cell (x right, y up); one stroke list per digit.
_DIGITS = {
    "0": [[(0, 0), (2, 0), (2, 4), (0, 4), (0, 0)]],
    "1": [[(1, 0), (1, 4)]],
    "2": [[(0, 4), (2, 4), (2, 2), (0, 2), (0, 0), (2, 0)]],
    "3": [[(0, 4), (2, 4), (2, 0), (0, 0)], [(0, 2), (2, 2)]],
    "4": [[(0, 4), (0, 2), (2, 2)], [(2, 4), (2, 0)]],
    "5": [[(2, 4), (0, 4), (0, 2), (2, 2), (2, 0), (0, 0)]],
    "6": [[(2, 4), (0, 4), (0, 0), (2, 0), (2, 2), (0, 2)]],
    "7": [[(0, 4), (2, 4), (2, 0)]],
    "8": [[(0, 0), (2, 0), (2, 4), (0, 4), (0, 0)], [(0, 2), (2, 2)]],
    "9": [[(2, 2), (0, 2), (0, 4), (2, 4), (2, 0), (0, 0)]],
}


def steps(lo: float, hi: float, count: int, *, scale: str = "linear") -> np.ndarray:
    """``count`` values from ``lo`` to ``hi`` inclusive, evenly or geometrically spaced.

    Parameters
    ----------
    lo, hi : float
        First and last value (> 0 for ``"geometric"``), any unit.
    count : int
        Number of values (>= 1; one value gives ``[lo]``).
    scale : {"linear", "geometric"}
        Equal differences or equal ratios between neighbours.

    Examples
    --------
    >>> steps(500, 2500, 5).tolist()
    [500.0, 1000.0, 1500.0, 2000.0, 2500.0]
    >>> steps(100, 1600, 3, scale="geometric").tolist()
    [100.0, 400.0, 1600.0]
    """
    if int(count) != count or count < 1:
        raise InputError(f"count must be a whole number >= 1, got {count!r}")
    if not (np.isfinite(lo) and np.isfinite(hi)):
        raise InputError(f"range must be finite, got {lo!r}…{hi!r}")
    if scale == "linear":
        return np.linspace(lo, hi, int(count))
    if scale == "geometric":
        if not (lo > 0 and hi > 0):
            raise InputError(f"a geometric range needs values > 0, got {lo!r}…{hi!r}")
        return np.geomspace(lo, hi, int(count))
    raise InputError(f"scale must be 'linear' or 'geometric', got {scale!r}")


def stroke_digits(text: str, *, x_mm: float, y_mm: float, height_mm: float) -> list[np.ndarray]:
    """Polylines (mm) that write the digits of ``text`` with the built-in stroke font.

    Parameters
    ----------
    text : str
        Digits only.
    x_mm, y_mm : float
        Lower-left corner of the first character, mm.
    height_mm : float
        Character height, mm (width is half of it, advance three quarters).

    Returns
    -------
    list of ndarray, shape (k, 2)

    Examples
    --------
    >>> [p.tolist() for p in stroke_digits("1", x_mm=0, y_mm=0, height_mm=4)]
    [[[1.0, 0.0], [1.0, 4.0]]]
    """
    unit = height_mm / 4.0
    out = []
    for k, ch in enumerate(str(text)):
        if ch not in _DIGITS:
            raise InputError(f"the stroke font has digits only, got {ch!r} in {text!r}")
        for stroke in _DIGITS[ch]:
            pts = np.asarray(stroke, float) * unit
            out.append(pts + [x_mm + 3.0 * unit * k, y_mm])
    return out


@dataclass
class GridPattern:
    """A burned test grid: the program and where every line of it is.

    Attributes
    ----------
    moves : Moves
        The whole job (lines, overscans with beam off, labels, fiducials).
    layout : dict
        JSON-ready description: ``lines`` (one dict per burned line with
        ``row``, ``col``, ``repeat``, ``power_mw``, ``s_word``,
        ``speed_mm_min``, ``x0_mm``, ``x1_mm``, ``y_mm``), ``fiducials_mm``,
        ``bounds_mm`` and the generating parameters.
    """

    moves: Moves
    layout: dict

    def job_time_s(self, machine=None, *, planner: str = "junction") -> float:
        """Planned job time in s (:func:`labkit.motion.plan`), before burning anything."""
        return float(plan(self.moves, machine, planner=planner).summary().job_time_s)

    def legend(self) -> str:
        """What the engraved numbers mean: row number → power, column number → speed.

        Printed by ``labkit cutwidth pattern`` and written at the head of the
        G-code, so the piece can be read without the layout file.

        >>> g = grid_pattern([500, 1000], [300, 600], label_mm=0, fiducial_mm=0, repeats=2)
        >>> print(g.legend())
        rows (engraved left, bottom to top; 2 repeats each): 1 = 500 mW (S200), 2 = 1000 mW (S400)
        columns (engraved on top, left to right): 1 = 300 mm/min, 2 = 600 mm/min
        """
        lines = self.layout["lines"]
        reps = max(d["repeat"] for d in lines) + 1
        powers = {d["row"] // reps: (d["power_mw"], d["s_word"]) for d in lines}
        speeds = {d["col"]: d["speed_mm_min"] for d in lines}
        rows = ", ".join(f"{i + 1} = {p:g} mW (S{s:g})" for i, (p, s) in sorted(powers.items()))
        cols = ", ".join(f"{j + 1} = {v:g} mm/min" for j, v in sorted(speeds.items()))
        each = f"; {reps} repeats each" if reps > 1 else ""
        return (f"rows (engraved left, bottom to top{each}): {rows}\n"
                f"columns (engraved on top, left to right): {cols}")

    def gcode(self, dialect: str = "grbl", **options) -> str:
        """The job as G-code in ``dialect`` (:func:`labkit.gcode.writer.emit`), the legend in its header.

        Travel is written beam-off (``M5`` before each rapid) unless ``travel_beam_off=False``
        is passed: a test grid must not burn its travel on a controller without laser mode.
        """
        options.setdefault("travel_beam_off", True)
        return emit(self.moves, dialect=dialect, comment=f"labkit cut-width test grid\n{self.legend()}", **options)


def _positive(name, values):
    values = np.atleast_1d(np.asarray(values, float))
    if values.ndim != 1 or len(values) == 0 or not np.all(np.isfinite(values) & (values > 0)):
        raise InputError(f"{name} must be finite values > 0, got {values.tolist()!r}")
    return values


def grid_pattern(powers_mw, speeds_mm_min, *, line_mm: float = 10.0, gap_mm: float = 6.0,
                 pitch_mm: float = 2.0, overscan_mm: float = 3.0, repeats: int = 1,
                 passes: int = 1, label_mm: float = 2.0, label_power_mw: float | None = None,
                 label_speed_mm_min: float | None = None, fiducial_mm: float = 2.0,
                 max_power_mw: float | None = None, s_max: float = 1000.0) -> GridPattern:
    """A power × speed grid of straight lines, labelled, with overscan and corner fiducials.

    Rows are powers (one row per power and repeat, bottom to top), columns speeds
    (left to right); every line runs in +X.

    Parameters
    ----------
    powers_mw : array_like
        Optical powers, mW (> 0, at most ``max_power_mw``).
    speeds_mm_min : array_like
        Feeds, mm/min (> 0).
    line_mm : float
        Burned length of each line, mm.
    gap_mm : float
        Clear space between columns, mm (must hold both overscans).
    pitch_mm : float
        Distance between rows, mm.
    overscan_mm : float
        Beam-off run before and after each line, mm, so the burn is at constant speed.
    repeats : int
        Copies of each (power, speed) line, on adjacent rows.
    passes : int
        Times each line is traced.
    label_mm : float
        Height of the engraved row/column numbers, mm (0: no labels).
    label_power_mw, label_speed_mm_min : float, optional
        Settings for labels and fiducials; default the middle power and the fastest speed.
    fiducial_mm : float
        Arm length of the corner crosses, mm (0: none).
    max_power_mw, s_max : float
        Power at full S and the S range, for the mW → S conversion (:func:`labkit.units.mw_to_s`).
        ``max_power_mw`` None: the machine description's (``labkit.motion.CBR40``, [CBR40]).

    Returns
    -------
    GridPattern

    Examples
    --------
    >>> g = grid_pattern([500, 1000], [300, 600, 1200], label_mm=0, fiducial_mm=0)
    >>> len(g.layout["lines"]), g.layout["lines"][0]["s_word"]
    (6, 200.0)
    """
    powers = _positive("powers_mw", powers_mw)
    speeds = _positive("speeds_mm_min", speeds_mm_min)
    if max_power_mw is None:
        from labkit.motion.spec import CBR40

        max_power_mw = CBR40.laser_max_power_mw
    if np.any(powers > max_power_mw):
        raise InputError(f"powers_mw must be <= max_power_mw={max_power_mw:g}, got {powers.max():g}")
    for name, v, lo in (("line_mm", line_mm, 0), ("pitch_mm", pitch_mm, 0)):
        if not (np.isfinite(v) and v > lo):
            raise InputError(f"{name} must be > {lo}, got {v!r}")
    for name, v in (("overscan_mm", overscan_mm), ("gap_mm", gap_mm), ("label_mm", label_mm),
                    ("fiducial_mm", fiducial_mm)):
        if not (np.isfinite(v) and v >= 0):
            raise InputError(f"{name} must be >= 0, got {v!r}")
    for name, v in (("repeats", repeats), ("passes", passes)):
        if int(v) != v or v < 1:
            raise InputError(f"{name} must be a whole number >= 1, got {v!r}")
    if gap_mm < 2 * overscan_mm:
        # a column's overscan would run over the neighbouring line with the beam off: harmless,
        # but the approach would no longer be at constant speed over its whole length
        raise InputError(f"gap_mm ({gap_mm:g}) must hold both overscans (2 × {overscan_mm:g} mm)")
    label_p = float(np.median(powers)) if label_power_mw is None else float(label_power_mw)
    label_v = float(speeds.max()) if label_speed_mm_min is None else float(label_speed_mm_min)
    to_s = dict(s_max=s_max, max_power_mw=max_power_mw)

    starts, ends, feeds, s_word, lines = [], [], [], [], []

    def cut(a, b, feed, s):
        starts.append(a); ends.append(b); feeds.append(feed); s_word.append(s)

    col_x = np.arange(len(speeds)) * (line_mm + gap_mm)
    for i, p in enumerate(powers):
        s = float(mw_to_s(p, **to_s))
        for r in range(int(repeats)):
            row = i * int(repeats) + r
            y = row * pitch_mm
            for j, v in enumerate(speeds):
                x0, x1 = col_x[j], col_x[j] + line_mm
                for _ in range(int(passes)):
                    # overscan in, burn, overscan out: contiguous, so no rapid breaks the speed
                    if overscan_mm > 0:
                        cut((x0 - overscan_mm, y), (x0, y), v, 0.0)
                    cut((x0, y), (x1, y), v, s)
                    if overscan_mm > 0:
                        cut((x1, y), (x1 + overscan_mm, y), v, 0.0)
                lines.append(dict(row=row, col=j, repeat=r, power_mw=float(p), s_word=s,
                                  speed_mm_min=float(v), x0_mm=float(x0), x1_mm=float(x1),
                                  y_mm=float(y), passes=int(passes)))
    n_rows = len(powers) * int(repeats)
    x_lo, x_hi = -overscan_mm, col_x[-1] + line_mm + overscan_mm
    y_lo, y_hi = 0.0, (n_rows - 1) * pitch_mm
    s_label = float(mw_to_s(label_p, **to_s))
    labels = []
    if label_mm > 0:
        for i in range(len(powers)):          # row numbers left of the grid, 1-based
            text = str(i + 1)
            y = i * int(repeats) * pitch_mm - label_mm / 2
            x = x_lo - label_mm - 0.75 * label_mm * len(text)
            labels.append(dict(text=text, kind="row", x_mm=x, y_mm=y))
        for j in range(len(speeds)):          # column numbers above the grid
            labels.append(dict(text=str(j + 1), kind="col", x_mm=float(col_x[j]),
                               y_mm=y_hi + pitch_mm + label_mm / 2))
        for lab in labels:
            for poly in stroke_digits(lab["text"], x_mm=lab["x_mm"], y_mm=lab["y_mm"], height_mm=label_mm):
                for a, b in zip(poly[:-1], poly[1:]):
                    cut(tuple(a), tuple(b), label_v, s_label)
    margin = max(label_mm * 2.5, pitch_mm)
    fiducials = []
    if fiducial_mm > 0:
        for fx, fy in ((x_lo - margin - 0.75 * label_mm * 2, y_lo - margin),
                       (x_hi + margin, y_lo - margin),
                       (x_hi + margin, y_hi + margin + label_mm),
                       (x_lo - margin - 0.75 * label_mm * 2, y_hi + margin + label_mm)):
            fiducials.append([float(fx), float(fy)])
            h = fiducial_mm
            cut((fx - h, fy), (fx + h, fy), label_v, s_label)
            cut((fx, fy - h), (fx, fy + h), label_v, s_label)
    moves = Moves.from_cuts(np.asarray(starts, float), np.asarray(ends, float), feed_mm_min=np.asarray(feeds),
                            s_word=np.asarray(s_word), s_max=s_max)
    everything = np.vstack([np.asarray(starts), np.asarray(ends)])
    layout = dict(
        version=LAYOUT_VERSION, units="mm", direction="+X",
        powers_mw=powers.tolist(), speeds_mm_min=speeds.tolist(),
        line_mm=float(line_mm), gap_mm=float(gap_mm), pitch_mm=float(pitch_mm),
        overscan_mm=float(overscan_mm), repeats=int(repeats), passes=int(passes),
        max_power_mw=float(max_power_mw), s_max=float(s_max),
        label_mm=float(label_mm), labels=labels,
        label_power_mw=label_p, label_speed_mm_min=label_v,
        fiducial_mm=float(fiducial_mm), fiducials_mm=fiducials,
        bounds_mm=[float(everything[:, 0].min()), float(everything[:, 1].min()),
                   float(everything[:, 0].max()), float(everything[:, 1].max())],
        lines=lines,
    )
    return GridPattern(moves=moves, layout=layout)


def write_pattern(gcode_path, pattern: GridPattern, *, dialect: str = "grbl", **options) -> Path:
    """Write the G-code and the layout JSON beside it (same name, ``.json``).

    Both go to temporary files first (:func:`labkit._files.atomic_output`) and replace
    the old pair only when both are complete, the layout last: a full disk or Ctrl-C
    leaves the old pair (or nothing), never a program without its layout. An existing
    symbolic link at either name is replaced, not written through.

    Parameters
    ----------
    gcode_path : str or Path
        Where the G-code goes.
    pattern : GridPattern
    dialect : str
        G-code dialect (see :func:`labkit.gcode.writer.emit`).

    Returns
    -------
    Path
        The layout JSON's path.
    """
    gcode_path = Path(gcode_path)
    json_path = gcode_path.with_suffix(".json")
    if json_path == gcode_path:
        raise InputError(f"the G-code file must not end in .json: {gcode_path}")
    from labkit._files import atomic_output

    text = pattern.gcode(dialect, **options)
    layout = dict(pattern.layout, dialect=str(dialect), gcode=gcode_path.name)
    with atomic_output(json_path) as layout_file:
        json.dump(layout, layout_file, indent=1)
        layout_file.flush()         # a full disk shows here, before the G-code is replaced
        os.fsync(layout_file.fileno())
        with atomic_output(gcode_path, encoding="ascii") as gcode_file:
            gcode_file.write(text)
    return json_path
