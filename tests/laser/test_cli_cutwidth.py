"""``labkit cutwidth``: the round trip pattern → synthetic scan → measure → fit → settings → window,
and one-line errors for bad input."""

import json
import re

import numpy as np
import pytest
from PIL import Image

from labkit.cli import main
from labkit.laser.measure import read_widths, render_scan
from labkit.laser.models import dose_width

W0, FTH = 0.12, 200.0          # the "material" the synthetic scan is burned into


def _run(capsys, *argv):
    code = main(["cutwidth", *map(str, argv)])
    out, err = capsys.readouterr()
    return code, out, err


def _scan(tmp_path, layout, widths, name="SCAN.png", dpi=600, **kw):
    img = render_scan(layout, widths, dpi=dpi, **kw)
    path = tmp_path / name
    Image.fromarray((img * 255).round().astype(np.uint8)).save(path, dpi=(dpi, dpi))
    return path


@pytest.fixture(scope="module")
def burned(tmp_path_factory):
    """A grid written by the command, 'burned' with the dose model, scanned rotated and noisy, measured."""
    tmp = tmp_path_factory.mktemp("cutwidth")
    assert main(["cutwidth", "pattern", "--powers", "500:2500:5", "--speeds", "300:1500:5",
                 "-o", str(tmp / "GRID.gcode")]) == 0
    layout = json.loads((tmp / "GRID.json").read_text())
    p = np.array([d["power_mw"] for d in layout["lines"]])
    v = np.array([d["speed_mm_min"] for d in layout["lines"]])
    truth = dose_width(p, v, W0, FTH)
    scan = _scan(tmp, layout, truth, rotation_deg=2.5, noise=0.03, blur_px=1.0, seed=5)
    assert main(["cutwidth", "measure", str(scan), "--layout", str(tmp / "GRID.json"),
                 "-o", str(tmp / "WIDTHS.csv")]) == 0
    assert main(["cutwidth", "fit", str(tmp / "WIDTHS.csv"), "-o", str(tmp / "FIT.json")]) == 0
    return tmp, layout, truth


def test_pattern_writes_gcode_layout_and_reports_job_time(burned, capsys):
    tmp, layout, _ = burned
    assert len(layout["lines"]) == 25
    assert sorted({d["power_mw"] for d in layout["lines"]}) == [500, 1000, 1500, 2000, 2500]
    assert sorted({d["speed_mm_min"] for d in layout["lines"]}) == [300, 600, 900, 1200, 1500]
    code, out, _ = _run(capsys, "pattern", "--powers", "100,400,1600", "--speeds", "300:1200:3",
                        "--scale", "geometric", "-o", tmp / "G2.gcode")
    assert code == 0 and "9 lines" in out
    secs = float(re.search(r"job time ([\d.]+) s", out).group(1))
    # at least every burned line's length over its feed (3 × 10 mm at 300, 600, 1200 mm/min)
    assert secs > 3 * (10 / 5 + 10 / 10 + 10 / 20)
    lay2 = json.loads((tmp / "G2.json").read_text())
    assert lay2["speeds_mm_min"] == pytest.approx([300, 600, 1200])
    # the legend, printed and at the head of the G-code, says what every engraved number means
    legend = "rows (engraved left, bottom to top): 1 = 100 mW (S40), 2 = 400 mW (S160), 3 = 1600 mW (S640)"
    assert legend in out
    assert "columns (engraved on top, left to right): 1 = 300 mm/min, 2 = 600 mm/min, 3 = 1200 mm/min" in out
    # (the header's comment lines are wrapped to fit GRBL's line buffer: joined back here)
    header = [t for t in (tmp / "G2.gcode").read_text().splitlines() if t.startswith(";")]
    assert legend in " ".join(t[2:] for t in header) and max(map(len, header)) <= 79


def test_measure_writes_tidy_csv_and_annotated_image(burned):
    tmp, layout, truth = burned
    df = read_widths(tmp / "WIDTHS.csv")
    for col in ("material", "thickness_mm", "machine", "beam_mm", "power_mw", "s_word", "speed_mm_min",
                "width_mm", "cut_through", "repeat", "notes"):
        assert col in df.columns
    assert (df.burned.to_numpy() == (truth > 0)).all()
    assert np.abs(df.width_mm.to_numpy() - truth).max() < 25.4 / 600        # one pixel
    png = Image.open(tmp / "WIDTHS.png")
    assert png.size[0] > 500 and np.asarray(png).std() > 0


