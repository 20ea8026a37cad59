"""Draw what a renderer draws, nothing else (issue 10 §2): each visibility rule as a
hand-made file, rendered by resvg (an independent renderer) and read by labkit. Every cut
lies on ink, and every stroke the renderer inks is cut."""

from __future__ import annotations

import io
import warnings
from pathlib import Path

import numpy as np
import pytest
import resvg_py
from PIL import Image
from scipy import ndimage

from labkit.vector.svg import MM_PER_PX, read_svg

PX_PER_UNIT = 10           # the documents are 400 px wide over a 40-unit viewBox
STROKE = 'stroke="#000" stroke-width="0.5" fill="none"'
DOC = ('<svg xmlns="http://www.w3.org/2000/svg" xmlns:xlink="http://www.w3.org/1999/xlink" '
       'width="400" height="400" viewBox="0 0 40 40">{}'
       f'<rect id="keep" x="2" y="30" width="6" height="6" {STROKE}/></svg>')
HIDDEN = f'x="10" y="10" width="12" height="12" {STROKE}'

RULES = {
    "flowRoot text frame": f'<flowRoot><flowRegion><rect id="frame" {HIDDEN}/></flowRegion>'
                           f'<flowPara>text</flowPara></flowRoot>',
    "defs": f'<defs><rect id="d" {HIDDEN}/></defs>',
    "clipPath contents": f'<clipPath id="c"><rect id="cp" {HIDDEN}/></clipPath>',
    "mask contents": f'<mask id="m"><rect id="mk" {HIDDEN}/></mask>',
    "symbol outside a use": f'<symbol id="s"><rect id="sy" {HIDDEN}/></symbol>',
    "symbol through a use": f'<symbol id="s"><rect id="sy" {HIDDEN}/></symbol><use xlink:href="#s"/>',
    "marker definition": f'<marker id="mm"><rect id="mr" {HIDDEN}/></marker>',
    "metadata": f'<metadata><rect id="md" {HIDDEN}/></metadata>',
    "display:none group": f'<g style="display:none"><rect id="dn" {HIDDEN}/></g>',
    "display attribute": f'<g display="none"><rect id="dn2" {HIDDEN}/></g>',
    "display:none by CSS class": f'<style>.off {{ display: none }}</style><rect class="off" {HIDDEN}/>',
    "visibility hidden, inherited": f'<g visibility="hidden"><rect id="vh" {HIDDEN}/></g>',
    "visibility visible overrides": f'<g visibility="hidden"><rect id="vv" visibility="visible" {HIDDEN}/></g>',
    "no fill and no stroke": '<rect id="np" x="10" y="10" width="12" height="12" fill="none" stroke="none"/>',
    "opacity 0": f'<rect id="op" opacity="0" {HIDDEN}/>',
    "transform-origin": f'<g transform="rotate(90)" transform-origin="20 20"><rect id="to" x="10" y="5" '
                        f'width="12" height="4" {STROKE}/></g>',
    "fill-only line (zero area)": '<path id="zl" d="M 10 10 L 30 20"/>',
    "fill-only curve (an area)": '<path id="fc" d="M 10 10 C 20 30 30 0 30 20"/>',
    # clip-path applied (a renderer paints only inside the clip region)
    "clip-path rectangle on a shape": f'<clipPath id="c1"><rect x="5" y="5" width="12" height="12"/>'
                                      f'</clipPath><circle id="cc" cx="15" cy="15" r="8" clip-path="url(#c1)" {STROKE}/>',
    "clip-path circle on a transformed group": f'<clipPath id="c2"><circle cx="10" cy="10" r="6"/></clipPath>'
                                               f'<g transform="translate(5,5) scale(1.2)" clip-path="url(#c2)">'
                                               f'<rect id="cg" x="3" y="3" width="14" height="14" {STROKE}/></g>',
    "clipPath with its own transform, defined in a moved group":
        f'<g transform="translate(30,0)"><defs><clipPath id="c3" transform="rotate(90 15 15)">'
        f'<rect x="8" y="8" width="10" height="10"/></clipPath></defs></g>'
        f'<rect id="ct" x="5" y="11" width="25" height="5" clip-path="url(#c3)" {STROKE}/>',
    "clipPath in objectBoundingBox units": f'<clipPath id="c4" clipPathUnits="objectBoundingBox">'
                                           f'<rect x="0.25" y="-0.5" width="0.5" height="2"/></clipPath>'
                                           f'<rect id="cb" x="8" y="10" width="24" height="12" clip-path="url(#c4)" {STROKE}/>',
    "nested clips intersect": f'<clipPath id="c5"><rect x="0" y="0" width="20" height="40"/></clipPath>'
                              f'<clipPath id="c6"><rect x="0" y="12" width="40" height="40"/></clipPath>'
                              f'<g clip-path="url(#c5)"><circle id="cn" cx="18" cy="16" r="7" clip-path="url(#c6)" {STROKE}/></g>',
    "clip-rule evenodd cuts a hole": f'<clipPath id="c7"><path clip-rule="evenodd" d="M4 4 H36 V28 H4 Z M14 10 H26 V22 H14 Z"/>'
                                     f'</clipPath><path id="ce" d="M2 16 H38" clip-path="url(#c7)" {STROKE}/>',
    "fill-only shape clipped to half": '<clipPath id="c8"><rect x="0" y="0" width="20" height="40"/></clipPath>'
                                       '<circle id="cf" cx="20" cy="15" r="8" fill="#000" clip-path="url(#c8)"/>',
    "shape clipped away entirely": f'<clipPath id="c9"><rect x="30" y="0" width="5" height="5"/></clipPath>'
                                   f'<rect id="cw" {HIDDEN} clip-path="url(#c9)"/>',
    # a mask of opaque white shapes shows exactly their union: applied as that clip region
    "mask of a white rectangle on a shape": f'<mask id="k1"><rect x="5" y="5" width="12" height="12" fill="#fff"/>'
                                            f'</mask><circle id="kc" cx="15" cy="15" r="8" mask="url(#k1)" {STROKE}/>',
    "mask of white shapes on a group, by style": f'<defs><mask id="k2"><g><circle cx="10" cy="10" r="6" style="fill:white"/>'
                                                f'<rect x="20" y="20" width="10" height="10" fill="#ffffff"/></g></mask></defs>'
                                                f'<g mask="url(#k2)"><rect id="kg" x="3" y="3" width="30" height="30" {STROKE}/></g>',
    "mask in objectBoundingBox content units": f'<mask id="k3" maskContentUnits="objectBoundingBox">'
                                               f'<rect x="0.25" y="-0.5" width="0.5" height="2" fill="#fff"/></mask>'
                                               f'<rect id="kb" x="8" y="10" width="24" height="12" mask="url(#k3)" {STROKE}/>',
    # rx, ry in percent: of the viewport's width and height, then clamped to half the side
    "rect rx in percent (ry auto, clamped)": f'<rect id="rp" x="5" y="10" width="30" height="12" rx="20%" {STROKE}/>',
    "rect rx and ry in percent": f'<rect id="rq" x="5" y="10" width="30" height="20" rx="10%" ry="15%" {STROKE}/>',
    "rect rx in percent of a nested viewport": f'<svg x="0" y="0" width="40" height="40" viewBox="0 0 20 20">'
                                               f'<rect id="rn" x="2" y="5" width="16" height="8" rx="20%" '
                                               f'stroke="#000" stroke-width="0.25" fill="none"/></svg>',
    # a clipPath holding text clips by the glyphs' outlines (the text's own fill is never drawn)
    "clip-path holding text on a filled shape": '<clipPath id="t1"><text x="4" y="26" font-family="DejaVu Sans" '
                                                'font-size="18">Ag</text></clipPath>'
                                                '<rect id="tf" x="3" y="3" width="34" height="30" fill="#000" '
                                                'clip-path="url(#t1)"/>',
    "clip-path holding text on a stroke": f'<clipPath id="t2"><text x="4" y="26" font-family="DejaVu Sans" '
                                          f'font-size="18" font-weight="bold">Ag</text></clipPath>'
                                          f'<path id="ts" d="M2 20 H38" clip-path="url(#t2)" {STROKE}/>',
    "text in a clipPath with a line of tspans": '<clipPath id="t3"><text x="4" y="16" font-family="DejaVu Sans" '
                                               'font-size="10"><tspan>O</tspan><tspan dx="2">H</tspan></text>'
                                               '</clipPath><circle id="tt" cx="14" cy="12" r="10" fill="#000" '
                                               'clip-path="url(#t3)"/>',
    "switch draws its first child": f'<switch><rect id="sw1" {HIDDEN}/>'
                                    f'<rect id="sw2" x="25" y="5" width="5" height="5" {STROKE}/></switch>',
}


