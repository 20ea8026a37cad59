"""Gray and dithered engraving, the job report, and the G-code round trip."""

import numpy as np
import pytest
from PIL import Image
from scipy import ndimage as ndi
from skimage import data

from labkit.errors import RasterError
from labkit.gcode import emit, parse
from labkit.raster import (DIFFUSION, burn_map, dither, gray_job, image_to_job, mask_job, power_map,
                           summarize, to_gray)
from labkit.toolpath import LaserMode, MoveKind


def _small_camera():
    return to_gray(data.camera()[::4, ::4])


def test_dither_hand_worked_floyd_steinberg():
    # 2×2 of 64: top-left → 0 (error 64): right 64+28=92, below-left —, below 64+20=84, diag 64+4=68
    # top-right 92 → 0 (error 92): below-left 84+17.25=101.25, below 68+28.75=96.75
    # bottom-left 101.25 → 0 (error 101.25): right 96.75+44.3=141.04 → 255
    assert dither(np.full((2, 2), 64.0)).tolist() == [[True, True], [True, False]]


@pytest.mark.parametrize("method", sorted(DIFFUSION))
def test_dither_keeps_the_mean_darkness(method):
    g = _small_camera()
    dots = dither(g, method)
    darkness = 1 - g / 255
    tol = 0.02 if method != "atkinson" else 0.06   # Atkinson drops 1/4 of the error on purpose
    assert abs(dots.mean() - darkness.mean()) < tol
    local = ndi.gaussian_filter(dots.astype(float), 3) - ndi.gaussian_filter(darkness, 3)
    assert np.abs(local).mean() < (0.05 if method != "atkinson" else 0.1)


def test_floyd_steinberg_close_to_pillow():
    g = data.camera()
    ours = dither(g.astype(float))
    pil = np.asarray(Image.fromarray(g).convert("1"), dtype=bool) == 0   # Pillow: FS, black = 0
    a = ndi.gaussian_filter(ours.astype(float), 2)
    b = ndi.gaussian_filter(pil.astype(float), 2)
    assert abs(ours.mean() - pil.mean()) < 0.01 and np.abs(a - b).mean() < 0.05


def test_serpentine_mirrors_on_odd_rows():
    g = _small_camera()
    assert not np.array_equal(dither(g, serpentine=True), dither(g))
    assert abs(dither(g, serpentine=True).mean() - dither(g).mean()) < 0.01


def test_gray_job_burns_each_pixel_once_at_its_power():
    g = _small_camera()
    for bidirectional in (True, False):
        for overscan, skip in ((0.0, 0.0), (1.0, 2.0), (3.0, 10.0)):
            job = gray_job(g, pixel_mm=0.2, min_power=0.1, max_power=0.9, white_level=240,
                           overscan_mm=overscan, skip_white_mm=skip, bidirectional=bidirectional)
            count, power = burn_map(job.moves, g.shape, 0.2)
            target = job.target
            assert np.array_equal(count, (target > 0).astype(int))
            assert np.array_equal(power, target.astype(float))
            assert np.array_equal(target, power_map(g, min_power=0.1, max_power=0.9, white_level=240))
            # cut length = burned pixels × pitch; laser only on feed moves
            assert job.report.cut_mm == pytest.approx((target > 0).sum() * 0.2)
            assert not job.moves.laser_on[job.moves.kind == MoveKind.RAPID].any()


def test_overscan_runs_past_each_span_with_the_laser_off():
    g = np.full((3, 10), 255.0); g[:, 3:7] = 0
    job = gray_job(g, pixel_mm=1.0, overscan_mm=2.0, bidirectional=True)
    m = job.moves
    feed = m.kind == MoveKind.LINE
    lead = feed & ~m.laser_on
    assert np.allclose(m.lengths_mm()[lead], 2.0)          # lead-in and lead-out of 2 mm each
    assert lead.sum() == 6
    burn = m[m.laser_on]
    assert burn.end[:, 0].tolist() == [7.0, 3.0, 7.0]          # alternating directions
    box = m.bounds(mask=feed)
    assert box[0, 0] == 1.0 and box[1, 0] == 9.0                # 3 − 2 and 7 + 2
    assert job.moves.laser[0] == LaserMode.DYNAMIC