def test_round_trip_recovers_the_material_and_the_settings(burned, capsys):
    tmp, _, _ = burned
    fit = json.loads((tmp / "FIT.json").read_text())
    assert fit["chosen"] == "dose"          # the data were made with it; cross-validation must see that
    dose = fit["models"]["dose"]["params"]
    assert dose["w0_mm"] == pytest.approx(W0, rel=0.02)
    assert dose["fth_mj_mm2"] == pytest.approx(FTH, rel=0.04)
    code, out, _ = _run(capsys, "settings", "--width", 0.2, "--speed", 600, "--fit", tmp / "FIT.json")
    assert code == 0
    power, lo, hi = map(float, re.search(r"power (\d+) mW, 95 % band (\d+)…(\d+)", out).groups())
    assert lo < power < hi
    # the power the command picks burns 0.2 mm into the true material, within 2 %
    assert dose_width(power, 600, W0, FTH) == pytest.approx(0.2, rel=0.02)
    code, out, _ = _run(capsys, "settings", "--width", 0.2, "--power", power, "--fit", tmp / "FIT.json")
    assert float(re.search(r"speed (\d+) mm/min", out).group(1)) == pytest.approx(600, abs=1.0)


def test_fit_json_and_text_agree_and_window_draws(burned, capsys):
    tmp, _, _ = burned
    code, out, _ = _run(capsys, "fit", tmp / "WIDTHS.csv", "--model", "dose", "--json")
    res = json.loads(out)
    assert code == 0 and list(res["models"]) == ["dose"]
    assert len(res["models"]["dose"]["residuals_mm"]) == res["data"]["burned"]
    code, out, _ = _run(capsys, "fit", tmp / "WIDTHS.csv", "--model", "empirical")
    assert "c11" in out and "cross-validated" in out
    code, out, _ = _run(capsys, "window", tmp / "FIT.json", "-o", tmp / "WINDOW.png", "--width", 0.2)
    assert code == 0 and Image.open(tmp / "WINDOW.png").size[0] > 300


def test_fit_of_the_synthetic_file_classifies_cut_through(capsys):
    code, out, _ = _run(capsys, "fit", "data/cutwidth/synthetic_paperboard.csv", "--json")
    res = json.loads(out)
    c = res["cut_through"]
    # the file's rule: cut where P/v exceeds twice the burn threshold ratio of w0=0.12, F_th=200
    from labkit.laser.models import threshold_ratio
    assert c["ratio50_mw_per_mm_min"] == pytest.approx(2 * threshold_ratio(0.12, 200.0), rel=0.25)


def _one_line_error(code, err):
    """The message of a refused command: exit 1, one line, no traceback."""
    assert code == 1
    assert "Traceback" not in err and err.count("\n") == 1
    return err


def test_a_csv_missing_a_column_is_named(tmp_path, capsys):
    bad = tmp_path / "w.csv"
    bad.write_text("power_mw,width_mm\n1000,0.1\n")
    err = _one_line_error(*_run(capsys, "fit", bad)[::2])
    assert "speed_mm_min" in err and "missing" in err
    bad.write_text("power_mw,speed_mm_min,width_mm\n1000,600,wide\n")
    err = _one_line_error(*_run(capsys, "fit", bad)[::2])
    assert "w.csv:2" in err and "width_mm" in err
    bad.write_text("power_mw,speed_mm_min,width_mm\n1000,600,0.1\n-5,600,0.1\n")
    err = _one_line_error(*_run(capsys, "fit", bad)[::2])
    assert "power_mw" in err and "> 0" in err


@pytest.mark.parametrize("opt, value", [("--powers", "0:2500:5"), ("--powers", "-500,1000"),
                                        ("--speeds", "300:0:3"), ("--speeds", "fast")])
def test_non_positive_powers_or_speeds_are_refused(tmp_path, capsys, opt, value):
    args = {"--powers": "500:2500:5", "--speeds": "300:1500:5", opt: value}
    # "--powers=-500,1000": a value starting with '-' must be attached, as for any argparse option
    code, _, err = _run(capsys, "pattern", f"--powers={args['--powers']}", f"--speeds={args['--speeds']}",
                        "-o", tmp_path / "g.gcode")
    assert opt in _one_line_error(code, err)
    assert not (tmp_path / "g.gcode").exists()


def test_a_scan_without_the_grid_is_refused(burned, tmp_path, capsys):
    tmp, _, _ = burned
    blank = tmp_path / "blank.png"
    Image.fromarray(np.full((400, 400), 230, np.uint8)).save(blank)
    assert "grid" in _one_line_error(*_run(capsys, "measure", blank, "--layout", tmp / "GRID.json",
                                           "--dpi", 600, "-o", tmp_path / "w.csv")[::2])
    noisy = (np.random.default_rng(0).random((400, 400)) * 255).astype(np.uint8)
    Image.fromarray(noisy).save(blank)
    assert "grid" in _one_line_error(*_run(capsys, "measure", blank, "--layout", tmp / "GRID.json",
                                           "--dpi", 600, "-o", tmp_path / "w.csv")[::2])


