"""Pictures of G-code programs, and the arc widget of chapter 02.

:func:`plot_moves` draws a program the way a laser user reads it: burning
moves coloured by power, travel dashed, arcs as arcs (flattened well below a
pixel), the start marked. :func:`plot_arc_choice` and :func:`arc_explorer`
show how G2/G3 with R picks one of two centres.
"""

from __future__ import annotations

import math

import numpy as np

from labkit.geometry.circle import arc_chord_points, chord_segments
from labkit.toolpath.moves import PLANE_AXES, MoveKind, Moves
from labkit.viz._widgets import show

__all__ = ["plot_moves", "moves_to_segments", "rasterize_moves", "plot_arc_choice", "arc_explorer", "gcode_playground",
           "save_preview"]

_PLANE_VIEW = {"xy": (0, 1), "xz": (0, 2), "yz": (1, 2)}

#: Above this many moves :func:`plot_moves` draws the job as an image (one pixel grid,
#: ``IMAGE_PIXELS`` on its long side) instead of one vector line per move: a line
#: collection of 200,000 moves takes seconds to draw, an image a fraction of one.
IMAGE_ABOVE_MOVES = 20_000
IMAGE_PIXELS = 1600
#: Pixel steps one image may take (~0.3 s): a job that retraces the drawing millions of
#: times is drawn on a coarser grid instead of taking minutes.
IMAGE_MAX_STEPS = 50_000_000


def moves_to_segments(moves: Moves, *, tol_mm: float, view: str = "xy"):
    """Every move as 2-D line pieces for drawing (arcs flattened within ``tol_mm``).

    Returns
    -------
    segments : ndarray, shape (m, 2, 2)
        Line pieces in the view's coordinates, mm.
    row : ndarray of int, shape (m,)
        The move each piece belongs to.
    """
    ax0, ax1 = _PLANE_VIEW[view]
    motion = np.flatnonzero(moves.is_motion & ~moves.is_arc)
    segs = [np.stack([moves.start[motion][:, [ax0, ax1]], moves.end[motion][:, [ax0, ax1]]], axis=1)]
    rows = [motion]
    arcs = np.flatnonzero(moves.is_arc)
    if len(arcs):
        sub = moves[arcs]
        radius = sub.radius_mm()
        sweep = sub.sweep_rad()
        counts = np.atleast_1d(chord_segments(radius, sweep, tol_mm)).astype(np.int64)
        axes = np.array([PLANE_AXES[17], PLANE_AXES[18], PLANE_AXES[19]])[sub.plane.astype(int) - 17]
        pts, arc, _ = arc_chord_points(sub.start, sub.end, sub.centre, axes, radius, sweep, counts)
        npts = counts + 1
        p2 = pts[:, [ax0, ax1]]
        last = np.cumsum(npts) - 1                   # no segment from an arc's end to the next
        keep = np.ones(len(arc) - 1, bool)
        keep[last[:-1]] = False
        segs.append(np.stack([p2[:-1], p2[1:]], axis=1)[keep])
        rows.append(arcs[arc[:-1][keep]])
    return np.concatenate(segs), np.concatenate(rows)


def _refuse_non_finite(moves: Moves) -> None:
    """A position that is not finite cannot be drawn (nor cut): say which move."""
    from labkit.toolpath.moves import check_moves

    check_moves(moves)


