"""The check behind 'every figure a chapter draws has labelled axes' (notebooks/conftest.py runs it on
every figure while nbval executes the chapters): it must flag what a reader cannot read and pass the rest."""

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from tests.notebooks.figure_axes import install, unlabelled_axes  # noqa: E402


def _drawn(fig):
    fig.canvas.draw()
    return fig


@pytest.fixture(autouse=True)
def _close():
    yield
    plt.close("all")


def test_a_plot_without_labels_is_flagged_on_both_axes():
    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 2])
    ax.set_title("speed")
    assert unlabelled_axes(_drawn(fig)) == ["'speed': no x label", "'speed': no y label"]


def test_a_labelled_plot_passes_and_a_missing_y_label_alone_is_named():
    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 2])
    ax.set_xlabel("time (s)")
    ax.set_ylabel("speed (mm/s)")
    assert unlabelled_axes(_drawn(fig)) == []
    ax.set_ylabel("")
    assert unlabelled_axes(_drawn(fig)) == ["'axes 1': no y label"]


def test_a_picture_with_its_axes_off_and_an_empty_panel_need_no_labels():
    fig, (a, b) = plt.subplots(1, 2)
    a.imshow(np.eye(3))
    a.set_axis_off()
    b.text(0.5, 0.5, "a table")
    assert unlabelled_axes(_drawn(fig)) == []


def test_shared_axes_need_the_label_only_where_the_numbers_are():
    fig, (top, bottom) = plt.subplots(2, 1, sharex=True)
    for ax in (top, bottom):
        ax.plot([0, 1], [1, 0])
        ax.set_ylabel("y (mm)")
    bottom.set_xlabel("x (mm)")        # the top panel's x tick labels are hidden by sharex
    assert unlabelled_axes(_drawn(fig)) == []


def test_a_twin_axis_and_a_colour_bar_need_their_own_labels():
    fig, ax = plt.subplots()
    im = ax.imshow(np.eye(3))
    ax.set_xlabel("x (px)")
    ax.set_ylabel("y (px)")
    bar = fig.colorbar(im)
    assert unlabelled_axes(_drawn(fig)) == ["'colour bar': no y label"]
    bar.set_label("power (mW)")
    twin = ax.twinx()
    twin.plot([0, 2], [0, 5])
    assert unlabelled_axes(_drawn(fig)) == ["'axes 3': no y label"]


def test_three_d_axes_need_a_z_label():
    fig = plt.figure()
    ax = fig.add_subplot(projection="3d")
    ax.plot([0, 1], [0, 1], [0, 1])
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    assert unlabelled_axes(_drawn(fig)) == ["'axes 1': no z label"]


def test_install_records_every_figure_rendered_by_savefig(tmp_path):
    from matplotlib.backend_bases import FigureCanvasBase

    original = FigureCanvasBase.print_figure
    try:
        findings = install()
        fig, ax = plt.subplots()
        ax.plot([0, 1], [0, 1])
        fig.savefig(tmp_path / "f.png")
        assert findings == [("", "'axes 1': no x label"), ("", "'axes 1': no y label")]
    finally:
        FigureCanvasBase.print_figure = original
