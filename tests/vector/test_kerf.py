"""Kerf compensation of SVG shapes as a laser user expects it (issue 31's defect): a closed shape
inside another is a hole and moves inwards, whichever element drew it and whatever its fill rule
(LightBurn and LaserGRBL offset nested shapes so); no drawn line is ever lost. Expected numbers
are worked by hand; the drawings are written by hand."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import shapely

from labkit.cli import main
from labkit.gcode import parse
from labkit.toolpath.build import prepare_paths
from labkit.vector.svg import read_svg

KERF = 0.2
HALF = KERF / 2


def _svg(body):
    return ('<svg xmlns="http://www.w3.org/2000/svg" width="100mm" height="60mm" viewBox="0 0 100 60">'
            f'{body}</svg>')


R = 'fill="none" stroke="#000"'
CASES = {
    # the defect: two rects, separate elements, both clockwise, nonzero
    "hole as its own rect": f'<rect x="10" y="10" width="40" height="40" {R}/><rect x="20" y="20" width="20" '
                            f'height="20" {R}/>',
    "hole on another layer": f'<rect x="10" y="10" width="40" height="40" {R}/><rect x="20" y="20" width="20" '
                             f'height="20" fill="none" stroke="#f00"/>',
    "hole in one path, same direction, nonzero": '<path d="M10 10 H50 V50 H10 Z M20 20 H40 V40 H20 Z" '
                                                 'fill="#000"/>',
    "hole in one path, evenodd": '<path d="M10 10 H50 V50 H10 Z M20 20 H40 V40 H20 Z" fill="#000" '
                                 'fill-rule="evenodd"/>',
    "island in a hole": f'<rect x="10" y="10" width="40" height="40" {R}/><rect x="20" y="20" width="20" '
                        f'height="20" {R}/><circle cx="30" cy="30" r="5" {R}/>',
    "a shape drawn twice": f'<rect x="10" y="10" width="40" height="40" {R}/><rect x="10" y="10" width="40" '
                           f'height="40" {R}/>',
    "overlapping shapes": f'<rect x="10" y="10" width="40" height="40" {R}/><circle cx="50" cy="30" r="12" {R}/>',
    "parts sharing an edge": f'<rect x="10" y="10" width="20" height="20" {R}/><rect x="30" y="10" width="20" '
                             f'height="20" {R}/>',
    "text (glyphs with counters)": '<text x="10" y="40" font-family="DejaVu Sans" font-size="30">OB8</text>',
}


def _compensated(body, kerf=KERF):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        drawn = read_svg(_svg(body), tol_mm=0.001).paths
    return drawn, [p for p in prepare_paths(drawn, kerf_mm=kerf, tol_mm=0.001) if p.closed]


GEOMETRIC = [c for c in CASES if not c.startswith("text")]


@pytest.mark.parametrize("case", GEOMETRIC)
def test_no_drawn_line_vanishes(case):
    """Each compensated shape lies half a kerf from the line it came from (every point of it,
    within the tolerance), and every point of the drawing has a cut beside it within
    kerf/2 · √2 (an inner right-angled corner): no drawn line is lost (a shape drawn twice may
    be cut once)."""
    drawn, cut = _compensated(CASES[case])
    assert len(cut) >= len({tuple(np.round(q.bounds(), 6).ravel()) for q in drawn})
    for p in cut:
        own = shapely.MultiLineString([q.sample(0.001) for q in drawn if q.source == p.source])
        d = shapely.distance(shapely.points(p.sample(0.001)), own)
        assert np.allclose(d, HALF, atol=0.005), f"{case}: {p.source} is not kerf/2 from its drawn line"
    beside = shapely.MultiLineString([p.sample(0.001) for p in cut])
    for q in drawn:
        gap = shapely.distance(shapely.points(q.sample(0.001)), beside)
        assert gap.max() <= HALF * np.sqrt(2) + 0.005, f"{case}: {q.source}'s line has no cut beside it"


def test_every_glyph_ring_is_kept_and_counters_are_holes():
    """'OB8': 2 + 3 + 3 rings. Each drawn ring has exactly one compensated partner (every point
    of it half a kerf from that ring); an outer ring's partner encloses more area, a counter's
    (a ring inside the glyph's outer ring) less."""
    drawn, cut = _compensated(CASES["text (glyphs with counters)"])
    assert len(drawn) == len(cut) == 8
    polys = [shapely.Polygon(p.sample(0.001)) for p in drawn]
    for q, poly in zip(drawn, polys):
        depth = sum(o.covers(shapely.Point(q.vertices[0])) for o in polys if o.area > poly.area)
        line = shapely.LineString(q.sample(0.001))
        partners = [p for p in cut
                    if np.allclose(shapely.distance(shapely.points(p.sample(0.001)), line), HALF, atol=0.005)]
        assert len(partners) == 1
        assert (abs(partners[0].signed_area_mm2()) > poly.area) == (depth % 2 == 0)


def _areas(cut):
    return sorted(abs(p.signed_area_mm2()) for p in cut)


OUTER = 40.2 ** 2 - (4 - np.pi) * HALF ** 2   # grown with round corners
HOLE = 19.8 ** 2                               # shrunk: its corners stay sharp


@pytest.mark.parametrize("case", ["hole as its own rect", "hole on another layer",
                                  "hole in one path, same direction, nonzero", "hole in one path, evenodd"])
def test_a_nested_shape_is_a_hole_whoever_drew_it(case):
    """40 mm square around a 20 mm one, kerf 0.2: the outline grows to 40.2 (round corners of
    r 0.1), the hole shrinks to 19.8 — the same whether the hole is its own element, on
    another layer, or a subpath under either fill rule."""
    _, cut = _compensated(CASES[case])
    assert _areas(cut) == pytest.approx([HOLE, OUTER], abs=0.005)      # mm² (the page's px round trip)


def test_an_island_in_a_hole_is_a_part():
    """Depth 2: the r 5 circle inside the hole is a part again and grows to r 5.1."""
    _, cut = _compensated(CASES["island in a hole"])
    assert _areas(cut) == pytest.approx([np.pi * 5.1 ** 2, HOLE, OUTER], abs=0.01)


def test_a_hole_the_kerf_closes_keeps_its_line():
    """A 0.15 mm hole with a 0.2 mm kerf: shrinking it leaves nothing, so its drawn line is
    cut as drawn, with a warning that names it."""
    body = f'<rect x="10" y="10" width="40" height="40" {R}/><rect id="pin" x="20" y="20" width="0.15" ' \
           f'height="0.15" {R}/>'
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        drawn = read_svg(_svg(body), tol_mm=0.001).paths
    with pytest.warns(UserWarning, match=r"rect#pin: a hole narrower than the kerf \(0.2 mm\) is cut on its drawn"):
        cut = prepare_paths(drawn, kerf_mm=KERF, tol_mm=0.001)
    pin = [p for p in cut if p.source == "rect#pin"]
    assert len(pin) == 1 and abs(pin[0].signed_area_mm2()) == pytest.approx(0.15 ** 2, rel=1e-3)


def test_svg2gcode_kerf_keeps_the_hole(tmp_path, capsys):
    """The reported defect end to end: svg2gcode --kerf 0.2 on an outline rect and a hole rect
    cuts both: the hole 20.1…39.9 (inside, cut first), the outline 9.9…50.1; y flipped on the
    60 mm page."""
    src = tmp_path / "plate.svg"
    src.write_text(_svg(CASES["hole as its own rect"]))
    out = tmp_path / "plate.gcode"
    assert main(["svg2gcode", str(src), "-o", str(out), "--kerf", str(KERF)]) == 0
    m = parse(out.read_text())
    on = m.laser_on
    loops, current = [], []
    for k in range(len(m)):                      # burning runs between rapids
        if on[k]:
            current.append(k)
        elif current:
            loops.append(current)
            current = []
    if current:
        loops.append(current)
    boxes = [np.vstack([m.start[idx, :2], m.end[idx, :2]]) for idx in loops]
    spans = [(b[:, 0].min(), b[:, 0].max(), b[:, 1].min(), b[:, 1].max()) for b in boxes]
    assert len(spans) == 2                       # the round corners are chords within --tol 0.01
    assert spans[0] == pytest.approx((20.1, 39.9, 20.1, 39.9), abs=0.01)
    assert spans[1] == pytest.approx((9.9, 50.1, 9.9, 50.1), abs=0.01)


def test_svg2gcode_names_a_hole_the_kerf_closes(tmp_path, capsys):
    src = tmp_path / "pin.svg"
    src.write_text(_svg(f'<rect x="10" y="10" width="40" height="40" {R}/><rect id="pin" x="20" y="20" '
                        f'width="0.15" height="0.15" {R}/>'))
    assert main(["svg2gcode", str(src), "-o", str(tmp_path / "pin.gcode"), "--kerf", str(KERF)]) == 0
    err = capsys.readouterr().err
    assert "warning: rect#pin: a hole narrower than the kerf (0.2 mm) is cut on its drawn line" in err