def rasterize_moves(moves: Moves, *, view: str = "xy", pixels: int = IMAGE_PIXELS):
    """Draw every move into a pixel grid: the greatest laser power and the travel per pixel.

    Each move (arcs flattened to well below a pixel) is walked pixel by pixel along
    its longer axis (a compiled digital differential analyser), so no pixel column
    or row it crosses is missed; the work is the drawn length in pixels and the
    memory the grid plus the flattened pieces.

    Parameters
    ----------
    moves : Moves
        Drawn as given (pass ``moves.in_work_coordinates()`` for work coordinates).
    view : {"xy", "xz", "yz"}
    pixels : int
        Pixels on the long side of the drawing (fewer when the job's drawn length
        would exceed :data:`IMAGE_MAX_STEPS` pixel steps, so the time stays bounded).

    Returns
    -------
    power : ndarray of float, shape (rows, cols)
        Greatest power in % of full along burning moves; NaN where nothing burns.
    travel : ndarray of bool, shape (rows, cols)
        Pixels crossed by moves with the beam off.
    extent : (xmin, xmax, ymin, ymax)
        The grid's extent in mm (row 0 at ``ymin``), for ``imshow(origin="lower")``.

    Examples
    --------
    >>> from labkit.gcode import parse
    >>> power, travel, extent = rasterize_moves(parse("M3 S500\\nG1 X10 Y10 F100"), pixels=11)
    >>> power.shape, float(np.nanmax(power)), int(np.isfinite(power).sum()), extent
    ((11, 11), 50.0, 11, (-0.5, 10.5, -0.5, 10.5))
    """
    ax0, ax1 = _PLANE_VIEW[view]
    box = moves.bounds()
    lo = box[0, [ax0, ax1]]
    size = float(np.nanmax(box[1, [ax0, ax1]] - lo)) or 1.0
    cell = size / (pixels - 1)
    cols = int(round((box[1, ax0] - lo[0]) / cell)) + 1
    rows = int(round((box[1, ax1] - lo[1]) / cell)) + 1
    segs, row_of = moves_to_segments(moves, tol_mm=cell / 4, view=view)
    from labkit.viz._gcode_draw import draw

    pix = (segs - lo) / cell                          # pixel units, pixel centres on integers
    steps = float(np.abs(pix[:, 1] - pix[:, 0]).max(axis=1).sum()) if len(pix) else 0.0
    if steps > IMAGE_MAX_STEPS and pixels > 64:
        # Overdrawn job: the same picture on a coarser grid (work ∝ pixels per piece).
        coarse = max(64, int(pixels * IMAGE_MAX_STEPS / steps))
        scale = (pixels - 1) / (coarse - 1)
        cell *= scale
        cols = int(round((box[1, ax0] - lo[0]) / cell)) + 1
        rows = int(round((box[1, ax1] - lo[1]) / cell)) + 1
        pix = (segs - lo) / cell
    burning = moves.laser_on[row_of]
    value = 100.0 * moves.power_fraction()[row_of]
    power, travel = draw(pix, value, burning, (rows, cols))
    extent = (lo[0] - cell / 2, lo[0] + (cols - 0.5) * cell,
              lo[1] - cell / 2, lo[1] + (rows - 0.5) * cell)
    return power, travel, tuple(float(v) for v in extent)


def power_colormap():
    """Laser power colours that read on white: plasma from dark violet (low) to orange (full),
    without its last, yellow fifth (full-power cuts vanished on a white page)."""
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap

    return ListedColormap(plt.get_cmap("plasma")(np.linspace(0.0, 0.8, 256)), name="labkit-power")


