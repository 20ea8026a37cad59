"""Measurement on synthetic scans rendered from the layout with known widths, rotation and noise."""

import numpy as np
import pytest

from labkit.errors import InputError
from labkit.laser.measure import measure_lines, render_scan, scale_from_reference
from labkit.laser.models import dose_width
from labkit.laser.patterns import grid_pattern


@pytest.fixture(scope="module")
def grid():
    g = grid_pattern([500, 1000, 1500, 2000, 2500], [300, 700, 1500])
    lines = g.layout["lines"]
    p = np.array([d["power_mw"] for d in lines])
    v = np.array([d["speed_mm_min"] for d in lines])
    return g.layout, dose_width(p, v, 0.12, 200.0)


@pytest.mark.parametrize("dpi, rot, noise, blur", [(600, 0.0, 0.0, 0.0), (600, 0.0, 0.05, 0.0),
                                                   (600, 3.0, 0.03, 1.0), (400, -4.0, 0.05, 0.7),
                                                   (1200, 1.5, 0.02, 2.0)])
def test_widths_within_a_pixel_and_unburned_lines_flagged(grid, dpi, rot, noise, blur):
    layout, truth = grid
    assert (truth == 0).any() and (truth > 0).any()
    img = render_scan(layout, truth, dpi=dpi, rotation_deg=rot, noise=noise, blur_px=blur, seed=3)
    df = measure_lines(img, layout, dpi=dpi)
    px = 25.4 / dpi
    assert np.abs(df.width_mm.to_numpy() - truth).max() < px       # stated tolerance: one pixel
    # and no systematic error from the burn's grey level: noise used to pull it darker
    # (mean -0.30 px at noise 0.05), blur lighter
    assert abs(np.mean(df.width_mm.to_numpy()[truth > 0] - truth[truth > 0])) < 0.1 * px
    assert (df.burned.to_numpy() == (truth > 0)).all()
    assert (df.loc[df.burned, "burned_fraction"] == 1.0).all()


def test_a_line_burned_over_part_of_its_length_reports_the_fraction(grid):
    layout, truth = grid
    img = render_scan(layout, truth, dpi=600)
    # paint over the right 60 % of the widest line with paper
    k = int(np.argmax(truth))
    d = layout["lines"][k]
    row_mm = d["y_mm"]
    g2 = render_scan(layout, np.where(np.arange(len(truth)) == k, 0.0, truth), dpi=600)
    cols = np.arange(img.shape[1])
    x_lo, _, x_hi, _ = layout["bounds_mm"]
    half = (img.shape[1] * 25.4 / 600) / 2
    x_mm = (x_lo + x_hi) / 2 + (cols + 0.5) * 25.4 / 600 - half
    cut = x_mm > d["x0_mm"] + 0.4 * (d["x1_mm"] - d["x0_mm"])
    mixed = img.copy()
    mixed[:, cut] = g2[:, cut]
    df = measure_lines(mixed, layout, dpi=600)
    assert df.burned_fraction[k] == pytest.approx(0.4 / 0.8 - 0.1 / 0.8, abs=0.05)
    assert row_mm == df.y_mm[k]


def test_a_scan_without_the_grid_is_a_named_error(grid):
    layout, _ = grid
    with pytest.raises(InputError, match="grid"):
        measure_lines(np.full((300, 300), 0.9), layout, dpi=600)
    blobs = np.full((300, 300), 0.9)
    blobs[10:20, 10:20] = 0.1
    with pytest.raises(InputError, match="corner crosses"):
        measure_lines(blobs, layout, dpi=600)


def test_scale_from_the_corner_crosses_when_no_dpi_is_known(grid):
    layout, truth = grid
    img = render_scan(layout, truth, dpi=500, rotation_deg=-3.0, noise=0.03, blur_px=1.0, seed=9)
    df = measure_lines(img, layout)          # no dpi: the crosses' layout spacing is the reference
    assert np.abs(df.width_mm.to_numpy() - truth).max() < 25.4 / 500


