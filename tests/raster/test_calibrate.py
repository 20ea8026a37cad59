"""Raster calibration (issue 30 §4, §5): scan offset from a simulated late beam, tone from a known curve.

The synthetic scans are made by labkit's burn simulator (the scan-offset pattern burned with a
beam that switches a known time late: ``simulate_burn(beam_delay_s=...)``) and by the cut-width
grid's scan renderer (the wedge's lines drawn at widths from a known curve), never by the fits'
own formulas.
"""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from labkit.errors import InputError
from labkit.laser.measure import render_scan
from labkit.laser.scanoffset import (ScanOffset, apply_scan_offset, fit_scan_offset, load_scan_offset,
                                     measure_scan_offset, scan_offset_pattern)
from labkit.laser.simulate import simulate_burn
from labkit.laser.tone import fit_tone, isotonic, load_tone, measure_wedge, wedge_pattern
from labkit.motion.spec import load_machine
from labkit.toolpath.moves import Moves

DIODE = load_machine("grbl-diode")      # 6000 mm/min: fast enough for a delay to show
W0, FTH = 0.1, 50.0


def _burned_scan(delay_s, *, rotation_deg=0.0, speeds=(1200, 2400, 3600, 4800)):
    g = scan_offset_pattern(speeds, power_mw=2000, pairs=3, line_mm=6, machine=DIODE)
    burn = simulate_burn(g.moves, machine=DIODE, w0_mm=W0, fth_mj_mm2=FTH, pixel_mm=0.02, beam_delay_s=delay_s)
    return g, burn.scan(dpi=1000, noise=0.02, rotation_deg=rotation_deg)


@pytest.mark.parametrize("delay_s, rotation_deg", [(0.002, 0.0), (0.0008, 1.5)])
def test_known_beam_delay_recovered_within_5_percent(delay_s, rotation_deg):
    g, img = _burned_scan(delay_s, rotation_deg=rotation_deg)
    df = measure_scan_offset(img, g.layout)
    # each direction lands v·delay off its command: the rows part by 2·v·delay
    expected = 2 * df.speed_mm_min / 60 * delay_s
    assert np.allclose(df.offset_mm, expected, atol=0.01 + 0.05 * expected)
    fit = fit_scan_offset(df.speed_mm_min, df.offset_mm, df.offset_sd_mm)
    assert fit.beam_delay_s == pytest.approx(delay_s, rel=0.05)
    assert abs(fit.intercept_mm) < 0.01
    assert fit.slope_sd_s < 0.05 * fit.slope_s


def test_pattern_rows_alternate_and_stay_in_layout():
    g = scan_offset_pattern([1200, 2400], power_mw=2000, pairs=2, line_mm=6, machine=DIODE)
    lines = g.layout["lines"]
    assert [ln["direction"] for ln in lines if ln["col"] == 0] == ["+X", "-X", "+X", "-X"]
    burn = g.moves[g.moves.laser_on]
    for ln in lines:
        on = (burn.start[:, 1] == ln["y_mm"]) & (np.minimum(burn.start[:, 0], burn.end[:, 0]) == ln["x0_mm"])
        assert on.sum() == 1
        dx = float(burn.end[on, 0][0] - burn.start[on, 0][0])
        assert dx == pytest.approx(6.0 if ln["direction"] == "+X" else -6.0)
    # the overscan lets the fastest feed be reached: v²/2a = (40 mm/s)²/(2·1000 mm/s²) = 0.8 mm
    assert g.layout["overscan_mm"] >= 0.8


def test_pattern_refuses_speed_above_machine_rate():
    with pytest.raises(InputError, match="above the machine's X rate"):
        scan_offset_pattern([1000, 2000], power_mw=1000)          # the CBR40 runs 1546 mm/min
    with pytest.raises(InputError, match="two speeds"):
        scan_offset_pattern([1000], power_mw=1000, machine=DIODE)


def test_apply_scan_offset_hand_worked():
    # a forward row at y 0, a link, a backward row at y 1, both at 3000 mm/min (50 mm/s)
    starts = [[-1, 0], [0, 0], [10, 0], [11, 0], [11, 1], [10, 1], [0, 1]]
    ends = [[0, 0], [10, 0], [11, 0], [11, 1], [10, 1], [0, 1], [-1, 1]]
    m = Moves.from_cuts(starts, ends, feed_mm_min=3000, s_word=[0, 500, 0, 0, 0, 500, 0], origin=(-1, 0, 0))
    assert len(m) == 7                                 # no rapid: one contiguous path
    out = apply_scan_offset(m, ScanOffset(slope_s=0.004, intercept_mm=0.01))
    shift = 0.004 * 50 + 0.01                          # 0.21 mm
    assert np.array_equal(out.start[:4], m.start[:4]) and np.array_equal(out.end[:3], m.end[:3])
    assert out.end[3, 0] == pytest.approx(11.0 + shift)    # the link leaves the forward row where it was
    assert np.allclose(out.start[4:, 0] - m.start[4:, 0], shift)
    assert np.allclose(out.end[4:, 0] - m.end[4:, 0], shift)
    assert np.allclose(out.start[1:], out.end[:-1])    # still one contiguous path
    assert np.array_equal(out.start[:, 1], m.start[:, 1])


