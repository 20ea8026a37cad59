"""The G-code preview draws what the program does."""

import matplotlib.pyplot as plt
import numpy as np

from labkit.gcode import parse
from labkit.viz.gcode import arc_explorer, moves_to_segments, plot_arc_choice, plot_moves


def test_preview_layers_cuts_rapids_and_dark_feeds():
    m = parse("G0 X10\nM3 S500\nG1 X20 F100\nG2 X30 I5\nM5\nG1 X0 Y5\nG0 X0 Y0")
    ax = plot_moves(m, colorbar=False)
    labels = sorted(c.get_label() for c in ax.collections)
    assert labels == ["cut", "feed, laser off", "rapid (G0)"]
    cut = next(c for c in ax.collections if c.get_label() == "cut")
    assert np.allclose(cut.get_array(), 50.0)              # S500 of 1000
    segs = cut.get_segments()
    # The half circle is drawn as an arc: G2 from X20 to X30 around X25 bulges up to Y = 5.
    assert max(p[:, 1].max() for p in segs) > 4.99
    plt.close("all")


def test_segments_follow_arcs_within_tolerance():
    m = parse("G0 X10\nG3 X-10 I-10 F100")
    segs, rows = moves_to_segments(m, tol_mm=0.001)
    mids = segs.mean(axis=1)[rows == 1]
    assert (10 - np.hypot(*mids.T)).max() <= 0.001


def test_arc_choice_plot_and_explorer():
    ax = plot_arc_choice((0, 0), (30, 10), 25, True)
    assert "G2" in ax.get_title()
    ax = plot_arc_choice((0, 0), (30, 10), 5, True)           # impossible: R below half the chord
    assert "smaller than half the chord" in ax.get_title()
    panel = arc_explorer()
    assert len(panel.children) == 3
    plt.close("all")


def test_interact_figure_redraws_on_change_and_reports_text():
    import ipywidgets as w

    from labkit.viz._widgets import interact_figure

    calls = []

    def draw(n, label):
        calls.append((n, label))
        fig, ax = plt.subplots()
        ax.plot(range(n))
        return fig, f"{label}: {n} points"

    panel = interact_figure(draw, n=w.IntSlider(value=3, min=1, max=9), label=w.Text(value="run"))
    assert calls == [(3, "run")] and panel.controls["n"].description == "n"
    panel.controls["n"].value = 5
    assert calls[-1] == (5, "run")
    outputs = panel.children[-1].outputs
    assert outputs[0]["text"] == "run: 5 points\n" and "image/png" in outputs[1]["data"]
    assert plt.get_fignums() == []          # figures are closed once rendered


# ---- big jobs are drawn as an image; the preview shows work coordinates ------------------

def test_rasterized_line_and_circle_land_on_their_pixels():
    from labkit.viz.gcode import rasterize_moves

    power, travel, extent = rasterize_moves(parse("M3 S250\nG1 X10 Y10 F100"), pixels=11)
    assert extent == (-0.5, 10.5, -0.5, 10.5)
    np.testing.assert_array_equal(np.isfinite(power), np.eye(11, dtype=bool))
    assert np.nanmax(power) == 25.0 and not travel.any()
    # A full circle of radius 50: every burned pixel centre within one pixel of the circle,
    # and every pixel column it spans is burned (no gaps).
    m = parse("G0 X50\nM3 S1000\nG2 X50 Y0 I-50 J0 F100")
    power, travel, (x0, x1, y0, y1) = rasterize_moves(m, pixels=201)
    cell = (x1 - x0) / power.shape[1]
    iy, ix = np.nonzero(np.isfinite(power))
    r = np.hypot(x0 + (ix + 0.5) * cell, y0 + (iy + 0.5) * cell)
    assert np.abs(r - 50).max() <= cell
    assert set(ix.tolist()) == set(range(power.shape[1]))
    assert travel[np.isnan(power)].sum() >= 1            # the rapid from the origin


def test_big_jobs_are_drawn_as_an_image_small_ones_as_lines():
    from labkit.toolpath import Moves
    from labkit.viz.gcode import IMAGE_ABOVE_MOVES

    n = IMAGE_ABOVE_MOVES // 2 + 1
    y = np.arange(n) * 0.1
    m = Moves.from_cuts(np.stack([np.zeros(n), y], 1), np.stack([np.full(n, 20.0), y], 1),
                        feed_mm_min=3000, s_word=500)
    assert len(m) > IMAGE_ABOVE_MOVES
    ax = plot_moves(m, colorbar=False)
    assert len(ax.images) == 2 and not ax.collections
    burned = np.isfinite(ax.images[1].get_array().filled(np.nan))
    assert burned.mean() > 0.9                              # the hatch covers its box
    ax = plot_moves(m[:100], colorbar=False)
    assert not ax.images and ax.collections
    plt.close("all")


def test_preview_draws_work_coordinates():
    m = parse("G10 L2 P1 X100 Y100\nG0 X0 Y0\nM3 S500\nG1 X10 F100\nG1 Y10")
    assert m.end[:, 0].max() == 110.0
    for as_image in (False, True):
        ax = plot_moves(m, colorbar=False, as_image=as_image)
        lo, hi = ax.get_xlim()
        # The cut ends at work X10 (machine 110); the head starts at machine 0 = work -100.
        assert -104 < lo < -100 and 10 < hi < 14
    plt.close("all")


