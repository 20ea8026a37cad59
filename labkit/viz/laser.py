"""Plots and a widget for cut-width characterisation (chapter 16, ``labkit cutwidth``).

matplotlib and ipywidgets are imported inside the functions, so importing
this module costs nothing.
"""

from __future__ import annotations

import numpy as np

__all__ = ["plot_scan_annotations", "plot_width_map", "process_window", "target_width_explorer", "plot_source"]


def _axes(ax, figsize=(7, 5)):
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=figsize)
    return ax


def plot_scan_annotations(image, layout: dict, widths, ax=None, *, transform=None):
    """The scan with every measured line outlined: green burned (width in µm), red flagged.

    Parameters
    ----------
    image : ndarray
        Grey scan (0 dark … 1 light).
    layout : dict
        The grid's layout.
    widths : DataFrame
        From :func:`labkit.laser.measure.measure_lines` (same order as ``layout["lines"]``).
    ax : matplotlib Axes, optional
    transform : SimilarityTransform, optional
        Layout mm → pixels; default :func:`labkit.laser.measure.register` on the image.

    Returns
    -------
    matplotlib Axes
    """
    from labkit.laser.measure import register

    img = np.asarray(image, float)
    tf = register(img, layout) if transform is None else transform
    ax = _axes(ax, figsize=(9, 9 * img.shape[0] / max(img.shape[1], 1)))
    ax.imshow(img, cmap="gray", vmin=0, vmax=1, extent=(0, img.shape[1], img.shape[0], 0))
    half = layout["pitch_mm"] / 2
    for d, (_, r) in zip(layout["lines"], widths.iterrows()):
        box = np.array([[d["x0_mm"], d["y_mm"] - half], [d["x1_mm"], d["y_mm"] - half],
                        [d["x1_mm"], d["y_mm"] + half], [d["x0_mm"], d["y_mm"] + half],
                        [d["x0_mm"], d["y_mm"] - half]])
        pix = tf(box * [1, -1])
        colour = "tab:green" if r["burned"] else "tab:red"
        ax.plot(pix[:, 0], pix[:, 1], color=colour, lw=0.8)
        label = f"{1000 * r['width_mm']:.0f}" if r["burned"] else "×"
        right = (pix[1] + pix[2]) / 2                  # the middle of the box's right side
        ax.text(right[0] + 4, right[1], label, color=colour, fontsize=8, ha="left", va="center")
    for f in layout.get("fiducials_mm", []):
        c = tf(np.array([[f[0], -f[1]]]))[0]
        ax.plot(*c, "+", color="tab:blue", ms=14, mew=1.5)
    ax.set_title("measured widths (µm); red ×: not burned; blue +: registered corners")
    ax.set_axis_off()
    return ax


def plot_width_map(power_mw, speed_mm_min, width_mm, ax=None, *, title="measured width"):
    """Heat map of width (mm) over the power × speed grid, one cell per (power, speed), repeats averaged.

    Returns
    -------
    matplotlib Axes
    """
    import pandas as pd

    ax = _axes(ax, figsize=(6, 4.5))
    t = pd.DataFrame(dict(p=power_mw, v=speed_mm_min, w=width_mm)).groupby(["p", "v"]).w.mean().unstack()
    im = ax.imshow(t.to_numpy(), origin="lower", aspect="auto", cmap="magma")
    ax.set_xticks(range(t.shape[1]), [f"{v:g}" for v in t.columns])
    ax.set_yticks(range(t.shape[0]), [f"{p:g}" for p in t.index])
    for i in range(t.shape[0]):
        for j in range(t.shape[1]):
            val = t.to_numpy()[i, j]
            ax.text(j, i, "—" if val == 0 else f"{val:.3f}", ha="center", va="center", fontsize=7,
                    color="white" if val < 0.6 * np.nanmax(t.to_numpy()) else "black")
    ax.set_xlabel("speed (mm/min)")
    ax.set_ylabel("power (mW)")
    ax.set_title(title)
    ax.figure.colorbar(im, ax=ax, label="width (mm)")
    return ax


