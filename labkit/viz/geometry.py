"""Plots and widgets for the geometry chapters (03 Bézier, 04 ellipse arcs, 05 SVG to G-code).

Imported lazily; matplotlib and ipywidgets load only here.
"""

from __future__ import annotations

import math

import numpy as np

from labkit.viz._widgets import show

__all__ = [
    "plot_paths",
    "plot_bezier_split",
    "plot_flattening",
    "bezier_explorer",
    "plot_ellipse_arcs",
    "ellipse_error_along",
    "ellipse_explorer",
    "plot_travel",
    "svg_job_explorer",
]

LINE_COLOUR = "tab:blue"
ARC_COLOUR = "tab:red"


def _ax(ax, figsize=(6, 6)):
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=figsize)
    return ax


def plot_paths(paths, ax=None, *, by="kind", show_vertices=False, lw=1.2, title=None):
    """Draw Paths: lines blue and arcs red (``by="kind"``), one colour per layer (``by="layer"``) or one
    colour per path (``by="path"``: how many separate pieces a drawing is made of)."""
    from matplotlib.collections import LineCollection

    ax = _ax(ax)
    layers = list(dict.fromkeys(p.layer for p in paths))
    cmap = {name: f"C{i % 10}" for i, name in enumerate(layers)}
    for k, p in enumerate(paths):
        for i in range(p.n_segments):
            seg = p.vertices[i:i + 2]
            if p.sweeps[i] != 0:
                c = p.centres[i]
                r = math.hypot(*(seg[0] - c))
                a0 = math.atan2(seg[0, 1] - c[1], seg[0, 0] - c[0])
                t = a0 + p.sweeps[i] * np.linspace(0, 1, max(8, int(abs(p.sweeps[i]) * 20)))
                seg = c + r * np.c_[np.cos(t), np.sin(t)]
            if by == "path":
                colour = f"C{k % 10}"
            else:
                colour = cmap[p.layer] if by == "layer" else (ARC_COLOUR if p.sweeps[i] else LINE_COLOUR)
            ax.add_collection(LineCollection([seg], colors=colour, linewidths=lw))
        if show_vertices:
            ax.plot(*p.vertices.T, ".", color="k", ms=3)
    ax.autoscale()
    ax.set_aspect("equal")
    ax.set_xlabel("X (mm)")
    ax.set_ylabel("Y (mm)")
    if by == "kind":
        ax.plot([], [], color=LINE_COLOUR, label="line (G1)")
        ax.plot([], [], color=ARC_COLOUR, label="arc (G2/G3)")
    elif by == "layer":
        for name in layers:
            ax.plot([], [], color=cmap[name], label=f"layer {name}")
    if by != "path":                  # one colour per path: the colours are the message, no legend
        ax.legend(loc="best", fontsize="small")
    if title:
        ax.set_title(title)
    return ax


def plot_bezier_split(ctrl, t=0.5, ax=None):
    """A cubic, its control polygon and the De Casteljau construction at ``t``."""
    from labkit.geometry.bezier import cubic_point, split_cubic

    ax = _ax(ax)
    c = np.asarray(ctrl, dtype=float)
    left, right = split_cubic(c, t)
    s = np.linspace(0, 1, 200)
    ax.plot(*cubic_point(left, s).T, color="tab:blue", lw=2.5, label="left half")
    ax.plot(*cubic_point(right, s).T, color="tab:orange", lw=2.5, label="right half")
    ax.plot(*c.T, "o--", color="gray", lw=1, label="control polygon")
    ab, bc, cd = (c[:-1] + t * (c[1:] - c[:-1]))
    abc, bcd = ab + t * (bc - ab), bc + t * (cd - bc)
    ax.plot(*np.array([ab, bc, cd]).T, "s-", color="tab:green", lw=1, ms=4, label="1st interpolation")
    ax.plot(*np.array([abc, bcd]).T, "^-", color="tab:purple", lw=1, ms=5, label="2nd interpolation")
    ax.plot(*left[3], "k*", ms=14, label=f"split point t = {t:.2f}")
    ax.plot(*left.T, ":", color="tab:blue", lw=1)
    ax.plot(*right.T, ":", color="tab:orange", lw=1)
    ax.set_aspect("equal")
    ax.legend(loc="best", fontsize="small")
    ax.set_xlabel("X (mm)")
    ax.set_ylabel("Y (mm)")
    return ax


def _flatten(ctrl, method, tol):
    from labkit.geometry.bezier import flatten_adaptive_t, flatten_cubic

    if method == "absolute":
        return flatten_cubic(ctrl, tol_mm=tol)
    if method == "chord 1 %":
        return flatten_cubic(ctrl, chord_fraction=0.01)
    return flatten_adaptive_t(ctrl, tol)