def test_corrected_gray_job_lands_aligned():
    """A bidirectional gray block burned with a late beam: ragged edges, straight after the correction."""
    from labkit.raster.engrave import gray_job

    delay = 0.002
    job = gray_job(np.zeros((8, 40)), pixel_mm=0.1, feed_mm_min=3000, s_max=1000, overscan_mm=1.5)

    def left_edges(moves):
        burn = simulate_burn(moves, machine=DIODE, w0_mm=0.05, fth_mj_mm2=FTH, pixel_mm=0.01, beam_delay_s=delay)
        ys = np.unique(moves.start[moves.laser_on, 1])
        rows = np.rint((ys - burn.y_mm[0]) / burn.pixel_mm).astype(int)
        return np.array([burn.x_mm[np.argmax(burn.burned[r])] for r in rows])

    before = left_edges(job.moves)
    # backward rows land 2·v·delay = 2·50·0.002 = 0.2 mm left of the forward ones
    assert np.ptp(before[0::2] - before[1::2].mean()) < 0.02
    assert before[0::2].mean() - before[1::2].mean() == pytest.approx(0.2, abs=0.02)
    after = left_edges(apply_scan_offset(job.moves, ScanOffset(slope_s=2 * delay, intercept_mm=0.0)))
    assert abs(after[0::2].mean() - after[1::2].mean()) < 0.02


def test_apply_scan_offset_refuses_column_scans():
    m = Moves.from_cuts([[0, 0], [1, 10]], [[0, 10], [1, 0]], feed_mm_min=3000, s_word=500)
    with pytest.raises(InputError, match="scans along Y"):
        apply_scan_offset(m, ScanOffset(slope_s=0.004, intercept_mm=0.0))


def test_raster_test_scan_offset_commands(tmp_path, capsys):
    """Pattern from the command line, burned late by the simulator, scanned to PNG, measured and fitted."""
    from PIL import Image

    from labkit.cli import main
    from labkit.gcode.reader import parse

    gcode = tmp_path / "so.gcode"
    assert main(["raster-test", "scan-offset", "--speeds", "1200:4800:4", "--power", "2000", "--line", "6",
                 "--machine", "grbl-diode", "-o", str(gcode)]) == 0
    layout = json.loads((tmp_path / "so.json").read_text())
    assert layout["kind"] == "scan-offset" and len(layout["lines"]) == 4 * 6
    burn = simulate_burn(parse(gcode.read_text()), machine=DIODE, w0_mm=W0, fth_mj_mm2=FTH, pixel_mm=0.02,
                         beam_delay_s=0.0015)
    Image.fromarray(np.rint(burn.scan(dpi=1000) * 255).astype(np.uint8)).save(tmp_path / "scan.png")
    capsys.readouterr()
    assert main(["raster-test", "measure-offset", str(tmp_path / "scan.png"), "--layout", str(tmp_path / "so.json"),
                 "-o", str(tmp_path / "off.json")]) == 0
    assert re.search(r"beam delay 1\.[45]\d\d ms", capsys.readouterr().out)
    assert load_scan_offset(tmp_path / "off.json").beam_delay_s == pytest.approx(0.0015, rel=0.05)


def test_fit_and_load_errors(tmp_path):
    with pytest.raises(InputError, match="two or more distinct speeds"):
        fit_scan_offset([1000, 1000], [0.1, 0.1])
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"format": "labkit-scan-offset", "version": 1, "slope_s": "fast", "intercept_mm": 0}))
    with pytest.raises(InputError, match="slope_s is 'fast'; expected a finite number"):
        load_scan_offset(bad)
    bad.write_text("{}")
    with pytest.raises(InputError, match="not a scan-offset model"):
        load_scan_offset(bad)
    f = fit_scan_offset([1200, 2400, 3600], [0.08, 0.16, 0.24])
    f.save(tmp_path / "ok.json")
    g = load_scan_offset(tmp_path / "ok.json")
    assert (g.slope_s, g.intercept_mm) == pytest.approx((f.slope_s, f.intercept_mm))


# -- tone -------------------------------------------------------------------------------------------

def _known_width(s, pitch):
    """Line width against S for the synthetic material: a saturating curve, below the pitch."""
    return pitch * 0.75 * (1 - np.exp(-np.asarray(s, float) / 300.0))


