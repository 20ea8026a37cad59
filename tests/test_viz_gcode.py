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