def test_measure_with_a_reference_length_instead_of_dpi(burned, tmp_path, capsys):
    tmp, layout, truth = burned
    img = render_scan(layout, truth, dpi=450, rotation_deg=-1.0, seed=2)
    path = tmp_path / "nodpi.png"
    Image.fromarray((img * 255).round().astype(np.uint8)).save(path)       # the file stores no dpi
    n = 50 / 25.4 * 450                                                    # a 50 mm ruler, horizontal
    code, out, err = _run(capsys, "measure", path, "--layout", tmp / "GRID.json", "--reference",
                          10, 20, 10 + n, 20, 50, "-o", tmp_path / "w.csv")
    assert code == 0, err
    assert "450 dpi" in out
    df = read_widths(tmp_path / "w.csv")
    assert np.abs(df.width_mm.to_numpy() - truth).max() < 25.4 / 450
    assert (tmp_path / "w.png").exists()


def test_a_scan_turned_upside_down_is_measured_in_its_own_cells(burned, tmp_path, capsys):
    tmp, layout, truth = burned
    scan = _scan(tmp_path, layout, truth, rotation_deg=181.0, noise=0.03, blur_px=1.0, seed=8)
    code, out, err = _run(capsys, "measure", scan, "--layout", tmp / "GRID.json", "-o", tmp_path / "w.csv")
    assert code == 0, err
    assert "turned 180° (upside down)" in out and "measured in its own cell" in out
    df = read_widths(tmp_path / "w.csv")
    assert np.abs(df.width_mm.to_numpy() - truth).max() < 25.4 / 600
    mirrored = tmp_path / "mirrored.png"
    Image.open(scan).transpose(Image.Transpose.FLIP_LEFT_RIGHT).save(mirrored, dpi=(600, 600))
    err = _one_line_error(*_run(capsys, "measure", mirrored, "--layout", tmp / "GRID.json",
                                "-o", tmp_path / "m.csv")[::2])
    assert "not where the layout puts them" in err and "mirrored" in err
    assert not (tmp_path / "m.csv").exists()


@pytest.mark.parametrize("field, text, message", [
    ("x1_mm", '"x1_mm": 10.0', r"lines\[0\].x1_mm is missing; expected a number"),
    ("pitch_mm", '"pitch_mm": NaN', "pitch_mm is nan; expected a finite number"),
    ("lines", '"lines": []', "lines is empty"),
    ("power_mw", '"power_mw": "500.0"', r"lines\[0\].power_mw is '500.0' \(text\)"),
])
def test_a_hand_edited_layout_is_one_line_naming_the_field(burned, tmp_path, capsys, field, text, message):
    tmp, layout, truth = burned
    scan = _scan(tmp_path, layout, truth)
    source = json.dumps(layout, indent=1)
    if field == "x1_mm":
        edited = source.replace('"x1_mm": 10.0,', "", 1)
    elif field == "lines":
        edited = json.dumps(dict(layout, lines=[]))
    elif field == "power_mw":
        edited = source.replace('"power_mw": 500.0', '"power_mw": "500.0"', 1)
    else:
        edited = source.replace('"pitch_mm": 2.0', '"pitch_mm": NaN')
    assert edited != source
    (tmp_path / "GRID.json").write_text(edited)
    err = _one_line_error(*_run(capsys, "measure", scan, "--layout", tmp_path / "GRID.json",
                                "-o", tmp_path / "w.csv")[::2])
    assert re.search(f"GRID.json: {message}", err), err