def ink(svg_text):
    png = resvg_py.svg_to_bytes(svg_string=svg_text)
    return np.asarray(Image.open(io.BytesIO(bytes(png))))[:, :, 3] > 0


def cut_pixels(drawing):
    """(row, col) pixel of every sample of every cut, in the render's frame."""
    dense = []
    for p in drawing.paths:
        uv = p.sample(0.01) / MM_PER_PX                 # mm → px (the render's pixels)
        for a, b in zip(uv[:-1], uv[1:]):               # every half pixel along each chord
            k = max(2, int(np.ceil(np.hypot(*(b - a)) / 0.5)) + 1)
            dense.append(a + np.linspace(0.0, 1.0, k)[:, None] * (b - a))
    return np.round(np.vstack(dense)[:, ::-1]).astype(int)


@pytest.mark.parametrize("rule", RULES)
def test_cuts_match_the_render(rule):
    text = DOC.format(RULES[rule])
    drawn = ink(text)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        d = read_svg(text, flip_y=False)
    rc = np.clip(cut_pixels(d), 0, drawn.shape[0] - 1)
    near_ink = ndimage.binary_dilation(drawn, iterations=2)
    off = ~near_ink[rc[:, 0], rc[:, 1]]
    assert not off.any(), f"{rule}: {off.sum()} cut samples where the renderer draws nothing ({[p.source for p in d.paths]})"
    cut_mask = np.zeros_like(drawn)
    cut_mask[rc[:, 0], rc[:, 1]] = True
    edge = drawn & ~ndimage.binary_erosion(drawn)           # a stroke's sides, a fill's outline
    distance = ndimage.distance_transform_edt(~cut_mask)
    assert distance[edge].max() <= 2.5 + 2, f"{rule}: the renderer inks an edge labkit does not cut"


