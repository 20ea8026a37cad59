"""Plots and widgets for the raster chapters (06 edge detection, 07 tool paths, 08 gray engraving).

matplotlib and ipywidgets are imported inside the functions, so importing
this module costs nothing.
"""

from __future__ import annotations

import numpy as np

from labkit.raster import (burn_map, detect_edges, gray_job, mask_job, max_magnitude, prewitt, roberts,
                           sobel)
from labkit.viz._widgets import interact_figure
from labkit.viz.gcode import plot_moves

__all__ = ["show_images", "edge_panel", "edge_explorer", "burned_image", "plot_job", "path_explorer",
           "gray_explorer", "save_job_preview"]

_MAGNITUDE = {"roberts": roberts, "sobel": sobel, "prewitt": prewitt}


def show_images(images: dict, *, ncols: int = 3, size: float = 3.2, cmap: str = "gray", vmax=None):
    """A grid of images with titles; boolean masks are drawn black = burn.

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib.pyplot as plt

    n = len(images)
    nrows = -(-n // ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(size * ncols, size * nrows * 0.85), squeeze=False)
    for ax, (title, img) in zip(axes.flat, images.items()):
        arr = np.asarray(img)
        if arr.dtype == bool:
            ax.imshow(~arr, cmap="gray", vmin=0, vmax=1, interpolation="nearest")
        else:
            ax.imshow(arr, cmap=cmap, vmin=0, vmax=vmax, interpolation="nearest")
        ax.set_title(title, fontsize="medium")
    for ax in axes.flat:
        ax.set_axis_off()
    fig.tight_layout()
    return fig


def edge_panel(gray, *, fraction: float = 0.25, blur: bool = False, pseudo: bool = False,
               level: float = 128, sigma: float = 2.0):
    """The four seed detectors and Canny side by side on one gray image.

    ``fraction`` sets each gradient operator's threshold as a fraction of
    its :func:`~labkit.raster.max_magnitude`.
    """
    from labkit.raster import blur as _blur

    shown = _blur(gray) if blur else np.asarray(gray, dtype=float)
    images = {"input" + (" (blurred)" if blur else ""): shown}
    images["SXOR"] = detect_edges(gray, "sxor", blur=blur, level=level)
    for op in ("roberts", "sobel", "prewitt"):
        t = fraction * max_magnitude(op, pseudo=pseudo)
        images[f"{op.title()}{' pseudo' if pseudo else ''} ≥ {t:.0f}"] = detect_edges(
            gray, op, threshold=t, pseudo=pseudo, blur=blur)
    images[f"Canny σ={sigma:g} (scikit-image)"] = detect_edges(gray, "canny", sigma=sigma, blur=blur)
    return show_images(images, ncols=3, vmax=255)


def edge_explorer(images: dict):
    """Widget: pick an image, a threshold fraction, blur and pseudo-convolution; see all detectors."""
    import ipywidgets as w
    import matplotlib.pyplot as plt

    def show(image, fraction, blur, pseudo):
        edge_panel(images[image], fraction=fraction, blur=blur, pseudo=pseudo)
        return plt.gcf()

    return interact_figure(show, image=w.Dropdown(options=list(images)),
                         fraction=w.FloatSlider(value=0.2, min=0.02, max=0.6, step=0.02,
                                                description="threshold"),
                         blur=w.Checkbox(value=False, description="blur first"),
                         pseudo=w.Checkbox(value=False, description="pseudo-convolution"))


def burned_image(job) -> np.ndarray:
    """What the job's moves burn, rasterised back: S per pixel (0 = untouched)."""
    _, power = burn_map(job.moves, job.report.shape, job.report.pixel_mm)
    return power


def plot_job(job, ax=None, *, show_travel: bool = True, title: str | None = None):
    """The job's path (cuts coloured by power, travel dashed) with its key figures in the title."""
    r = job.report
    if title is None:
        title = (f"{r.mode}: {r.segments} segments, {r.tool_lines} tool lines\n"
                 f"cut {r.cut_mm:.0f} mm, travel {r.travel_mm:.0f} mm")
    ax = plot_moves(job.moves, ax, show_travel=show_travel, colorbar=False, linewidth=0.8, title=title,
                    cmap="plasma_r")
    ax.title.set_fontsize("medium")
    return ax


def path_explorer(masks: dict, *, pixel_mm: float = 1.0, feed_mm_min: float = 1300.0):
    """Widget: zig-zag vs spiral on a mask, with the connection order and the report."""
    import ipywidgets as w
    import matplotlib.pyplot as plt

    def show(image, mode, order, direction):
        job = mask_job(masks[image], pixel_mm=pixel_mm, mode=mode, order=order, direction=direction,
                       feed_mm_min=feed_mm_min)
        fig, ax = plt.subplots(figsize=(7, 6))
        plot_job(job, ax)
        return fig, job.report.format()

    return interact_figure(show, image=w.Dropdown(options=list(masks)),
                         mode=w.ToggleButtons(options=["zigzag", "spiral"]),
                         order=w.ToggleButtons(options=["indexed", "scan"]),
                         direction=w.ToggleButtons(options=["bidirectional", "unidirectional"]))


