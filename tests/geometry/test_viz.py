"""Smoke tests of the geometry plots and widgets (headless): they draw what they say."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from labkit.geometry import Path  # noqa: E402
from labkit.viz import geometry as vg  # noqa: E402

CTRL = np.array([[0, 0], [10, 40], [50, -20], [60, 20]], float)


def test_plots_draw_their_geometry():
    ax = vg.plot_paths([Path.rectangle(0, 0, 10, 5), Path.circle((20, 2), 2)])
    assert len(ax.collections) == 6                     # 4 lines + 2 arcs
    ax = vg.plot_bezier_split(CTRL, 0.3)
    assert len(ax.lines) >= 6
    ax = vg.plot_flattening(CTRL, "absolute", 0.5)
    assert "segments" in ax.get_title()
    ax = vg.plot_ellipse_arcs(20, 10, 3)
    assert "max deviation" in ax.get_title()
    ax = vg.plot_travel([Path.rectangle(0, 0, 1, 1), Path.rectangle(5, 0, 1, 1)])
    assert ax.get_title().endswith("travel 5 mm")             # (0,0) → (0,0), then (0,0) → (5,0)
    plt.close("all")


def test_error_along_matches_reported_deviation():
    from labkit.geometry import ellipse_to_arcs

    t, err = vg.ellipse_error_along(20, 10, 4, samples=20001)
    assert err.max() == pytest.approx(ellipse_to_arcs((0, 0), 20, 10, arcs_per_quadrant=4).deviation_mm,
                                      rel=0.02)


def test_widgets_build():
    for widget in (vg.bezier_explorer(), vg.ellipse_explorer(),
                   vg.svg_job_explorer([Path.rectangle(0, 0, 10, 5), Path.circle((20, 2), 2)])):
        assert widget.children
    plt.close("all")
