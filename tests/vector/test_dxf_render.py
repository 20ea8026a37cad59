"""What labkit cuts from each DXF of data/ against what ezdxf's drawing add-on draws
(issue 27): both rasterised on one pixel grid, every cut lies on ink and every inked edge
is cut, within a tolerance of a few pixels — the DXF counterpart of the resvg checks of
test_render_rules.py.

The add-on draws with a configuration that shows what a laser cuts: HATCH boundaries as
outlines (HatchPolicy.SHOW_OUTLINE — labkit cuts the outline, or fills it when asked),
linetypes solid (labkit cuts a dashed line whole), and only the entity kinds labkit cuts,
plus WIPEOUT and INSERT (text, dimensions, points and faces are skipped by labkit with a
warning and left out of the picture), and polylines without their width (labkit cuts a wide
polyline's centre line, where the add-on fills a band). What is compared is the job's
geometry (chains joined, a piece of no length dropped). Everything else — draw order, wipeouts, blocks,
planes, ellipse ratios — is the add-on's own.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from scipy import ndimage

from labkit.errors import GeometryError
from labkit.vector.dxf import CUT_KINDS, read_dxf

DATA = Path(__file__).resolve().parents[2] / "data" / "dxf"
FILES = sorted(DATA.glob("*.dxf")) + sorted((DATA / "ezdxf").glob("*.[dD][xX][fF]"))
SIDE_PX = 800               # the longer side of the picture
MARGIN_PX = 20
SLACK_PX = 3                # line width, antialiasing and the flattening of both renderings


def ezdxf_ink(path, box):
    """ezdxf's drawing of ``path`` in the drawing's units (the window ``box`` =
    ((x0, y0), (x1, y1)) mapped onto the pixel grid), as a boolean ink mask."""
    import ezdxf
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from ezdxf import recover
    from ezdxf.addons.drawing import Frontend, RenderContext
    from ezdxf.addons.drawing.config import (BackgroundPolicy, ColorPolicy, Configuration,
                                             HatchPolicy, LinePolicy, LineweightPolicy,
                                             TextPolicy)
    from ezdxf.addons.drawing.matplotlib import MatplotlibBackend

    try:
        doc = ezdxf.readfile(path)
    except ezdxf.DXFError:
        doc, _ = recover.readfile(path)
    for layout in [doc.modelspace(), *doc.blocks]:       # a wide polyline is cut along its
        for e in layout.query("LWPOLYLINE POLYLINE"):       # centre line: drawn without width
            if e.dxftype() == "LWPOLYLINE":
                e.set_points(list(e.get_points("xyb")), format="xyb")
                e.dxf.const_width = 0
            else:
                e.dxf.default_start_width = e.dxf.default_end_width = 0
                for v in e.vertices:
                    v.dxf.start_width = v.dxf.end_width = 0
    (x0, y0), (x1, y1) = box
    w, h = grid_size(box)
    fig = plt.figure(figsize=(w / 100, h / 100), dpi=100)
    ax = fig.add_axes([0, 0, 1, 1])
    ax.set_axis_off()
    config = Configuration(hatch_policy=HatchPolicy.SHOW_OUTLINE, line_policy=LinePolicy.SOLID,
                           color_policy=ColorPolicy.COLOR, background_policy=BackgroundPolicy.WHITE,
                           text_policy=TextPolicy.IGNORE, lineweight_policy=LineweightPolicy.ABSOLUTE,
                           lineweight_scaling=0.0, min_lineweight=1.5)  # 2 px
    keep = CUT_KINDS | {"WIPEOUT", "INSERT"}
    frontend = Frontend(RenderContext(doc), MatplotlibBackend(ax, adjust_figure=False), config)
    # every entity black (a layer colour may be white, or missing from the layer table); a
    # WIPEOUT still fills with the background colour, as the add-on draws it
    frontend.push_property_override_function(lambda entity, props: setattr(props, "color", "#000000"))
    frontend.draw_layout(doc.modelspace(), filter_func=lambda e: e.dxftype() in keep)
    ax.set_xlim(x0 - MARGIN_PX * scale(box), x1 + MARGIN_PX * scale(box))
    ax.set_ylim(y0 - MARGIN_PX * scale(box), y1 + MARGIN_PX * scale(box))
    fig.canvas.draw()
    rgb = np.asarray(fig.canvas.buffer_rgba())[:, :, :3]
    plt.close(fig)
    return rgb.min(axis=2) < 200


def scale(box):
    """Drawing units per pixel."""
    (x0, y0), (x1, y1) = box
    return max(x1 - x0, y1 - y0) / (SIDE_PX - 2 * MARGIN_PX)


def grid_size(box):
    (x0, y0), (x1, y1) = box
    s = scale(box)
    return (int(round((x1 - x0) / s)) + 2 * MARGIN_PX, int(round((y1 - y0) / s)) + 2 * MARGIN_PX)


def cut_mask(paths, box):
    """Every cut, sampled every half pixel, on the same grid (row 0 at the top)."""
    (x0, y0), _ = box
    s = scale(box)
    w, h = grid_size(box)
    mask = np.zeros((h, w), bool)
    for p in paths:
        pts = p.sample(0.1 * s)
        for a, b in zip(pts[:-1], pts[1:]):
            k = max(2, int(np.ceil(np.hypot(*(b - a)) / (0.5 * s))) + 1)
            q = a + np.linspace(0.0, 1.0, k)[:, None] * (b - a)
            col = np.round((q[:, 0] - x0) / s + MARGIN_PX).astype(int)
            row = np.round(h - ((q[:, 1] - y0) / s + MARGIN_PX)).astype(int)
            ok = (row >= 0) & (row < h) & (col >= 0) & (col < w)
            mask[row[ok], col[ok]] = True
    return mask


@pytest.mark.parametrize("path", FILES, ids=[f.name for f in FILES])
def test_cuts_match_what_ezdxf_draws(path):
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            d = read_dxf(path, units="mm", tol_mm=1e-3)   # drawing units, whatever they are
    except GeometryError:
        return                       # refused with labkit's error (test_dxf_corpus says which)
    if not d.paths:
        return
    from labkit.geometry.path import paths_bounds
    from labkit.toolpath.build import prepare_paths

    paths = prepare_paths(d.paths, tol_mm=1e-3, order=False)
    lo, hi = paths_bounds(paths)
    box = (tuple(lo), tuple(hi))
    drawn = ezdxf_ink(str(path), box)
    cut = cut_mask(paths, box)
    assert drawn.shape == cut.shape, (drawn.shape, cut.shape)
    assert drawn.any(), f"{path.name}: ezdxf draws nothing where labkit cuts"
    off = cut & ~ndimage.binary_dilation(drawn, iterations=SLACK_PX)
    assert not off.any(), (f"{path.name}: {int(off.sum())} cut pixels where ezdxf draws nothing "
                           f"(first at row, col {np.argwhere(off)[0].tolist()})")
    uncut = drawn & ~ndimage.binary_dilation(cut, iterations=SLACK_PX + 1)
    assert not uncut.any(), (f"{path.name}: {int(uncut.sum())} inked pixels labkit does not cut "
                             f"(first at row, col {np.argwhere(uncut)[0].tolist()})")


def test_the_comparison_sees_a_hidden_line():
    """Not vacuous: the lines under wipeout_random.dxf's WIPEOUT, cut whole (as labkit did
    before issue 27), put cut pixels where ezdxf draws nothing."""
    import ezdxf

    path = DATA / "ezdxf" / "wipeout_random.dxf"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        d = read_dxf(path, units="mm", tol_mm=1e-3)
    from labkit.geometry.path import Path as Cut, paths_bounds

    lines = [Cut([tuple(e.dxf.start)[:2], tuple(e.dxf.end)[:2]]) for e in
             ezdxf.readfile(path).modelspace().query("LINE")]
    lo, hi = paths_bounds(d.paths)
    box = (tuple(lo), tuple(hi))
    drawn = ezdxf_ink(str(path), box)
    off = cut_mask(lines, box) & ~ndimage.binary_dilation(drawn, iterations=SLACK_PX)
    assert off.sum() > 100
