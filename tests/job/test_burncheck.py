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