def test_an_overdrawn_job_is_drawn_on_a_coarser_grid(monkeypatch):
    import labkit.viz.gcode as vg

    m = parse("M3 S500\n" + "G1 X10 Y1 F100\nG1 X0 Y0\n" * 50)
    full, _, _ = vg.rasterize_moves(m, pixels=1001)
    assert full.shape == (101, 1001)
    monkeypatch.setattr(vg, "IMAGE_MAX_STEPS", 10_000)    # 100 pieces x 1000 steps > 10,000
    coarse, _, extent = vg.rasterize_moves(m, pixels=1001)
    assert coarse.shape[1] == 100 and extent[0] < 0 < 10 < extent[1]
    assert np.isfinite(coarse).any(axis=0).all()          # still every column of the line


def test_playground_report_wraps_between_words():
    """The playground's report fits its column without the browser breaking a word: every line
    is at most PLAYGROUND_COLUMNS characters, and joining the lines gives back every word."""
    from labkit.viz.gcode import PLAYGROUND_COLUMNS, gcode_playground

    text = "G21 G90\nG1 X10 Y10\nG2 X30 Y10 R4 F600\nG1 X1.2.5\n"
    panel = gcode_playground(text)
    report = panel.children[0].children[0].children[2]
    shown = "".join(o["text"] for o in report.outputs if o.get("output_type") == "stream")
    lines = shown.rstrip("\n").split("\n")
    assert len(lines) > 10 and max(map(len, lines)) <= PLAYGROUND_COLUMNS
    words = " ".join(shown.split())
    # X1.2.5: GRBL's reader ends the number at the second point and answers error 1 there
    for expected in ("error 22: feed motion without a feed rate", "error 34:",
                     "error 1: a word must start with a letter (got '.';", "estimated time"):
        assert expected in words
    plt.close("all")


def test_numpy_twin_draws_the_pixels_the_compiled_kernel_draws(monkeypatch):
    """The drawing kernel run as Python (numpy, in batches of steps) and compiled: the same
    grids, pixel for pixel, on random pieces that cross the border (clipped) and overlap."""
    from labkit._jit import forced
    from labkit.viz import _gcode_draw

    rng = np.random.default_rng(7)
    pieces = rng.uniform(-20, 220, size=(3000, 2, 2))
    value = rng.uniform(0, 100, 3000)
    burning = rng.random(3000) < 0.6
    monkeypatch.setattr(_gcode_draw, "NUMPY_STEPS", 10_000)     # many batches
    for powers in (value, np.full(3000, 42.0)):                 # one power: the twin's plain store
        with forced("python"):
            py_power, py_travel = _gcode_draw.draw(pieces, powers, burning, (180, 200))
        with forced("compiled"):
            nb_power, nb_travel = _gcode_draw.draw(pieces, powers, burning, (180, 200))
        np.testing.assert_array_equal(py_power, nb_power)
        np.testing.assert_array_equal(py_travel, nb_travel)
        assert np.isfinite(py_power).sum() > 10_000 and py_travel.sum() > 5_000
def test_numpy_twin_draws_pieces_along_the_axes_as_the_kernel_steps_them():
    """Travel, and burning pieces of one power, along X or Y (every piece of a raster job) are
    drawn by the twin as whole runs of pixels; where the kernel's steps of one pixel could
    skip a pixel (a whole number of pixels long, halves rounding to even) the twin walks
    them as the kernel does. The same grids on pieces at half and whole pixels, crossing
    the border, of several powers and of one."""
    from labkit._jit import forced
    from labkit.viz import _gcode_draw

    rng = np.random.default_rng(11)
    runs = whole = 0
    for trial in range(120):
        n = int(rng.integers(1, 300))
        shape = (int(rng.integers(1, 50)), int(rng.integers(1, 50)))
        pieces = rng.uniform(-8, 60, (n, 2, 2))
        if trial % 3 == 0:
            pieces = np.round(pieces * 2) / 2                    # halves: ties of the rounding
        elif trial % 3 == 1:
            pieces = np.round(pieces)                            # whole lengths
        along = rng.random(n)
        pieces[along < 0.45, 1, 1] = pieces[along < 0.45, 0, 1]                          # along X
        pieces[(along >= 0.45) & (along < 0.9), 1, 0] = pieces[(along >= 0.45) & (along < 0.9), 0, 0]
        burning = rng.random(n) < 0.6
        unbroken = _gcode_draw._spans_along_axes(pieces[:, 0, 0], pieces[:, 0, 1], pieces[:, 1, 0],
                                                 pieces[:, 1, 1])[0]
        runs += int(unbroken.sum())
        lengths = np.abs(pieces[:, 1] - pieces[:, 0]).max(axis=1)
        whole += int(((lengths == np.round(lengths)) & (lengths > 0) & (along < 0.9)).sum())
        for value in (rng.uniform(0, 100, n), np.full(n, 55.0)):
            with forced("python"):
                py_power, py_travel = _gcode_draw.draw(pieces, value, burning, shape)
            with forced("compiled"):
                nb_power, nb_travel = _gcode_draw.draw(pieces, value, burning, shape)
            np.testing.assert_array_equal(py_power, nb_power)
            np.testing.assert_array_equal(py_travel, nb_travel)
    assert runs > 5000 and whole > 2000


