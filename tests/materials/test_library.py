"""The material library (labkit.materials, labkit materials, --material on the converters),
checked against hand-worked cases: the logistic cut-through inverted by hand, the dose model's
closed form, a Monte-Carlo spread of the fit's parameters, and parts offset by half the kerf."""

import json
import math
import re

import numpy as np
import pytest

from labkit.cli import main
from labkit.errors import InputError
from labkit.gcode.reader import parse
from labkit.materials import Library, Material, Setting, read_library, setting_from_fit, write_library

W0, FTH = 0.1, 300.0                       # the hand-made fit's dose model
B0, B1 = 0.0, 10.0                         # its cut-through model: 50 % at P/v = 1 mW per mm/min
COV = [[1e-6, 0.0], [0.0, 1e-4]]           # of (w0, ln F_th)


def _dose_width(p_mw, v_mm_min):
    """W = w0·sqrt(2 ln(F_peak/F_th)), F_peak = sqrt(2/π)·P/(v·w0), v in mm/s — written out here."""
    f_peak = math.sqrt(2 / math.pi) * p_mw / (v_mm_min / 60 * W0)
    return W0 * math.sqrt(2 * math.log(f_peak / FTH))


@pytest.fixture
def fit_file(tmp_path):
    """A saved fit written by hand in the 'labkit cutwidth fit -o' format."""
    res = dict(format="labkit-cutwidth-fit", version=1, source="widths.csv",
               data=dict(n=50, burned=46, power_mw=[500.0, 2500.0], speed_mm_min=[300.0, 1500.0]),
               models=dict(dose=dict(model="dose", params=dict(w0_mm=W0, fth_mj_mm2=FTH),
                                     ci=dict(w0_mm=[0.098, 0.102], fth_mj_mm2=[294.0, 306.0]),
                                     level=0.95, rmse_mm=0.004, n=46, cov=COV, residuals_mm=[])),
               chosen="dose", cut_through=dict(b0=B0, b1=B1, ratio50_mw_per_mm_min=1.0, n=50, n_cut=30))
    path = tmp_path / "FIT.json"
    path.write_text(json.dumps(res))
    return path


def test_cut_from_fit_is_the_hand_inverted_logistic(fit_file):
    s = setting_from_fit(fit_file, "cut", power_mw=1000.0, cut_probability=0.95)
    # logit(0.95) = ln 19 = b0 + b1 ln(P/v)  →  P/v = exp(ln 19 / 10) = 1.342379…
    assert s.speed_mm_min == pytest.approx(1000 / 19 ** 0.1, abs=1e-3)
    assert s.speed_mm_min == pytest.approx(744.945, abs=1e-3)
    assert s.kerf_mm == pytest.approx(_dose_width(1000, 744.945), abs=1e-4)
    assert s.kerf_mm == pytest.approx(0.12342, abs=1e-4)
    assert s.origin == "fit" and s.fit["file"] == str(fit_file) and s.fit["scan"] == "widths.csv"
    assert len(s.fit["sha256"]) == 64 and s.fit["model"] == "dose"


def test_kerf_interval_matches_a_monte_carlo_spread_of_the_parameters(fit_file):
    s = setting_from_fit(fit_file, "cut", power_mw=1000.0)
    rng = np.random.default_rng(3)
    w0, ln_fth = rng.multivariate_normal([W0, math.log(FTH)], COV, 20000).T
    f_peak = math.sqrt(2 / math.pi) * 1000 / (s.speed_mm_min / 60 * w0)
    widths = w0 * np.sqrt(2 * np.log(f_peak / np.exp(ln_fth)))
    half = (s.kerf_ci_mm[1] - s.kerf_ci_mm[0]) / 2
    # t(0.975, 44) · sd; the Monte-Carlo sd with 20000 draws is good to about 1 %
    from scipy import stats

    assert half / stats.t.ppf(0.975, 44) == pytest.approx(widths.std(), rel=0.03)


def test_score_and_fill_burn_the_wanted_width(fit_file):
    s = setting_from_fit(fit_file, "score", power_mw=1000.0, width_mm=0.15)
    assert _dose_width(1000, s.speed_mm_min) == pytest.approx(0.15, abs=1e-5)
    f = setting_from_fit(fit_file, "fill", power_mw=800.0, width_mm=0.12)
    assert f.line_interval_mm == 0.12 and _dose_width(800, f.speed_mm_min) == pytest.approx(0.12, abs=1e-5)