def plot_moves(moves: Moves, ax=None, *, view: str = "xy", show_travel: bool = True,
               cmap=None, linewidth: float = 1.2, colorbar: bool = True,
               title: str | None = None, as_image: bool | None = None):
    """Draw a program: cuts coloured by laser power, travel dashed, start marked.

    Positions are drawn in work coordinates (``moves.work_end``…), as the program's
    X Y Z words state them, whatever G54-G59 / G92 offsets put them in machine space.

    Parameters
    ----------
    moves : Moves
    ax : matplotlib Axes, optional
        Drawn into a new figure when omitted.
    view : {"xy", "xz", "yz"}
        Projection.
    show_travel : bool
        Draw rapids (dashed grey) and feed moves with the beam off (thin cyan).
    cmap : str or Colormap, optional
        Colour map of the power (0…100 % of ``moves.s_max``); default
        :func:`power_colormap`, which reads on white.
    colorbar : bool
        Add a power colour bar.
    as_image : bool, optional
        Draw through :func:`rasterize_moves` (an image) instead of vector lines.
        Default: above :data:`IMAGE_ABOVE_MOVES` moves.

    Returns
    -------
    matplotlib.axes.Axes
    """
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection

    _refuse_non_finite(moves)
    if cmap is None:
        cmap = power_colormap()
    if view not in _PLANE_VIEW:
        raise ValueError(f"view must be one of {sorted(_PLANE_VIEW)}, got {view!r}")
    if ax is None:
        _, ax = plt.subplots(figsize=(7, 6))
    if len(moves) == 0 or not moves.is_motion.any():
        ax.set_title(title or "empty program")
        return ax
    moves = moves.in_work_coordinates()     # what the program's words say (G54-G59, G92)
    ax0, ax1 = _PLANE_VIEW[view]
    box = moves.bounds()
    extent = float(np.nanmax(box[1, [ax0, ax1]] - box[0, [ax0, ax1]])) or 1.0
    if as_image is None:
        as_image = len(moves) > IMAGE_ABOVE_MOVES
    if as_image:
        handles = _draw_image(ax, moves, view, show_travel, cmap, colorbar)
        _finish(ax, moves, box, extent, ax0, ax1, title, handles)
        return ax
    segs, rows = moves_to_segments(moves, tol_mm=extent * 2e-4, view=view)
    burning = moves.laser_on[rows]
    rapid = moves.kind[rows] == MoveKind.RAPID
    dark_feed = ~burning & ~rapid
    if show_travel and rapid.any():
        ax.add_collection(LineCollection(segs[rapid], colors="0.55", linewidths=0.7,
                                         linestyles=(0, (3, 3)), label="rapid (G0)"))
    if show_travel and dark_feed.any():
        ax.add_collection(LineCollection(segs[dark_feed], colors="tab:cyan", linewidths=0.8,
                                         alpha=0.8, label="feed, laser off"))
    if burning.any():
        power = 100.0 * moves.power_fraction()[rows[burning]]
        lc = LineCollection(segs[burning], cmap=cmap, linewidths=linewidth, label="cut")
        lc.set_array(power)
        lc.set_clim(0.0, 100.0)
        ax.add_collection(lc)
        if colorbar:
            ax.figure.colorbar(lc, ax=ax, label="laser power (% of full)", shrink=0.6, pad=0.02)
    _finish(ax, moves, box, extent, ax0, ax1, title)
    return ax


def _draw_image(ax, moves, view, show_travel, cmap, colorbar):
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch

    power, travel, extent = rasterize_moves(moves, view=view)
    if show_travel and travel.any():
        ax.imshow(np.where(travel & np.isnan(power), 1.0, np.nan), origin="lower", extent=extent,
                  cmap=ListedColormap(["0.7"]), vmin=0, vmax=1, interpolation="nearest")
    im = ax.imshow(power, origin="lower", extent=extent, cmap=cmap, vmin=0.0, vmax=100.0,
                   interpolation="nearest")
    if colorbar:
        ax.figure.colorbar(im, ax=ax, label="laser power (% of full)", shrink=0.6, pad=0.02)
    handles = [Patch(color=im.cmap(0.8), label="cut")]
    if show_travel and travel.any():
        handles.append(Patch(color="0.7", label="travel, laser off"))
    return handles


def _line_handles(ax):
    """Legend entries for the drawn collections, a cut coloured as its lines are (by power: the
    colour of the mean power drawn), not in the default colour of an uncoloured line."""
    from matplotlib.lines import Line2D

    handles = []
    for c in ax.collections:
        label = c.get_label()
        if not label or label.startswith("_"):
            continue
        if c.get_array() is not None:
            colour = c.cmap(c.norm(float(np.mean(c.get_array()))))
        else:
            colour = c.get_edgecolor()[0]
        style = c.get_linestyle()[0]
        handles.append(Line2D([], [], color=colour, lw=max(float(c.get_linewidth()[0]), 1.0),
                              ls=(style[0], style[1]) if style[1] else "-", label=label))
    return handles


