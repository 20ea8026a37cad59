"""The command line's Pillow previews (issue 29): the same picture as matplotlib's, without it."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from labkit.gcode import parse
from labkit.viz import preview

ROOT = Path(__file__).resolve().parents[1]
GCODE = ROOT / "data" / "gcode" / "cncjs"


def test_power_colours_are_matplotlibs_plasma():
    import matplotlib

    from labkit.viz.gcode import power_colormap

    f = (np.arange(256) + 0.5) / 256                   # the centres of matplotlib's 256 entries
    ours = preview.power_colours(f).astype(int)
    theirs = np.rint(power_colormap()(f)[:, :3] * 255).astype(int)
    assert np.abs(ours - theirs).max() <= 3       # power_colormap re-samples plasma's table: ±1 more
    reversed_ = np.rint(matplotlib.colormaps["plasma_r"](f)[:, :3] * 255).astype(int)
    assert np.abs(preview.power_colours(f, low=1.0, high=0.0).astype(int) - reversed_).max() <= 3
    assert preview.power_colours([np.nan]).tolist() == [[255, 255, 255]]


def test_power_colours_of_a_grid_are_each_pixels_own():
    """The colours of a picture's grid are worked out for its drawn pixels only, and once
    when they are all one power: each pixel gets what it alone would get."""
    rng = np.random.default_rng(2)
    grid = rng.uniform(-0.5, 1.5, (30, 40))
    grid[rng.random(grid.shape) < 0.4] = np.nan
    grid[0, :3] = (np.inf, -np.inf, 1.0)
    one = np.where(np.isnan(grid), np.nan, 0.37)
    for values in (grid, one):
        for low, high in ((0.0, 0.8), (1.0, 0.0)):
            rgb = preview.power_colours(values, low=low, high=high)
            assert rgb.shape == values.shape + (3,) and rgb.dtype == np.uint8
            for r, c in zip(*np.nonzero(np.ones(values.shape, bool))):
                assert rgb[r, c].tolist() == preview.power_colours([values[r, c]], low=low, high=high)[0].tolist()


def _matplotlib_burn(moves, extent, shape, *, show_travel=False):
    """Drawn pixels of matplotlib's vector drawing (plot_moves) of ``extent`` on ``shape``
    pixels, row 0 at the bottom."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    from labkit.viz.gcode import plot_moves

    rows, cols = shape
    fig = plt.figure(figsize=(cols / 100, rows / 100), dpi=100)
    ax = fig.add_axes((0, 0, 1, 1))
    plot_moves(moves, ax, show_travel=show_travel, colorbar=False, as_image=False, title="")
    ax.get_legend().remove()
    for line in list(ax.lines):                         # the start marker
        line.remove()
    ax.set_xlim(extent[0], extent[1])
    ax.set_ylim(extent[2], extent[3])
    ax.set_axis_off()
    fig.canvas.draw()
    rgb = np.asarray(fig.canvas.buffer_rgba())[..., :3]
    plt.close(fig)
    assert rgb.shape[:2] == shape
    return (rgb.min(axis=2) < 200)[::-1]


def _within(mask, other, pixels):
    """Fraction of ``mask``'s pixels within ``pixels`` of a pixel of ``other``."""
    from scipy.ndimage import binary_dilation

    near = binary_dilation(other, iterations=pixels)
    return float((mask & near).sum() / max(1, mask.sum()))


def _jsdc_svg_with_arcs():
    """cncjs's jsdc.svg (its Béziers fitted as arcs, as svg2gcode --arcs cuts them)."""
    import warnings

    from labkit.toolpath.build import LayerSettings
    from labkit.toolpath.job import vector_job
    from labkit.vector import read_svg

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        drawing = read_svg(ROOT / "data" / "svg" / "cncjs" / "jsdc.svg", tol_mm=0.01)
    return vector_job(drawing.paths, default=LayerSettings(feed_mm_min=1000, s_word=600), arcs=True,
                      tol_mm=0.01).moves


