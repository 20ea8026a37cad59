"""SVG <text> cut as a renderer draws it (issue 31): the glyphs of a file in Inkscape's form held to
resvg's drawing, positions held to the font file's own metrics (fontTools, not matplotlib), and
svg2gcode end to end."""

from __future__ import annotations

import io
import warnings
from pathlib import Path

import numpy as np
import pytest
import resvg_py
from PIL import Image
from scipy import ndimage

from labkit.cli import main
from labkit.errors import InputError
from labkit.gcode import parse
from labkit.vector.svg import MM_PER_PX, read_svg
from labkit.vector.text import svg_text_paths

INKSCAPE = Path(__file__).resolve().parents[2] / "data" / "svg" / "labkit" / "inkscape_text.svg"


def _metrics(char, family="DejaVu Sans"):
    """(left side bearing, advance) of a glyph in em, from the font file itself."""
    from fontTools.ttLib import TTFont
    from matplotlib.font_manager import FontProperties, findfont

    font = TTFont(findfont(FontProperties(family=family)))
    name = font.getBestCmap()[ord(char)]
    advance, lsb = font["hmtx"][name]
    return lsb / font["head"].unitsPerEm, advance / font["head"].unitsPerEm


def _dense_pixels(paths, zoom):
    """(row, col) of every half pixel along every path, at ``zoom`` px per CSS px."""
    out = []
    for p in paths:
        uv = p.sample(0.005) / MM_PER_PX * zoom
        for a, b in zip(uv[:-1], uv[1:]):
            k = max(2, int(np.ceil(np.hypot(*(b - a)) / 0.5)) + 1)
            out.append(a + np.linspace(0.0, 1.0, k)[:, None] * (b - a))
    return np.round(np.vstack(out)[:, ::-1]).astype(int)


def test_inkscape_text_is_cut_where_resvg_draws_it():
    """Lines of tspans, a bold word with text after it, kerning (AVAWAY), a centred line with
    a '$' in it, a rotated text: every cut lies on resvg's ink and every edge resvg inks is cut,
    within 1.5 px at 4 px per CSS px (0.1 mm)."""
    d = read_svg(INKSCAPE, flip_y=False)
    assert d.layers == ["#ff0000", "#000000", "#0000ff"] and not d.skipped
    assert {p.source for p in d.paths} == {"rect#outline", "text#name", "text#centred", "text#rotated"}
    _held_to_resvg(INKSCAPE, d.paths)


def _held_to_resvg(path, paths, zoom=4):
    """Every cut on resvg's ink and every edge resvg inks cut, within 1.5 px at ``zoom``."""
    png = resvg_py.svg_to_bytes(svg_path=str(path), dpi=96.0, zoom=zoom)
    drawn = np.asarray(Image.open(io.BytesIO(bytes(png))))[:, :, 3] > 0
    rc = _dense_pixels(paths, zoom)
    assert ndimage.distance_transform_edt(~drawn)[rc[:, 0], rc[:, 1]].max() <= 1.5
    cut = np.zeros_like(drawn)
    cut[rc[:, 0], rc[:, 1]] = True
    edge = drawn & ~ndimage.binary_erosion(drawn)
    assert ndimage.distance_transform_edt(~cut)[edge].max() <= 1.5


HAND = {   # written by hand
    "letter- and word-spacing, kerning kept, end anchor":
        '<text x="5" y="15" style="font-family:\'DejaVu Sans\';font-size:8px;letter-spacing:1.5px;'
        'word-spacing:4px">Sp aced out</text><text x="95" y="32" style="font-family:\'DejaVu Sans\';'
        'font-size:6px;letter-spacing:-0.3px;text-anchor:end">Tight <tspan style="letter-spacing:2px">wide'
        '</tspan></text>',
    "pretty-printed tspans, middle anchor, spaces around a bold run":
        '\n  <text x="50" y="15" font-family="DejaVu Sans" font-size="8" text-anchor="middle">\n'
        '    <tspan x="50" y="15">Middle A</tspan>\n    <tspan x="50" y="30">B</tspan>\n  </text>\n'
        '  <text x="95" y="38" font-family="DejaVu Sans" font-size="5" text-anchor="end">  end  '
        '<tspan font-weight="bold">bold</tspan>  </text>\n',
}


