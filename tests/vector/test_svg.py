"""SVG import: every element within tolerance of dense svgelements samples mapped by the exact matrix."""

import glob
import math
import os
import warnings

import numpy as np
import pytest
import svgelements as se

from labkit.errors import GeometryError, InputError
from labkit.geometry import Path, hausdorff
from labkit.vector import read_svg, svg_reference_samples

DATA = os.path.join(os.path.dirname(__file__), "..", "..", "data", "svg")
FILES = sorted(f for f in glob.glob(os.path.join(DATA, "*", "*.svg")) if "em-values" not in f)


def _worst(path, tol, arcs=True):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        d = read_svg(path, tol_mm=tol, arcs=arcs)
    ref = svg_reference_samples(path, tol_mm=tol)
    by = {}
    for p in d.paths:
        by.setdefault(p.source, []).append(p)
    worst = 0.0
    for label, polys in ref.items():
        polys = [q for q in polys if np.ptp(q, axis=0).max() > 1e-9]
        if not polys:
            continue                                  # a zero-length path: nothing to cut
        if label in d.invisible:
            continue                                  # a renderer paints nothing: never cut
        assert label in by, f"{os.path.basename(path)}: element {label} was dropped"
        h = hausdorff(by[label], [Path.polyline(q) for q in polys])
        worst = max(worst, h)
        assert max(p.deviation_mm for p in by[label]) <= tol
    return worst, d


def test_the_set_is_there():
    assert len(FILES) >= 35


@pytest.mark.parametrize("tol", [0.1, 0.01])
@pytest.mark.parametrize("path", FILES, ids=os.path.basename)
def test_every_element_within_tolerance(path, tol):
    worst, _ = _worst(path, tol)
    assert worst <= tol


@pytest.mark.parametrize("name", ["transforms.svg", "arc_flags.svg", "shapes.svg", "smooth_curves.svg"])
def test_lines_only_mode_within_tolerance(name):
    path = next(f for f in FILES if f.endswith(name))
    worst, d = _worst(path, 0.05, arcs=False)
    assert worst <= 0.05
    assert not any(p.is_arc.any() for p in d.paths)


def test_arcs_mode_keeps_circles_as_arcs():
    d = read_svg(next(f for f in FILES if f.endswith("units_mm.svg")))
    circle = next(p for p in d.paths if p.source == "circle#circle-r5mm")
    assert circle.is_arc.all()
    np.testing.assert_allclose(circle.radii_mm(), 5.0, rtol=1e-5)   # svgelements: 1 mm = 3.7795 px


@pytest.mark.parametrize("name, label, side_mm", [
    ("units_mm.svg", "rect#square-10mm", 10.0),
    ("units_in.svg", "rect#square-half-inch", 12.7),
    ("units_px.svg", "rect#square-96px", 25.4),
])
def test_units_to_mm(name, label, side_mm):
    d = read_svg(next(f for f in FILES if f.endswith(name)))
    sq = next(p for p in d.paths if p.source == label)
    size = np.diff(sq.bounds(), axis=0)[0]
    np.testing.assert_allclose(size, [side_mm, side_mm], rtol=1e-5)


def test_length_attribute_in_mm_and_page_size():
    d = read_svg(next(f for f in FILES if f.endswith("units_px.svg")))
    line = next(p for p in d.paths if p.source == "simpleline#line-mm-attr")
    assert line.length_mm == pytest.approx(20.0)
    assert d.width_mm == pytest.approx(192 * 25.4 / 96) and d.height_mm == pytest.approx(25.4)


def test_flip_y():
    svg = ('<svg xmlns="http://www.w3.org/2000/svg" width="10mm" height="10mm" viewBox="0 0 10 10">'
           '<line x1="0" y1="1" x2="5" y2="1" stroke="black"/></svg>')
    assert read_svg(svg).paths[0].start.tolist() == pytest.approx([0, 9])
    assert read_svg(svg, flip_y=False).paths[0].start.tolist() == pytest.approx([0, 1])


def test_colours_layers_and_fill_rule():
    d = read_svg(next(f for f in FILES if f.endswith("transforms.svg")))
    assert d.layers == ["#ff0000", "#0000ff", "#00aa00", "#000000"]
    curves = next(p for p in d.paths if p.source == "path#matrix-curves")
    assert curves.fill == "#00aa00" and curves.fill_rule == "evenodd" and curves.closed
    ell = next(p for p in d.paths if p.source == "ellipse#skewed-ellipse")
    assert ell.stroke == "#ff0000" and ell.fill is None and ell.fill_rule == "nonzero"