def test_hidden_content_is_really_in_the_files():
    """The rules are not vacuous: the same rectangle, left visible, is inked and cut."""
    text = DOC.format(f'<rect id="shown" {HIDDEN}/>')
    assert ink(text)[100:220, 100:220].any()
    assert [p.source for p in read_svg(text).paths] == ["rect#shown", "rect#keep"]


def test_clip_path_that_holds_text_is_applied():
    """Issue 27: a clipPath holding text clips by the glyphs (no warning, the shape named as
    clipped); the render rules above hold the result to resvg's drawing."""
    text = DOC.format('<clipPath id="c"><text x="10" y="20" font-family="DejaVu Sans" font-size="12">A</text>'
                      f'</clipPath><rect id="clipped" x="8" y="14" width="14" height="3" clip-path="url(#c)" '
                      f'{STROKE}/>')                  # its long sides cross the A's legs
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        d = read_svg(text, flip_y=False)
    assert d.clipped == ["rect#clipped"]
    pieces = [p for p in d.paths if p.source == "rect#clipped"]
    # y = 14 crosses the two legs (two short pieces), y = 17 the crossbar (one piece, inside the A)
    unit = 10 * MM_PER_PX
    assert sorted(round(p.length_mm / unit) for p in pieces) == [1, 1, 6]
    assert all(10 < p.bounds()[0][0] / unit and p.bounds()[1][0] / unit < 18 for p in pieces)


def test_clip_path_keeps_arcs_and_reports_the_clipped_shapes():
    """A circle clipped to its upper half stays one arc (G2/G3), exact to the tolerance, and
    the drawing names the shapes the clip shortened."""
    text = ('<svg xmlns="http://www.w3.org/2000/svg" width="40mm" height="40mm" viewBox="0 0 40 40">'
            '<clipPath id="h"><rect x="0" y="0" width="40" height="20"/></clipPath>'
            '<circle id="c" cx="20" cy="20" r="10" stroke="red" fill="none" clip-path="url(#h)"/>'
            '<rect id="r" x="1" y="1" width="5" height="5" stroke="red" fill="none" clip-path="url(#h)"/></svg>')
    d = read_svg(text, tol_mm=0.001)
    arc = d.paths[0]
    assert (arc.n_segments, int(arc.is_arc.sum())) == (1, 1)
    assert abs(arc.radii_mm()[0] - 10.0) < 0.001 and abs(abs(arc.sweeps[0]) - np.pi) < 1e-3
    assert d.clipped == ["circle#c"]               # the rectangle lies wholly inside
    assert d.paths[1].source == "rect#r" and d.paths[1].n_segments == 4