def test_white_runs_are_skipped_by_rapids_only_when_long():
    g = np.full((1, 30), 255.0); g[0, 2:4] = 0; g[0, 6:8] = 0; g[0, 20:22] = 0
    job = gray_job(g, pixel_mm=1.0, overscan_mm=0.0, skip_white_mm=5.0)
    m = job.moves
    rapids = m[m.kind == MoveKind.RAPID]
    assert len(rapids) == 2                          # to the start, and across the 12-pixel gap
    idle = m[(m.kind == MoveKind.LINE) & ~m.laser_on]
    assert idle.lengths_mm().tolist() == [2.0]       # the 2-pixel gap is crossed at S0
    assert job.report.travel_mm == pytest.approx(rapids.lengths_mm().sum())


def test_dither_job_full_power_dots():
    g = _small_camera()
    job = gray_job(g, pixel_mm=0.2, dither="atkinson", max_power=0.6)
    count, power = burn_map(job.moves, g.shape, 0.2)
    assert np.array_equal(count > 0, dither(g, "atkinson"))
    assert set(np.unique(power)) <= {0.0, 600.0}
    assert job.report.mode == "dither"


def test_report_figures_zigzag_vs_spiral():
    mask = ~data.horse()
    z = mask_job(mask, pixel_mm=1.0, mode="zigzag", feed_mm_min=1300)
    s = mask_job(mask, pixel_mm=1.0, mode="spiral", feed_mm_min=1300)
    for job in (z, s):
        r = job.report
        assert r.cut_mm == pytest.approx(mask.sum())        # edge-to-edge: 1 mm per pixel
        assert r.marked_pixels == mask.sum()
        total = r.cut_mm + r.travel_mm
        assert r.time_s == pytest.approx(total / 1300 * 60)
        assert r.tool_lines == int(job.moves.laser_on.sum())
        assert r.rapids + r.tool_lines == r.moves
    assert z.report.segments == z.report.tool_lines             # one line per zig-zag segment
    assert s.report.tool_lines > s.report.segments
    assert s.report.segments_before == 1                        # the horse is one island
    assert z.report.segments_before == mask.any(axis=1).sum()   # 328 × 400: fewer rows → rows
    text = z.report.format()
    assert "segments before / after pathing" in text and "estimated time" in text


def test_gcode_round_trip_and_line_count():
    mask = ~data.horse()[::4, ::4]
    job = mask_job(mask, pixel_mm=0.5, mode="spiral", feed_mm_min=1000, s_word=800)
    text = emit(job.moves)
    report = job.report.with_gcode(text)
    assert report.gcode_lines == text.count("\n") > job.report.moves
    back = parse(text)
    feed = back.kind == MoveKind.LINE
    assert np.isclose(back.lengths_mm()[back.laser_on].sum(), job.report.cut_mm)
    assert not back.laser_on[back.kind == MoveKind.RAPID].any()
    count, _ = burn_map(back, mask.shape, 0.5, tol_mm=1e-3)
    assert np.array_equal(count, mask.astype(int)) and feed.sum() == job.report.tool_lines


@pytest.mark.parametrize("mode", ["zigzag", "spiral", "edges", "gray", "dither"])
def test_image_to_job_modes(mode):
    cam = data.camera()
    job = image_to_job(cam, mode=mode, beam_mm=0.5, width_mm=64.0, feed_mm_min=2000)
    assert job.report.shape == (128, 128) and job.report.mode == mode
    count, _ = burn_map(job.moves, job.report.shape, 0.5)
    target = job.target > 0
    assert np.array_equal(count, target.astype(int))


def test_image_to_job_mask_input_and_size_error():
    horse = ~data.horse()                               # 400 × 328 px
    job = image_to_job(horse, mode="zigzag", beam_mm=0.3, width_mm=100.0, resample="nearest")
    ex, ey = job.report.size_error_mm
    assert abs(ex) <= 0.15 and abs(ey) <= 0.15
    assert job.report.shape == (273, 333)
    inv = image_to_job(horse, mode="zigzag", beam_mm=0.3, width_mm=100.0, resample="nearest", invert=True)
    assert inv.report.marked_pixels + job.report.marked_pixels == 273 * 333