@pytest.mark.parametrize("case", HAND)
def test_hand_written_text_is_cut_where_resvg_draws_it(case, tmp_path):
    path = tmp_path / "t.svg"
    path.write_text('<svg xmlns="http://www.w3.org/2000/svg" width="100mm" height="40mm" viewBox="0 0 100 40">'
                    f'{HAND[case]}</svg>')
    paths = read_svg(path, flip_y=False).paths
    assert paths, f"{case}: no text cut"
    _held_to_resvg(path, paths)                       # asserts: every cut on resvg's ink, its ink cut


def test_rotated_characters_are_named():
    with pytest.warns(UserWarning, match=r"text#r: rotate='30' on characters is not applied"):
        svg_text_paths(_text('<text id="r" x="10" y="20" rotate="30">abc</text>'))


def _text(body, size=8):
    return (f'<svg xmlns="http://www.w3.org/2000/svg" width="100mm" height="40mm" viewBox="0 0 100 40">'
            f'<g font-family="DejaVu Sans" font-size="{size}">{body}</g></svg>')    # written by hand


def _left(paths):
    return min(p.bounds()[0][0] for p in paths)


def test_characters_placed_one_by_one_from_an_x_list():
    """x="10 30 50" places each H's pen there: its ink starts at x + size · lsb (font file)."""
    paths = svg_text_paths(_text('<text id="h" x="10 30 50" y="20">HHH</text>'), tol_mm=0.001)
    lsb, _ = _metrics("H")
    lefts = sorted({round(q.bounds()[0][0], 3) for q in paths})
    assert lefts == pytest.approx([10 + 8 * lsb, 30 + 8 * lsb, 50 + 8 * lsb], abs=2e-3)


def test_white_space_collapses_and_anchor_shifts_by_the_advance():
    """'H   I' reads as 'H I' (SVG collapses spaces); text-anchor middle moves the line left by
    half its advance: H + space + I advances from the font file (no kerning between them)."""
    lsb, adv_h = _metrics("H")
    _, adv_space = _metrics(" ")
    _, adv_i = _metrics("I")
    start = svg_text_paths(_text('<text x="50" y="20">H   I</text>'), tol_mm=0.001)
    one = svg_text_paths(_text('<text x="50" y="20">H I</text>'), tol_mm=0.001)
    assert [q.bounds().tolist() for q in start] == [q.bounds().tolist() for q in one]
    middle = svg_text_paths(_text('<text x="50" y="20" text-anchor="middle">H   I</text>'), tol_mm=0.001)
    assert _left(middle) == pytest.approx(50 + 8 * lsb - 8 * (adv_h + adv_space + adv_i) / 2, abs=2e-3)
    preserved = svg_text_paths(_text('<text x="50" y="20" xml:space="preserve">H   I</text>'), tol_mm=0.001)
    right = max(q.bounds()[1][0] for q in preserved) - max(q.bounds()[1][0] for q in one)
    assert right == pytest.approx(8 * 2 * adv_space, abs=2e-3)       # two more spaces kept


def test_a_tail_after_a_tspan_follows_it():
    """'<tspan>H</tspan>I': the I (the text after the tspan, which svgelements alone drops) is
    drawn one H advance to the right of the H's pen."""
    lsb_h, adv_h = _metrics("H")
    lsb_i, _ = _metrics("I")
    paths = svg_text_paths(_text('<text x="10" y="20"><tspan>H</tspan>I</text>'), tol_mm=0.001)
    lefts = sorted(round(q.bounds()[0][0], 4) for q in paths)
    assert lefts == pytest.approx([10 + 8 * lsb_h, 10 + 8 * adv_h + 8 * lsb_i], abs=2e-3)