def _finish(ax, moves, box, extent, ax0, ax1, title, handles=None):
    first = int(np.flatnonzero(moves.is_motion)[0])
    start = ax.plot(*moves.start[first, [ax0, ax1]], "o", color="tab:green", ms=7, label="start",
                    zorder=5)[0]
    ax.set_xlim(box[0, ax0] - 0.03 * extent, box[1, ax0] + 0.03 * extent)
    ax.set_ylim(box[0, ax1] - 0.03 * extent, box[1, ax1] + 0.03 * extent)
    ax.set_aspect("equal")
    ax.set_xlabel(f"{'XYZ'[ax0]} (mm)")
    ax.set_ylabel(f"{'XYZ'[ax1]} (mm)")
    if handles is None:
        handles = _line_handles(ax)
    # below the drawing, never over it
    ax.legend(handles=handles + [start], loc="upper center", bbox_to_anchor=(0.5, -0.13),
              ncol=len(handles) + 1, fontsize="small", frameon=False)
    if title is None and moves.source:
        title = str(moves.source).rsplit("/", 1)[-1]
    if title:
        ax.set_title(title)


def save_preview(moves: Moves, path, *, dpi: int = 120, **options) -> None:
    """Draw :func:`plot_moves` into a PNG file (headless)."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 7))
    plot_moves(moves, ax, **options)
    fig.tight_layout()
    from labkit._files import write_figure    # a temporary file renamed when complete

    write_figure(fig, path, dpi=dpi)
    plt.close(fig)


#: a legend under the drawing, where it hides none of the circles
_LEGEND_BELOW = dict(loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=2, fontsize="small", frameon=False)


def plot_arc_choice(start, end, radius, clockwise, ax=None):
    """Draw both circles of radius |R| through start and end, and the arc G2/G3 R picks.

    Parameters
    ----------
    start, end : (float, float)
        mm.
    radius : float
        R in mm; negative asks for the arc over 180°.
    clockwise : bool
        G2 (True) or G3 (False).

    Returns
    -------
    matplotlib.axes.Axes
    """
    import matplotlib.pyplot as plt

    from labkit.errors import GeometryError
    from labkit.gcode.arcs import arc_angles, centre_from_radius, centres_from_radius

    if ax is None:
        _, ax = plt.subplots(figsize=(6, 6))
    p1 = np.asarray(start, dtype=float)
    p2 = np.asarray(end, dtype=float)
    word = "G2" if clockwise else "G3"
    ax.plot(*zip(p1, p2), ":", color="0.5", lw=1)
    ax.plot(*p1, "o", color="tab:green", ms=8, label="start P1")
    ax.plot(*p2, "s", color="tab:red", ms=8, label="end P2")
    try:
        both = centres_from_radius(p1, p2, radius)
    except GeometryError as exc:
        ax.set_title(f"{word} R{radius:g}: {exc}", fontsize="small", color="tab:red")
        ax.set_aspect("equal")
        ax.set_xlabel("X (mm)")
        ax.set_ylabel("Y (mm)")
        ax.legend(**_LEGEND_BELOW)
        return ax
    chosen = centre_from_radius(p1, p2, radius, clockwise)
    r = abs(radius)
    t = np.linspace(0, 2 * math.pi, 361)
    for k, c in enumerate(both):
        ax.plot(c[0] + r * np.cos(t), c[1] + r * np.sin(t), "--", color="0.75", lw=1)
        ax.plot(*c, "x", color="0.4", ms=9, mew=2, label="candidate centres" if k == 0 else None)
    a0, sweep = arc_angles(p1, p2, chosen, clockwise)
    ts = a0 + sweep * np.linspace(0, 1, 200)
    ax.plot(chosen[0] + r * np.cos(ts), chosen[1] + r * np.sin(ts), color="tab:blue", lw=3,
            label=f"{word} arc, sweep {math.degrees(abs(sweep)):.1f}°")
    ax.plot(*chosen, "+", color="tab:blue", ms=14, mew=3, label="chosen centre")
    mid = chosen + r * np.array([math.cos(a0 + sweep / 2), math.sin(a0 + sweep / 2)])
    ax.annotate("", xy=mid + 0.08 * r * np.array([-math.sin(a0 + sweep / 2), math.cos(a0 + sweep / 2)])
                * np.sign(sweep), xytext=mid, arrowprops=dict(arrowstyle="->", color="tab:blue", lw=2))
    rule = "R > 0: the sweep under 180°" if radius > 0 else "R < 0: the sweep over 180°"
    ax.set_title(f"{word} X{p2[0]:g} Y{p2[1]:g} R{radius:g}  —  {rule}", fontsize="medium")
    ax.set_aspect("equal")
    ax.set_xlabel("X (mm)")
    ax.set_ylabel("Y (mm)")
    ax.legend(**_LEGEND_BELOW)
    return ax


def arc_explorer(start=(0.0, 0.0), end=(30.0, 10.0), radius=25.0):
    """An ipywidgets panel: move the end point, change R, flip its sign, switch G2/G3.

    Returns
    -------
    ipywidgets.VBox
        Sliders for end X, end Y and |R|, toggles for the sign of R and the
        direction, and the plot of :func:`plot_arc_choice`.
    """
    import ipywidgets as w
    import matplotlib.pyplot as plt

    end_x = w.FloatSlider(value=end[0], min=-40, max=40, step=0.5, description="end X (mm)")
    end_y = w.FloatSlider(value=end[1], min=-40, max=40, step=0.5, description="end Y (mm)")
    r_abs = w.FloatSlider(value=abs(radius), min=1, max=60, step=0.5, description="|R| (mm)")
    sign = w.ToggleButtons(options=[("R > 0 (short arc)", 1), ("R < 0 (long arc)", -1)],
                           value=1 if radius >= 0 else -1, description="sign")
    direction = w.ToggleButtons(options=[("G2 (CW)", True), ("G3 (CCW)", False)], value=True,
                                description="motion")
    out = w.Output()

    def redraw(*_):
        fig, ax = plt.subplots(figsize=(6, 6))
        plot_arc_choice(start, (end_x.value, end_y.value), sign.value * r_abs.value,
                        direction.value, ax=ax)
        ax.set_xlim(-70, 70)
        ax.set_ylim(-70, 70)
        show(out, figure=fig)

    for widget in (end_x, end_y, r_abs, sign, direction):
        widget.observe(redraw, names="value")
    redraw()
    return w.VBox([w.HBox([end_x, end_y, r_abs]), w.HBox([sign, direction]), out])


PLAYGROUND_COLUMNS = 60
"""Characters per line of the playground's report: what its 460 px column shows in JupyterLab's
13 px monospace font without the browser breaking a word."""


def _wrap_report(lines, width=PLAYGROUND_COLUMNS):
    """Wrap report lines at spaces (never inside a word), continuation lines indented.

    >>> print(_wrap_report(["a:1:2: error 22: feed motion without a feed rate"], width=24))
    a:1:2: error 22: feed
        motion without a feed
        rate
    """
    import textwrap

    out = []
    for line in lines:
        out.extend(textwrap.wrap(line, width, subsequent_indent="    ", break_long_words=False,
                                 break_on_hyphens=False, replace_whitespace=False,
                                 drop_whitespace=True) or [""])
    return "\n".join(out)


def gcode_playground(text: str = "G21 G90\nM3 S600\nG0 X10 Y10\nG1 X40 F1200\nG2 X40 Y40 I0 J15\n"
                     "G1 X10\nG3 X10 Y10 R15\nM5\n", dialect: str = "grbl"):
    """An ipywidgets panel: edit G-code, see its diagnostics, summary and preview as you type.

    Returns
    -------
    ipywidgets.VBox
    """
    import ipywidgets as w
    import matplotlib.pyplot as plt

    from labkit.gcode import parse
    from labkit.gcode.dialects import DIALECTS
    from labkit.gcode.simulate import summarize

    editor = w.Textarea(value=text, layout=w.Layout(width="420px", height="260px"))
    choose = w.Dropdown(options=list(DIALECTS), value=dialect, description="dialect")
    report = w.Output(layout=w.Layout(width="460px"))
    picture = w.Output()

    def redraw(*_):
        moves = parse(editor.value, dialect=choose.value, lenient=True)
        lines = [err.format() for err in moves.diagnostics] or ["no errors"]
        show(report, text=_wrap_report(lines + summarize(moves).format().splitlines()))
        fig, ax = plt.subplots(figsize=(5, 4.5))
        plot_moves(moves, ax, colorbar=False, title="preview")
        show(picture, figure=fig)

    editor.observe(redraw, names="value")
    choose.observe(redraw, names="value")
    redraw()
    return w.VBox([w.HBox([w.VBox([choose, editor, report]), picture])])
