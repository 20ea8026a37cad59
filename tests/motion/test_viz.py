"""Plots and widgets of the motion chapters draw what they say (headless)."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from .motion_jobs import zigzag_moves  # noqa: E402

from labkit.motion import block_profiles, line_points, plan, step_trace  # noqa: E402
from labkit.toolpath import LaserMode, MovesBuilder  # noqa: E402
from labkit.viz import motion as vm  # noqa: E402


@pytest.fixture(autouse=True)
def _close():
    yield
    plt.close("all")


def test_lattice_path_draws_every_point_and_the_exact_line():
    pts = line_points([0, 0], [7, 3])
    ax = vm.plot_lattice_path(pts, line=((0, 0), (7, 3)), title="t")
    marker = [ln for ln in ax.lines if ln.get_marker() == "s"][0]
    assert np.array_equal(np.c_[marker.get_xdata(), marker.get_ydata()], pts)
    assert ax.get_title() == "t"
    ax = vm.plot_lattice_path(pts, colour_by=[0] * 4 + [1] * 4, labels={0: "a", 1: "b"})
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["a", "b"]


def test_profile_plots_reach_the_peak():
    p = block_profiles(10.0, 1.0, 20.0, 1.0, 40, 40)
    for against in ("distance", "time"):
        ax = vm.plot_profile(p, 0, against=against)
        y = ax.lines[0].get_ydata()
        assert y.max() == pytest.approx(20.0) and y[0] == pytest.approx(1.0)


def test_plan_plots_and_super_block_lines():
    p = plan(zigzag_moves(rows=3), planner="hq")
    ax = vm.plot_speed_time(p)
    edges = len(np.flatnonzero(np.diff(p.lookahead.super_block)))
    assert len(ax.lines) == 1 + edges
    assert ax.lines[0].get_ydata().max() == pytest.approx(p.profiles.peak_mm_s.max())
    ax = vm.plot_speed_distance(p)
    assert ax.lines[0].get_xdata().max() == pytest.approx(p.profiles.length_mm.sum())
    ax = vm.plot_power_time(p)
    assert ax.lines[0].get_ydata().max() == pytest.approx(p.blocks.power_mw.max())
    ax = vm.plot_burn(p)
    assert ax.get_ylabel() == "dose (mJ/mm)"


def test_step_rates_follow_the_trace():
    b = MovesBuilder(feed_mm_min=600, s_word=300, laser=LaserMode.DYNAMIC)
    b.line(x=0.2, y=0.1)
    tr = step_trace(plan(b.build(), planner="hq"))
    ax = vm.plot_step_rates(tr)
    x_rate = ax.lines[0].get_ydata()
    assert x_rate.max() <= 10.0 * 2133.34 * 1.01          # X never above 10 mm/s worth of steps
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["X axis", "Y axis"]


def test_compare_planners_table():
    table, plans = vm.compare_planners(zigzag_moves(rows=3))
    assert list(table.index) == ["fast", "normal", "hq", "junction"]
    assert table.loc["hq", "job time (s)"] >= table.loc["fast", "job time (s)"]
    assert set(plans) == set(table.index)


@pytest.mark.parametrize("factory,controls", [
    (vm.bresenham_explorer, {"x_end", "y_end", "radius", "centre_dx", "sweep_deg"}),
    (vm.profile_explorer, {"length_mm", "cap_mm_s", "entry_mm_s", "exit_mm_s", "up", "down", "law"}),
    (lambda: vm.lookahead_explorer(lambda r, s: zigzag_moves(rows=r, segments_per_row=s)),
     {"rows", "segments", "buffer_blocks", "law"}),
    (lambda: vm.laser_explorer(lambda p, f, m: zigzag_moves(rows=2, s_word=p, feed_mm_min=f, laser=m)),
     {"s_word", "feed_mm_min", "mode", "planner", "loops"}),
])
def test_widgets_build_with_their_controls(factory, controls):
    widget = factory()
    assert set(widget.controls) == controls
    shown = widget.children[-1].outputs
    assert any("image/png" in o.get("data", {}) for o in shown)      # drawn on creation
    # labels are words for students (with units), not Python names such as s_word
    for name, control in widget.controls.items():
        label = control.description
        assert label and "_" not in label, f"{name}: label {label!r}"