def _known_darkness(s, pitch):
    # render_scan: paper 0.9, burn 0.1; the lines cover width/pitch of each patch
    return 0.8 / 0.9 * _known_width(s, pitch) / pitch


@pytest.fixture(scope="module")
def wedge_scan():
    g = wedge_pattern(12)
    s = np.array([ln["s_word"] for ln in g.layout["lines"]])
    img = render_scan(g.layout, _known_width(s, g.layout["pitch_mm"]), dpi=1200, noise=0.02, rotation_deg=2.0)
    return g, img


def test_wedge_measured_and_fitted_to_the_known_curve(wedge_scan):
    g, img = wedge_scan
    pitch = g.layout["pitch_mm"]
    df = measure_wedge(img, g.layout)
    assert len(df) == 12 and df.s_word.tolist() == pytest.approx(1000 * np.arange(1, 13) / 12)
    assert df.darkness.to_numpy() == pytest.approx(_known_darkness(df.s_word, pitch), abs=0.01)
    assert (df.darkness_sd > 0).all()
    curve = fit_tone(df.s_word, df.darkness, spread=df.darkness_sd, weights=df.pixels)
    between = np.linspace(40, 1000, 50)                 # between the knots too
    assert curve.darkness_at(between) == pytest.approx(_known_darkness(between, pitch), abs=0.015)
    assert np.all(np.diff(curve.darkness_at(np.linspace(0, 1000, 500))) >= 0)
    # inverted: the S for a darkness, within 5 % of full power where the curve is not flat
    wanted = np.array([400.0, 600.0, 800.0])
    assert curve.s_for(_known_darkness(wanted, pitch)) == pytest.approx(wanted, abs=50)


def test_wedge_burned_by_the_dose_simulator_follows_the_dose_model():
    """A wedge burned in the virtual material: each patch as dark as the dose model's closed-form
    line width over the line interval (:func:`labkit.laser.models.dose_width`), and the fitted curve too."""
    from labkit.laser.models import dose_width, peak_fluence

    g = wedge_pattern(8, line_interval_mm=0.2, patch_mm=4, patch_lines=10, label_mm=1.5)
    v, w0 = g.layout["speeds_mm_min"][0], 0.05
    fth = float(peak_fluence(2500, v, w0)) / 15          # burns from S 67 on; 0.12 mm wide at full power
    burn = simulate_burn(g.moves, w0_mm=w0, fth_mj_mm2=fth, pixel_mm=0.0125)
    df = measure_wedge(burn.scan(dpi=1200, noise=0.01), g.layout)

    def model(s):
        # the scan: paper 0.9, burn 0.1; lines far enough apart (0.2 mm = 4 w0) not to add up
        return 0.8 / 0.9 * dose_width(2500 * np.asarray(s) / 1000, v, w0, fth) / 0.2

    # within 0.025 (5 % of the darkest patch): the scan's pixels average the simulated edges
    assert df.darkness.to_numpy() == pytest.approx(model(df.s_word), abs=0.025)
    curve = fit_tone(df.s_word, df.darkness, weights=df.pixels)
    s = np.linspace(125, 1000, 200)
    assert curve.darkness_at(s) == pytest.approx(model(s), abs=0.025)


def test_wedge_feed_within_the_machine():
    assert wedge_pattern(4).layout["speeds_mm_min"] == [pytest.approx(1546.0875)]     # the CBR40's X rate
    assert wedge_pattern(4, machine=DIODE).layout["speeds_mm_min"] == [3000.0]
    with pytest.raises(InputError, match="above the machine's X rate"):
        wedge_pattern(4, speed_mm_min=3000.0)


def test_isotonic_pools_violators():
    assert isotonic([3.0, 1.0, 2.0]).tolist() == pytest.approx([2.0, 2.0, 2.0])
    assert isotonic([1.0, 0.0], weights=[3, 1]).tolist() == pytest.approx([0.75, 0.75])
    assert isotonic([0.1, 0.2, 0.3]).tolist() == [0.1, 0.2, 0.3]


def test_correct_gray_inverts_a_square_root_material():
    # darkness = sqrt(S/1000): wanted share w needs S = 1000·w², so gray' = 255·(1 − w²)
    s = np.linspace(1000 / 32, 1000, 32)
    curve = fit_tone(s, np.sqrt(s / 1000))
    g = np.array([0.0, 63.75, 127.5, 191.25, 254.0, 255.0])
    w = 1 - g / 255
    out = curve.correct_gray(g, s_max=1000)
    assert out[:5] == pytest.approx(255 * (1 - w[:5] ** 2), abs=2.0)
    assert out[5] == 255.0                              # white stays unburned
    # a linear material needs no correction
    lin = fit_tone(s, 0.8 * s / 1000)
    assert lin.correct_gray(g[:5], s_max=1000) == pytest.approx(g[:5], abs=0.5)


