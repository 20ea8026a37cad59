"""Predicted against scanned burn (issue 31 §4, first part): synthetic scans made from the prediction
with injected defects — a line missing, a region over-burned, a 0.1 mm shift — that must be found
where they were put, and a clean scan that must show none."""

import numpy as np
import pytest
from scipy import ndimage

from labkit.burncheck import check_burn, overlay, predict_burn
from labkit.gcode import parse

# three score lines at S300 and a 6 mm square cut at S800, written by hand
PROGRAM = """G21 G90
M3 S300 F600
G0 X2 Y2
G1 X12
G0 Y4
G1 X2
G0 X2 Y6
G1 X12
M5
G0 X16 Y1
M3 S800 F300
G1 X22
G1 Y7
G1 X16
G1 Y1
M5
"""
W0, FTH = 0.1, 40.0


@pytest.fixture(scope="module")
def prediction():
    moves = parse(PROGRAM)
    return moves, predict_burn(moves, w0_mm=W0, fth_mj_mm2=FTH, pixel_mm=0.02)


def _rc(burn, x, y):
    return int(round((y - burn.y_mm[0]) / burn.pixel_mm)), int(round((x - burn.x_mm[0]) / burn.pixel_mm))


def test_a_clean_scan_shows_nothing(prediction):
    moves, burn = prediction
    assert burn.burned.any()
    res = check_burn(burn, burn.burned.copy(), moves=moves)
    assert res.defects == [] and res.shift_mm == pytest.approx((0, 0), abs=1e-9)


def test_a_missing_line_is_found_on_its_layer(prediction):
    moves, burn = prediction
    scan = burn.burned.copy()
    r, _ = _rc(burn, 0, 4)                              # the middle score line, y = 4, x 2…12
    half = int(np.ceil(3 * W0 / burn.pixel_mm))
    c0, c1 = _rc(burn, 2, 0)[1] - half, _rc(burn, 12, 0)[1] + half
    scan[r - half:r + half + 1, c0:c1 + 1] = False
    res = check_burn(burn, scan, moves=moves)
    d = res.defects[0]
    assert d.kind == "missing" and d.layer_s == 300
    x0, y0, x1, y1 = d.bbox_mm
    assert x0 == pytest.approx(2, abs=0.2) and x1 == pytest.approx(12, abs=0.2) and 3.8 < y0 <= y1 < 4.2
    assert res.shift_mm == pytest.approx((0, 0), abs=0.01)