def test_scale_from_a_marked_reference_length(grid):
    layout, truth = grid
    dpi = 800
    img = render_scan(layout, truth, dpi=dpi, rotation_deg=2.0, seed=1)
    # a 40 mm ruler photographed at 30° in the image: its ends 40 mm · dpi/25.4 px apart
    n = 40 / 25.4 * dpi
    a = np.deg2rad(30)
    found = scale_from_reference((100.0, 200.0), (100.0 + n * np.cos(a), 200.0 + n * np.sin(a)), 40.0)
    assert found == pytest.approx(dpi, rel=1e-12)
    df = measure_lines(img, layout, dpi=found)
    assert np.abs(df.width_mm.to_numpy() - truth).max() < 25.4 / dpi
    # a reference that contradicts the crosses by more than 20 % is refused, not silently used
    with pytest.raises(InputError, match="disagrees"):
        measure_lines(img, layout, dpi=found * 1.5)
    with pytest.raises(InputError, match="reference"):
        scale_from_reference((0, 0), (10, 0), 0.0)


def test_render_scan_equals_the_whole_image_formula(grid):
    """render_scan computes each stroke only near it; every pixel must still equal the coverage
    formula evaluated over the whole image (a rotated scan at 200 dpi, compared exactly)."""
    from labkit.laser.measure import _segments

    layout, truth = grid
    dpi, rot = 200.0, 7.0
    got = render_scan(layout, truth, dpi=dpi, rotation_deg=rot)
    px = 25.4 / dpi
    x_lo, y_lo, x_hi, y_hi = layout["bounds_mm"]
    cx, cy = (x_lo + x_hi) / 2, (y_lo + y_hi) / 2
    half = np.hypot(x_hi - x_lo, y_hi - y_lo) / 2 + 5.0
    n = int(np.ceil(2 * half / px))
    u = (np.arange(n) + 0.5) * px - half
    uu, vv = np.meshgrid(u, -u)
    t = np.deg2rad(rot)
    x, y = cx + np.cos(t) * uu + np.sin(t) * vv, cy - np.sin(t) * uu + np.cos(t) * vv
    dark = np.zeros((n, n))
    for x0, y0, x1, y1, w in _segments(layout, np.asarray(truth, float), 0.3):
        if w > 0:
            d = np.array([x1 - x0, y1 - y0]); L = np.hypot(*d); d /= L
            along = np.clip((x - x0) * d[0] + (y - y0) * d[1], 0, L)
            dist = np.hypot(x - (x0 + along * d[0]), y - (y0 + along * d[1]))
            dark = np.maximum(dark, np.clip(0.5 + (w / 2 - dist) / px, 0, 1))
    np.testing.assert_array_equal(got, np.clip(0.9 - 0.8 * dark, 0, 1))


def _cells(layout):
    return np.array([(d["row"], d["col"]) for d in layout["lines"]])


def test_a_scan_turned_180_is_measured_in_its_own_cells(grid):
    """The corner crosses alone fit a piece turned 180° as well as an upright one; the engraved
    numbers (rows left, columns top) tell them apart, so every width lands in its own cell."""
    from labkit.laser.measure import register

    layout, truth = grid
    # a wrong turn would show: the grid's widths are not symmetric under 180°
    by_cell = {tuple(c): w for c, w in zip(_cells(layout), truth)}
    rows, cols = _cells(layout).max(axis=0)
    assert any(abs(w - by_cell[(rows - r, cols - c)]) > 0.02 for (r, c), w in by_cell.items())
    for turn, dpi in ((180.0, 600), (182.5, 400), (90.0, 500)):
        img = render_scan(layout, truth, dpi=dpi, rotation_deg=turn, noise=0.03, blur_px=1.0, seed=7)
        tf = register(img, layout)
        assert np.degrees(tf.rotation) % 360 == pytest.approx(-turn % 360, abs=0.5)
        df = measure_lines(img, layout, dpi=dpi, transform=tf)
        assert np.abs(df.width_mm.to_numpy() - truth).max() < 25.4 / dpi
        assert (df.burned.to_numpy() == (truth > 0)).all()


