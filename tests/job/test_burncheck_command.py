"""``labkit burncheck predict|compare`` end to end: the predicted scan is written as a PNG that stores
its dpi; that picture read back as a scan shows nothing; with one score line painted over with paper
(by hand, below) the line is reported missing, the command exits 1 and writes its report and overlay."""

import json
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from labkit.burncheck import predict_burn
from labkit.cli import main
from labkit.gcode import parse

from .test_burncheck import FTH, PROGRAM, W0

DPI, MARGIN = 600, 3.0


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("burncheck")
    (d / "label.gcode").write_text(PROGRAM)
    assert main(["burncheck", "predict", str(d / "label.gcode"), "--w0", str(W0), "--fth", str(FTH),
                 "-o", str(d / "predicted.png"), "--dpi", str(DPI), "--margin", str(MARGIN)]) == 0
    return d


def test_the_predicted_picture_stores_its_resolution_and_levels(files):
    with Image.open(files / "predicted.png") as im:
        assert im.info["dpi"][0] == pytest.approx(DPI, abs=0.01)
        a = np.asarray(im)
    assert a.max() == round(0.9 * 255) and abs(int(a.min()) - 0.1 * 255) <= 0.5     # 25.5 rounds either way


def test_a_clean_scan_exits_0(files, capsys):
    assert main(["burncheck", "compare", str(files / "label.gcode"), str(files / "predicted.png"),
                 "--w0", str(W0), "--fth", str(FTH)]) == 0
    out = capsys.readouterr().out
    assert "no region differs" in out and "S300" in out and "S800" in out


def test_a_line_painted_over_is_reported_missing(files, capsys):
    a = np.asarray(Image.open(files / "predicted.png")).copy()
    burn = predict_burn(parse(PROGRAM), w0_mm=W0, fth_mj_mm2=FTH, pixel_mm=W0 / 8)
    px = 25.4 / DPI
    top = burn.extent[3] + MARGIN                     # the picture's top edge, mm
    r = int(round((top - 4.0) / px))                  # the score line at y = 4 …
    c0, c1 = int(round((1.5 - burn.extent[0] + MARGIN) / px)), int(round((12.5 - burn.extent[0] + MARGIN) / px))
    a[r - 6:r + 7, c0:c1] = round(0.9 * 255)          # … under paper, x 1.5 … 12.5 mm
    Image.fromarray(a).save(files / "scan.png", dpi=(DPI, DPI))
    rc = main(["burncheck", "compare", str(files / "label.gcode"), str(files / "scan.png"), "--w0", str(W0),
               "--fth", str(FTH), "-o", str(files / "report.json"), "--overlay", str(files / "overlay.png")])
    assert rc == 1
    doc = json.loads((files / "report.json").read_text())
    assert doc["format"] == "labkit-burncheck" and doc["version"] == 2          # 2: a layer's S is s_word
    (d,) = doc["defects"]
    assert d["kind"] == "missing" and d["layer_s"] == 300
    assert d["bbox_mm"][0] == pytest.approx(2, abs=0.2) and d["bbox_mm"][2] == pytest.approx(12, abs=0.2)
    assert 3.8 < d["bbox_mm"][1] <= d["bbox_mm"][3] < 4.2
    with Image.open(files / "overlay.png") as im:
        ov = np.asarray(im.convert("RGB"))
    assert (ov == (220, 30, 30)).all(axis=2).any()
    assert "missing" in capsys.readouterr().out


def test_without_a_dose_model_it_says_what_it_needs(files, capsys):
    assert main(["burncheck", "predict", str(files / "label.gcode"), "-o", str(files / "x.png")]) == 1
    assert "expected --fit FIT.json (a cut-width fit) or both --w0 and --fth" in capsys.readouterr().err
    assert not (files / "x.png").exists()


def test_a_scan_without_a_resolution_needs_dpi(files, capsys):
    Image.fromarray(np.full((50, 50), 200, np.uint8)).save(files / "nodpi.png")
    assert main(["burncheck", "compare", str(files / "label.gcode"), str(files / "nodpi.png"),
                 "--w0", str(W0), "--fth", str(FTH)]) == 1
    assert "stores no resolution; expected --dpi" in capsys.readouterr().err


def test_the_dose_model_comes_from_a_fit_and_a_typed_value_beats_it(tmp_path, capsys):
    from labkit.laser.measure import read_widths
    from labkit.laser.models import fit_table

    data = Path(__file__).resolve().parents[2] / "data" / "cutwidth" / "synthetic_paperboard.csv"
    res = fit_table(read_widths(data), source=data.name)
    (tmp_path / "fit.json").write_text(json.dumps(res))
    w0, fth = res["models"]["dose"]["params"]["w0_mm"], res["models"]["dose"]["params"]["fth_mj_mm2"]
    (tmp_path / "p.gcode").write_text("G21 G90\nM3 S800 F300\nG1 X5\nM5\n")
    assert main(["burncheck", "predict", str(tmp_path / "p.gcode"), "--fit", str(tmp_path / "fit.json"),
                 "-o", str(tmp_path / "a.png")]) == 0
    assert f"w0 {w0:.4g} mm, F_th {fth:.4g} mJ/mm² (fit {tmp_path / 'fit.json'})" in capsys.readouterr().out
    assert main(["burncheck", "predict", str(tmp_path / "p.gcode"), "--fit", str(tmp_path / "fit.json"),
                 "--w0", "0.1", "-o", str(tmp_path / "b.png")]) == 0
    assert f"w0 0.1 mm, F_th {fth:.4g} mJ/mm² (fit {tmp_path / 'fit.json'}, typed --w0)" in capsys.readouterr().out
    # the narrower beam burns a narrower line (dose_width at 2000 mW, 300 mm/min: 0.272 mm at the fit's
    # w0 0.119 mm, 0.236 mm at 0.1 mm): fewer dark rows in its picture
    rows = [int((np.asarray(Image.open(tmp_path / f)) < 128).any(axis=1).sum()) for f in ("a.png", "b.png")]
    assert rows[1] < rows[0]