@pytest.mark.parametrize("kw, match", [
    (dict(operation="cut", power_mw=100.0), "outside the measured powers 500…2500"),
    (dict(operation="score", power_mw=1000.0), "needs the wanted line width"),
    (dict(operation="score", power_mw=1000.0, width_mm=2.0), "gives no speed"),
    (dict(operation="engrave", power_mw=1000.0), "expected one of cut, score, fill, image"),
])
def test_from_fit_refusals(fit_file, kw, match):
    op = kw.pop("operation")
    with pytest.raises(InputError, match=match):
        setting_from_fit(fit_file, op, **kw)


def test_cut_needs_a_cut_through_model(fit_file):
    res = json.loads(fit_file.read_text())
    res["cut_through"] = None
    fit_file.write_text(json.dumps(res))
    with pytest.raises(InputError, match="no usable cut-through model"):
        setting_from_fit(fit_file, "cut", power_mw=1000.0)


def test_round_trip(tmp_path):
    lib = Library(machine="cbr40-laser")
    lib.materials['birch "3 mm"'] = Material('birch "3 mm"', 3.0, "note with é and \\", dict(
        cut=Setting("typed", 2250.0, 120.0, 3, kerf_mm=0.2, air=True, dynamic=True, note="by hand"),
        fill=Setting("fit", 800.0, 900.0, line_interval_mm=0.1, kerf_mm=0.1, kerf_ci_mm=(0.09, 0.11),
                     fit=dict(file="f.json", sha256="0" * 64, date="2026-01-01T00:00:00+00:00",
                              scan="w.csv", model="dose", level=0.95, rule="r"))))
    path = write_library(lib, tmp_path / "lib.toml")
    back = read_library(path)
    assert back.machine == lib.machine and back.materials == lib.materials


@pytest.mark.parametrize("text, match", [
    ('format = "labkit-materials"\nversion = 1\n[material.a.cut]\norigin = "typed"\npower_mw = 1\n',
     r"speed_mm_min is missing"),
    ('format = "labkit-materials"\nversion = 2\n', "version = 2; this labkit reads version 1"),
    ('format = "other"\nversion = 1\n', "expected format = \"labkit-materials\""),
    ('format = "labkit-materials"\nversion = 1\nmaterial = [1,,2]\n', r"not valid TOML: .*line 3, column"),
    ('format = "labkit-materials"\nversion = 1\n[material.a.cut]\norigin = "typed"\npower_mw = -1\n'
     'speed_mm_min = 100\n', r"material 'a', cut: power_mw = -1; expected a finite number >= 0"),
    ('format = "labkit-materials"\nversion = 1\n[material.a.cut]\norigin = "fit"\npower_mw = 1\n'
     'speed_mm_min = 100\n', r"needs a \[\.fit\] table"),
    ('format = "labkit-materials"\nversion = 1\n[material.a.cut]\norigin = "guess"\npower_mw = 1\n'
     'speed_mm_min = 100\n', "origin = 'guess'; expected one of typed, fit, starting-point"),
    ('format = "labkit-materials"\nversion = 1\n[material.a.cut]\norigin = "typed"\npower_mw = 1\n'
     'speed_mm_min = 100\nspeed = 3\n', r"unknown key\(s\) speed"),
    ('format = "labkit-materials"\nversion = 1\n[material.a.cut]\norigin = "typed"\npower_mw = 1\n'
     'speed_mm_min = 100\npasses = 1.5\n', "passes = 1.5; expected a whole number >= 1"),
])
def test_bad_library_is_a_clear_error(tmp_path, text, match):
    path = tmp_path / "lib.toml"
    path.write_text(text)
    with pytest.raises(InputError, match=match):
        read_library(path)


# --- the command line ---------------------------------------------------------------------------

SVG = ('<svg xmlns="http://www.w3.org/2000/svg" width="40mm" height="30mm" viewBox="0 0 40 30">'
       '<rect x="5" y="5" width="30" height="20" fill="none" stroke="#000"/></svg>')   # written by hand


@pytest.fixture
def config(tmp_path, monkeypatch):
    monkeypatch.setenv("LABKIT_CONFIG_DIR", str(tmp_path / "cfg"))
    return tmp_path / "cfg" / "materials" / "cbr40-laser.toml"


def _run(capsys, *argv):
    code = main([*map(str, argv)])
    out, err = capsys.readouterr()
    return code, out, err