def test_a_missing_font_is_named_and_nothing_is_written(tmp_path, capsys):
    src = tmp_path / "t.svg"
    src.write_text(_text('<text id="sign" x="10" y="20" font-family="No Such Family 27">Hi</text>'))
    out = tmp_path / "t.gcode"
    assert main(["svg2gcode", str(src), "-o", str(out)]) == 1
    err = capsys.readouterr().err
    assert "text#sign ('Hi'): font 'No Such Family 27' is not installed" in err and "Traceback" not in err
    assert not out.exists()
    with pytest.raises(InputError, match="No Such Family 27"):
        read_svg(src)


def test_text_on_a_path_is_named_not_dropped_silently():
    doc = _text('<path id="p" d="M10 30 H90" stroke="#000" fill="none"/>'
                '<text id="tp"><textPath href="#p">along</textPath></text>')
    with pytest.warns(UserWarning, match=r"not cut: .*text#tp \(on a path\)"):
        d = read_svg(doc)
    assert d.skipped == ["text#tp (on a path)"]


def test_svg2gcode_cuts_and_fills_text(tmp_path, capsys):
    """The program burns where the reader's text lies, with the layer settings given by colour;
    --fill hatches inside the letters (more burned length than the outlines alone)."""
    out = tmp_path / "text.gcode"
    assert main(["svg2gcode", str(INKSCAPE), "-o", str(out), "--layer", "#0000ff:500:300"]) == 0
    moves = parse(out.read_text())
    burn = moves.laser_on & (moves.feed_mm_min == 500.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        blue = [p for p in read_svg(INKSCAPE).paths if p.layer == "#0000ff"]
    lo = np.min([p.bounds()[0] for p in blue], axis=0)
    hi = np.max([p.bounds()[1] for p in blue], axis=0)
    ends = np.vstack([moves.start[burn, :2], moves.end[burn, :2]])
    assert ends.min(axis=0) == pytest.approx(lo, abs=0.01) and ends.max(axis=0) == pytest.approx(hi, abs=0.01)
    outline = float(moves.lengths_mm()[moves.laser_on].sum())
    assert outline == pytest.approx(sum(p.length_mm for p in read_svg(INKSCAPE, warn=False).paths), rel=2e-3)
    filled = tmp_path / "filled.gcode"
    assert main(["svg2gcode", str(INKSCAPE), "-o", str(filled), "--fill", "--fill-spacing", "0.2"]) == 0
    hatched = parse(filled.read_text())
    assert float(hatched.lengths_mm()[hatched.laser_on].sum()) > 2 * outline


@pytest.mark.parametrize("body, error", [
    ('<text x="1" y="30" font-size="1e300">big</text>', "text placed beyond"),
    ('<text x="1" y="30">' + "W" * 400_000 + "</text>", "400000 characters of text in text"),
    ('<text x="1" y="30" font-size="-3">negative</text><text x="1" y="30" font-size="0">zero</text>'
     '<rect id="r" x="80" y="5" width="5" height="5" fill="#000"/>', None),
    ('<text x="1" y="30">\U0001F600 \u2603 \u00e9</text>', None),
])
def test_hostile_text_is_an_error_or_a_drawing_never_a_traceback(body, error):
    """A size past double precision and a text past the segment budget are named errors; a
    font-size of zero or below draws nothing (as resvg: no ink); characters the font lacks do
    not end the reading."""
    from labkit.errors import LabkitError

    doc = _text(body)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if error:
            with pytest.raises(LabkitError, match=error):
                read_svg(doc)
            return
        d = read_svg(doc)
    if "negative" in body:
        png = resvg_py.svg_to_bytes(svg_string=doc, dpi=96.0)          # mm need a dpi
        ink = np.asarray(Image.open(io.BytesIO(bytes(png))))[:, :, 3] > 0
        assert ink.any() and not ink[:, : ink.shape[1] * 3 // 4].any()      # only the rect, right
        assert [p.source for p in d.paths] == ["rect#r"]
    else:
        assert d.paths
