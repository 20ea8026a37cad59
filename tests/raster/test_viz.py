"""The raster plots and widgets build headless and draw what they say."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from skimage import data  # noqa: E402

from labkit.raster import burn_map, gray_job, mask_job, to_gray  # noqa: E402
from labkit.viz import raster as vr  # noqa: E402


@pytest.fixture(autouse=True)
def _close():
    yield
    plt.close("all")


def test_edge_panel_has_six_panels():
    fig = vr.edge_panel(to_gray(data.coins()[::4, ::4]), fraction=0.2, blur=True, pseudo=True)
    titles = [ax.get_title() for ax in fig.axes if ax.get_title()]
    assert len(titles) == 6 and titles[0] == "input (blurred)" and any("Canny" in t for t in titles)


def test_burned_image_and_plot_job():
    mask = ~data.horse()[::8, ::8]
    job = mask_job(mask, pixel_mm=1.0, mode="spiral")
    assert np.array_equal(vr.burned_image(job) > 0, mask)
    ax = vr.plot_job(job)
    assert "spiral" in ax.get_title() and f"{job.report.segments} segments" in ax.get_title()


def test_preview_file(tmp_path):
    g = to_gray(data.camera()[::8, ::8])
    job = gray_job(g, pixel_mm=0.5, dither="floyd-steinberg")
    out = tmp_path / "p.png"
    vr.save_job_preview(job, out)
    assert out.stat().st_size > 5_000
    count, _ = burn_map(job.moves, g.shape, 0.5)
    assert count.max() == 1


def test_widgets_build():
    mask = ~data.horse()[::8, ::8]
    g = to_gray(data.camera()[::8, ::8])
    for w in (vr.edge_explorer({"camera": g}), vr.path_explorer({"horse": mask}), vr.gray_explorer(g)):
        assert len(w.children) >= 4   # controls + output
        assert any("image/png" in o.get("data", {}) for o in w.children[-1].outputs)


def test_a_big_job_is_previewed_on_a_coarse_grid_that_shows_the_burn(tmp_path, monkeypatch):
    mask = ~data.horse()[::4, ::4]
    job = mask_job(mask, pixel_mm=0.5, mode="zigzag")
    monkeypatch.setattr(vr, "FULL_BURN_MAP_PIXELS", 0)
    monkeypatch.setattr(vr, "burned_image", lambda job: pytest.fail("full burn map drawn"))
    captured = {}
    real_imshow = matplotlib.axes.Axes.imshow

    def imshow(ax, img, *args, **kwargs):
        captured.setdefault("img", np.asarray(img))
        return real_imshow(ax, img, *args, **kwargs)

    monkeypatch.setattr(matplotlib.axes.Axes, "imshow", imshow)
    out = tmp_path / "big.png"
    vr.save_job_preview(job, out)
    assert out.stat().st_size > 5_000
    # The coarse grid burns where the mask is dark: compare the fraction of burned area
    # with the mask's (the grid's pixels are not the image's, so only to a few %).
    img = captured["img"]
    assert max(img.shape) <= max(mask.shape) + 1 and img.max() == 100.0
    assert abs((img > 0).mean() - mask.mean()) < 0.05 * max(mask.mean(), 0.1) + 0.02