@pytest.mark.parametrize("width, given, model, solve", [
    ("1e-12", ("--power", 1000), "empirical", "speed"),       # was "speed nan mm/min", exit 0
    ("1e-12", ("--speed", 600), "power_law", "power"),        # was "power 0 mW"
    ("50", ("--speed", 600), "dose", "power"),                # was "power inf mW"
])
def test_settings_refuse_a_width_the_model_does_not_reach(burned, capsys, width, given, model, solve):
    tmp, _, _ = burned
    err = _one_line_error(*_run(capsys, "settings", "--width", width, *given, "--fit", tmp / "FIT.json",
                                "--model", model)[::2])
    assert f"--width {width}: the {model} model gives no {solve} for it" in err
    lo, hi = map(float, re.search(r"it reaches ([\d.e+-]+)…([\d.e+-]+) mm there", err).groups())
    s_lo, s_hi = map(float, re.search(r"within ([\d.e+-]+)…([\d.e+-]+) (mW|mm/min)", err).groups()[:2])
    # the searched span is the measured one (the fit's data) widened by half its length each side, in ln
    from labkit.laser.models import load_fit

    res, fit = load_fit(tmp / "FIT.json", model)
    m_lo, m_hi = res["data"]["power_mw" if solve == "power" else "speed_mm_min"]
    if model != "empirical":          # the empirical inversion searches its own (burned) data's span
        pad = 0.5 * np.log(m_hi / m_lo)
        assert (s_lo, s_hi) == pytest.approx((m_lo * np.exp(-pad), m_hi * np.exp(pad)), rel=1e-3)
    # the widest width named is the model's at the end of the span where it burns most
    # (the most power, or the least speed): each model here grows with P/v
    g = float(given[1])
    widest = fit.width(s_hi, g) if solve == "power" else fit.width(g, s_lo)
    assert hi == pytest.approx(float(widest), rel=1e-3)
    # a width inside the range is still answered
    mid = 0.5 * (lo + hi)
    code, out, _ = _run(capsys, "settings", "--width", f"{mid:.4f}", *given, "--fit", tmp / "FIT.json",
                        "--model", model)
    assert code == 0 and "nan" not in out and "inf" not in out


def test_measure_outputs_never_overwrite_its_inputs(burned, tmp_path, capsys):
    tmp, layout, truth = burned
    scan = _scan(tmp_path, layout, truth)
    grid = tmp_path / "GRID.json"
    grid.write_text((tmp / "GRID.json").read_text())
    before = scan.read_bytes(), grid.read_text()
    for extra, what in ((["-o", tmp_path / "w.csv", "--annotated", scan],
                         "SCAN.png; expected a different output name (--annotated), the input is left untouched"),
                        (["-o", grid], "GRID.json: is also the input file"),
                        (["-o", tmp_path / "w.csv", "--annotated", tmp_path / "w.csv"], "is also the widths CSV")):
        err = _one_line_error(*_run(capsys, "measure", scan, "--layout", grid, *extra)[::2])
        assert what in err
    assert (scan.read_bytes(), grid.read_text()) == before and not (tmp_path / "w.csv").exists()
    # the default annotated name (the CSV's, .png) would be the scan: another name is taken
    code, out, err = _run(capsys, "measure", scan, "--layout", grid, "-o", tmp_path / "SCAN.csv")
    assert code == 0, err
    assert scan.read_bytes() == before[0] and (tmp_path / "SCAN.annotated.png").exists()


def test_fit_and_window_never_overwrite_their_input(burned, tmp_path, capsys):
    tmp, _, _ = burned
    widths = tmp_path / "w.csv"
    widths.write_text((tmp / "WIDTHS.csv").read_text())
    assert "is also the input file" in _one_line_error(*_run(capsys, "fit", widths, "-o", widths)[::2])
    fit = tmp_path / "FIT.json"
    fit.write_text((tmp / "FIT.json").read_text())
    assert "is also the input file" in _one_line_error(*_run(capsys, "window", fit, "-o", fit)[::2])
    assert widths.read_text() == (tmp / "WIDTHS.csv").read_text() and fit.read_text() == (tmp / "FIT.json").read_text()


def test_pattern_replaces_a_linked_layout_without_writing_through_the_link(tmp_path, capsys):
    precious = tmp_path / "precious.json"
    precious.write_text('{"another grid": true}')
    (tmp_path / "G.json").symlink_to(precious)
    code, _, err = _run(capsys, "pattern", "--powers", "500,1000", "--speeds", "300,600", "-o", tmp_path / "G.gcode")
    assert code == 0, err
    assert precious.read_text() == '{"another grid": true}'
    assert not (tmp_path / "G.json").is_symlink()
    assert len(json.loads((tmp_path / "G.json").read_text())["lines"]) == 4


def test_a_layout_without_numbers_says_the_orientation_was_not_checked(burned, tmp_path, capsys):
    tmp, layout, truth = burned
    bare = dict(layout, labels=[], label_mm=0.0)
    (tmp_path / "BARE.json").write_text(json.dumps(bare))
    scan = _scan(tmp_path, bare, truth)
    code, out, err = _run(capsys, "measure", scan, "--layout", tmp_path / "BARE.json", "-o", tmp_path / "w.csv")
    assert code == 0, err
    assert "no engraved numbers, so the scan's orientation was not checked" in out