def test_text_is_drawn_and_images_are_named():
    """Text is cut as its glyphs (issue 31; tests/vector/test_text.py checks where); a bitmap
    is not a vector shape and is named."""
    path = next(f for f in FILES if f.endswith("text_image.svg"))
    with pytest.warns(UserWarning, match=r"not cut: 1 element\(s\) .*image#photo"):
        d = read_svg(path)
    assert d.skipped == ["image#photo"]
    sources = [p.source for p in d.paths]
    assert sources[0] == "rect#frame" and set(sources[1:]) == {"text#label"} and len(sources) == 1 + 9


def test_reify_trap_is_avoided():
    """svgelements' reify() bakes a skewed ellipse wrongly; labkit stays within tolerance."""
    path = next(f for f in FILES if f.endswith("transforms.svg"))
    truth = svg_reference_samples(path)["ellipse#skewed-ellipse"]
    baked = se.SVG.parse(path, reify=True)
    el = next(e for e in baked.elements() if getattr(e, "id", None) == "skewed-ellipse")
    k = 25.4 / 96
    h_page = float(baked.height)
    pts = []
    for seg in el.segments():
        if isinstance(seg, se.Arc):
            pts.append(np.asarray(seg.npoint(np.linspace(0, 1, 500)), float))
    reified = np.vstack(pts) * [k, -k] + [0, h_page * k]
    reify_err = hausdorff(Path.polyline(reified), [Path.polyline(q) for q in truth])
    ours = [p for p in read_svg(path, tol_mm=0.01).paths if p.source == "ellipse#skewed-ellipse"]
    assert reify_err > 0.5                            # millimetres off
    assert hausdorff(ours, [Path.polyline(q) for q in truth]) <= 0.01


def test_arc_flags_pick_four_different_arcs():
    d = read_svg(next(f for f in FILES if f.endswith("arc_flags.svg")), tol_mm=0.01)
    lengths = {p.source: p.length_mm for p in d.paths}
    small = [lengths["path#arc-00"], lengths["path#arc-01"]]
    large = [lengths["path#arc-10"], lengths["path#arc-11"]]
    assert max(small) < min(large)
    starts = {p.source: p.start for p in d.paths}
    np.testing.assert_allclose(starts["path#arc-00"], starts["path#arc-11"])


def test_errors():
    with pytest.raises(GeometryError, match="tol_mm must be > 0"):
        read_svg(FILES[0], tol_mm=0)
    with pytest.raises(InputError, match="no such file; expected an existing SVG file"):
        read_svg("no/such/file.svg")
    with pytest.raises(GeometryError, match=r"em-values.svg: cannot read this SVG \(em units.*rect#rect1"):
        read_svg(os.path.join(DATA, "resvg", "shapes_rect_em-values.svg"))


def test_greedy_fit_merges_collinear_sides_including_the_closing_one():
    """A rectangle drawn with split sides (the last one by Z) comes back as its four sides;
    with the biarc fit the drawn lines are kept as they are."""
    svg = ('<svg xmlns="http://www.w3.org/2000/svg" width="20mm" height="20mm" viewBox="0 0 20 20">'
           '<path d="M0 0 L5 0 L10 0 L10 10 L0 10 L0 5 Z" stroke="#000" fill="none"/></svg>')
    p = read_svg(svg, tol_mm=0.01).paths[0]
    assert p.closed and p.n_segments == 4 and not p.is_arc.any()
    corners = {tuple(np.round(q, 3)) for q in p.vertices}      # svgelements: 1 mm = 3.7795296 px
    assert corners == {(0.0, 20.0), (10.0, 20.0), (10.0, 10.0), (0.0, 10.0)}
    assert read_svg(svg, tol_mm=0.01, fit="biarc").paths[0].n_segments == 6


def test_lines_only_deviation_is_measured_not_zero():
    """arcs=False reported 0.0000 mm: the flattened chords' deviation was never measured.
    It must be positive, within the tolerance, and match an independent measurement
    (svgelements' own dense samples against the output path)."""
    from labkit.geometry.measure import path_distance
    from labkit.vector.svg import svg_reference_samples

    svg = ('<svg xmlns="http://www.w3.org/2000/svg" width="40mm" height="40mm" viewBox="0 0 40 40">'
           '<path id="s" d="M 2 2 C 10 40 30 -10 38 30" stroke="#000" fill="none"/></svg>')
    p = read_svg(svg, tol_mm=0.05, arcs=False).paths[0]
    truth = path_distance(p, svg_reference_samples(svg, per_segment=20000)["path#s"][0]).max()
    assert 0 < p.deviation_mm <= 0.05
    assert abs(p.deviation_mm - truth) < 0.005
