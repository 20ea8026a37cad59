"""The rotating-wire probe ([MicroCAM] ch. 4) against geometry worked independently:
the tip's sweep by rotating the wire in 3-D, contact overshoot bounded by the feed per
revolution, a scanned cylinder against its true circle, a gauge block calibration."""

import dataclasses
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from labkit.cli import main
from labkit.errors import GeometryError
from labkit.micromachining.probe import (ProbeSettings, ae_signal, calibrate_effective_diameter_mm, circle_part,
                                         detect_contact, effective_diameter_mm, fit_circle, probe_contact,
                                         profile_error_mm, rounded_square_part, scan_errors, scan_xy)


@pytest.mark.parametrize("length, bend, stylus_r, wire_d", [(1.0, 45.0, 0.0, 0.0), (0.5, 45.0, 0.0635, 0.102),
                                                             (0.8, 30.0, 0.2, 0.05), (0.3, 80.0, 0.1, 0.0)])
def test_effective_diameter_is_the_swept_tip_circle(length, bend, stylus_r, wire_d):
    """Build the bent wire in 3-D — leaving the stylus at R_s, bent β from the spin axis, its
    cut end a disc of diameter d_w square to the wire — spin it about z, and take the widest
    point any rim point reaches."""
    b = math.radians(bend)
    axis = np.array([math.sin(b), 0.0, -math.cos(b)])          # along the wire, outwards and down
    tip = np.array([stylus_r, 0.0, 0.0]) + length * axis
    # rim of the cut end: circle of radius d_w/2 square to the wire
    e1 = np.array([math.cos(b), 0.0, math.sin(b)])             # ⟂ axis, in the bend plane
    e2 = np.array([0.0, 1.0, 0.0])
    a = np.linspace(0, 2 * np.pi, 3601)
    rim = tip + (wire_d / 2) * (np.cos(a)[:, None] * e1 + np.sin(a)[:, None] * e2)
    spin = Rotation.from_euler("z", np.linspace(0, 360, 73)[:, None], degrees=True)
    swept = np.concatenate([spin[k].apply(rim) for k in range(len(spin))])
    reach = np.hypot(swept[:, 0], swept[:, 1]).max()
    assert effective_diameter_mm(length, bend, stylus_r, wire_d) == pytest.approx(2 * reach, abs=1e-7)


def test_a_wire_inside_the_stylus_and_bad_geometry_are_refused():
    with pytest.raises(GeometryError, match="stylus would touch first"):
        effective_diameter_mm(0.05, 45.0, 0.0, stylus_outer_radius_mm=0.1)
    for bad in ((0.0, 45.0), (1.0, 0.0), (1.0, 95.0)):
        with pytest.raises(GeometryError):
            effective_diameter_mm(*bad)


def test_detection_takes_the_first_pulse_and_ignores_the_later_ones():
    s = ProbeSettings(noise_rms=0.0)
    t = np.arange(400) / s.sample_rate_hz
    sig = ae_signal(t, np.array([0.002, 0.008, 0.014]), s, np.random.default_rng(1))
    assert detect_contact(sig, s.threshold) == int(np.ceil(0.002 * s.sample_rate_hz))
    assert detect_contact(np.zeros(10), 0.1) == -1
    # with noise at a tenth of the threshold, no false contact before the touch over 50 seeds
    noisy = ProbeSettings(noise_rms=0.01, threshold=0.1)
    for seed in range(50):
        sig = ae_signal(t, np.array([0.01]), noisy, np.random.default_rng(seed))
        assert detect_contact(sig, noisy.threshold) >= int(0.01 * noisy.sample_rate_hz)