def test_materials_commands(tmp_path, config, fit_file, capsys):
    code, out, _ = _run(capsys, "materials", "add", "card", "--power-mw", 1250, "--speed", 600, "--kerf", 0.2,
                        "--thickness", 0.5, "--note", "typed from a test burn")
    assert code == 0 and config.exists()
    code, out, err = _run(capsys, "materials", "add", "card", "--power-mw", 1, "--speed", 1)
    assert code == 1 and "exists" in err and "--replace" in err
    assert _run(capsys, "materials", "from-fit", fit_file, "--name", "card", "--operation", "score",
                "--width", 0.15, "--power-mw", 1000)[0] == 0
    code, out, _ = _run(capsys, "materials", "list")
    assert re.search(r"card\s+0.5 mm\s+cut \[typed\], score \[fit\]", out)
    code, out, _ = _run(capsys, "materials", "show", "card")
    assert "1250 mW, 600 mm/min, kerf 0.200 mm [typed]" in out and f"fit {fit_file}" in out
    assert _run(capsys, "materials", "remove", "card:score")[0] == 0
    assert list(read_library(config).materials["card"].operations) == ["cut"]
    code, _, err = _run(capsys, "materials", "show", "paper")
    assert code == 1 and "no material 'paper'; expected one of: card" in err


def test_svg2gcode_takes_the_library_and_typed_values_win(tmp_path, config, capsys):
    svg = tmp_path / "card.svg"
    svg.write_text(SVG)
    # 1250 mW of the CBR-40's 2500 mW at S max 1000 is S500; kerf 0.2 mm grows the 30 × 20 outline by 0.1 mm a side
    assert _run(capsys, "materials", "add", "card", "--power-mw", 1250, "--speed", 600, "--kerf", 0.2,
                "--passes", 2)[0] == 0
    out_file = tmp_path / "a.gcode"
    code, out, err = _run(capsys, "svg2gcode", svg, "-o", out_file, "--material", "card")
    assert code == 0, err
    text = out_file.read_text()
    moves = parse(text)
    xs = np.concatenate([moves.start[:, 0], moves.end[:, 0]])
    ys = np.concatenate([moves.start[:, 1], moves.end[:, 1]])
    # the offset's round corners are flattened within --tol 0.01 mm, so each side may fall that short
    assert xs.max() - xs[xs > 1].min() == pytest.approx(30.2, abs=0.02)
    assert ys.max() - ys[ys > 1].min() == pytest.approx(20.2, abs=0.02)
    assert "S500" in text and "F600" in text
    header = " ".join(line[1:].strip() for line in text.splitlines() if line.startswith(";"))
    assert "material card:cut" in header and "typed by hand" in header and "--kerf 0.2" in header
    code, out, err = _run(capsys, "svg2gcode", svg, "-o", out_file, "--material", "card", "--power", 300,
                          "--passes", 1)
    text = out_file.read_text()
    program = "\n".join(line for line in text.splitlines() if not line.startswith(";"))
    assert code == 0 and "S300" in program and "S500" not in program and "F600" in program
    assert "typed --power --passes" in out
    one_pass = parse(text)
    assert len(moves) - 1 == 2 * (len(one_pass) - 1)        # the library's two passes (less the first rapid)


def test_material_errors_on_the_converters(tmp_path, config, capsys):
    svg = tmp_path / "card.svg"
    svg.write_text(SVG)
    code, _, err = _run(capsys, "svg2gcode", svg, "-o", tmp_path / "a.gcode", "--material", "card")
    assert code == 1 and "has no material library yet" in err and not (tmp_path / "a.gcode").exists()
    _run(capsys, "materials", "add", "card", "--power-mw", 1250, "--speed", 600)
    code, _, err = _run(capsys, "svg2gcode", svg, "-o", tmp_path / "a.gcode", "--material", "card:score")
    assert code == 1 and "has no 'score' settings; it has cut" in err
    code, _, err = _run(capsys, "svg2gcode", svg, "-o", tmp_path / "a.gcode", "--material", "card:etch")
    assert code == 1 and "operation 'etch'" in err
    code, _, err = _run(capsys, "svg2gcode", svg, "-o", tmp_path / "a.gcode", "--material", "card",
                        "--machine", "grbl-diode")
    assert code == 1 and "has no material library yet" in err


def test_img2gcode_takes_power_speed_and_line_interval(tmp_path, config, capsys):
    from PIL import Image

    img = tmp_path / "dot.png"
    Image.fromarray(np.full((20, 20), 0, np.uint8)).save(img)          # a black square, made here
    _run(capsys, "materials", "add", "card", "--operation", "image", "--power-mw", 1000, "--speed", 1200,
         "--line-interval", 0.2)
    out_file = tmp_path / "dot.gcode"
    code, out, err = _run(capsys, "img2gcode", img, "-o", out_file, "--width", 4, "--material", "card:image",
                          "--preview", "none", "--axis", "columns")
    assert code == 0, err
    text = out_file.read_text()
    # 1000 mW of 2500 mW is S400; a 4 mm square at a 0.2 mm pitch is 20 lines
    assert "S400" in text and "F1200" in text and "material card:image" in out
    xs = sorted({round(float(x), 3) for x in parse(text).end[:, 0]} - {0.0})
    assert len(xs) == 20 and np.allclose(np.diff(xs), 0.2)