def gray_explorer(gray, *, pixel_mm: float = 0.2, feed_mm_min: float = 3000.0):
    """Widget: power range, gamma, dithering and overscan on one gray image."""
    import ipywidgets as w
    import matplotlib.pyplot as plt

    from labkit.raster import DIFFUSION, adjust_gamma

    def show(min_power, max_power, gamma, method, overscan_mm):
        g = adjust_gamma(gray, gamma)
        job = gray_job(g, pixel_mm=pixel_mm, feed_mm_min=feed_mm_min, min_power=min_power,
                       max_power=max(min_power, max_power),
                       dither=None if method == "power" else method, overscan_mm=overscan_mm)
        fig, axes = plt.subplots(1, 2, figsize=(10, 4.6))
        axes[0].imshow(burned_image(job), cmap="gray_r", vmin=0, vmax=job.moves.s_max,
                       interpolation="nearest")
        axes[0].set_title("S per pixel, rasterised back from the moves")
        axes[0].set_axis_off()
        r = job.report
        axes[1].barh(["burn", "overscan + gaps (S0)", "rapids"], [r.cut_mm, r.idle_feed_mm, r.travel_mm],
                     color=["tab:red", "tab:cyan", "0.6"])
        axes[1].set_xlabel("distance (mm)")
        axes[1].set_ylabel("the head's path")
        axes[1].set_title(f"estimated time {r.time_s / 60:.1f} min at F{feed_mm_min:g}")
        fig.tight_layout()
        return fig

    wide = {"description_width": "initial"}       # the labels shown whole, not cut off
    return interact_figure(show,
                         min_power=w.FloatSlider(value=0.1, min=0.0, max=1.0, step=0.05,
                                                 description="min power (share of full)", style=wide),
                         max_power=w.FloatSlider(value=0.8, min=0.05, max=1.0, step=0.05,
                                                 description="max power (share of full)", style=wide),
                         gamma=w.FloatSlider(value=1.0, min=0.3, max=3.0, step=0.1, description="gamma"),
                         method=w.Dropdown(options=["power"] + sorted(DIFFUSION), description="mode"),
                         overscan_mm=w.FloatSlider(value=2.0, min=0.0, max=10.0, step=0.5,
                                                   description="overscan (mm)", style=wide))


#: Above this many image pixels the preview's left panel draws the moves on a grid of
#: :data:`labkit.viz.gcode.IMAGE_PIXELS` instead of rasterising them back pixel for pixel:
#: the figure shows ~800 pixels across anyway, and the full map costs 16 bytes a pixel
#: (1.9 GB for a 10,837² job) and seconds to hand to matplotlib.
FULL_BURN_MAP_PIXELS = 4_000_000


def save_job_preview(job, path, *, dpi: int = 110, max_path_moves: int = 200_000) -> None:
    """PNG with what the moves burn (rasterised back) and, for jobs not too large, the path drawing.

    Jobs of more than :data:`FULL_BURN_MAP_PIXELS` pixels are rasterised on a coarser
    grid (:func:`labkit.viz.gcode.rasterize_moves`), so the preview takes a bounded time
    and memory whatever the image size.
    """
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    from labkit.viz.gcode import IMAGE_PIXELS, rasterize_moves

    draw_path = len(job.moves) <= max_path_moves
    fig, axes = plt.subplots(1, 2 if draw_path else 1, figsize=(13 if draw_path else 7, 6), squeeze=False)
    r = job.report
    w, h = r.size_mm
    rows, cols = r.shape
    if rows * cols <= FULL_BURN_MAP_PIXELS:
        axes[0, 0].imshow(burned_image(job), cmap="gray_r", vmin=0, vmax=job.moves.s_max,
                          extent=(0, w, 0, h), interpolation="nearest")
        axes[0, 0].set_title(f"burned pixels ({r.mode}), rasterised back from the moves")
    else:
        # Never finer than the beam pixels, or the scan lines would show as stripes.
        power, _, extent = rasterize_moves(job.moves, pixels=min(IMAGE_PIXELS, max(rows, cols)))
        axes[0, 0].imshow(np.nan_to_num(power, nan=0.0), cmap="gray_r", vmin=0, vmax=100.0,
                          origin="lower", extent=extent, interpolation="nearest")
        axes[0, 0].set_xlim(0, w)
        axes[0, 0].set_ylim(0, h)
        axes[0, 0].set_title(f"burned ({r.mode}), the moves drawn on a "
                             f"{power.shape[1]} × {power.shape[0]} grid")
    axes[0, 0].set_xlabel("X (mm)")
    axes[0, 0].set_ylabel("Y (mm)")
    if draw_path:
        plot_job(job, axes[0, 1])
    fig.tight_layout()
    from labkit._files import write_figure    # a temporary file renamed when complete

    write_figure(fig, path, dpi=dpi)
    plt.close(fig)
