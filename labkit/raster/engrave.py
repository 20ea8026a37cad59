"""Image → Moves: binary paths (zig-zag, spiral, edges) and gray engraving (power or dither).

The image's bottom-left corner is machine X0 Y0, one pixel is ``pixel_mm``
(normally the beam diameter, see :mod:`labkit.raster.resample`). Cuts are
G1 with the laser on; travel between segments is G0 (beam off). Gray
engraving adds G1 moves at S 0 — overscan lead-ins/outs and short white
gaps crossed at speed — which burn nothing.

The report carries the figures of [LaserApp]'s tables 4.3–4.8: segments before
and after pathing, tool lines, G-code lines, cut and travel distance and an
estimated time at constant speed (the seed's assumption: no acceleration).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace

import numpy as np

from labkit.budget import check_budget
from labkit.errors import RasterError
from labkit.raster import _scanlines
from labkit.raster._border import check_image_2d, check_mask
from labkit.raster.color import adjust_gamma, blank_mask, invert as _invert, threshold, to_gray
from labkit.raster.diffusion import DIFFUSION, dither as _dither
from labkit.raster.edges import detect_edges
from labkit.raster.filters import blur as _blur, sharpen as _sharpen
from labkit.raster.islands import label_islands
from labkit.raster.pathing import Connection, Segments, connect, spiral_segments, zigzag_segments
from labkit.raster.resample import beam_shape, resample_to_beam
from labkit.toolpath.moves import LaserMode, MoveKind, Moves
from labkit.units import s_within

__all__ = ["MODES", "RasterSettings", "placed_size", "DEFAULT_DPI", "RasterReport", "RasterJob", "segments_to_moves", "mask_job", "gray_job",
           "power_map", "image_to_job", "summarize", "raster_program", "dithered_moves_estimate"]

#: Modes of :func:`image_to_job` (and ``labkit img2gcode --mode``).
MODES = ("zigzag", "spiral", "edges", "gray", "dither")


@dataclass(frozen=True)
class RasterReport:
    """What a raster job will do ([LaserApp] tables 4.3–4.8 and more).

    Distances in mm, time in s, feeds in mm/min. ``segments_before`` is the
    seed's "segments pre-pathing" (scan lines holding marked pixels for
    zig-zag, islands for spiral); ``segments`` the segments after pathing;
    ``tool_lines`` the laser-on cuts. ``gcode_lines`` is filled in once the
    program is written (:meth:`with_gcode`).
    """

    mode: str
    shape: tuple[int, int]
    pixel_mm: float
    marked_pixels: int
    segments_before: int
    segments: int
    tool_lines: int
    moves: int
    rapids: int
    cut_mm: float
    travel_mm: float
    idle_feed_mm: float
    time_s: float
    feed_mm_min: float
    rapid_mm_min: float
    distance_evaluations: int = 0
    size_error_mm: tuple[float, float] = (0.0, 0.0)
    gcode_lines: int | None = None
    extra: dict = field(default_factory=dict)

    @property
    def size_mm(self) -> tuple[float, float]:
        """Engraved (width, height), mm."""
        return (self.shape[1] * self.pixel_mm, self.shape[0] * self.pixel_mm)

    def with_gcode(self, text: str) -> "RasterReport":
        """The report with ``gcode_lines`` counted from the program text."""
        return replace(self, gcode_lines=text.count("\n"))

    def rows(self) -> list[tuple[str, str]]:
        """(label, value) pairs, rounded for printing."""
        w, h = self.size_mm
        out = [
            ("mode", self.mode),
            ("image", f"{self.shape[1]} × {self.shape[0]} px at {self.pixel_mm:g} mm = {w:.2f} × {h:.2f} mm"),
            ("size error", f"{self.size_error_mm[0]:+.3f} × {self.size_error_mm[1]:+.3f} mm"),
            ("marked pixels", f"{self.marked_pixels}"),
            ("segments before / after pathing", f"{self.segments_before} / {self.segments}"),
            ("tool lines (laser on)", f"{self.tool_lines}"),
            ("moves / rapids", f"{self.moves} / {self.rapids}"),
            ("G-code lines", "-" if self.gcode_lines is None else f"{self.gcode_lines}"),
            ("cut distance", f"{self.cut_mm:.1f} mm"),
            ("travel distance (G0)", f"{self.travel_mm:.1f} mm"),
            ("laser-off feed (overscan, gaps)", f"{self.idle_feed_mm:.1f} mm"),
            ("estimated time", f"{_hms(self.time_s)} at F{self.feed_mm_min:g}, G0 at {self.rapid_mm_min:g} mm/min"),
        ]
        if self.distance_evaluations:
            out.append(("connection distance evaluations", f"{self.distance_evaluations}"))
        return out

    def format(self) -> str:
        """The report as aligned text lines."""
        rows = self.rows()
        width = max(len(k) for k, _ in rows)
        return "\n".join(f"{k:<{width}}  {v}" for k, v in rows)


def _hms(seconds: float) -> str:
    s = int(round(seconds))
    return f"{s // 3600}:{s // 60 % 60:02d}:{s % 60:02d}"


@dataclass(frozen=True)
class RasterJob:
    """A raster job: the moves, the report, and what the moves should burn.

    Attributes
    ----------
    moves : Moves
    report : RasterReport
    target : ndarray
        The mask the moves must burn (binary modes and dither), or the S value
        each pixel must get (gray mode, 0 = not burned).
    segments : Segments or None
        The ordered segments (binary modes).
    connection : Connection or None
    """

    moves: Moves
    report: RasterReport
    target: np.ndarray
    segments: Segments | None = None
    connection: Connection | None = None


def summarize(moves: Moves, *, feed_mm_min: float, rapid_mm_min: float | None = None):
    """The :class:`~labkit.gcode.simulate.JobSummary` of a raster job (lengths mm, times s).

    [LaserApp] §4.1 estimates time as distance / speed with no acceleration;
    travel (G0) runs at ``rapid_mm_min`` (default: the engraving feed ``feed_mm_min``, as
    that estimate assumes one speed for everything); feed moves run at their own feed.

    Examples
    --------
    >>> m = Moves.from_cuts([[0, 0], [5, 0]], [[3, 0], [9, 0]], feed_mm_min=600, s_word=800)
    >>> s = summarize(m, feed_mm_min=600)
    >>> s.cut_length_mm, s.travel_length_mm, s.estimated_time_s, s.cut_moves, s.counts["rapid"]
    (7.0, 2.0, 0.9, 2, 1)
    """
    from labkit.gcode.simulate import summarize as summarize_job

    rapid = feed_mm_min if rapid_mm_min is None else rapid_mm_min
    if not (feed_mm_min > 0 and rapid > 0):
        raise RasterError(f"feed_mm_min and rapid_mm_min must be > 0, got {feed_mm_min!r}, {rapid_mm_min!r}")
    return summarize_job(moves, rapid_mm_min=rapid)


def _check_positive(name, value):
    if not (value > 0 and math.isfinite(value)):
        raise RasterError(f"{name} must be a finite number > 0, got {value!r}")


def segments_to_moves(segments: Segments, *, pixel_mm: float, feed_mm_min: float, s_word: float,
                      laser=LaserMode.CONSTANT, s_max: float = 1000.0) -> Moves:
    """Cuts along the segments in their order, joined by rapids (image corner at X0 Y0).

    Examples
    --------
    >>> s = zigzag_segments(np.array([[True, True, False, True]]), axis="rows")
    >>> m = segments_to_moves(s, pixel_mm=0.5, feed_mm_min=900, s_word=1000)
    >>> [MoveKind(k).name for k in m.kind], m.end[:, 0].tolist()
    (['RAPID', 'LINE', 'RAPID', 'LINE'], [0.0, 1.0, 1.5, 2.0])
    """
    _check_positive("pixel_mm", pixel_mm)
    _check_positive("feed_mm_min", feed_mm_min)
    if not s_within(s_word, s_max, positive=True):
        raise RasterError(f"s_word must be in (0, {s_max:g}], got {s_word!r}")
    a, b = segments.cuts()
    scale = 0.5 * float(pixel_mm)
    return Moves.from_cuts(a * scale, b * scale, feed_mm_min=feed_mm_min, s_word=s_word,
                           laser=laser, s_max=s_max)


def _report(mode, moves, *, shape, pixel_mm, marked, before, segments, feed_mm_min, rapid_mm_min,
            evaluations=0, size_error_mm=(0.0, 0.0), **extra) -> RasterReport:
    s = summarize(moves, feed_mm_min=feed_mm_min, rapid_mm_min=rapid_mm_min)
    return RasterReport(
        mode=mode, shape=(int(shape[0]), int(shape[1])), pixel_mm=float(pixel_mm),
        marked_pixels=int(marked), segments_before=int(before), segments=int(segments),
        tool_lines=s.cut_moves, moves=len(moves), rapids=s.counts["rapid"],
        cut_mm=round(s.cut_length_mm, 6), idle_feed_mm=round(s.idle_feed_length_mm, 6),
        travel_mm=round(s.travel_length_mm - s.idle_feed_length_mm, 6),
        time_s=round(s.estimated_time_s, 6),
        feed_mm_min=float(feed_mm_min), rapid_mm_min=float(rapid_mm_min or feed_mm_min),
        distance_evaluations=int(evaluations), size_error_mm=tuple(float(e) for e in size_error_mm),
        extra=extra)


def mask_job(mask, *, pixel_mm: float, mode: str = "zigzag", feed_mm_min: float = 1000.0,
             s_word: float = 1000.0, order: str = "indexed", axis: str = "auto",
             direction: str = "bidirectional", ends: str = "edge", laser=LaserMode.CONSTANT,
             s_max: float = 1000.0, rapid_mm_min: float | None = None,
             size_error_mm=(0.0, 0.0), report_mode: str | None = None) -> RasterJob:
    """Path a one-bit image by zig-zag or spiral and turn it into Moves.

    Parameters
    ----------
    mask : ndarray of bool, 2-D
        True = burn.
    pixel_mm : float
        Pixel size (beam diameter), mm.
    mode : {"zigzag", "spiral"}
        The path generator (:func:`~labkit.raster.pathing.zigzag_segments`,
        :func:`~labkit.raster.pathing.spiral_segments`).
    feed_mm_min : float
        Cutting feed, mm/min.
    s_word : float
        Laser power word S for the cuts (0 < S ≤ ``s_max``).
    order : {"indexed", "reference", "scan"}
        Segment connection (:func:`~labkit.raster.pathing.connect`).
    axis, direction : str
        Zig-zag scan lines and direction (see ``zigzag_segments``).
    ends : {"edge", "centre"}
        Path ends at pixel edges or centres.
    laser : LaserMode
        M3 (constant) or M4 (dynamic).
    s_max : float
        S meaning full power.
    rapid_mm_min : float, optional
        Travel speed for the time estimate (default = feed, the seed's assumption).
    size_error_mm : (float, float)
        Resampling size error to carry into the report.
    report_mode : str, optional
        Name of the mode in the report (default ``mode``).

    Returns
    -------
    RasterJob

    Examples
    --------
    >>> m = np.zeros((4, 6), bool); m[1:3, 1:5] = True
    >>> job = mask_job(m, pixel_mm=0.1, mode="zigzag")
    >>> r = job.report
    >>> r.segments_before, r.segments, r.tool_lines, round(r.cut_mm, 3)
    (2, 2, 2, 0.8)
    """
    m = check_mask(mask)
    if mode == "zigzag":
        segs = zigzag_segments(m, axis=axis, direction=direction, ends=ends)
        lines_axis = axis if axis != "auto" else ("rows" if m.shape[0] < m.shape[1] else "columns")
        before = int(m.any(axis=1 if lines_axis == "rows" else 0).sum())
    elif mode == "spiral":
        segs = spiral_segments(m, ends=ends)
        before = label_islands(m)[1]
    else:
        raise RasterError(f"mode must be 'zigzag' or 'spiral' for a mask, got {mode!r}")
    conn = connect(segs, method=order)
    ordered = segs.reordered(conn)
    moves = segments_to_moves(ordered, pixel_mm=pixel_mm, feed_mm_min=feed_mm_min, s_word=s_word,
                              laser=laser, s_max=s_max)
    report = _report(report_mode or mode, moves, shape=m.shape, pixel_mm=pixel_mm, marked=m.sum(),
                     before=before, segments=len(segs), feed_mm_min=feed_mm_min,
                     rapid_mm_min=rapid_mm_min, evaluations=conn.examined, size_error_mm=size_error_mm)
    return RasterJob(moves, report, m, ordered, conn)


def power_map(gray, *, s_max: float = 1000.0, min_power: float = 0.0, max_power: float = 1.0,
              white_level: float = 255.0) -> np.ndarray:
    """Power S per pixel, proportional to darkness.

    S = round(s_max · (min_power + (1 − g/255) · (max_power − min_power))) for
    pixels darker than ``white_level``; 0 (not burned) for the others.

    Parameters
    ----------
    gray : array_like, 2-D
        labkit gray (0…255).
    s_max : float
        S for full power (GRBL ``$30``).
    min_power, max_power : float
        Fractions 0…1 of full power for the lightest and the darkest pixel
        (a laser needs a minimum power to mark at all).
    white_level : float
        Pixels at or above it are white: skipped.

    Examples
    --------
    >>> power_map(np.array([[0.0, 127.5, 254.0, 255.0]]), min_power=0.2, max_power=0.8).tolist()
    [[800, 500, 202, 0]]
    """
    arr = np.asarray(check_image_2d(gray, "gray"), dtype=np.float64)
    if not 0 <= min_power <= max_power <= 1:
        raise RasterError(f"need 0 <= min_power <= max_power <= 1, got {min_power!r}, {max_power!r}")
    _check_positive("s_max", s_max)
    # s_max · (min_power + (1 − g/255) · (max_power − min_power)), one operation at a time in
    # one array (the same roundings; a photo's temporaries were 4 × 8 B a pixel).
    s = np.clip(arr, 0, 255)
    s /= 255.0
    np.subtract(1.0, s, out=s)
    s *= max_power - min_power
    s += min_power
    s *= s_max
    out = np.rint(s, out=s).astype(np.int64)
    out[arr >= white_level] = 0
    return out


def gray_job(gray, *, pixel_mm: float, feed_mm_min: float = 3000.0, s_max: float = 1000.0,
             min_power: float = 0.0, max_power: float = 1.0, white_level: float = 255.0,
             dither: str | None = None, serpentine: bool = False, overscan_mm: float = 2.0,
             skip_white_mm: float = 5.0, bidirectional: bool = True, laser=LaserMode.DYNAMIC,
             rapid_mm_min: float | None = None, size_error_mm=(0.0, 0.0), blank=None) -> RasterJob:
    """Line-by-line gray engraving: power follows darkness, or dithered dots at full power.

    Parameters
    ----------
    gray : array_like, 2-D
        labkit gray (0…255), one pixel per beam diameter.
    pixel_mm : float
        Pixel size = line spacing, mm.
    feed_mm_min : float
        Scanning feed, mm/min.
    s_max, min_power, max_power, white_level
        Power mapping (:func:`power_map`). With ``dither`` every dot gets
        ``max_power``.
    dither : str, optional
        Error diffusion method (:data:`~labkit.raster.diffusion.DIFFUSION`);
        None for proportional power.
    serpentine : bool
        Serpentine scan for the dithering.
    overscan_mm : float
        How far the head runs on past each burn span, laser off, so that it
        burns only at full speed (≥ 0).
    skip_white_mm : float
        White gaps longer than this (and longer than two overscans) are
        crossed by a rapid; shorter ones at the feed with S 0.
    bidirectional : bool
        Alternate the scan direction line by line.
    laser : LaserMode
        M4 (dynamic, default: power scales with the actual speed) or M3.
    blank : ndarray of bool, optional
        Pixels with nothing here (:func:`~labkit.raster.color.blank_mask`): never
        burned; the dithering sees them as white.

    Returns
    -------
    RasterJob
        ``target`` is the S map the moves must burn.

    Examples
    --------
    >>> g = np.array([[255.0, 0.0, 127.5, 255.0, 255.0, 0.0]])
    >>> job = gray_job(g, pixel_mm=1.0, overscan_mm=1.0, skip_white_mm=1.0)
    >>> [(float(a), float(b), float(s)) for a, b, s in
    ...  zip(job.moves.start[:, 0], job.moves.end[:, 0], job.moves.s_word)]   # doctest: +NORMALIZE_WHITESPACE
    [(0.0, 0.0, 0.0), (0.0, 1.0, 0.0), (1.0, 2.0, 1000.0), (2.0, 3.0, 500.0), (3.0, 4.0, 0.0),
     (4.0, 5.0, 0.0), (5.0, 6.0, 1000.0), (6.0, 7.0, 0.0)]
    """
    arr = check_image_2d(gray, "gray")
    _check_positive("pixel_mm", pixel_mm)
    _check_positive("feed_mm_min", feed_mm_min)
    if not (overscan_mm >= 0 and skip_white_mm >= 0):
        raise RasterError(f"overscan_mm and skip_white_mm must be >= 0, got {overscan_mm!r}, {skip_white_mm!r}")
    if blank is not None:
        blank = np.asarray(blank)
        if blank.dtype != bool or blank.shape != arr.shape:
            raise RasterError(f"blank must be a boolean array (True = nothing here) of the gray image's "
                              f"shape {arr.shape}, got {blank.dtype} {blank.shape}")
    if dither is not None:
        if dither not in DIFFUSION:
            raise RasterError(f"dither must be one of {sorted(DIFFUSION)} or None, got {dither!r}")
        source = arr if blank is None else np.where(blank, 255.0, arr)
        from labkit._jit import expecting
        from labkit.gcode.writer import emit_work

        # the moves these dots make are written later: declared now, the diffusion decides
        # Python or compiled for the whole job (a photo's dots make about a move a pixel)
        with expecting(emit_work(dithered_moves_estimate(source))):
            dots = _dither(source, dither, serpentine=serpentine)
        del source
        power = np.where(dots, int(round(s_max * max_power)), 0).astype(np.int64)
        if not 0 < max_power <= 1:
            raise RasterError(f"max_power must be in (0, 1] for dithering, got {max_power!r}")
    else:
        power = power_map(arr, s_max=s_max, min_power=min_power, max_power=max_power,
                          white_level=white_level)
    if blank is not None:
        power[blank] = 0
    overscan_px = overscan_mm / pixel_mm
    skip_px = max(skip_white_mm, 2.0 * overscan_mm) / pixel_mm
    moves = _scan_moves(power, bool(bidirectional), float(skip_px), float(overscan_px), float(pixel_mm),
                        feed_mm_min=feed_mm_min, laser=laser, s_max=s_max)
    burn_lines = int((power > 0).any(axis=1).sum())
    report = _report("dither" if dither else "gray", moves, shape=arr.shape, pixel_mm=pixel_mm,
                     marked=(power > 0).sum(), before=burn_lines, segments=burn_lines,
                     feed_mm_min=feed_mm_min, rapid_mm_min=rapid_mm_min, size_error_mm=size_error_mm,
                     overscan_mm=overscan_mm)
    return RasterJob(moves, report, power)


def dithered_moves_estimate(gray) -> int:
    """About how many moves :func:`gray_job` makes of ``gray`` dithered, before dithering.

    Error diffusion spreads dots as evenly as their density allows, so a pixel of darkness
    d (0 white … 1 black) starts or ends a dot about 2 min(d, 1 - d) times on average; the
    edges of dark shapes (the only changes in a black-and-white image) add their lead-ins,
    lead-outs and rapids, about two moves each. The moves made are 0.6-1.2 times this on
    the images of ``data/images`` and the benchmark ladder's masks and photographs (32² to
    4096² px): close enough for :func:`labkit._jit.expecting` to choose Python or compiled
    for the job.

    >>> dithered_moves_estimate(np.full((10, 10), 127.5))     # a checkerboard: a move a pixel
    100
    """
    g = np.asarray(gray, dtype=np.float64)
    if g.ndim != 2 or not g.size:
        return 0
    spread = 0.0
    edges = 0
    step = max(1, BAND_PIXELS // g.shape[1])             # a band of rows at a time: a few MB
    for r in range(0, g.shape[0], step):
        band = g[r:r + step]
        d = np.clip(1.0 - band / 255.0, 0.0, 1.0)
        spread += float((2.0 * np.minimum(d, 1.0 - d)).sum())
        dark = band < 128
        edges += int(np.count_nonzero(dark[:, 1:] != dark[:, :-1]))
    return int(round(spread)) + 2 * edges


def _scan_moves(power, bidirectional, skip_px, overscan_px, pixel_mm, *, feed_mm_min, laser, s_max) -> Moves:
    """The scan lines as Moves, the rows written in place by the kernel: what
    ``Moves.from_cuts`` makes of the same cuts, without the cuts held in between (a
    photo has about one cut per pixel)."""
    args = (power, bidirectional, skip_px, overscan_px, pixel_mm)
    n = _scanlines.scan_moves(*args, False, *_move_columns(0))
    # A photo makes about one move per pixel: the count is known before any row is made.
    cause = f"a {power.shape[1]:,} × {power.shape[0]:,} px gray job of {n:,} moves"
    check_budget("moves", n, cause=cause, option="the size (width, height, dpi) or raise the beam diameter")
    check_budget("raster_bytes", n * BYTES_PER_GRAY_MOVE, cause=cause,
                 option="the size (width, height, dpi) or raise the beam diameter")
    kind, start, end, s_word = _move_columns(n)
    _scanlines.scan_moves(*args, True, kind, start, end, s_word)
    # Columns that are one value for every row are read-only views of that value (no memory
    # a row): a photo's 2.26 M moves hold 33 B less each (what Moves.copy() copies is writable).
    return Moves(kind=kind, start=start, end=end, feed_mm_min=_same(float(feed_mm_min), n),
                 s_word=s_word, laser=_same(np.int8(int(laser)), n),
                 centre=_same(np.full(3, np.nan), n), plane=_same(np.int8(17), n), s_max=s_max)


def _same(value, n):
    """``value`` for each of n rows as a read-only view (no memory per row)."""
    value = np.asarray(value)
    return np.broadcast_to(value, (n,) + value.shape)


def _move_columns(n):
    """kind, start, end and S columns for n rows. Every row starts where the row before it
    ended (a rapid joins cuts that do not meet; the first starts at the origin), so start and
    end are two views of one array of n + 1 points: 24 B a move less. Moves.copy() parts them."""
    points = np.zeros((n + 1, 3))
    return np.zeros(n, np.int8), points[:-1], points[1:], np.zeros(n, np.float32)


#: Pixels per band when an image is thresholded band by band (8 MB of float64 gray).
BAND_PIXELS = 1 << 20


#: Working memory of :func:`image_to_job`, bytes per pixel, measured (peak RSS of
#: ``labkit img2gcode`` at 2048² and 4096², the slope, rounded up): per source pixel when
#: the whole image is resampled (float64 gray and scikit-image's copies) and per beam
#: pixel for each mode; zig-zag and spiral at one pixel per beam hold only the mask.
BYTES_PER_SOURCE_PIXEL = 48
BYTES_PER_BEAM_PIXEL = {"zigzag": 4, "spiral": 8, "edges": 32, "gray": 40, "dither": 32}
BYTES_PER_BEAM_PIXEL_BANDED = 2
#: Peak memory per move of a gray or dithered job from its Moves to its G-code text and
#: preview (``labkit img2gcode --mode gray`` on a 500 × 450 photo, 2.26 M moves: 102.5 B
#: above the same command on a tiny image, rounded up; 239-243 B before a move's start, end
#: and constant columns shared memory), checked once the moves are counted.
BYTES_PER_GRAY_MOVE = 120


def working_bytes(source_shape, beam_shape, mode: str, *, banded: bool = False) -> float:
    """Estimated peak working memory of :func:`image_to_job`, bytes (see the constants).

    >>> f"{working_bytes((10_837, 10_837), (10_837, 10_837), 'zigzag', banded=True) / 1e9:.2f} GB"
    '0.23 GB'
    >>> f"{working_bytes((10_837, 10_837), (10_837, 10_837), 'gray') / 1e9:.1f} GB"
    '10.3 GB'
    """
    source = float(source_shape[0]) * float(source_shape[1])
    beam = float(beam_shape[0]) * float(beam_shape[1])
    if banded:
        return BYTES_PER_BEAM_PIXEL_BANDED * beam
    return BYTES_PER_SOURCE_PIXEL * source + BYTES_PER_BEAM_PIXEL.get(mode, 40) * beam


def _mask_in_bands(image: np.ndarray, weights, invert: bool, level: float) -> np.ndarray:
    """``threshold(to_gray(image))`` (inverted first if asked) without the blank pixels,
    computed in bands of rows."""
    if image.ndim == 2 and image.dtype == np.uint8:
        # 8-bit gray is labkit gray as it is (to_gray's scale is 255 / 255) and has no alpha
        return (np.subtract(255, image, dtype=np.uint8) if invert else image) < level
    rows, cols = image.shape[:2]
    mask = np.empty((rows, cols), bool)
    step = max(1, BAND_PIXELS // max(cols, 1))
    for r0 in range(0, rows, step):
        band = image[r0:r0 + step]
        gray = to_gray(band, weights)
        mask[r0:r0 + step] = _not_blank(threshold(_invert(gray) if invert else gray, level), blank_mask(band))
    return mask


@dataclass(frozen=True)
class RasterSettings:
    """Every choice of a raster engraving, in one record ([LaserApp] §3.4.1).

    ``image_to_job(image, settings)`` takes it whole; ``image_to_job(image,
    mode="gray", beam_mm=0.2)`` builds one from the defaults. A field left
    None takes the mode's default: the binary modes (zigzag, spiral, edges)
    cut at 1000 mm/min with M3, the gray modes scan at 3000 mm/min with M4.

    Attributes
    ----------
    mode : {"zigzag", "spiral", "edges", "gray", "dither"}
        Binary modes threshold at ``level`` and path the marked pixels; ``edges``
        paths the edge pixels (:func:`~labkit.raster.edges.detect_edges`);
        ``gray`` maps darkness to power; ``dither`` diffuses it to full-power dots.
    beam_mm : float
        Beam diameter = output pixel size, mm.
    width_mm, height_mm, pixel_mm, dpi : float, optional
        The engraved size: exactly one, or none to keep one input pixel per beam
        (:func:`~labkit.raster.resample.resample_to_beam`).
    pixel_aspect : float, optional
        Height / width of one image pixel (non-square pixels are engraved at the true
        aspect ratio); None: the image's own (a :class:`~labkit.raster.io.RasterImage`)
        or 1.
    resample : {"bicubic", "nearest"}
    weights : str
        Gray weights (:data:`~labkit.raster.color.GRAY_WEIGHTS`).
    level : float
        Threshold of the binary modes, 0…256 (darker than it burns).
    invert, blur, sharpen : bool
        [LaserApp]'s filters, applied before resampling.
    gamma : float
        Gamma of the gray modes (> 0).
    tone : ToneCurve, optional
        Gray mode: the material's measured darkness against S (:mod:`labkit.laser.tone`); the
        grays are corrected so the burned tones follow the image.
    edge_operator, edge_threshold, edge_pseudo, edge_path
        Edge detector and how its pixels are pathed (``"spiral"`` or ``"zigzag"``).
    feed_mm_min : float, optional
        Cutting (binary) or scanning (gray) feed, mm/min.
    laser : LaserMode, optional
        M3 or M4.
    s_max : float
        S meaning full power.
    rapid_mm_min : float, optional
        Travel speed for the time estimate.
    s_word, order, axis, direction, ends
        Binary modes: S of the cuts and how runs are connected and scanned
        (:func:`mask_job`).
    min_power, max_power, white_level, dither, serpentine, overscan_mm, skip_white_mm, bidirectional
        Gray modes: the power map and the scan (:func:`gray_job`); ``dither``
        None in mode ``"dither"`` means Floyd–Steinberg.
    """

    mode: str = "zigzag"
    beam_mm: float = 0.1
    width_mm: float | None = None
    height_mm: float | None = None
    pixel_mm: float | None = None
    dpi: float | None = None
    pixel_aspect: float | None = None
    resample: str = "bicubic"
    weights: str = "seed"
    level: float = 128
    invert: bool = False
    blur: bool = False
    sharpen: bool = False
    gamma: float = 1.0
    tone: object | None = None
    edge_operator: str = "sobel"
    edge_threshold: float | None = None
    edge_pseudo: bool = False
    edge_path: str = "spiral"
    feed_mm_min: float | None = None
    laser: LaserMode | None = None
    s_max: float = 1000.0
    rapid_mm_min: float | None = None
    s_word: float = 1000.0
    order: str = "indexed"
    axis: str = "auto"
    direction: str = "bidirectional"
    ends: str = "edge"
    min_power: float = 0.0
    max_power: float = 1.0
    white_level: float = 255.0
    dither: str | None = None
    serpentine: bool = False
    overscan_mm: float = 2.0
    skip_white_mm: float = 5.0
    bidirectional: bool = True

    def __post_init__(self):
        if self.mode not in MODES:
            raise RasterError(f"mode must be one of {MODES}, got {self.mode!r}")
        if not (isinstance(self.beam_mm, (int, float)) and self.beam_mm > 0 and math.isfinite(self.beam_mm)):
            raise RasterError(f"beam_mm must be a finite number > 0 mm, got {self.beam_mm!r}")
        if not self.gamma > 0:
            raise RasterError(f"gamma must be > 0, got {self.gamma!r}")
        if self.edge_path not in ("spiral", "zigzag"):
            raise RasterError(f"edge_path must be 'spiral' or 'zigzag', got {self.edge_path!r}")
        if self.pixel_aspect is not None and not (self.pixel_aspect > 0 and math.isfinite(self.pixel_aspect)):
            raise RasterError(f"pixel_aspect must be a finite number > 0, got {self.pixel_aspect!r}")

    @property
    def gray_mode(self) -> bool:
        return self.mode in ("gray", "dither")

    def size(self, pixel_aspect: float = 1.0) -> dict:
        """The size fields given and the pixel aspect (this record's, else ``pixel_aspect``),
        for :func:`~labkit.raster.resample.resample_to_beam`."""
        aspect = self.pixel_aspect if self.pixel_aspect is not None else pixel_aspect
        return dict(width_mm=self.width_mm, height_mm=self.height_mm, pixel_mm=self.pixel_mm, dpi=self.dpi,
                    pixel_aspect=aspect)

    def burn_options(self) -> dict:
        """Keywords of :func:`mask_job` or :func:`gray_job` for this mode (the mode's defaults
        where a field is None)."""
        common = dict(s_max=self.s_max, rapid_mm_min=self.rapid_mm_min)
        if self.feed_mm_min is not None:
            common["feed_mm_min"] = self.feed_mm_min
        if self.laser is not None:
            common["laser"] = self.laser
        if self.gray_mode:
            dither = self.dither or ("floyd-steinberg" if self.mode == "dither" else None)
            return dict(common, min_power=self.min_power, max_power=self.max_power,
                        white_level=self.white_level, dither=dither, serpentine=self.serpentine,
                        overscan_mm=self.overscan_mm, skip_white_mm=self.skip_white_mm,
                        bidirectional=self.bidirectional)
        return dict(common, s_word=self.s_word, order=self.order, axis=self.axis,
                    direction=self.direction, ends=self.ends)


_SETTING_NAMES = tuple(f.name for f in fields(RasterSettings))


#: Resolution assumed for an image file that states none (the CSS pixel: browsers and most tools).
DEFAULT_DPI = 96.0


def placed_size(shape, *, width_mm=None, height_mm=None, dpi=None, file_dpi=None, pixel_aspect=1.0):
    """How large an image will be engraved, and where that size came from.

    Parameters
    ----------
    shape : (rows, cols, ...)
        The image's shape in pixels.
    width_mm, height_mm : float, optional
        The size asked for (the other side follows the aspect ratio).
    dpi : float, optional
        The resolution asked for; else the file's ``file_dpi``; else
        :data:`DEFAULT_DPI`.
    file_dpi : float, optional
        The resolution stated in the file.
    pixel_aspect : float
        Height / width of one pixel (:attr:`~labkit.raster.io.RasterImage.pixel_aspect`):
        the dpi is the horizontal resolution and the height follows the true aspect.

    Returns
    -------
    width_mm, height_mm : float
    size : dict
        The one size keyword for :class:`RasterSettings` (``width_mm``,
        ``height_mm`` or ``dpi``).
    source : str
        Where the size came from, for the user (a file without a resolution
        is said so: a 72-dpi photo becomes a metre-wide job without warning
        otherwise).

    Examples
    --------
    >>> placed_size((300, 600), file_dpi=None)[::3]
    (158.75, 'no resolution in the file: 96 dpi assumed (96 dpi)')
    >>> placed_size((300, 600), width_mm=100)[:2]
    (100, 50.0)
    >>> placed_size((300, 600), file_dpi=200, pixel_aspect=2.0)[::3]
    (76.2, "the file's resolution (200 dpi across, 100 dpi down)")
    """
    rows, cols = int(shape[0]), int(shape[1])
    if not (pixel_aspect > 0 and math.isfinite(pixel_aspect)):
        raise RasterError(f"pixel_aspect must be a finite number > 0, got {pixel_aspect!r}")
    if width_mm is not None:
        w, size, source = width_mm, dict(width_mm=width_mm), "--width"
    elif height_mm is not None:
        w, size, source = height_mm * cols / rows / pixel_aspect, dict(height_mm=height_mm), "--height"
    else:
        res = dpi or file_dpi or DEFAULT_DPI
        w, size = cols * 25.4 / res, dict(dpi=res)
        density = (f"{res:g} dpi" if pixel_aspect == 1 else      # PNG stores whole dots per metre
                   f"{res:.5g} dpi across, {res / pixel_aspect:.5g} dpi down")
        source = ("--dpi" if dpi else "the file's resolution" if file_dpi
                  else f"no resolution in the file: {DEFAULT_DPI:g} dpi assumed") + f" ({density})"
    return w, w * rows / cols * pixel_aspect, size, source


def image_to_job(image, settings: RasterSettings | None = None, **changes) -> RasterJob:
    """The whole chain of [LaserApp] §3.4.1 from an image array to Moves.

    gray → (invert, sharpen, blur, gamma) → resample to the beam → then by mode:
    ``zigzag``/``spiral`` threshold at ``level`` and path; ``edges`` runs an
    edge detector and paths the edge pixels (``edge_path``); ``gray`` maps
    darkness to power; ``dither`` diffuses to full-power dots. In every mode the
    image's blank pixels (fully transparent, :func:`~labkit.raster.color.blank_mask`)
    are never burned, whatever the colour under them and whatever the filters.

    Parameters
    ----------
    image : array_like or RasterImage
        Any image :func:`~labkit.raster.color.to_gray` takes (a bool mask
        is used as is, True = burn), or a file read by
        :func:`~labkit.raster.io.read_image` (its pixel aspect is used).
    settings : RasterSettings, optional
        Every choice of the job (default: :class:`RasterSettings`'s defaults).
    **changes
        Fields of :class:`RasterSettings` to change, e.g. ``mode="gray",
        beam_mm=0.2, width_mm=50``.

    Returns
    -------
    RasterJob

    Raises
    ------
    RasterError
        A name that is not a field of :class:`RasterSettings` (the fields are
        listed), or a field out of range.

    Examples
    --------
    >>> mask = np.zeros((4, 6), bool); mask[1:3, 1:5] = True
    >>> job = image_to_job(mask, beam_mm=0.5, pixel_mm=0.5)
    >>> job.report.mode, len(job.moves) > 0
    ('zigzag', True)
    >>> image_to_job(mask, beam_mm=0.5, pixel_mm=0.5, speed=3)
    Traceback (most recent call last):
    ...
    labkit.errors.RasterError: image_to_job: unknown setting(s) speed; expected fields of RasterSettings: mode, beam_mm, ...
    """
    from labkit.raster.io import RasterImage

    unknown = sorted(set(changes) - set(_SETTING_NAMES))
    if unknown:
        raise RasterError(f"image_to_job: unknown setting(s) {', '.join(unknown)}; "
                          f"expected fields of RasterSettings: {', '.join(_SETTING_NAMES)}")
    cfg = replace(settings or RasterSettings(), **changes)
    if isinstance(image, RasterImage):
        size = cfg.size(image.pixel_aspect)
        image = image.pixels
    else:
        size = cfg.size()
    arr = np.asarray(image)
    is_mask = arr.dtype == bool and arr.ndim == 2
    if is_mask and (cfg.mode in ("gray", "dither", "edges") or cfg.blur or cfg.sharpen):
        arr = np.where(arr, 0, 255).astype(np.uint8)     # a mask means True = burn = black
        is_mask = False
    if arr.ndim in (2, 3) and arr.size:
        out_shape = beam_shape(arr.shape, cfg.beam_mm, **size)
        banded = (cfg.mode in ("zigzag", "spiral") and not (cfg.blur or cfg.sharpen) and arr.dtype.kind == "u"
                  and out_shape == arr.shape[:2])
        need = working_bytes(arr.shape[:2], out_shape, cfg.mode, banded=banded or is_mask)
        check_budget("raster_bytes", need,
                     cause=f"a {arr.shape[1]:,} × {arr.shape[0]:,} px image engraved as "
                           f"{out_shape[1]:,} × {out_shape[0]:,} beam pixels ({cfg.mode})",
                     option="the size (width, height, dpi) or raise the beam diameter")
    else:
        banded = False
    blank = None
    if is_mask:
        arr = ~arr if cfg.invert else arr
    elif banded:
        # One pixel per beam already and every step is per pixel: threshold band by band,
        # so the whole image is never held as float64 gray (8 bytes a pixel), only the mask.
        arr, is_mask = _mask_in_bands(arr, cfg.weights, cfg.invert, cfg.level), True
    else:
        blank = blank_mask(arr)
        arr = to_gray(arr, cfg.weights)
        if cfg.invert:
            arr = _invert(arr)
        if cfg.sharpen:
            arr = _sharpen(arr)
        if cfg.blur:
            arr = _blur(arr)
    res = resample_to_beam(arr, beam_mm=cfg.beam_mm, **size, method=cfg.resample, level=cfg.level)
    img = res.image
    if blank is not None:
        # Blank where most of the beam pixel is blank (the same resampling as the image).
        blank = resample_to_beam(blank, beam_mm=cfg.beam_mm, **size, method=cfg.resample, level=128).image
    common = dict(pixel_mm=cfg.beam_mm, size_error_mm=res.error_mm)
    if cfg.gray_mode:
        if cfg.gamma != 1.0:
            img = adjust_gamma(img, cfg.gamma)
        if cfg.tone is not None:
            if cfg.mode != "gray":
                raise RasterError("a tone curve (measured on a wedge of S) sets the power of each gray; dithered "
                                  "dots all burn at --max-power, so it does not apply: use mode gray")
            img = cfg.tone.correct_gray(img, s_max=cfg.s_max, min_power=cfg.min_power, max_power=cfg.max_power,
                                        white_level=cfg.white_level)
        return gray_job(img, **common, **cfg.burn_options(), blank=blank)
    if cfg.mode == "edges":
        if img.shape[0] > arr.shape[0] or img.shape[1] > arr.shape[1]:
            # Upscaling spreads a sharp edge over several beam pixels, so no gradient
            # reaches the detector's threshold and the job came out empty: find the
            # edges of the shapes (thresholded at ``level``) at the beam's resolution.
            img = np.where(img < cfg.level, 0.0, 255.0)
        mask = detect_edges(img, cfg.edge_operator, threshold=cfg.edge_threshold, pseudo=cfg.edge_pseudo,
                            level=cfg.level)
        return mask_job(_not_blank(mask, blank), mode=cfg.edge_path, report_mode="edges", **common,
                        **cfg.burn_options())
    mask = img if is_mask else threshold(img, cfg.level)
    return mask_job(_not_blank(mask, blank), mode=cfg.mode, **common, **cfg.burn_options())


def _not_blank(mask: np.ndarray, blank: np.ndarray | None) -> np.ndarray:
    """The burn mask without the blank pixels."""
    return mask if blank is None else mask & ~blank


def raster_program(image, *, feed_mm_min: float, pitch_mm: float, mode: str = "gray", dialect: str = "grbl",
                   compact: bool = True, comment: str | None = None, **settings) -> str:
    """The G-code ``labkit img2gcode`` writes for an image at one feed and pixel pitch.

    One pixel of ``image`` per ``pitch_mm`` (no resampling unless a size is given in
    ``settings``); the program as text, compact (:func:`~labkit.gcode.writer.emit`'s
    ``compact``: no spaces, relative moves along a row where shorter) unless asked
    otherwise. Made for measuring a format on a link (bytes, the stall-free feed).

    Parameters
    ----------
    image : array_like, RasterImage or path
        What :func:`image_to_job` takes, or an image file (:func:`~labkit.raster.io.read_image`).
    feed_mm_min : float
        Scanning (gray, dither) or cutting feed, mm/min.
    pitch_mm : float
        Pixel pitch = line spacing = beam diameter, mm.
    mode : str
        One of :data:`MODES`.
    dialect : str
        G-code dialect (compact needs ``grbl`` or ``labkit-fw``).
    compact : bool
        Compact text (default) or the spaced, absolute text.
    comment : str, optional
        A header comment.
    **settings
        Other fields of :class:`RasterSettings`.

    Returns
    -------
    str

    Examples
    --------
    >>> g = np.array([[255, 0, 128, 128, 255]], np.uint8)
    >>> print(raster_program(g, feed_mm_min=6000, pitch_mm=0.1, overscan_mm=0.2).split("M5\\n", 1)[1])
    M4S0
    G0X-.1Y.05
    G1X.1F6000
    X.2S1000
    X.4S498
    X.6S0
    M5
    M2
    <BLANKLINE>

    (so short a row is shorter absolute; a photo's rows are written relative).
    """
    from labkit.gcode.writer import emit

    from pathlib import Path

    from labkit.raster.io import read_image

    if isinstance(image, (str, Path)):
        image = read_image(image)
    if not any(settings.get(k) is not None for k in ("width_mm", "height_mm", "pixel_mm", "dpi")):
        settings["pixel_mm"] = pitch_mm          # one image pixel per beam pixel
    job = image_to_job(image, mode=mode, beam_mm=pitch_mm, feed_mm_min=feed_mm_min, **settings)
    return emit(job.moves, dialect=dialect, compact=compact, comment=comment)