def test_bitmap_only_file_is_an_error_not_an_empty_job(tmp_path, run_labkit_cli):
    path = tmp_path / "bitmap.svg"
    path.write_text('<svg xmlns="http://www.w3.org/2000/svg" width="40mm" height="40mm">'
                    '<image id="i" width="5" height="5" href="data:image/png;base64,iVBORw0KGgo="/></svg>')
    code, err = run_labkit_cli(["svg2gcode", str(path), "-o", str(tmp_path / "o.gcode")])
    assert code == 1
    assert "nothing to cut: the SVG holds only image (1 element(s)); engrave bitmaps with svg2gcode --images" in err
    assert not (tmp_path / "o.gcode").exists()


def test_text_is_cut_and_the_bitmap_beside_it_named(tmp_path, run_labkit_cli):
    """Text was skipped before issue 31; now it is cut and only the bitmap is named."""
    path = tmp_path / "text.svg"
    path.write_text('<svg xmlns="http://www.w3.org/2000/svg" width="40mm" height="40mm">'
                    '<text id="t" x="5" y="15">Hello</text><image id="i" width="5" height="5" '
                    'href="data:image/png;base64,iVBORw0KGgo="/></svg>')
    code, err = run_labkit_cli(["svg2gcode", str(path), "-o", str(tmp_path / "o.gcode")])
    assert code == 0
    assert "not cut: 1 element(s) that are not vector shapes: image#i — engrave bitmaps with svg2gcode --images" \
        in err
    assert "text#t" not in err and (tmp_path / "o.gcode").exists()


def test_skipped_elements_are_reported_once():
    text = DOC.format('<text id="t1" x="5" y="5">a</text><flowRoot id="f"><flowRegion><rect/>'
                      '</flowRegion></flowRoot>')
    with pytest.warns(UserWarning) as caught:
        d = read_svg(text)
    assert d.skipped == ["flowRoot#f"]                      # the text is drawn, the frame is not
    assert "text#t1" in {p.source for p in d.paths}
    assert sum("flowRoot#f" in str(w.message) for w in caught) == 1


@pytest.fixture
def run_labkit_cli():
    import contextlib

    from labkit import cli

    def run(argv):
        err = io.StringIO()
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
            code = cli.main(argv)
        return code, err.getvalue()
    return run


CORPUS = sorted((Path(__file__).resolve().parents[2] / "data" / "svg").glob("*/*.svg"))


@pytest.mark.parametrize("path", CORPUS, ids=[f"{p.parent.name}/{p.name}" for p in CORPUS])
def test_corpus_cuts_lie_on_what_resvg_draws(path):
    """Every file of the SVG corpus (resvg's, svg2gcode's, cncjs's and labkit's own): each
    cut sample lies on resvg's ink (within one CSS px, rendered at 4 px per CSS px). A file labkit refuses
    is a refusal, not a cut."""
    from labkit.errors import LabkitError

    zoom = 4
    # text without a font-family: SVG leaves the initial family to the renderer (resvg takes
    # Times New Roman, Inkscape and labkit sans-serif); resvg is given labkit's, DejaVu Sans
    png = resvg_py.svg_to_bytes(svg_path=str(path), dpi=96.0, zoom=zoom, font_family="DejaVu Sans")
    drawn = np.asarray(Image.open(io.BytesIO(bytes(png))))[:, :, 3] > 0
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            d = read_svg(path, flip_y=False)
    except LabkitError:
        return
    if not d.paths:
        assert not drawn.any() or d.skipped, f"{path.name}: resvg draws, labkit reads nothing"
        return
    rc = np.round(cut_pixels(d) * zoom).astype(int)
    inside = (rc >= 0).all(1) & (rc[:, 0] < drawn.shape[0]) & (rc[:, 1] < drawn.shape[1])
    # within one CSS px (0.26 mm) of ink: a fill's edge is where its last pixel is covered
    distance = ndimage.distance_transform_edt(~drawn)[rc[inside, 0], rc[inside, 1]]
    assert distance.max() <= zoom + 1, (f"{path.name}: a cut sample {distance.max() / zoom:.1f} px "
                                        f"from resvg's ink")


OFF_PAGE = DOC.format(f'<circle id="big" cx="35" cy="20" r="10" {STROKE}/>')