def test_engrave_errors():
    g = np.zeros((4, 4))
    with pytest.raises(RasterError, match="mode must be one of"):
        image_to_job(g, mode="hatch", dpi=100)
    with pytest.raises(RasterError, match="mode must be 'zigzag' or 'spiral'"):
        mask_job(g < 1, pixel_mm=0.1, mode="gray")
    with pytest.raises(RasterError, match="min_power <= max_power"):
        power_map(g, min_power=0.8, max_power=0.2)
    with pytest.raises(RasterError, match="overscan_mm and skip_white_mm must be >= 0"):
        gray_job(g, pixel_mm=0.1, overscan_mm=-1)
    with pytest.raises(RasterError, match="dither must be one of"):
        gray_job(g, pixel_mm=0.1, dither="ordered")
    with pytest.raises(RasterError, match="pixel_mm must be"):
        gray_job(g, pixel_mm=0)
    with pytest.raises(RasterError, match="s_word must be in"):
        mask_job(g < 1, pixel_mm=0.1, s_word=0)
    with pytest.raises(RasterError, match="feed_mm_min and rapid_mm_min must be > 0"):
        summarize(mask_job(g < 1, pixel_mm=0.1).moves, feed_mm_min=0)
    with pytest.raises(RasterError, match="method must be one of"):
        dither(g, "bayer")


def test_settings_are_one_record_with_named_fields():
    """image_to_job takes one RasterSettings (or its fields by name); an unknown name is refused
    with the valid ones listed, instead of reaching mask_job or gray_job."""
    from labkit.errors import RasterError
    from labkit.raster.engrave import RasterSettings, image_to_job

    img = np.full((20, 30), 255, np.uint8)
    img[5:15, 5:25] = 0
    s = RasterSettings(mode="gray", beam_mm=0.5, pixel_mm=0.5, feed_mm_min=2400)
    a = image_to_job(img, s)
    b = image_to_job(img, mode="gray", beam_mm=0.5, pixel_mm=0.5, feed_mm_min=2400)
    assert len(a.moves) == len(b.moves) > 0 and np.array_equal(a.moves.end, b.moves.end)
    assert set(a.moves.feed_mm_min[a.moves.laser_on]) == {2400.0}
    # the mode's defaults where a field is None: gray scans with M4, binary cuts with M3
    assert s.burn_options().get("laser") is None and "dither" in s.burn_options()
    assert "s_word" in RasterSettings(mode="zigzag").burn_options()
    with pytest.raises(RasterError, match=r"unknown setting\(s\) feed; expected fields of RasterSettings: mode, beam_mm"):
        image_to_job(img, mode="gray", beam_mm=0.5, pixel_mm=0.5, feed=2400)
    for bad, msg in ((dict(beam_mm=0), "beam_mm must be"), (dict(gamma=0), "gamma must be"),
                     (dict(edge_path="hilbert"), "edge_path must be")):
        with pytest.raises(RasterError, match=msg):
            RasterSettings(**bad)


def test_placed_size_says_where_the_size_came_from():
    from labkit.raster.engrave import placed_size

    assert placed_size((1000, 4000), file_dpi=72)[3] == "the file's resolution (72 dpi)"
    w, h, size, source = placed_size((1000, 4000))
    assert (round(w, 3), round(h, 3), size) == (1058.333, 264.583, {"dpi": 96.0})
    assert "no resolution in the file" in source
    assert placed_size((100, 200), height_mm=50)[:3] == (100.0, 50.0, {"height_mm": 50})


@pytest.mark.parametrize("s_max, min_power, max_power, white_level",
                         [(1000.0, 0.0, 1.0, 255.0), (1000.0, 0.2, 0.8, 255.0), (255.0, 0.13, 0.77, 250.0)])
def test_power_map_is_the_docstring_formula_value_for_value(s_max, min_power, max_power, white_level):
    """power_map works in one array; S must be the formula's, rounded the same, on grays in and
    out of 0…255 (the rounding of every .5 included)."""
    rng = np.random.default_rng(7)
    gray = np.concatenate([rng.uniform(-20, 280, 20_000), np.arange(0, 256, 0.5)])[None, :]
    arr = gray.astype(np.float64)
    darkness = 1.0 - np.clip(arr, 0, 255) / 255.0
    expected = np.rint(s_max * (min_power + darkness * (max_power - min_power))).astype(np.int64)
    expected[arr >= white_level] = 0
    got = power_map(gray, s_max=s_max, min_power=min_power, max_power=max_power, white_level=white_level)
    assert got.dtype == np.int64 and np.array_equal(got, expected)