@pytest.mark.parametrize("job", ["jsdc-laser.gcode", "jsdc.svg --arcs", "Circle_Diamond_Square_Calibration.gcode"])
def test_pillow_draws_the_pixels_matplotlib_draws(job):
    """Real jobs: cncjs's laser job (cuts only), its SVG cut with arcs (96 arcs, cuts only),
    and its calibration program (75 arcs, all with the beam off: travel). The Pillow grid
    and matplotlib's vector lines rasterised at the same size cover the same pixels within
    2 px, both ways (matplotlib dashes the rapids: within 3 px there)."""
    if job.endswith("--arcs"):
        moves = _jsdc_svg_with_arcs()
    else:
        moves = parse((GCODE / job).read_bytes(), filename=job, lenient=True).in_work_coordinates()
    travel = not moves.laser_on.any()
    rgb, extent, _ = preview.moves_raster(moves, scale_px_mm=6.0, show_travel=travel)
    ours = rgb.min(axis=2) < 200
    theirs = _matplotlib_burn(moves, extent, ours.shape, show_travel=travel)
    assert ours.sum() > 1000 and theirs.sum() > 1000
    assert _within(theirs, ours, 2) > 0.99
    assert _within(ours, theirs, 3 if travel else 2) > 0.99
    if job != "jsdc-laser.gcode":
        assert moves.is_arc.sum() > 70                   # arcs drawn as arcs, not chords


def test_travel_is_pale_and_under_the_cuts():
    moves = parse("G0 X0 Y0\nM3 S1000\nG1 X10 F600\nM5\nG0 X10 Y10\nG0 X0 Y0\n")
    rgb, extent, travel = preview.moves_raster(moves, scale_px_mm=10.0)
    assert travel
    colours = {tuple(c) for c in rgb.reshape(-1, 3).tolist()}
    assert (179, 179, 179) in colours and tuple(preview.power_colours(1.0).tolist()) in colours
    assert rgb[0, 50].tolist() == preview.power_colours(1.0).tolist()   # the cut along Y0 wins


def test_preview_format_is_checked_without_matplotlib():
    assert preview.preview_format("a.JPG") == "jpg"
    with pytest.raises(Exception, match=r"p\.gcode: cannot draw a '\.gcode' file; expected one of .*\.png"):
        preview.preview_format("p.gcode")


_IMPORTS = """
import json, sys
from labkit.cli import main
code = main(sys.argv[1:])
print(json.dumps({"code": code, "matplotlib": sorted(m for m in sys.modules if m.split('.')[0] == 'matplotlib')}))
"""


def _run_cli(args, cwd):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    done = subprocess.run([sys.executable, "-c", _IMPORTS, *map(str, args)], capture_output=True, text=True,
                          env=env, cwd=cwd, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_no_command_preview_imports_matplotlib(tmp_path):
    """labkit preview, img2gcode's default preview and svg2gcode --preview: a fresh process
    never has matplotlib in sys.modules, and the PNGs are the size asked for."""
    runs = {
        "preview.png": ["preview", GCODE / "tball-pocket-laser.gcode", "-o", tmp_path / "preview.png"],
        "heart.png": ["img2gcode", ROOT / "data" / "images" / "heart.png", "-o", tmp_path / "heart.gcode"],
        "svg.png": ["svg2gcode", GCODE / "jsdc.svg", "-o", tmp_path / "svg.gcode", "--preview",
                    tmp_path / "svg.png"],
    }
    for png, args in runs.items():
        result = _run_cli(args, tmp_path)
        assert result == {"code": 0, "matplotlib": []}, (png, result)
        with Image.open(tmp_path / png) as im:
            assert im.format == "PNG" and im.mode == "RGB"
            size = im.size
        assert size == {"preview.png": (960, 840), "heart.png": (1430, 660), "svg.png": (960, 840)}[png]


def test_vector_previews_are_drawn_by_matplotlib(tmp_path):
    from labkit.cli import main

    out = tmp_path / "p.svg"
    assert main(["preview", str(GCODE / "jsdc-laser.gcode"), "-o", str(out)]) == 0
    assert out.read_text().lstrip().startswith("<?xml") and "<svg" in out.read_text()


def test_job_preview_shows_the_burn_where_the_moves_burn():
    """Left half of a 40 × 20 px mask burned: the picture is dark over the left half of the
    drawing area only (burn_map, averaged down to the picture)."""
    from labkit.raster import mask_job

    mask = np.zeros((20, 40), bool)
    mask[:, :20] = True
    job = mask_job(mask, pixel_mm=1.0, mode="zigzag", feed_mm_min=1000.0)
    image = np.asarray(preview.draw_job(job, dpi=50, max_path_moves=0))
    dark = image.max(axis=2) < 10                      # burned black (the frame's ink is 30)
    cols = np.flatnonzero(dark.any(axis=0))
    rows = np.flatnonzero(dark.any(axis=1))
    width = cols[-1] - cols[0] + 1
    height = rows[-1] - rows[0] + 1
    assert abs(width / height - 1.0) < 0.05            # 20 × 20 mm burned of the 40 × 20 mm area
    assert dark[:, cols[-1] + 3:cols[-1] + width].sum() == 0   # the right half stays white
