"""The calibration files whose S word key was renamed (``power_s`` → ``s_word``, issue 28 §4) are
read in both versions: a version 1 file gives what its version 2 twin gives, a later version is
refused by name, and labkit writes version 2."""

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from PIL import Image

from labkit.cli import main
from labkit.errors import InputError
from labkit.laser.measure import (WIDTHS_HEADER, check_layout, measure_lines, read_widths,
                                  render_scan)
from labkit.laser.patterns import LAYOUT_VERSION, grid_pattern, write_pattern
from labkit.laser.tone import TONE_VERSION, fit_tone, load_tone

DATA = Path(__file__).resolve().parents[2] / "data" / "cutwidth"


def _as_version_1(lines):
    return [{("power_s" if k == "s_word" else k): v for k, v in d.items()} for d in lines]


def test_widths_table_reads_version_1_and_2(tmp_path):
    committed = DATA / "synthetic_paperboard.csv"                 # version 1: no version line
    assert WIDTHS_HEADER not in committed.read_text()
    old = read_widths(committed)
    raw = pd.read_csv(committed, skiprows=1)                      # its one SYNTHETIC comment line
    assert "power_s" not in old.columns
    assert old.s_word.tolist() == raw.power_s.tolist() and len(old) == 50
    new_path = tmp_path / "v2.csv"
    new_path.write_text(WIDTHS_HEADER + "\n" + old.to_csv(index=False))
    pd.testing.assert_frame_equal(read_widths(new_path), old)
    later = tmp_path / "v3.csv"
    later.write_text(new_path.read_text().replace("version 2", "version 3", 1))
    with pytest.raises(InputError, match="labkit-cutwidth-table version 3; this labkit reads versions 1 and 2"):
        read_widths(later)


def test_layout_reads_version_1_and_2(tmp_path, capsys):
    g = grid_pattern([800, 1600], [300, 900], repeats=1, label_mm=2.0)
    write_pattern(tmp_path / "G.gcode", g)
    v2 = json.loads((tmp_path / "G.json").read_text())
    assert v2["version"] == LAYOUT_VERSION == 2 and "s_word" in v2["lines"][0]
    v1 = dict(v2, version=1, lines=_as_version_1(v2["lines"]))
    (tmp_path / "G1.json").write_text(json.dumps(v1))
    assert check_layout(v1) == v2 and v1["lines"][0]["power_s"] == v2["lines"][0]["s_word"]   # the file's dict as it was
    assert check_layout(v2) is v2
    widths = np.array([0.10, 0.20, 0.15, 0.25])
    img = render_scan(v1, widths, dpi=600, rotation_deg=1.0)
    pd.testing.assert_frame_equal(measure_lines(img, v1, dpi=600), measure_lines(img, v2, dpi=600))
    Image.fromarray((img * 255).round().astype(np.uint8)).save(tmp_path / "S.png", dpi=(600, 600))
    for name in ("G.json", "G1.json"):
        out = tmp_path / f"{name}.csv"
        assert main(["cutwidth", "measure", str(tmp_path / "S.png"), "--layout", str(tmp_path / name),
                     "-o", str(out)]) == 0
        assert out.read_text().splitlines()[0] == WIDTHS_HEADER
        df = read_widths(out)
        assert df.s_word.tolist() == [d["s_word"] for d in v2["lines"]]
        assert np.abs(df.width_mm.to_numpy() - widths).max() < 25.4 / 600
    v3 = dict(v2, version=3)
    with pytest.raises(InputError, match="layout version 3; this labkit reads versions 1 and 2"):
        check_layout(v3)
    with pytest.raises(InputError, match=r"lines\[0\].power_s is missing"):
        check_layout(dict(v2, version=1))             # version 1 names it power_s
    capsys.readouterr()


def test_tone_curve_reads_version_1_and_2(tmp_path):
    s = np.linspace(125, 1000, 8)
    fit_tone(s, np.sqrt(s / 1000), spread=np.full(8, 0.01), feed_mm_min=3000).save(tmp_path / "v2.json")
    doc = json.loads((tmp_path / "v2.json").read_text())
    assert doc["version"] == TONE_VERSION == 2 and "s_word" in doc and "power_s" not in doc
    old = {("power_s" if k == "s_word" else k): v for k, v in doc.items()} | {"version": 1}
    (tmp_path / "v1.json").write_text(json.dumps(old))
    a, b = load_tone(tmp_path / "v1.json"), load_tone(tmp_path / "v2.json")
    for field in ("s_word", "darkness", "measured", "spread"):
        assert getattr(a, field).tolist() == getattr(b, field).tolist()
    assert (a.s_max, a.feed_mm_min) == (b.s_max, b.feed_mm_min) == (1000.0, 3000.0)
    (tmp_path / "v3.json").write_text(json.dumps(doc | {"version": 3}))
    with pytest.raises(InputError, match="tone curve version 3; this labkit reads versions 1 and 2"):
        load_tone(tmp_path / "v3.json")
    (tmp_path / "v2old.json").write_text(json.dumps(old | {"version": 2}))
    with pytest.raises(InputError, match="s_word, darkness and s_max must be numbers"):
        load_tone(tmp_path / "v2old.json")