def test_an_over_burned_region_is_found(prediction):
    moves, burn = prediction
    scan = burn.burned.copy()
    r0, c0 = _rc(burn, 16, 1)
    r1, c1 = _rc(burn, 22, 7)
    corner = np.zeros_like(scan)
    corner[r0:r0 + (r1 - r0) // 3, c0:c0 + (c1 - c0) // 3] = True   # the square's lower-left third, charred
    scan |= ndimage.binary_dilation(scan & corner, iterations=8)
    res = check_burn(burn, scan, moves=moves)
    d = res.defects[0]
    assert d.kind == "extra" and d.layer_s == 800
    x0, y0, x1, y1 = d.bbox_mm
    assert 15.5 < x0 and x1 < 18.5 and 0.5 < y0 and y1 < 3.5


def test_a_tenth_of_a_millimetre_shift_is_measured_and_undone(prediction):
    moves, burn = prediction
    k = int(round(0.1 / burn.pixel_mm))                # 5 pixels of 0.02 mm
    scan = np.roll(burn.burned, k, axis=1)             # the whole burn 0.1 mm to +x
    res = check_burn(burn, scan, moves=moves)
    assert res.shift_mm == pytest.approx((0.1, 0.0), abs=0.005)
    assert res.defects == []
    assert "shifted by (+0.100, +0.000) mm" in res.summary()


def test_overlay_colours(prediction):
    _, burn = prediction
    scan = burn.burned.copy()
    scan[:, : scan.shape[1] // 2] = False
    img = overlay(burn, scan)
    assert img.dtype == np.uint8 and img.shape == burn.burned.shape + (3,)
    assert ((img == (220, 30, 30)).all(axis=2)).sum() == (burn.burned & ~scan).sum()


# ---- grey darkness and scan files (issue 31 §4, second part) -------------------------------------
# A label written by hand: three score lines (S300), a hatched patch (S250, 0.3 mm apart, 1200 mm/min,
# partly covered: each line narrower than the interval) and a 6 mm square cut (S800). The "real" burns
# are the same program with a defect put into the program itself, burned in the same virtual material
# and scanned at 600 dpi with 3 mm of paper, noise, and the grey levels of another scanner.

from labkit.burncheck import check_scan, predicted_scan, scan_darkness  # noqa: E402
from labkit.errors import InputError  # noqa: E402
from labkit.laser.models import dose_width  # noqa: E402

INTERVAL, DPI, PAPER, SOLID = 0.3, 600.0, 0.85, 0.25
MW_PER_S = 2.5                                       # the default machine: S1000 = 2500 mW


def label(score_ys=(2, 4, 6), fill=((250, 1200), (250, 1200)), cut_dx=0.0):
    lines = ["G21 G90", "M3 S300 F600"]
    for y in score_ys:
        lines += [f"G0 X2 Y{y}", "G1 X12"]
    lines += ["M5", "M3"]
    for i, y in enumerate(np.arange(9, 12.001, INTERVAL)):
        halves = ((2, 7), (7, 12)) if i % 2 == 0 else ((12, 7), (7, 2))
        lines.append(f"G0 X{halves[0][0]} Y{y:.3f}")
        for x0, x1 in halves:
            s, f = fill[0] if min(x0, x1) < 7 else fill[1]      # left half, right half
            lines.append(f"G1 X{x1} S{s} F{f}")
    lines += ["M5", f"G0 X{16 + cut_dx:g} Y1", "M3 S800 F300", f"G1 X{22 + cut_dx:g}", "G1 Y7",
              f"G1 X{16 + cut_dx:g}", "G1 Y1", "M5"]
    return "\n".join(lines) + "\n"


def scanned(program):
    """The burn of ``program`` as another scanner sees it: paper 0.85, solid burn 0.25, noise 0.02."""
    real = predict_burn(parse(program), w0_mm=W0, fth_mj_mm2=FTH, pixel_mm=0.02)
    img = real.scan(dpi=DPI, margin_mm=3.0, noise=0.02, seed=3)
    return SOLID + (img - 0.1) / 0.8 * (PAPER - SOLID)


@pytest.fixture(scope="module")
def label_prediction():
    moves = parse(label())
    return moves, predict_burn(moves, w0_mm=W0, fth_mj_mm2=FTH, pixel_mm=0.02)


def test_the_predicted_scan_levels_are_the_ones_burncheck_reads_back(label_prediction):
    # burncheck turns a predicted scan back into darkness through Burn.scan's paper 0.9 and burn 0.1
    _, burn = label_prediction
    img = predicted_scan(burn, dpi=DPI, margin_mm=1.0)
    assert img.max() == pytest.approx(0.9) and img.min() == pytest.approx(0.1)


def test_scan_darkness_is_one_minus_grey_over_paper():
    img = np.full((10, 10), 0.8)
    img[2:5, 2:8] = 0.3
    d = scan_darkness(img)
    assert d[0, 0] == 0 and d[3, 3] == pytest.approx(1 - 0.3 / 0.8)
    assert scan_darkness(img, paper=0.6)[0, 0] == pytest.approx(1 - 0.8 / 0.6)
    with pytest.raises(InputError, match="2-D grey image"):
        scan_darkness(np.zeros(5))


def test_a_clean_scan_is_found_and_shows_nothing(label_prediction):
    moves, burn = label_prediction
    res = check_scan(burn, scanned(label()), dpi=DPI, moves=moves)
    assert res.defects == []
    assert res.solid_darkness == pytest.approx(1 - SOLID / PAPER, abs=0.01)
    px = 25.4 / DPI                                   # the prediction lies on the 3 mm of paper, to a pixel
    assert res.shift_mm[0] == pytest.approx(3.0, abs=px) and res.shift_mm[1] == pytest.approx(3.0, abs=px)
    assert [L.s_word for L in res.layers] == [250, 300, 800]
    for L in res.layers:
        assert L.scanned_mm2 == pytest.approx(L.predicted_mm2, rel=0.03)
        assert abs(L.darkness_change) < 0.03 and np.hypot(*L.shift_mm) < 0.025
    # the hatched patch is as dark as the dose model's width over the line interval (closed form)
    fill = res.layers[0]
    w = float(dose_width(250 * MW_PER_S, 1200, W0, FTH))
    assert 0.4 < w / INTERVAL < 0.9
    patch = res.predicted[(np.arange(res.predicted.shape[0]) * px + res.extent_mm[2] > 9.5)
                          & (np.arange(res.predicted.shape[0]) * px + res.extent_mm[2] < 11.5)]
    assert patch.mean() == pytest.approx(w / INTERVAL * (10 / (res.extent_mm[1] - res.extent_mm[0])), rel=0.1)
    assert fill.length_mm == pytest.approx(11 * 10, abs=1)


def test_a_missing_score_line_is_found_with_its_numbers(label_prediction):
    moves, burn = label_prediction
    res = check_scan(burn, scanned(label(score_ys=(2, 6))), dpi=DPI, moves=moves)
    assert len(res.defects) == 1
    d = res.defects[0]
    assert d.kind == "missing" and d.layer_s == 300 and d.darkness < -0.8
    x0, y0, x1, y1 = d.bbox_mm
    assert x0 == pytest.approx(2, abs=0.2) and x1 == pytest.approx(12, abs=0.2) and 3.8 < y0 <= y1 < 4.2
    score = next(L for L in res.layers if L.s_word == 300)
    # one line of three: a third of the layer's burn is missing, and its darkness falls by a third
    assert score.missing_mm2 == pytest.approx(score.predicted_mm2 / 3, rel=0.1)
    assert score.scanned_darkness == pytest.approx(score.predicted_darkness * 2 / 3, rel=0.1)
    # the missing area per mm of the layer's path is the line's width, as the dose model gives it
    assert -score.width_change_mm * score.length_mm / 10 == pytest.approx(
        float(dose_width(300 * MW_PER_S, 600, W0, FTH)), rel=0.15)


@pytest.mark.parametrize("kind, right_half", [("light", (100, 1200)), ("dark", (250, 300))])
def test_a_region_too_light_or_over_burned_is_found_by_its_darkness(label_prediction, kind, right_half):
    # the right half of the patch burned weaker (S100) or four times slower (300 mm/min)
    moves, burn = label_prediction
    res = check_scan(burn, scanned(label(fill=((250, 1200), right_half))), dpi=DPI, moves=moves)
    assert [d.kind for d in res.defects] == [kind]
    d = res.defects[0]
    assert d.layer_s == 250
    x0, y0, x1, y1 = d.bbox_mm
    assert 6.5 < x0 < 7.6 and 11.5 < x1 < 12.3 and 8.7 < y0 < 9.3 and 11.7 < y1 < 12.3
    # by how much: the dose model's widths over the interval (closed form), as a share of a solid burn
    expected = (min(float(dose_width(right_half[0] * MW_PER_S, right_half[1], W0, FTH)), INTERVAL)
                - float(dose_width(250 * MW_PER_S, 1200, W0, FTH))) / INTERVAL
    assert d.darkness == pytest.approx(expected, abs=0.05)
    assert (d.darkness < 0) == (kind == "light")


def test_one_layer_a_tenth_of_a_millimetre_off_the_rest_is_measured(label_prediction):
    moves, burn = label_prediction
    res = check_scan(burn, scanned(label(cut_dx=0.1)), dpi=DPI, moves=moves)
    cut = next(L for L in res.layers if L.s_word == 800)
    assert cut.shift_mm == pytest.approx((0.1, 0.0), abs=0.01)
    assert all(np.hypot(*L.shift_mm) < 0.025 for L in res.layers if L.s_word != 800)
    assert res.defects == []                           # the shift is undone before the areas compare
    row = next(r for r in res.summary().splitlines() if r.strip().startswith("S800"))
    assert row.endswith(f"({cut.shift_mm[0]:+.3f}, {cut.shift_mm[1]:+.3f})") and ("+0.09" in row or "+0.10" in row)


def test_the_check_draws_its_overlay_and_writes_its_numbers(label_prediction):
    moves, burn = label_prediction
    res = check_scan(burn, scanned(label(score_ys=(2, 6))), dpi=DPI, moves=moves)
    img = res.overlay()
    assert img.dtype == np.uint8 and img.shape == res.predicted.shape + (3,)
    red = (img == (220, 30, 30)).all(axis=2)
    assert red.sum() * res.pixel_mm ** 2 == pytest.approx(res.defects[0].area_mm2)
    import json

    doc = json.loads(json.dumps(res.to_dict()))
    assert doc["defects"][0]["kind"] == "missing" and len(doc["layers"]) == 3


def test_grey_darkness_on_the_prediction_grid(label_prediction):
    # check_burn with a grey scan: the prediction's own burned share at darkness 0.7, the right half
    # of the patch at 60 % of it
    moves, burn = label_prediction
    dark = 0.7 * np.clip(burn.coverage, 0, 1)
    right = (burn.x_mm[None, :] > 7) & (burn.y_mm[:, None] > 8.5) & (burn.y_mm[:, None] < 12.5)
    dark = np.where(right, 0.6 * dark, dark)
    res = check_burn(burn, dark, moves=moves)
    kinds = {d.kind for d in res.defects}
    assert "light" in kinds and "extra" not in kinds and "dark" not in kinds
    assert res.solid_darkness == pytest.approx(0.7, abs=0.01)


def test_bad_scans_are_refused(label_prediction):
    moves, burn = label_prediction
    with pytest.raises(InputError, match="smaller than the predicted burn"):
        check_scan(burn, np.full((20, 20), 0.8), dpi=DPI)
    with pytest.raises(InputError, match="not darker where the prediction burns"):
        check_scan(burn, np.full((400, 700), 0.8), dpi=DPI)
    with pytest.raises(InputError, match="tolerance must be > 0 and < 1"):
        check_scan(burn, np.full((400, 700), 0.8), dpi=DPI, tolerance=2)
    with pytest.raises(InputError, match="dpi must be > 0"):
        check_scan(burn, np.full((400, 700), 0.8), dpi=0)


@pytest.mark.parametrize("turn_deg", [0.7, -1.5])
def test_a_piece_turned_on_the_scanner_is_turned_back_and_its_defect_still_found(label_prediction, turn_deg):
    # the label without its middle fold, laid on the scanner turned by hand (Burn.scan turns it CCW)
    moves, burn = label_prediction
    real = predict_burn(parse(label(score_ys=(2, 6))), w0_mm=W0, fth_mj_mm2=FTH, pixel_mm=0.02)
    img = real.scan(dpi=DPI, margin_mm=3.0, noise=0.02, seed=3, rotation_deg=turn_deg)
    res = check_scan(burn, SOLID + (img - 0.1) / 0.8 * (PAPER - SOLID), dpi=DPI, moves=moves)
    assert res.turn_deg == pytest.approx(turn_deg, abs=0.05)
    assert [d.kind for d in res.defects] == ["missing"] and res.defects[0].layer_s == 300
    x0, y0, x1, y1 = res.defects[0].bbox_mm
    assert x0 == pytest.approx(2, abs=0.2) and x1 == pytest.approx(12, abs=0.2) and 3.8 < y0 <= y1 < 4.2
    assert all(np.hypot(*L.shift_mm) < 0.025 for L in res.layers)
    assert f"turned {res.turn_deg:+.2f}°" in res.summary()