def test_the_contact_overshoots_by_at_most_one_feed_per_revolution():
    """The tip faces the part once per revolution at a random phase: the recorded centre lies
    beyond the geometric contact by 0 … f/RPM (plus one sample of travel), spread over it."""
    s = ProbeSettings(feed_mm_min=20.0, rpm=10_000.0)            # 2 µm per revolution
    part = circle_part((0.0, 0.0), 5.0)
    over = []
    for seed in range(200):
        rec, geo = probe_contact((-7.0, 0.3), (1.0, 0.0), part, s, np.random.default_rng(seed), max_travel_mm=5.0)
        assert part(geo) == pytest.approx(s.radius_mm, abs=1e-9)      # exactly at reach
        over.append(rec[0] - geo[0])
        assert rec[1] == pytest.approx(0.3)
    over = np.array(over)
    per_sample = s.feed_mm_min / 60.0 / s.sample_rate_hz
    assert over.min() >= -1e-12
    assert over.max() <= s.feed_per_rev_mm + per_sample + 1e-12
    assert over.max() - over.min() > 0.8 * s.feed_per_rev_mm        # the resolution is the whole rev
    assert over.mean() == pytest.approx(s.feed_per_rev_mm / 2, rel=0.15)


def test_no_contact_and_a_start_within_reach_are_named_errors():
    part = circle_part((0.0, 0.0), 1.0)
    rng = np.random.default_rng(0)
    with pytest.raises(GeometryError, match="no contact within"):
        probe_contact((-5.0, 0.0), (-1.0, 0.0), part, ProbeSettings(), rng, max_travel_mm=2.0)
    with pytest.raises(GeometryError, match="within the probe's reach"):
        probe_contact((-1.5, 0.0), (1.0, 0.0), part, ProbeSettings(), rng)
    with pytest.raises(GeometryError, match="never crossed the threshold"):
        probe_contact((-5.0, 0.0), (1.0, 0.0), part, ProbeSettings(threshold=5.0), rng, max_travel_mm=5.0)


def test_a_scanned_plug_gauge_gives_its_circle():
    """[MicroCAM] §4.4's 12.7 mm plug gauge, about a hundred points around it: the compensated
    profile fits a circle of the true diameter (less the mean overshoot) and centre."""
    s = ProbeSettings(feed_mm_min=10.0, rpm=10_000.0)            # 1 µm per revolution
    res = scan_xy(circle_part((2.0, -1.0), 6.35), (-8.0, -1.0), (1.0, 0.0), s, step_mm=0.45, seed=4)
    assert 95 <= len(res.contacts) <= 105
    centre, r = fit_circle(res.profile)
    assert np.abs(centre - [2.0, -1.0]).max() < 0.2e-3
    # each contact stops on average half a revolution's approach late: inside by f/2
    assert r == pytest.approx(6.35 - s.feed_per_rev_mm / 2, abs=0.2e-3)
    # the contact centres lie on the circle of reach (6.35 + D_e / 2) up to the overshoot
    reach = np.hypot(*(res.contacts - [2.0, -1.0]).T)
    assert reach.max() <= 6.35 + s.radius_mm + 1e-9
    assert reach.min() >= 6.35 + s.radius_mm - s.feed_per_rev_mm - 1e-6
    # every start is outside the part's reach, and the scan went once around
    assert all(circle_part((2.0, -1.0), 6.35)(p) > s.radius_mm for p in res.starts)
    angle = np.unwrap(np.arctan2(res.contacts[:, 1] + 1.0, res.contacts[:, 0] - 2.0))
    assert abs(angle[-1] - angle[0]) == pytest.approx(2 * np.pi, abs=1.5 * 0.45 / (6.35 + s.radius_mm))


