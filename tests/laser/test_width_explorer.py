"""The target-width explorer of chapter 16: its slider stops where the laser and the data stop, and a width
a model cannot burn at a speed is said to be not reachable (it printed 'nan mW' and drew nothing)."""

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402

from labkit.laser.models import Fit, dose_width  # noqa: E402
from labkit.viz.laser import target_width_explorer  # noqa: E402

W0, FTH = 0.12, 200.0
DOSE = Fit("dose", dict(w0_mm=W0, fth_mj_mm2=FTH), {}, 0.95, 0.001, 25, cov=[[1e-8, 0.0], [0.0, 1e-6]])


def _text(box):
    return box.children[-1].outputs[0]["text"]


def test_the_slider_ends_at_the_widest_line_the_laser_burns_at_the_slowest_speed():
    box = target_width_explorer({"dose": DOSE}, speeds_mm_min=(200, 1600), max_power_mw=2500)
    widest = dose_width(2500, 200, W0, FTH)           # the closed form: 0.304 mm
    assert box.controls["width"].max == np.floor(widest * 100) / 100 == 0.30


def test_the_slider_ends_at_the_widest_line_measured_when_given():
    box = target_width_explorer({"dose": DOSE}, speeds_mm_min=(200, 1600), max_power_mw=2500,
                                max_width_mm=0.2847)
    assert box.controls["width"].max == 0.28


def test_a_width_beyond_the_laser_at_600_mm_min_is_not_reachable_with_the_power_it_needs():
    box = target_width_explorer({"dose": DOSE}, speeds_mm_min=(200, 1600), max_power_mw=2500)
    assert _text(box).startswith("dose: 1206 mW at 600 mm/min")      # 0.2 mm: reachable
    box.controls["width"].value = 0.30
    # by hand: P = F_th exp(W²/2w0²) v w0 / sqrt(2/pi), v = 600/60 mm/s
    need = FTH * np.exp(0.30 ** 2 / (2 * W0 ** 2)) * 10.0 * W0 / np.sqrt(2 / np.pi)
    text = _text(box)
    assert "nan" not in text
    assert text.startswith(f"dose: not reachable at 600 mm/min (needs {need:.0f} mW, more than the laser's 2500 mW)")


def test_a_model_that_cannot_be_inverted_says_so_instead_of_nan():
    from labkit.laser import fit_empirical

    p = np.repeat([500.0, 1000, 1500, 2000, 2500], 5)
    v = np.tile([300.0, 600, 900, 1200, 1500], 5)
    w = dose_width(p, v, W0, FTH)
    empirical = fit_empirical(p, v, np.where(w > 0, w, 0.0))
    box = target_width_explorer({"empirical": empirical}, speeds_mm_min=(200, 1600), max_power_mw=6000)
    box.controls["width"].value = box.controls["width"].max
    assert "nan" not in _text(box)