def test_img2gcode_tone_and_scan_offset(tmp_path, capsys):
    from PIL import Image

    from labkit.cli import main
    from labkit.gcode.reader import parse

    s = np.linspace(1000 / 32, 1000, 32)
    fit_tone(s, np.sqrt(s / 1000), feed_mm_min=3000).save(tmp_path / "tone.json")
    fit_scan_offset([1200, 2400], [0.08, 0.16]).save(tmp_path / "off.json")
    ramp = np.repeat(np.array([[0, 128, 192]], np.uint8).repeat(4, axis=1), 4, axis=0)
    Image.fromarray(ramp).save(tmp_path / "ramp.png")
    common = ["img2gcode", str(tmp_path / "ramp.png"), "--mode", "gray", "--beam", "0.1", "--feed", "3000", "--dpi", "254", "--resample", "nearest",
              "--preview", "none", "--overscan", "1"]
    assert main(common + ["-o", str(tmp_path / "plain.gcode")]) == 0
    assert main(common + ["-o", str(tmp_path / "tone.gcode"), "--tone", str(tmp_path / "tone.json"),
                          "--scan-offset", str(tmp_path / "off.json")]) == 0
    plain = parse((tmp_path / "plain.gcode").read_text())
    tone = parse((tmp_path / "tone.gcode").read_text())
    # gray 128 asks for darkness share w = 1 - 128/255 = 0.498: S 498 plain, 1000·w² = 248 on the square-root material
    assert sorted(set(plain.s_word[plain.laser_on].tolist())) == pytest.approx([247, 498, 1000], abs=1)
    assert sorted(set(tone.s_word[tone.laser_on].tolist())) == pytest.approx([61, 248, 1000], abs=3)
    # backward rows moved by 0.004 s × 50 mm/s = 0.2 mm in +X
    back = tone.laser_on & (tone.end[:, 0] < tone.start[:, 0])
    back_plain = plain.laser_on & (plain.end[:, 0] < plain.start[:, 0])
    assert tone.end[back, 0] - plain.end[back_plain, 0] == pytest.approx(np.full(back.sum(), 0.2), abs=1e-3)
    assert "warning" not in capsys.readouterr().err
    slower = [a if a != "3000" else "1500" for a in common]
    assert main(slower + ["-o", str(tmp_path / "slow.gcode"), "--tone", str(tmp_path / "tone.json")]) == 0
    assert "was measured at 3000 mm/min, the job runs at 1500" in capsys.readouterr().err


def test_tone_bad_inputs(tmp_path, capsys):
    from labkit.cli import main

    bad = tmp_path / "t.json"
    bad.write_text(json.dumps({"format": "labkit-tone-curve", "version": 1, "s_max": 1000,
                               "power_s": [0, 500, 1000], "darkness": [0, 0.5, 0.4]}))
    with pytest.raises(InputError, match="darkness non-decreasing"):
        load_tone(bad)
    with pytest.raises(InputError, match="same S"):
        fit_tone([500, 500], [0.1, 0.2])
    assert main(["img2gcode", str(bad), "-o", str(tmp_path / "x.gcode"), "--mode", "dither", "--tone",
                 str(bad)]) == 1
    assert "--tone applies to --mode gray" in capsys.readouterr().err


def test_raster_test_command_round_trip(tmp_path, wedge_scan, capsys):
    """The wedge command's layout, a scan of it saved as PNG, measure-tone: a curve file img2gcode reads."""
    from PIL import Image

    from labkit.cli import main

    assert main(["raster-test", "wedge", "--steps", "12", "-o", str(tmp_path / "w.gcode")]) == 0
    layout = json.loads((tmp_path / "w.json").read_text())
    g, img = wedge_scan
    assert layout["lines"] == g.layout["lines"]
    Image.fromarray(np.rint(img * 255).astype(np.uint8)).save(tmp_path / "scan.png")
    assert main(["raster-test", "measure-tone", str(tmp_path / "scan.png"), "--layout", str(tmp_path / "w.json"),
                 "-o", str(tmp_path / "curve.json")]) == 0
    curve = load_tone(tmp_path / "curve.json")
    assert (curve.feed_mm_min, curve.line_interval_mm) == (layout["speeds_mm_min"][0], layout["pitch_mm"])
    assert json.loads((tmp_path / "curve.json").read_text())["feed_mm_min"] == layout["speeds_mm_min"][0]
    assert curve.darkness_at(500.0) == pytest.approx(_known_darkness(500.0, layout["pitch_mm"]), abs=0.02)
    assert main(["raster-test", "measure-offset", str(tmp_path / "scan.png"), "--layout", str(tmp_path / "w.json"),
                 "-o", str(tmp_path / "off.json")]) == 1
    assert "expected 'scan-offset'" in capsys.readouterr().err