def plot_flattening(ctrl, method="absolute", tol_mm=0.5, ax=None):
    """The curve and its flattened polyline; the title gives the count and the measured deviation."""
    from labkit.geometry import Path, hausdorff
    from labkit.geometry.bezier import cubic_point

    ax = _ax(ax)
    c = np.asarray(ctrl, dtype=float)
    pts = _flatten(c, method, tol_mm)
    truth = cubic_point(c, np.linspace(0, 1, 4001))
    dev = hausdorff(Path.polyline(pts), Path.polyline(truth))
    ax.plot(*truth.T, color="lightgray", lw=6, label="curve")
    ax.plot(*pts.T, ".-", color="tab:blue", lw=1.2, ms=5, label="flattened")
    ax.set_aspect("equal")
    ax.set_title(f"{method}: {len(pts) - 1} segments, deviation {dev:.3f} mm")
    ax.legend(loc="best", fontsize="small")
    ax.set_xlabel("X (mm)")
    ax.set_ylabel("Y (mm)")
    return ax


def bezier_explorer(ctrl=((0, 0), (10, 40), (50, -20), (60, 20))):
    """Widget: move the split parameter t, pick a flattening method and tolerance."""
    import ipywidgets as w
    import matplotlib.pyplot as plt

    t = w.FloatSlider(value=0.5, min=0.0, max=1.0, step=0.01, description="split t")
    method = w.ToggleButtons(options=["absolute", "chord 1 %", "[DobotLaser] t-steps"], description="flatten")
    tol = w.FloatLogSlider(value=0.5, base=10, min=-3, max=1, step=0.1, description="tol (mm)")
    out = w.Output()

    def redraw(*_):
        fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 5))
        plot_bezier_split(ctrl, t.value, ax=a1)
        plot_flattening(ctrl, method.value, tol.value, ax=a2)
        show(out, figure=fig)

    for widget in (t, method, tol):
        widget.observe(redraw, names="value")
    redraw()
    return w.VBox([w.HBox([t, tol]), method, out])


#: How the chapters name ``ellipse_to_arcs``' choices of third point.
THIRD_POINT_NAMES = {"midpoint": "midpoint", "seed": "[LaserApp]'s"}


def plot_ellipse_arcs(rx=20.0, ry=10.0, n=3, method="midpoint", ax=None, *, centres=True):
    """An ellipse, its arcs (alternating colours), hand-over points and arc centres."""
    from labkit.geometry.ellipse import ellipse_point, ellipse_to_arcs

    ax = _ax(ax)
    p = ellipse_to_arcs((0, 0), rx, ry, arcs_per_quadrant=n, method=method)
    ax.plot(*ellipse_point((0, 0), rx, ry, 0, np.linspace(0, 2 * np.pi, 400)).T, color="lightgray",
            lw=6, label="ellipse")
    for i in range(p.n_segments):
        c = p.centres[i]
        r = math.hypot(*(p.vertices[i] - c))
        a0 = math.atan2(p.vertices[i, 1] - c[1], p.vertices[i, 0] - c[0])
        ang = a0 + p.sweeps[i] * np.linspace(0, 1, 40)
        ax.plot(c[0] + r * np.cos(ang), c[1] + r * np.sin(ang), color=f"C{i % 2}", lw=1.6)
    ax.plot(*p.vertices.T, "k.", ms=6, label="hand-over points")
    if centres:
        ax.plot(*p.centres.T, "x", color="tab:red", ms=5, label="arc centres")
    ax.set_aspect("equal")
    ax.set_title(f"{n} arcs per quadrant, {THIRD_POINT_NAMES.get(method, method)} third point\n"
                 f"max deviation {p.deviation_mm:.4f} mm")
    # below the axes: the arc centres can lie anywhere around the ellipse
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=3, fontsize="small", frameon=False)
    ax.set_xlabel("X (mm)")
    ax.set_ylabel("Y (mm)")
    return ax


def ellipse_error_along(rx, ry, n, method="midpoint", samples=2000):
    """(parameter t in rad, distance of the ellipse point to the arc chain in mm) around the ellipse."""
    from labkit.geometry.ellipse import ellipse_point, ellipse_to_arcs
    from labkit.geometry.measure import path_distance

    p = ellipse_to_arcs((0, 0), rx, ry, arcs_per_quadrant=n, method=method)
    t = np.linspace(0, 2 * np.pi, samples)
    return t, path_distance(p, ellipse_point((0, 0), rx, ry, 0, t))