def test_geometry_outside_the_page_is_named_with_how_much():
    """A circle of radius 10 centred 5 units inside the right edge: 5 units (13.2 mm at 2.646
    mm per unit) beyond the page and a third of its length (2π·10/3 units) outside."""
    unit = 10 * MM_PER_PX
    with pytest.warns(UserWarning, match=r"1 shape\(s\) reach outside the 105\.833 × 105\.833 mm page, "
                      r"up to 13\.2 mm beyond its edge \((\d+\.\d) mm of path outside.*circle#big") as w:
        d = read_svg(OFF_PAGE)
    import re

    outside = float(re.search(r"\((\d+\.\d) mm of path outside", str(w[-1].message)).group(1))
    assert outside == pytest.approx(2 * np.pi * 10 * unit / 3, abs=0.1)
    assert [p.source for p in d.paths] == ["circle#big", "rect#keep"]      # kept whole by default


def test_clip_to_page_cuts_what_the_renderer_shows():
    drawn = ink(OFF_PAGE)
    d = read_svg(OFF_PAGE, flip_y=False, clip_to_page=True)
    assert d.clipped == ["circle#big"]
    rc = cut_pixels(d)
    assert (rc >= 0).all() and (rc <= 400).all()          # on the page (its edge is px 400)
    rc = np.minimum(rc, 399)
    assert ndimage.binary_dilation(drawn, iterations=2)[rc[:, 0], rc[:, 1]].all()
    kept = sum(p.length_mm for p in d.paths if p.source == "circle#big")
    assert kept == pytest.approx(2 * np.pi * 10 * 10 * MM_PER_PX * 2 / 3, rel=1e-4)


def test_rect_radius_in_percent_is_a_stadium_as_resvg_draws_it():
    """resvg's own test file shapes_rect_percentage-values-1.svg: a 160 × 80 rect in a
    200 × 100 viewBox with rx="20%" — rx = 20 % of 200 = 40, ry = rx, within half the
    height: a stadium of two half circles (r = 40), not an ellipse through the edge
    midpoints. Every edge resvg fills is cut, and the arcs have radius 40 units."""
    path = Path(__file__).resolve().parents[2] / "data" / "svg" / "resvg" / "shapes_rect_percentage-values-1.svg"
    zoom = 4
    png = resvg_py.svg_to_bytes(svg_path=str(path), dpi=96.0, zoom=zoom)
    rgba = np.asarray(Image.open(io.BytesIO(bytes(png)))).astype(int)
    green = (rgba[:, :, 3] > 127) & (rgba[:, :, 1] > rgba[:, :, 0] + 50)    # the rect, not the frame
    d = read_svg(path, flip_y=False)
    rect = next(p for p in d.paths if p.source == "rect#rect1")
    assert np.allclose(rect.radii_mm()[rect.is_arc] / MM_PER_PX, 40.0)
    edge = green & ~ndimage.binary_erosion(green)
    cut = np.zeros_like(green)
    rc = np.round(cut_pixels(type(d)([rect])) * zoom).astype(int)
    cut[np.clip(rc[:, 0], 0, cut.shape[0] - 1), np.clip(rc[:, 1], 0, cut.shape[1] - 1)] = True
    assert edge.any()
    assert ndimage.distance_transform_edt(~cut)[edge].max() <= zoom + 1      # within a CSS px


def test_masked_shapes_are_named_in_a_warning_not_cut_silently():
    """A mask other than opaque white shapes (here a black hole in a white rectangle: its
    luminance, not a union of shapes) is not applied: a shape masked itself and one in a
    masked group are named in a warning (cut whole, as the warning says); an unmasked shape
    and the mask's own contents are not."""
    text = DOC.format('<defs><mask id="m"><rect id="mr" width="20" height="40" fill="#fff"/>'
                      '<circle cx="10" cy="10" r="3" fill="#000"/></mask></defs>'
                      f'<g mask="url(#m)"><rect id="ma" {HIDDEN}/></g>'
                      f'<circle id="mb" cx="30" cy="10" r="4" mask="url(#m)" {STROKE}/>')
    with pytest.warns(UserWarning, match=r"mask is not applied; 2 shape\(s\) under a mask are cut "
                                         r"whole .*: rect#ma, circle#mb — apply the mask"):
        d = read_svg(text)
    assert [p.source for p in d.paths] == ["rect#ma", "circle#mb", "rect#keep"]