def test_the_reconstruction_error_follows_the_feed_per_revolution():
    """The error table the issue asks for: on a rounded square, the largest error is bounded by
    the feed per revolution plus the normal estimate's error, which grows with the step-over."""
    part = rounded_square_part((0.0, 0.0), 10.0, 2.0)
    df = scan_errors(part, (-7.0, 0.0), (1.0, 0.0), step_overs_mm=[0.25, 1.0],
                     feeds_per_rev_mm=[1e-4, 1e-3, 1e-2], seed=2)
    for step, g in df.groupby("step_mm"):
        g = g.sort_values("feed_per_rev_mm")
        if step == 0.25:                                          # where the resolution dominates
            assert np.all(np.diff(g.rms_error_mm) > 0)           # coarser resolution, larger error
        assert g.rms_error_mm.iloc[-1] > 5 * g.rms_error_mm.iloc[0]
        # the probe stops late by f/2 on average: the profile lies inside by about that
        coarse = g.iloc[-1]
        assert coarse.mean_error_mm == pytest.approx(-coarse.feed_per_rev_mm / 2, rel=0.2)
    fine = df[df.step_mm == 0.25]
    # (the normal estimated from neighbours adds up to ~0.15 µm where a side meets a corner)
    assert np.all(fine.max_error_mm <= 1.05 * fine.feed_per_rev_mm + 1.5e-4)
    # a step-over of 1 mm on 2 mm corners: the normal from neighbouring contacts errs by µm
    assert df[(df.step_mm == 1.0) & (df.feed_per_rev_mm == 1e-4)].max_error_mm.iloc[0] > \
        df[(df.step_mm == 0.25) & (df.feed_per_rev_mm == 1e-4)].max_error_mm.iloc[0]


def test_signed_distances_of_the_parts():
    sq = rounded_square_part((1.0, 1.0), 10.0, 2.0)
    assert sq((6.5, 1.0)) == pytest.approx(0.5)
    assert sq((1.0, 1.0)) == pytest.approx(-5.0)
    assert sq((1.0 + 3 + 2 / math.sqrt(2), 1.0 + 3 + 2 / math.sqrt(2))) == pytest.approx(0.0, abs=1e-12)
    assert profile_error_mm([[7.0, 0.0], [0.0, 3.0]], circle_part((0, 0), 5.0)).tolist() == [2.0, -2.0]


def test_calibration_on_a_simulated_gauge_block():
    """[MicroCAM] calibrated D_e on a 20 mm gauge block: touch both faces, the centres lie a
    block width plus D_e apart. Here the faces of a 20 mm square are touched in the simulation."""
    s = ProbeSettings(feed_mm_min=1.0, rpm=10_000.0)             # 0.1 µm per revolution
    block = rounded_square_part((0.0, 0.0), 20.0, 0.0)
    rng = np.random.default_rng(3)
    left, _ = probe_contact((-12.0, 0.0), (1.0, 0.0), block, s, rng, max_travel_mm=5.0)
    right, _ = probe_contact((12.0, 0.0), (-1.0, 0.0), block, s, rng, max_travel_mm=5.0)
    de = calibrate_effective_diameter_mm(right[0] - left[0], 20.0)
    assert de == pytest.approx(s.effective_diameter_mm, abs=2 * s.feed_per_rev_mm + 1e-9)
    with pytest.raises(GeometryError, match="farther apart"):
        calibrate_effective_diameter_mm(19.0, 20.0)


def test_probe_command(capsys, tmp_path):
    assert main(["probe", "diameter", "--length", "1", "--bend", "30"]) == 0
    assert "D_e = 1 mm" in capsys.readouterr().out                   # 2 · 1 · sin 30°
    assert main(["probe", "scan", "--step", "0.5", "--feed-per-rev", "0.001", "--csv", str(tmp_path / "s.csv")]) == 0
    out = capsys.readouterr().out
    assert "91 contacts" in out and "fitted circle: diameter 12.699" in out
    data = np.loadtxt(tmp_path / "s.csv", delimiter=",", skiprows=1)
    assert data.shape == (91, 5) and np.abs(data[:, 4]).max() <= 0.00101
    assert main(["probe", "scan", "--part", "square", "--size", "10", "--step", "0.5", "1",
                 "--feed-per-rev", "0.001"]) == 0
    assert len(capsys.readouterr().out.strip().splitlines()) == 3       # header and two rows
    assert main(["probe", "calibrate", "--distance", "21.629", "--block", "20"]) == 0
    assert "D_e = 1.629 mm" in capsys.readouterr().out
    assert main(["probe", "scan", "--part", "square", "--size", "4", "--corner", "3"]) == 1
    assert "--corner 3 mm is more than half the side" in capsys.readouterr().err