def process_window(fit, ax=None, *, power_range_mw=(200.0, 2500.0), speed_range_mm_min=(200.0, 2000.0),
                   target_mm: float = 0.2, cut_model: dict | None = None, no_burn_fit=None, points=None):
    """The process window: width contours over power × speed ([CBR40] figure 10's axes).

    The region where the dose model burns nothing (P/v below its threshold) is
    shaded; the wanted width's contour is drawn thick; the logistic model's
    50 % cut-through line is dashed when given.

    Parameters
    ----------
    fit : labkit.laser.models.Fit
        The model whose widths are contoured.
    ax : matplotlib Axes, optional
    power_range_mw, speed_range_mm_min : (float, float)
        Axes' spans.
    target_mm : float
        Wanted width, mm.
    cut_model : dict, optional
        From :func:`labkit.laser.models.fit_cut_through`.
    no_burn_fit : Fit, optional
        The dose fit whose threshold shades the no-cut region (default ``fit`` if it is one).
    points : (power, speed, width) arrays, optional
        Measured lines to overlay (unburned ones as crosses).

    Returns
    -------
    matplotlib Axes
    """
    from labkit.laser.models import threshold_ratio

    ax = _axes(ax)
    p = np.linspace(*power_range_mw, 160)
    v = np.linspace(*speed_range_mm_min, 160)
    V, P = np.meshgrid(v, p)
    W = np.asarray(fit.width(P, V), float)
    dose = no_burn_fit if no_burn_fit is not None else (fit if fit.model == "dose" else None)
    burns = np.ones_like(W, bool)
    if dose is not None:
        ratio = threshold_ratio(dose.params["w0_mm"], dose.params["fth_mj_mm2"])
        burns = P / V > ratio
        ax.contourf(V, P, (~burns).astype(float), levels=[0.5, 1.5], colors=["tab:purple"], alpha=0.35)
        ax.plot(v, ratio * v, color="tab:purple", lw=1)
        ax.text(0.97, 0.04, "no cut", transform=ax.transAxes, ha="right", color="tab:purple", weight="bold")
    Wm = np.where(burns & (W > 0), W, np.nan)
    finite = Wm[np.isfinite(Wm)]
    if finite.size:
        levels = np.round(np.linspace(finite.min(), finite.max(), 9)[1:-1], 3)
        cs = ax.contour(V, P, Wm, levels=np.unique(levels), colors="0.35", linewidths=0.7)
        ax.clabel(cs, fmt="%.3f", fontsize=7)
        if finite.min() < target_mm < finite.max():
            ax.contour(V, P, Wm, levels=[target_mm], colors="tab:red", linewidths=2.5)
            ax.plot([], [], color="tab:red", lw=2.5, label=f"{target_mm:g} mm wanted")
    if cut_model is not None and np.isfinite(cut_model.get("ratio50_mw_per_mm_min", np.nan)):
        ax.plot(v, cut_model["ratio50_mw_per_mm_min"] * v, "k--", lw=1.2, label="50 % cut through")
    if points is not None:
        pp, vv, ww = (np.asarray(a, float) for a in points)
        ax.scatter(vv[ww > 0], pp[ww > 0], s=12, c="k", label="measured")
        ax.scatter(vv[ww <= 0], pp[ww <= 0], s=20, marker="x", c="tab:purple", label="not burned")
    ax.set_xlim(*speed_range_mm_min)
    ax.set_ylim(*power_range_mw)
    ax.set_xlabel("speed (mm/min)")
    ax.set_ylabel("power (mW)")
    ax.set_title(f"process window ({fit.model} model): width (mm)")
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="upper left", fontsize="small")
    return ax


