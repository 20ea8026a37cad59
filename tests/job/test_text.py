"""SVG <text> in a job: glyph outlines placed as a renderer places them, checked against the font
file's own metrics read with fontTools (not through matplotlib), and a missing font named."""

import numpy as np
import pytest

from labkit.errors import InputError
from labkit.jobfile import compose_job, read_job, svg_text_paths

SVG = """<svg xmlns="http://www.w3.org/2000/svg" width="60mm" height="40mm" viewBox="0 0 60 40">
<text id="t1" x="10" y="20" font-family="DejaVu Sans" font-size="8" fill="#000000">H</text>
<g transform="translate(5 0)"><text id="t2" x="10" y="35" font-size="5" font-family="{family}"
   fill="#ff0000" text-anchor="end">I</text></g>
</svg>"""                                               # written by hand


def _metrics(char):
    """(left side bearing, advance, yMin, yMax) of a glyph in em, from the font file itself."""
    from fontTools.ttLib import TTFont
    from matplotlib.font_manager import FontProperties, findfont

    font = TTFont(findfont(FontProperties(family="DejaVu Sans")))
    upm = font["head"].unitsPerEm
    name = font.getBestCmap()[ord(char)]
    glyph = font["glyf"][name]
    advance, lsb = font["hmtx"][name]
    return lsb / upm, advance / upm, glyph.yMin / upm, glyph.yMax / upm


def test_glyphs_sit_where_the_font_puts_them(tmp_path):
    p = tmp_path / "t.svg"
    p.write_text(SVG.format(family="DejaVu Sans"))
    paths = svg_text_paths(p, tol_mm=0.001)
    h = [q for q in paths if q.source == "text#t1"]
    lsb, _, y0, y1 = _metrics("H")
    box = np.array([q.bounds() for q in h])
    lo, hi = box[:, 0].min(axis=0), box[:, 1].max(axis=0)
    # 8 mm type at x = 10, baseline y = 20 on a 40 mm page (flipped: 40 − 20 = 20)
    assert lo[0] == pytest.approx(10 + 8 * lsb, abs=2e-3) and lo[1] == pytest.approx(20 + 8 * y0, abs=2e-3)
    assert hi[1] == pytest.approx(20 + 8 * y1, abs=2e-3)
    assert all(q.closed and q.layer == "#000000" for q in h)
    # 'I', 5 mm, anchored at its end at x = 10 + 5 (the group's translate): its advance ends there
    i = [q for q in paths if q.source == "text#t2"]
    lsb_i, adv_i, _, _ = _metrics("I")
    left = min(q.bounds()[0][0] for q in i)
    assert left == pytest.approx(15 - 5 * adv_i + 5 * lsb_i, abs=2e-3) and i[0].layer == "#ff0000"


def test_missing_font_is_named(tmp_path):
    p = tmp_path / "t.svg"
    p.write_text(SVG.format(family="No Such Family 31"))
    with pytest.raises(InputError, match=r"text#t2 \('I'\): font 'No Such Family 31' is not installed"):
        svg_text_paths(p)


def test_text_engraved_by_a_job(tmp_path):
    (tmp_path / "t.svg").write_text(SVG.format(family="DejaVu Sans"))
    (tmp_path / "job.toml").write_text('format = "labkit-job"\nversion = 1\nmachine = "cbr40-laser"\n'
                                       '[[layer]]\nsource = "t.svg"\noperation = "fill"\nselect = ["#000000"]\n'
                                       'power_mw = 500.0\nspeed_mm_min = 1000.0\nline_interval_mm = 0.2\n')
    composed = compose_job(read_job(tmp_path / "job.toml"))
    m = composed.moves
    (x0, y0), (x1, y1) = composed.layers[0]["bounds_mm"]
    lsb, adv, g0, g1 = _metrics("H")
    assert x0 == pytest.approx(10 + 8 * lsb, abs=0.02) and y1 == pytest.approx(20 + 8 * g1, abs=0.02)
    # the hatch fills the H: burned length ≈ its area / the line interval, plus the outline
    assert float(m.lengths_mm()[m.laser_on].sum()) > 0.5 * (x1 - x0) * (y1 - y0) / 0.2