def ellipse_explorer():
    """Widget: radius ratio, arcs per quadrant and the choice of third point."""
    import ipywidgets as w
    import matplotlib.pyplot as plt

    ratio = w.FloatSlider(value=2.0, min=1.05, max=5.0, step=0.05, description="rx / ry")
    n = w.IntSlider(value=3, min=1, max=24, description="arcs/quadrant")
    # labels name the source ([LaserApp]); the values are ellipse_to_arcs' method names
    method = w.ToggleButtons(options=[("midpoint", "midpoint"), ("LaserApp's", "seed")],
                             description="3rd point")
    seed_default = w.Button(description="LaserApp's n")
    out = w.Output()

    def redraw(*_):
        rx, ry = 20.0, 20.0 / ratio.value
        fig, (a1, a2) = plt.subplots(1, 2, figsize=(12, 4.8), gridspec_kw={"width_ratios": [1.2, 1]})
        plot_ellipse_arcs(rx, ry, n.value, method.value, ax=a1)
        t, err = ellipse_error_along(rx, ry, n.value, method.value)
        a2.plot(np.degrees(t), err * 1000, color="tab:red")
        a2.set_xlabel("ellipse parameter t (°)")
        a2.set_ylabel("distance to the arcs (µm)")
        a2.set_xlim(0, 360)
        a2.grid(alpha=0.3)
        show(out, figure=fig)

    def use_default(_):
        from labkit.geometry.ellipse import default_arcs_per_quadrant

        n.value = default_arcs_per_quadrant(ratio.value, 1.0)

    seed_default.on_click(use_default)
    for widget in (ratio, n, method):
        widget.observe(redraw, names="value")
    redraw()
    return w.VBox([w.HBox([ratio, n]), w.HBox([method, seed_default]), out])


def plot_travel(paths, ax=None, *, origin=(0.0, 0.0), title=None):
    """Cuts (thin, by layer colour) and the travel between them (dashed), with its length."""
    from labkit.geometry.order import travel_length

    ax = _ax(ax)
    plot_paths(paths, ax=ax, by="layer", lw=0.8)
    starts = np.array([p.start for p in paths])
    ends = np.array([p.end for p in paths])
    prev = np.vstack([np.asarray(origin, float)[None], ends[:-1]])
    for a, b in zip(prev, starts):
        ax.plot([a[0], b[0]], [a[1], b[1]], "--", color="0.4", lw=0.7)
    total = travel_length(starts, ends, origin)
    ax.set_title(f"{title + ': ' if title else ''}travel {total:.0f} mm")
    if ax.get_legend():
        ax.get_legend().remove()
    return ax


def svg_job_explorer(paths):
    """Widget: a vector job from imported Paths — arcs on/off, tolerance, fill, kerf, ordering."""
    import ipywidgets as w
    import matplotlib.pyplot as plt

    from labkit.gcode import emit
    from labkit.gcode.simulate import summarize
    from labkit.geometry.path import count_segments
    from labkit.toolpath.build import build_moves, prepare_paths
    from labkit.viz.gcode import plot_moves

    arcs = w.Checkbox(value=True, description="arcs (G2/G3)")
    fill = w.Checkbox(value=False, description="hatch fill")
    order = w.ToggleButtons(options=["drawing order", "greedy", "greedy + 2-opt"], value="greedy + 2-opt",
                            description="order")
    spacing = w.FloatSlider(value=1.0, min=0.3, max=3.0, step=0.1, description="fill step (mm)")
    angle = w.IntSlider(value=0, min=0, max=175, step=5, description="fill angle (°)")
    kerf = w.FloatSlider(value=0.0, min=0.0, max=2.0, step=0.1, description="kerf (mm)")
    out = w.Output()

    def redraw(*_):
        src = paths
        if not arcs.value:
            src = [p if not p.is_arc.any() else p.with_geometry(p.sample(0.005)) for p in paths]
        job = prepare_paths(src, kerf_mm=kerf.value, arcs=arcs.value, fill=fill.value,
                            fill_spacing_mm=spacing.value, fill_angle_rad=math.radians(angle.value),
                            order=order.value != "drawing order", improve=order.value == "greedy + 2-opt")
        moves = build_moves(job)
        text = emit(moves)
        s = summarize(moves)
        lines, n_arcs = count_segments(job)
        fig, ax = plt.subplots(figsize=(7, 6))
        plot_moves(moves, ax=ax)
        info = (f"segments {lines + n_arcs} ({lines} lines, {n_arcs} arcs) · G-code lines "
                f"{text.count(chr(10))} · cut {s.cut_length_mm:.0f} mm · travel {s.travel_length_mm:.0f} mm")
        show(out, text=info, figure=fig)

    for widget in (arcs, fill, order, spacing, angle, kerf):
        widget.observe(redraw, names="value")
    redraw()
    return w.VBox([w.HBox([arcs, fill, kerf]), order, w.HBox([spacing, angle]), out])