def target_width_explorer(fits: dict, *, speeds_mm_min=(200.0, 2000.0), max_power_mw: float | None = None,
                          width_mm: float = 0.2, max_width_mm: float | None = None):
    """Target-width slider → the power each model asks for at every speed, with the band.

    The slider ends at the widest line a fit can burn within the laser's maximum at the
    slowest speed shown (and at ``max_width_mm``, the widest line measured, when given:
    a fit says nothing beyond its data). A speed at which a model needs more than the
    laser's maximum, or where it cannot be inverted, is drawn as not reachable and said so.

    Parameters
    ----------
    fits : dict
        Name → :class:`labkit.laser.models.Fit`.
    speeds_mm_min : (float, float)
        Speed axis span, mm/min.
    max_power_mw : float, optional
        The laser's maximum, mW (drawn as a line; settings above it cannot be burned);
        default the machine description's (``labkit.motion.CBR40``).
    width_mm : float
        Slider's starting value, mm.
    max_width_mm : float, optional
        The widest line the data hold, mm; the slider does not go beyond it.

    Returns
    -------
    ipywidgets.VBox
    """
    if max_power_mw is None:
        from labkit.motion import CBR40

        max_power_mw = CBR40.laser_max_power_mw
    import ipywidgets as w
    import matplotlib.pyplot as plt

    from labkit.laser.models import power_band
    from labkit.viz._widgets import interact_figure

    v = np.linspace(*speeds_mm_min, 120)
    # the widest line any fit burns at full power and the slowest speed shown
    widest = max(float(np.nan_to_num(f.width(max_power_mw, v[0]))) for f in fits.values())
    if max_width_mm is not None:
        widest = min(widest, float(max_width_mm))
    slider_max = np.floor(widest * 100.0) / 100.0
    slider_min = min(0.05, slider_max)
    k600 = int(np.argmin(np.abs(v - 600.0)))

    def draw(width):
        fig, ax = plt.subplots(figsize=(6.5, 4))
        lines = []
        for name, f in fits.items():
            p, lo, hi = (np.asarray(a, float) for a in power_band(f, width, v))
            ok = np.isfinite(p) & (p <= max_power_mw)
            shown = np.where(ok, p, np.nan)
            if ok.any():
                (line,) = ax.plot(v, shown, label=name)
                ax.fill_between(v, np.where(ok, lo, np.nan), np.where(ok, hi, np.nan),
                                color=line.get_color(), alpha=0.25)
            else:
                ax.plot([], [], label=f"{name}: not reachable")
            if ok[k600] and np.isfinite(lo[k600]) and np.isfinite(hi[k600]):
                lines.append(f"{name}: {p[k600]:.0f} mW at {v[k600]:.0f} mm/min "
                             f"(95 % band {lo[k600]:.0f}…{hi[k600]:.0f} mW)")
            elif ok[k600]:
                lines.append(f"{name}: {p[k600]:.0f} mW at {v[k600]:.0f} mm/min (no band here)")
            elif np.isfinite(p[k600]):
                lines.append(f"{name}: not reachable at {v[k600]:.0f} mm/min (needs {p[k600]:.0f} mW, "
                             f"more than the laser's {max_power_mw:.0f} mW)")
            else:
                lines.append(f"{name}: not reachable at {v[k600]:.0f} mm/min (the model gives no power "
                             f"for this width within its data)")
        ax.axhline(max_power_mw, color="k", ls=":", label="laser maximum")
        ax.set_ylim(0, 1.3 * max_power_mw)
        ax.set_xlim(*speeds_mm_min)
        ax.set_xlabel("speed (mm/min)")
        ax.set_ylabel("power (mW)")
        ax.set_title(f"power for a {width:.2f} mm line")
        ax.legend(fontsize="small", loc="upper right")
        return fig, "\n".join(lines)

    return interact_figure(draw, width=w.FloatSlider(value=min(width_mm, slider_max), min=slider_min,
                                                    max=slider_max, step=0.01,
                                                    description="width (mm)", readout_format=".2f"))


def plot_source(readings, fit, ax=None):
    """P–I readings with the fitted line (left axis) and I–V readings (right axis).

    Parameters
    ----------
    readings : DataFrame or dict
        ``current_a``, ``optical_mw``, optionally ``voltage_v``.
    fit : labkit.laser.source.SourceFit
    ax : matplotlib Axes, optional

    Returns
    -------
    matplotlib Axes
        The power axis (the voltage axis is its twin).
    """
    ax = _axes(ax, figsize=(7, 4.5))
    i = np.asarray(readings["current_a"], float)
    ax.plot(i, readings["optical_mw"], "o", color="tab:blue", label="optical power (readings)")
    grid = np.linspace(0, i.max(), 200)
    ax.plot(grid, fit.power_mw(grid), color="tab:blue",
            label=f"fit: I_th {1000 * fit.threshold_a:.0f} mA, η_s {fit.slope_w_per_a:.2f} W/A")
    ax.axvline(fit.threshold_a, color="tab:blue", ls=":", lw=1)
    ax.set_xlabel("current (A)")
    ax.set_ylabel("optical power (mW)", color="tab:blue")
    if "voltage_v" in readings:
        ax2 = ax.twinx()
        ax2.plot(i, readings["voltage_v"], "s", ms=4, color="tab:orange", label="voltage (readings)")
        if fit.series_ohm is not None:
            above = grid[grid > fit.threshold_a]
            ax2.plot(above, fit.v0_v + fit.series_ohm * above, color="tab:orange", lw=1,
                     label=f"V = {fit.v0_v:.2f} V + {fit.series_ohm:.2f} Ω·I")
        ax2.set_ylabel("voltage (V)", color="tab:orange")
        ax2.legend(loc="lower right", fontsize="small")
    ax.legend(loc="upper left", fontsize="small")
    ax.set_title("laser source: P–I and I–V")
    return ax