def test_the_virtual_material_burned_and_scanned_upside_down():
    """The whole job (lines, numbers, crosses) burned by the dose simulation, scanned turned 180°."""
    from labkit.laser.simulate import simulate_burn

    g = grid_pattern([800.0, 1600.0, 2400.0], [300.0, 1500.0])
    burn = simulate_burn(g.moves, w0_mm=0.12, fth_mj_mm2=200.0, pixel_mm=0.04)
    dpi = 400
    img = burn.scan(dpi=dpi, rotation_deg=178.0, noise=0.02, blur_px=0.8, seed=4)
    df = measure_lines(img, g.layout, dpi=dpi)
    expected = dose_width(df.power_mw.to_numpy(), df.speed_mm_min.to_numpy(), 0.12, 200.0)
    assert (df.burned.to_numpy() == (expected > 0)).all()
    assert np.abs(df.width_mm.to_numpy() - expected).max() < 25.4 / dpi


@pytest.mark.parametrize("flip", [np.fliplr, np.flipud], ids=["left-right", "top-bottom"])
def test_a_mirrored_scan_is_refused(grid, flip):
    layout, truth = grid
    img = flip(render_scan(layout, truth, dpi=400, rotation_deg=1.0, noise=0.02, seed=2))
    with pytest.raises(InputError, match="engraved row and column numbers are not where the layout puts them"):
        measure_lines(img, layout, dpi=400)


def test_an_8_bit_scan_measures_as_the_scan_it_was_rounded_from(grid):
    """Rounded to 8 bits, paper (0.9) and burn (0.1) fall half a grey step between levels. A plain
    median read them a whole step off and moved every width by about -3 µm against the same scan
    unrounded; read between the steps, rounding moves the mean width by less than 0.2 µm."""
    layout, truth = grid
    burned = truth > 0
    for seed in (5, 6):
        img = render_scan(layout, truth, dpi=600, rotation_deg=2.5, noise=0.03, blur_px=1.0, seed=seed)
        exact = measure_lines(img, layout, dpi=600).width_mm.to_numpy()
        rounded = measure_lines(np.round(img * 255) / 255, layout, dpi=600).width_mm.to_numpy()
        assert abs(np.mean(rounded[burned] - exact[burned])) < 0.0002
        assert np.abs(rounded - exact).max() < 0.002


@pytest.mark.parametrize("edit, message", [
    (lambda L: L.update(lines=[]), "lines is empty; expected at least one burned line"),
    (lambda L: L["lines"][3].pop("x1_mm"), r"lines\[3\].x1_mm is missing; expected a number"),
    (lambda L: L["lines"][0].update(y_mm="2.0"), r"lines\[0\].y_mm is '2.0' \(text\); expected a finite number"),
    (lambda L: L.update(pitch_mm=float("nan")), "pitch_mm is nan; expected a finite number"),
    (lambda L: L.update(pitch_mm=0), "pitch_mm is 0; expected a number > 0"),
    (lambda L: L["fiducials_mm"][2].__setitem__(1, float("nan")), r"fiducials_mm\[2\] y is nan"),
    (lambda L: L.update(fiducials_mm=L["fiducials_mm"][:3]), "fiducials_mm is .*; expected the four corner"),
    (lambda L: L["lines"][1].update(speed_mm_min=-5), r"lines\[1\].speed_mm_min is -5; expected a number > 0"),
    (lambda L: L["lines"][1].update(row=True), r"lines\[1\].row is True"),
    (lambda L: L["labels"][0].update(text="A"), r"labels\[0\].text is 'A' \(text\); expected digits"),
    (lambda L: L["labels"][2].pop("kind"), r"labels\[2\].kind is None; expected 'row' or 'col'"),
    (lambda L: L.update(lines={"x0_mm": 1}), "lines is .*; expected a list of burned lines"),
])
def test_a_hand_edited_layout_names_the_field(grid, edit, message):
    import copy

    from labkit.laser.measure import check_layout

    layout = copy.deepcopy(grid[0])
    edit(layout)
    with pytest.raises(InputError, match=f"GRID.json: {message}"):
        check_layout(layout, source="GRID.json")
    with pytest.raises(InputError, match=f"layout: {message}"):
        measure_lines(np.full((50, 50), 0.9), layout)
