"""The command line's previews, drawn with numpy and Pillow (never matplotlib).

``labkit preview``, ``img2gcode``'s default preview and the ``--preview`` of
``svg2gcode`` / ``dxf2gcode`` write their pictures here. They show what the
notebooks' matplotlib plots show (:func:`labkit.viz.gcode.plot_moves`,
:func:`labkit.viz.raster.save_job_preview`): cuts coloured by laser power, travel
pale, arcs as arcs (flattened within a quarter of a pixel), the start marked, mm
axes, a power scale and a legend in Pillow's default font. Importing matplotlib
costs a command about half a second and drawing a big job through it seconds
more; the moves are drawn here straight into a pixel grid
(:func:`labkit.viz.gcode.rasterize_moves`) the size of the picture.

Vector formats (``.svg``, ``.pdf``, ``.eps``, ``.ps``) are drawn by the matplotlib
functions, which is what a vector file is asked for.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from labkit.errors import InputError

__all__ = ["preview_format", "power_colours", "moves_raster", "draw_moves", "draw_job", "write_moves_preview",
           "write_job_preview"]

#: File suffixes drawn by Pillow, and the Pillow format of each.
PILLOW_FORMATS = {"png": "PNG", "jpg": "JPEG", "jpeg": "JPEG", "webp": "WEBP", "bmp": "BMP",
                  "tif": "TIFF", "tiff": "TIFF", "gif": "GIF"}
#: Vector suffixes: drawn by matplotlib (lines stay lines in the file).
VECTOR_FORMATS = ("eps", "pdf", "ps", "svg", "svgz")

#: matplotlib's "plasma" at 33 equally spaced points (0, 1/32, …, 1), sRGB 0…255; colours
#: between are interpolated linearly (within 3/255 of matplotlib's 256-entry table).
_PLASMA = np.array([
    [13, 8, 135], [34, 6, 144], [49, 5, 151], [63, 4, 156], [76, 2, 161], [89, 1, 165],
    [102, 0, 167], [114, 1, 168], [126, 3, 168], [138, 9, 165], [149, 17, 161], [160, 26, 156],
    [170, 35, 149], [179, 44, 142], [188, 53, 135], [196, 62, 127], [204, 71, 120], [211, 81, 113],
    [218, 90, 106], [224, 99, 99], [230, 108, 92], [235, 118, 85], [240, 128, 78], [245, 139, 71],
    [248, 149, 64], [251, 161, 57], [253, 172, 51], [254, 184, 44], [253, 197, 39], [252, 210, 37],
    [248, 223, 37], [244, 237, 39], [240, 249, 33]], float)

_WHITE = (255, 255, 255)
_INK = (30, 30, 30)
_TRAVEL = (179, 179, 179)          # matplotlib's "0.7": the image preview's travel
_START = (44, 160, 44)             # tab:green
_FIGURE_IN = (8.0, 7.0)            # the matplotlib preview's figure, inches
_JOB_FIGURE_IN = (13.0, 6.0)


def preview_format(path) -> str:
    """The format a preview named ``path`` is written in (``png`` when it has no suffix).

    Commands call it before any work, so a preview named ``out.gcode`` is refused
    before the program beside it is written; it imports neither Pillow's plugins
    nor matplotlib.

    Returns
    -------
    str
        The suffix, lower case: one of :data:`PILLOW_FORMATS` or :data:`VECTOR_FORMATS`.

    Raises
    ------
    InputError
        No preview is drawn in that format; the message lists those that are.

    Examples
    --------
    >>> preview_format("job.PNG"), preview_format("job"), preview_format("job.svg")
    ('png', 'png', 'svg')
    """
    target = Path(os.fspath(path))
    fmt = target.suffix.lstrip(".").lower() or "png"
    if fmt not in PILLOW_FORMATS and fmt not in VECTOR_FORMATS:
        known = sorted([*PILLOW_FORMATS, *VECTOR_FORMATS])
        raise InputError(f"{target}: cannot draw a '.{fmt}' file; expected one of "
                         f"{', '.join('.' + k for k in known)}")
    return fmt


def power_colours(fraction, *, low: float = 0.0, high: float = 0.8) -> np.ndarray:
    """sRGB colours (uint8, shape ``(..., 3)``) of the plasma map between ``low`` and ``high``.

    The defaults are :func:`labkit.viz.gcode.power_colormap` (plasma without its last,
    yellow fifth, which vanishes on white); ``low=1, high=0`` is matplotlib's
    ``plasma_r``. NaN fractions are white.

    Parameters
    ----------
    fraction : array_like of float
        Power as a fraction of full, 0…1 (clipped).

    Examples
    --------
    >>> power_colours([0.0, 1.0]).tolist()
    [[13, 8, 135], [252, 168, 53]]
    """
    given = np.asarray(fraction, float)
    rgb = np.empty(given.shape + (3,), np.uint8)
    drawn = ~np.isnan(given)
    values = given[drawn]               # a picture's grid is mostly blank, and often one power
    one = values.size and values.min() == values.max()
    colours = _plasma(values[:1] if one else values, low, high)
    for channel in range(3):            # a plane at a time: a fraction of a mask of RGB triples
        if one:
            rgb[..., channel] = np.where(drawn, colours[0, channel], _WHITE[channel])
        else:
            plane = np.full(given.shape, _WHITE[channel], np.uint8)
            plane[drawn] = colours[:, channel]
            rgb[..., channel] = plane
    return rgb


def _plasma(values, low, high):
    """:func:`power_colours` of values that are not NaN, shape (n, 3)."""
    where = (low + (high - low) * np.clip(np.nan_to_num(values), 0.0, 1.0)) * (len(_PLASMA) - 1)
    rgb = np.empty((len(values), 3), np.uint8)
    nodes = np.arange(len(_PLASMA))
    for channel in range(3):
        rgb[:, channel] = np.rint(np.interp(where, nodes, _PLASMA[:, channel]))
    return rgb


def _font(size: int):
    from PIL import ImageFont

    return ImageFont.load_default(size=size)


def _vertical_text(image, centre, text, font):
    """``text`` turned a quarter anticlockwise (read bottom to top), centred on ``centre``."""
    from PIL import Image, ImageDraw

    left, top, right, bottom = font.getbbox(text)
    label = Image.new("RGB", (right - left + 2, bottom - top + 2), _WHITE)
    ImageDraw.Draw(label).text((1 - left, 1 - top), text, fill=_INK, font=font)
    label = label.rotate(90, expand=True)
    image.paste(label, (int(centre[0] - label.width / 2), int(centre[1] - label.height / 2)))


def _nice_step(span: float, ticks: int = 6) -> float:
    """A 1, 2 or 5 × 10ⁿ step giving about ``ticks`` ticks over ``span``."""
    raw = max(span, 1e-9) / ticks
    power = 10.0 ** np.floor(np.log10(raw))
    return float(power * min((m for m in (1, 2, 5, 10) if m * power >= raw), default=10))


class _Axes:
    """A drawing area of a picture: mm → pixels at one scale on both axes (equal aspect)."""

    def __init__(self, image, box_px, view_mm):
        left, top, right, bottom = box_px
        x0, x1, y0, y1 = view_mm
        self.image = image
        self.scale = min((right - left) / max(x1 - x0, 1e-12), (bottom - top) / max(y1 - y0, 1e-12))
        width = (x1 - x0) * self.scale
        height = (y1 - y0) * self.scale
        self.left = int(round(left + ((right - left) - width) / 2))
        self.top = int(round(top + ((bottom - top) - height) / 2))
        self.width = max(1, int(round(width)))
        self.height = max(1, int(round(height)))
        self.view = view_mm

    def px(self, x_mm, y_mm):
        """Picture pixel (column, row) of a point in mm."""
        x0, _, _, y1 = self.view
        return self.left + (x_mm - x0) * self.scale, self.top + (y1 - y_mm) * self.scale

    def paste(self, rgb, extent_mm, resample):
        """Put an image (row 0 at the bottom, ``extent_mm`` as ``imshow``'s) into the area."""
        from PIL import Image

        layer = Image.new("RGB", (self.width, self.height), _WHITE)
        c0, r0 = self.px(extent_mm[0], extent_mm[3])
        c1, r1 = self.px(extent_mm[1], extent_mm[2])
        size = (max(1, int(round(c1 - c0))), max(1, int(round(r1 - r0))))
        picture = Image.fromarray(np.ascontiguousarray(rgb[::-1]))
        if picture.size != size:
            picture = picture.resize(size, resample)
        layer.paste(picture, (int(round(c0)) - self.left, int(round(r0)) - self.top))
        self.image.paste(layer, (self.left, self.top))

    def frame(self, draw, xlabel, ylabel, title, font):
        """The frame, mm ticks and labels on both axes, and the title above."""
        x0, x1, y0, y1 = self.view
        right, bottom = self.left + self.width, self.top + self.height
        draw.rectangle((self.left - 1, self.top - 1, right, bottom), outline=_INK)
        step = _nice_step(max(x1 - x0, y1 - y0))
        for value in np.arange(np.ceil(x0 / step) * step, x1 + 1e-9, step):
            c = self.px(value, y0)[0]
            draw.line((c, bottom, c, bottom + 4), fill=_INK)
            draw.text((c, bottom + 6), f"{value + 0.0:g}", fill=_INK, font=font, anchor="mt")
        for value in np.arange(np.ceil(y0 / step) * step, y1 + 1e-9, step):
            r = self.px(x0, value)[1]
            draw.line((self.left - 5, r, self.left - 1, r), fill=_INK)
            draw.text((self.left - 7, r), f"{value + 0.0:g}", fill=_INK, font=font, anchor="rm")
        draw.text(((self.left + right) / 2, bottom + 22), xlabel, fill=_INK, font=font, anchor="mt")
        _vertical_text(self.image, (self.left - 50, (self.top + bottom) / 2), ylabel, font)
        if title:
            for k, line in enumerate(reversed(title.splitlines())):
                draw.text(((self.left + right) / 2, self.top - 6 - 15 * k), line, fill=_INK, font=font,
                          anchor="mb")


def _thicken(power):
    """Cuts two pixels wide (as matplotlib's 1.2 pt lines at 120 dpi): the greater power of
    each pixel and its left, lower and lower-left neighbours."""
    value = np.where(np.isnan(power), -1.0, power)
    out = value.copy()
    np.maximum(out[1:, :], value[:-1, :], out=out[1:, :])
    np.maximum(out[:, 1:], value[:, :-1], out=out[:, 1:])
    np.maximum(out[1:, 1:], value[:-1, :-1], out=out[1:, 1:])
    out[out < 0] = np.nan
    return out


def moves_raster(moves, *, scale_px_mm: float, view: str = "xy", show_travel: bool = True,
                 colours=power_colours):
    """The moves drawn on a grid of ``scale_px_mm`` pixels a mm: the picture's drawing area.

    Cuts are two pixels wide in their power's colour (the greatest power where cuts
    cross), travel one pixel of pale grey under them, the rest white.

    Parameters
    ----------
    moves : Moves
        Drawn as given (work coordinates are the caller's choice).
    scale_px_mm : float
        Pixels per mm; a job that would take more than
        :data:`labkit.viz.gcode.IMAGE_MAX_STEPS` pixel steps is drawn coarser.
    view : {"xy", "xz", "yz"}
    show_travel : bool
    colours : callable
        Power fraction → sRGB, as :func:`power_colours`.

    Returns
    -------
    rgb : ndarray of uint8, shape (rows, cols, 3)
        Row 0 at the bottom (the least Y).
    extent : (xmin, xmax, ymin, ymax)
        mm, as :func:`labkit.viz.gcode.rasterize_moves` gives it.
    travel_drawn : bool
        Whether any travel pixel was drawn.
    """
    return _coloured(*_raster(moves, scale_px_mm, view), show_travel, colours)


def _raster(moves, scale_px_mm, view):
    """``rasterize_moves`` with one grid cell per picture pixel (the long side's span at
    ``scale_px_mm``): (power, travel, extent)."""
    from labkit.viz.gcode import _PLANE_VIEW, rasterize_moves

    ax0, ax1 = _PLANE_VIEW[view]
    box = moves.bounds()
    span = float(np.nanmax(box[1, [ax0, ax1]] - box[0, [ax0, ax1]])) or 1.0
    power, travel, grid = rasterize_moves(moves, view=view, pixels=max(2, int(span * scale_px_mm) + 1))
    return power, travel, grid, scale_px_mm


def _coloured(power, travel, grid, scale_px_mm, show_travel, colours):
    """:func:`moves_raster`'s picture of a :func:`_raster` grid."""
    if power.shape[1] >= (grid[1] - grid[0]) * scale_px_mm - 1:       # not coarsened
        power = _thicken(power)
    rgb = colours(power / 100.0)
    travel = travel & np.isnan(power)
    travel_drawn = bool(show_travel and travel.any())
    if travel_drawn:
        rgb[travel] = _TRAVEL
    return rgb, grid, travel_drawn


def _moves_panel(image, draw, box_px, moves, *, view, show_travel, title, colours, font, raster=None):
    """Draw ``moves`` (work coordinates) into ``box_px`` of ``image``; returns the area.
    ``raster(scale_px_mm)`` gives the :func:`_raster` grid when the caller has one."""
    from PIL import Image

    from labkit.viz.gcode import _PLANE_VIEW

    ax0, ax1 = _PLANE_VIEW[view]
    box = moves.bounds()
    lo, hi = box[0, [ax0, ax1]], box[1, [ax0, ax1]]
    pad = 0.03 * (float(np.nanmax(hi - lo)) or 1.0)         # as plot_moves' margins
    area = _Axes(image, box_px, (lo[0] - pad, hi[0] + pad, lo[1] - pad, hi[1] + pad))
    grid = raster(area.scale) if raster else _raster(moves, area.scale, view)
    rgb, grid, travel_drawn = _coloured(*grid, show_travel, colours)
    area.paste(rgb, grid, Image.NEAREST)
    first = int(np.flatnonzero(moves.is_motion)[0])
    c, r = area.px(*moves.start[first, [ax0, ax1]])
    draw.ellipse((c - 4, r - 4, c + 4, r + 4), fill=_START, outline=_WHITE)
    area.frame(draw, f"{'XYZ'[ax0]} (mm)", f"{'XYZ'[ax1]} (mm)", title, font)
    legend = [("cut", tuple(int(v) for v in colours(np.array(0.8)))), ("start", _START)]
    if travel_drawn:
        legend.insert(1, ("travel, laser off", _TRAVEL))
    right = area.left + area.width
    draw.rectangle((right - 126, area.top + 2, right - 4, area.top + 14 + 15 * len(legend) - 1), fill=_WHITE,
                   outline=(204, 204, 204))
    for k, (label, colour) in enumerate(legend):
        y = area.top + 8 + 15 * k
        draw.rectangle((right - 120, y - 4, right - 110, y + 4), fill=colour)
        draw.text((right - 104, y), label, fill=_INK, font=font, anchor="lm")
    return area


def _colour_bar(image, draw, area, colours, font, label):
    """A vertical power scale, 0…100 %, right of ``area``."""
    left = area.left + area.width + 14
    top, height = area.top + area.height * 0.2, area.height * 0.6
    rows = max(2, int(height))
    strip = colours(np.linspace(1.0, 0.0, rows))
    for k in range(rows):
        draw.line((left, top + k, left + 10, top + k), fill=tuple(int(v) for v in strip[k]))
    draw.rectangle((left, top, left + 10, top + rows - 1), outline=_INK)
    for percent in (0, 25, 50, 75, 100):
        y = top + (rows - 1) * (1 - percent / 100)
        draw.line((left + 10, y, left + 13, y), fill=_INK)
        draw.text((left + 15, y), f"{percent}", fill=_INK, font=font, anchor="lm")
    _vertical_text(image, (left + 42, top + height / 2), label, font)


def draw_moves(moves, *, dpi: int = 120, view: str = "xy", show_travel: bool = True,
               title: str | None = None):
    """A program drawn as :func:`labkit.viz.gcode.plot_moves` draws it, as a Pillow image.

    Cuts are coloured by laser power (:func:`power_colours`, two pixels wide), travel
    (rapids and feeds with the beam off) pale grey, arcs flattened within a quarter
    pixel, the start a green dot, in work coordinates, with mm axes, a power scale
    (% of full) and a legend.

    Parameters
    ----------
    moves : Moves
    dpi : int
        Pixels per inch of the 8 × 7 inch picture (matplotlib's figure size).
    view : {"xy", "xz", "yz"}
    show_travel : bool
    title : str, optional
        Default: the program's file name.

    Returns
    -------
    PIL.Image.Image
        RGB.
    """
    from PIL import Image, ImageDraw

    from labkit.viz.gcode import _PLANE_VIEW, _refuse_non_finite

    if view not in _PLANE_VIEW:
        raise ValueError(f"view must be one of {sorted(_PLANE_VIEW)}, got {view!r}")
    _refuse_non_finite(moves)
    size = (int(round(_FIGURE_IN[0] * dpi)), int(round(_FIGURE_IN[1] * dpi)))
    image = Image.new("RGB", size, _WHITE)
    draw = ImageDraw.Draw(image)
    font = _font(max(9, int(round(dpi / 10))))
    if title is None and moves.source:
        title = str(moves.source).rsplit("/", 1)[-1]
    if len(moves) == 0 or not moves.is_motion.any():
        draw.text((size[0] / 2, size[1] / 2), title or "empty program", fill=_INK, font=font, anchor="mm")
        return image
    box = (80, 40, size[0] - 80, size[1] - 50)
    area = _moves_panel(image, draw, box, moves.in_work_coordinates(), view=view, show_travel=show_travel,
                        title=title, colours=power_colours, font=font)
    _colour_bar(image, draw, area, power_colours, font, "laser power (% of full)")
    return image


def draw_job(job, *, dpi: int = 110, max_path_moves: int = 200_000):
    """A raster job's preview as :func:`labkit.viz.raster.save_job_preview` draws it, as a
    Pillow image: what the moves burn, and (up to ``max_path_moves`` moves) the path.

    The burn is rasterised back from the moves (:func:`labkit.raster.burn_map`, S per
    beam pixel, averaged down to the picture) for jobs of up to
    :data:`labkit.viz.raster.FULL_BURN_MAP_PIXELS` beam pixels, and drawn on a grid of
    the picture's own pixels (:func:`labkit.viz.gcode.rasterize_moves`) above that.
    Darker is more power (0 … ``s_max``). The path is drawn with cuts in ``plasma_r``
    and travel pale, as the notebooks' ``plot_job``.

    Returns
    -------
    PIL.Image.Image
        RGB, 13 × 6 inches (7 × 6 without the path) at ``dpi``.
    """
    from PIL import Image, ImageDraw

    from labkit.viz.raster import FULL_BURN_MAP_PIXELS

    draw_path = len(job.moves) <= max_path_moves
    inches = _JOB_FIGURE_IN if draw_path else (7.0, 6.0)
    size = (int(round(inches[0] * dpi)), int(round(inches[1] * dpi)))
    image = Image.new("RGB", size, _WHITE)
    draw = ImageDraw.Draw(image)
    font = _font(max(9, int(round(dpi / 10))))
    r = job.report
    w, h = r.size_mm
    rows, cols = r.shape
    panel_right = size[0] // 2 if draw_path else size[0]
    moves = job.moves.in_work_coordinates()
    shared = {}                # one drawing of the moves serves both panels of a big job

    def raster(scale_px_mm):
        if "grid" not in shared:
            shared["grid"] = _raster(moves, scale_px_mm, "xy")
        return shared["grid"]

    if draw_path and moves.is_motion.any():
        title = (f"{r.mode}: {r.segments} segments, {r.tool_lines} tool lines\n"
                 f"cut {r.cut_mm:.0f} mm, travel {r.travel_mm:.0f} mm")
        _moves_panel(image, draw, (size[0] // 2 + 75, 45, size[0] - 20, size[1] - 50), moves, view="xy",
                     show_travel=True, title=title, colours=lambda f: power_colours(f, low=1.0, high=0.0),
                     font=font, raster=raster if rows * cols > FULL_BURN_MAP_PIXELS else None)
    area = _Axes(image, (75, 45, panel_right - 20, size[1] - 50), (0.0, w, 0.0, h))
    if rows * cols <= FULL_BURN_MAP_PIXELS:
        from labkit.raster.coverage import burn_map

        _, s = burn_map(job.moves, (rows, cols), r.pixel_mm)
        shade = np.rint(255.0 * (1.0 - np.clip(s / job.moves.s_max, 0.0, 1.0))).astype(np.uint8)
        del s
        gray = np.repeat(shade[::-1, :, None], 3, axis=2)     # burn_map's row 0 is the top
        area.paste(gray, (0.0, w, 0.0, h), Image.BOX)       # beam pixels averaged, not dropped
        heading = f"burned pixels ({r.mode}), rasterised back from the moves"
    else:
        # On the picture's pixels, never finer than the beam's (the scan lines would show
        # as stripes): the path panel's drawing when there is one.
        power, _, extent, _ = raster(min(max(area.width, area.height), max(rows, cols)) /
                                     max(float(np.nanmax(np.ptp(moves.bounds()[:, :2], axis=0))), 1e-9))
        shade = np.rint(255.0 * (1.0 - np.nan_to_num(power, nan=0.0) / 100.0)).astype(np.uint8)
        area.paste(np.repeat(shade[..., None], 3, axis=2), extent, Image.NEAREST)
        heading = f"burned ({r.mode}), the moves drawn on a {power.shape[1]} x {power.shape[0]} grid"
    area.frame(draw, "X (mm)", "Y (mm)", heading, font)
    return image


def _write(path, picture, vector_writer) -> None:
    """Write ``picture()`` (a Pillow image) whole to ``path`` — a temporary file renamed when
    complete — or, for a vector suffix, call ``vector_writer()`` (matplotlib)."""
    from labkit._files import atomic_output

    fmt = preview_format(path)
    if fmt in VECTOR_FORMATS:
        vector_writer()
        return
    image = picture()
    if fmt == "gif":
        image = image.convert("P", palette=1, colors=256)    # Image.Palette.ADAPTIVE
    # zlib's fastest level: a third of the default's time on a preview, a few % more bytes
    options = {"compress_level": 1} if fmt == "png" else {}
    with atomic_output(path, "wb") as fh:
        image.save(fh, format=PILLOW_FORMATS[fmt], **options)


def write_moves_preview(moves, path, *, dpi: int = 120, view: str = "xy", show_travel: bool = True) -> None:
    """Write :func:`draw_moves`'s picture of ``moves`` to ``path`` (format by its suffix).

    Raster formats are drawn with Pillow; vector formats by
    :func:`labkit.viz.gcode.save_preview` (matplotlib).

    Raises
    ------
    InputError
        An unknown suffix (:func:`preview_format`), or the file cannot be written.
    """
    def vector():
        from labkit.viz.gcode import save_preview

        save_preview(moves, path, dpi=dpi, view=view, show_travel=show_travel)

    _write(path, lambda: draw_moves(moves, dpi=dpi, view=view, show_travel=show_travel), vector)


def write_job_preview(job, path, *, dpi: int = 110) -> None:
    """Write :func:`draw_job`'s picture of a raster job to ``path`` (vector formats by
    :func:`labkit.viz.raster.save_job_preview`, matplotlib).
    """
    def vector():
        from labkit.viz.raster import save_job_preview

        save_job_preview(job, path, dpi=dpi)

    _write(path, lambda: draw_job(job, dpi=dpi), vector)
