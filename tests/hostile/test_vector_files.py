"""Hostile SVG and DXF files (issue 9): each gets its error with its place — never a
mirrored page, a moved or dropped element, a recursion traceback, minutes of work or all
the memory. Big cases are generated here, never committed."""

from __future__ import annotations

import math
import re
import warnings
from pathlib import Path

import ezdxf
import numpy as np
import pytest

from labkit.errors import BudgetError, GeometryError
from labkit.vector import read_dxf, read_svg
from labkit.vector.dxf import spline_points

HEAD = ('<svg xmlns="http://www.w3.org/2000/svg" xmlns:xlink="http://www.w3.org/1999/xlink" '
        'width="40mm" height="40mm"{attrs}>')


def svg(body, attrs=""):
    return HEAD.format(attrs=attrs) + body + "</svg>"


def fan_out(levels, copies=4, tag="use"):
    """``copies`` references per level, ``levels`` deep: copies**levels rectangles."""
    defs = '<defs><rect id="l0" width="1" height="1" stroke="#000"/>'
    for i in range(1, levels + 1):
        defs += f'<g id="l{i}">' + f'<{tag} xlink:href="#l{i - 1}"/>' * copies + "</g>"
    return svg(defs + f'</defs><use xlink:href="#l{levels}"/>')


@pytest.mark.parametrize("name,text,message", [
    ("negative viewBox", svg('<rect width="5" height="5"/>', ' viewBox="0 0 -40 40"'),
     r"<string>:1:1: <svg> viewBox='0 0 -40 40' has a width or height that is not positive"),
    ("zero viewBox", svg('<rect width="5" height="5"/>', ' viewBox="0 0 40 0"'),
     r"viewBox='0 0 40 0' has a width or height that is not positive"),
    ("NaN in path data", svg('<path d="M 0 0 L nan 5" stroke="#000"/>'),
     r"<string>:1:\d+: <path> attribute d='M 0 0 L nan 5' holds 'nan', not a finite number"),
    ("NaN centre", svg('<circle cx="NaN" cy="1" r="1"/>'),
     r"<circle> attribute cx='NaN' holds 'NaN', not a finite number"),
    ("infinite width", svg('<rect width="1e400" height="5"/>'),
     r"<rect> attribute width='1e400' holds '1e400', not a finite number"),
    ("Infinity in a transform", svg('<g transform="translate(Infinity 0)"><rect width="1" height="1"/></g>'),
     r"<g> attribute transform=.* holds 'Infinity'"),
    ("transform overflow", svg('<g transform="scale(1e300)"><g transform="scale(1e300)">'
                               '<rect width="5" height="5"/></g></g>'),
     r"rect\[\d+\]: a point at \(.*\) mm lies beyond 1.1e\+10 mm, where double precision no longer "
     r"resolves the tolerance of 0.01 mm"),
    ("use of itself", svg('<g id="a"><use xlink:href="#a"/></g>'),
     r"<string>:1:\d+: <use> cycle: #a → #a"),
    ("use of an ancestor", svg('<g id="top"><g><rect width="1" height="1"/><use href="#top"/></g></g>'),
     r"<use> cycle: #top → #top"),
    ("mutual uses", svg('<defs><g id="a"><use xlink:href="#b"/></g><g id="b"><use xlink:href="#a"/></g>'
                        '</defs><use xlink:href="#a"/>'),
     r"<use> cycle: #[ab] → #[ab] → #[ab]"),
    ("1,000 nested groups", svg("<g>" * 1000 + '<rect width="1" height="1"/>' + "</g>" * 1000),
     r"elements nested 257 deep; labkit reads at most 256 levels"),
    ("HTML", "<html><body><p>not a drawing</p></body></html>",
     r"not an SVG document \(the root element is <html>, expected <svg>\)"),
    ("rx in percent without a viewport", '<svg xmlns="http://www.w3.org/2000/svg"><rect rx="10%" '
     'width="5" height="5" stroke="#000"/></svg>',
     r"<rect> rx='10%': a percentage needs the viewport's size, and the document gives none"),
    ("rx percent of nothing", svg('<rect rx="abc%" width="5" height="5"/>', ' viewBox="0 0 40 40"'),
     r"<rect> rx='abc%': expected a number or a percentage"),
    ("broken XML", svg('<rect width="1" height="1">'),
     r"<string>:1:\d+: not well-formed XML \(mismatched tag\)"),
])
def test_svg_reader_refuses_with_the_place(name, text, message):
    with pytest.raises(GeometryError, match=message):
        read_svg(text)


def test_deep_nesting_within_the_limit_is_read_exactly():
    """200 nested translations of 0.1 user units: the rectangle lands 20 units over."""
    body = '<g transform="translate(0.1 0)">' * 200 + '<rect width="1" height="1" stroke="#000"/>' + "</g>" * 200
    d = read_svg(svg(body, ' viewBox="0 0 40 40"'), flip_y=False)
    assert np.allclose(d.paths[0].bounds(), [[20.0, 0.0], [21.0, 1.0]], atol=1e-9)


def test_use_fan_out_counts_every_copy():
    """4 levels of 4 uses: 256 rectangles, each at the same place (the independent count)."""
    d = read_svg(fan_out(4))
    assert len(d.paths) == 4 ** 4


def test_use_fan_out_bomb_is_refused_before_expansion(tmp_path, run_labkit):
    path = tmp_path / "bomb.svg"
    path.write_text(fan_out(11))
    r = run_labkit(["svg2gcode", path, "-o", tmp_path / "o.gcode"], time_s=30, memory_mb=400)
    assert r.code == 1
    assert re.search(r"too much work: [\d,]+ elements \(budget 2,000,000\) from <use> copies", r.stderr)
    assert not (tmp_path / "o.gcode").exists()


def test_ten_thousand_nested_groups_fail_fast(tmp_path, run_labkit):
    path = tmp_path / "deep.svg"
    path.write_text(svg("<g>" * 10_000 + '<rect width="1" height="1"/>' + "</g>" * 10_000))
    r = run_labkit(["svg2gcode", path, "-o", tmp_path / "o.gcode"], time_s=20, memory_mb=300)
    assert r.code == 1 and f"{path}:1:" in r.stderr and "nested 257 deep" in r.stderr


# --- DXF -------------------------------------------------------------------------------------

def dxf_text(entities, blocks=None, units=4):
    """A minimal R12 DXF written tag by tag, so values ezdxf would refuse to write
    (scale 0, ratio 0, NaN) reach the reader as a hostile file would carry them."""
    out = []

    def tags(*pairs):
        for code, value in pairs:
            out.extend([str(code), str(value)])

    tags((0, "SECTION"), (2, "HEADER"), (9, "$ACADVER"), (1, "AC1009"), (9, "$INSUNITS"),
         (70, units), (0, "ENDSEC"))
    if blocks:
        tags((0, "SECTION"), (2, "BLOCKS"))
        for name, ents in blocks.items():
            tags((0, "BLOCK"), (8, "0"), (2, name), (70, 0), (10, 0), (20, 0), (30, 0), (3, name))
            for e in ents:
                tags(*e)
            tags((0, "ENDBLK"), (8, "0"))
        tags((0, "ENDSEC"))
    tags((0, "SECTION"), (2, "ENTITIES"))
    for e in entities:
        tags(*e)
    tags((0, "ENDSEC"), (0, "EOF"))
    return "\n".join(out) + "\n"


LINE = [(0, "LINE"), (8, "0"), (10, 0), (20, 0), (11, 10), (21, 0)]
FULL = 2 * math.pi


def insert(name, x=0, *extra):
    return [(0, "INSERT"), (8, "0"), (2, name), (10, x), (20, 0), *extra]


@pytest.mark.parametrize("name,entities,blocks,message", [
    ("NaN arc centre", [[(0, "ARC"), (8, "0"), (10, "nan"), (20, 0), (40, 5), (50, 0), (51, 90)]], None,
     r"ARC #\w+ on layer '0': the centre or radius holds nan, not a finite number"),
    ("infinite radius", [[(0, "CIRCLE"), (8, "0"), (10, 0), (20, 0), (40, "1e400")]], None,
     r"CIRCLE #\w+ on layer '0': the centre or radius holds inf"),
    ("NaN line end", [[(0, "LINE"), (8, "cut"), (10, 0), (20, 0), (11, "nan"), (21, 0)]], None,
     r"LINE #\w+ on layer 'cut': an end point holds nan"),
    ("NaN insertion point", [insert("B", "nan")], {"B": [LINE]},
     r"INSERT #\w+ on layer '0': the insertion point, scale or rotation holds nan"),
    ("NaN ellipse ratio", [[(0, "ELLIPSE"), (8, "0"), (10, 0), (20, 0), (11, 10), (21, 0), (40, "nan"),
                            (41, 0), (42, FULL)]], None,
     r"ELLIPSE #\w+ on layer '0': the centre, axis, ratio or parameters holds nan"),
    ("block inserting itself", [insert("A")], {"A": [LINE, insert("A", 1)]},
     r"block references form a cycle \(A → A\)"),
    ("blocks inserting each other", [insert("A")], {"A": [insert("B")], "B": [insert("A")]},
     r"block references form a cycle \(A → B → A\)"),
])
def test_dxf_reader_refuses_with_the_entity(tmp_path, name, entities, blocks, message):
    path = tmp_path / "hostile.dxf"
    path.write_text(dxf_text(entities, blocks))
    with pytest.raises(GeometryError, match=message):
        read_dxf(path)


@pytest.mark.parametrize("name,odd,blocks,message", [
    ("INSERT at x scale 0", insert("B", 0, (41, 0)), {"B": [LINE]},
     r"INSERT#\w+ \(block 'B' inserted at scale 0 × 1 collapses to a line\)"),
    ("ELLIPSE of ratio 0", [(0, "ELLIPSE"), (8, "0"), (10, 0), (20, 0), (11, 10), (21, 0), (40, 0),
                            (41, 0), (42, FULL)], None,
     r"ELLIPSE#\w+ \(axis ratio 0: the ellipse has no width\)"),
    ("ELLIPSE with no major axis", [(0, "ELLIPSE"), (8, "0"), (10, 0), (20, 0), (11, 0), (21, 0),
                                    (40, 0.5), (41, 0), (42, FULL)], None,
     r"ELLIPSE#\w+ \(its major axis has length 0\)"),
    ("CIRCLE of radius 0", [(0, "CIRCLE"), (8, "0"), (10, 0), (20, 0), (40, 0)], None,
     r"CIRCLE#\w+ \(radius 0: a point\)"),
])
def test_one_entity_that_cannot_be_cut_is_skipped_not_the_drawing(tmp_path, name, odd, blocks, message):
    """Issue 27: one odd entity is skipped with a warning that names it and says why; the
    rest of the drawing (a 10 mm LINE) is read."""
    path = tmp_path / "odd.dxf"
    path.write_text(dxf_text([odd, LINE], blocks))
    with pytest.warns(UserWarning, match=r"skipped 1 entities that cannot be cut: " + message):
        d = read_dxf(path)
    assert [p.vertices.tolist() for p in d.paths] == [[[0.0, 0.0], [10.0, 0.0]]]


def test_malformed_viewport_is_not_a_readable_dxf_not_a_traceback():
    """Hand-written R12 file: a VIEWPORT without the MVIEW extended data R12 keeps its
    settings in; ezdxf's loader (strict and recover mode) ends in an AttributeError."""
    path = Path(__file__).resolve().parents[2] / "data" / "dxf" / "r12_viewport_without_xdata.dxf"
    with pytest.raises(GeometryError, match=r"r12_viewport_without_xdata.dxf: not a readable DXF "
                                            r"file \(ezdxf: AttributeError: 'NoneType' object"):
        read_dxf(path)


def test_nan_bulge_is_refused_not_straightened(tmp_path):
    doc = ezdxf.new()
    doc.modelspace().add_lwpolyline([(0, 0, 0.5), (10, 0, 0)], format="xyb")
    doc.saveas(tmp_path / "p.dxf")
    text = (tmp_path / "p.dxf").read_text().replace("\n 42\n0.5\n", "\n 42\nnan\n")
    assert "nan" in text
    (tmp_path / "p.dxf").write_text(text)
    with pytest.raises(GeometryError, match=r"LWPOLYLINE #\w+ on layer '0': a vertex or bulge holds nan"):
        read_dxf(tmp_path / "p.dxf")


@pytest.mark.parametrize("degree,message", [(0, r"degree 0 is outside 1…25"),
                                            (1000, r"degree 1000 is outside 1…25")])
def test_spline_degree_out_of_range(tmp_path, degree, message):
    doc = ezdxf.new()
    doc.modelspace().add_spline_control_frame([(0, 0), (5, 5), (10, 0), (15, 5)], degree=3)
    doc.saveas(tmp_path / "s.dxf")
    text = (tmp_path / "s.dxf").read_text()
    assert "\n 71\n3\n" in text
    (tmp_path / "s.dxf").write_text(text.replace("\n 71\n3\n", f"\n 71\n{degree}\n"))
    with pytest.raises(GeometryError, match=r"SPLINE #\w+ on layer '0': " + message):
        read_dxf(tmp_path / "s.dxf")


def test_insert_fan_out_bomb_is_refused_before_expansion(tmp_path, run_labkit):
    """4 inserts per level, 10 levels: 4^10 ≈ 1 M lines, plus every INSERT — over budget."""
    blocks = {"L0": [LINE]}
    for i in range(1, 11):
        blocks[f"L{i}"] = [insert(f"L{i - 1}", j) for j in range(4)]
    path = tmp_path / "bomb.dxf"
    path.write_text(dxf_text([insert("L10")], blocks))
    r = run_labkit(["dxf2gcode", path, "-o", tmp_path / "o.gcode"], time_s=30, memory_mb=400)
    assert r.code == 1
    assert re.search(r"too much work: [\d,]+ elements \(budget 2,000,000\) from copies inside block "
                     r"'L10'", r.stderr), r.stderr
    assert not (tmp_path / "o.gcode").exists()


def test_minsert_grid_is_counted_and_drawn(tmp_path):
    """A MINSERT of 2 columns (20 mm apart) × 3 rows (50 mm apart) of a 10 mm line."""
    ents = [insert("B", 0, (70, 2), (71, 3), (44, 20), (45, 50))]
    path = tmp_path / "grid.dxf"
    path.write_text(dxf_text(ents, {"B": [LINE]}))
    d = read_dxf(path)
    starts = sorted(tuple(p.vertices[0]) for p in d.paths)
    assert starts == [(0.0, 0.0), (0.0, 50.0), (0.0, 100.0), (20.0, 0.0), (20.0, 50.0), (20.0, 100.0)]


def test_huge_circle_is_four_arcs_not_gigabytes():
    """A 1e9 mm circle is two half-circle arcs in the reader; nothing is flattened here."""
    path_text = dxf_text([[(0, "CIRCLE"), (8, "0"), (10, 0), (20, 0), (40, "1e9")]])
    import tempfile, os
    with tempfile.TemporaryDirectory() as tmp:
        p = os.path.join(tmp, "huge.dxf")
        with open(p, "w") as f:
            f.write(path_text)
        d = read_dxf(p)
    assert d.paths[0].n_segments == 2 and d.paths[0].is_arc.all()


def test_mirrored_arc_lands_where_ezdxf_puts_it(tmp_path):
    """An ARC with extrusion −Z (a mirrored block, or CAD's habit): its points match
    ezdxf's own OCS → WCS evaluation."""
    doc = ezdxf.new()
    doc.header["$INSUNITS"] = 4
    arc = doc.modelspace().add_arc((10, 0), 5, 0, 90, dxfattribs={"extrusion": (0, 0, -1)})
    doc.saveas(tmp_path / "m.dxf")
    ref = np.array([(w.x, w.y) for w in arc.vertices([0, 45, 90])])     # world coordinates
    p = read_dxf(tmp_path / "m.dxf").paths[0]
    assert np.allclose(p.vertices[[0, -1]], ref[[0, 2]], atol=1e-9)
    assert np.allclose(np.hypot(*(ref[1] - p.centres[0])), 5.0)


def distance_to_polyline(points, poly):
    """Distance of each point to the nearest segment of ``poly``."""
    a, b = poly[:-1][None], poly[1:][None]
    q = points[:, None]
    ab = b - a
    t = np.clip(((q - a) * ab).sum(-1) / np.maximum((ab * ab).sum(-1), 1e-300), 0, 1)
    return np.hypot(*(q - a - t[..., None] * ab).transpose(2, 0, 1)).min(axis=1)


def test_spline_points_against_ezdxf_inside_the_knot_range():
    """A clamped cubic and an unclamped (periodic-style) one: labkit's points lie on
    ezdxf's evaluation, and never beyond the control polygon's box."""
    ctrl = np.array([[0, 0], [10, 20], [30, -10], [40, 10], [60, 0], [70, 15]], float)
    for knots in (np.r_[0, 0, 0, 0, 1, 2, 3, 3, 3, 3], np.arange(10.0)):
        pts = spline_points(3, ctrl, knots, tol_mm=1e-3)
        from ezdxf.math import BSpline
        ref = BSpline(np.c_[ctrl, np.zeros(6)], order=4, knots=knots)
        dense = np.array([(q.x, q.y) for q in (ref.point(t) for t in np.linspace(knots[3], knots[6], 4001))])
        assert distance_to_polyline(dense, pts).max() < 1e-3      # the curve is within tol
        assert distance_to_polyline(pts, dense).max() < 1e-4      # on it, within the dense sag
        assert (pts >= ctrl.min(0) - 1e-9).all() and (pts <= ctrl.max(0) + 1e-9).all()
        assert np.allclose(pts[0], dense[0]) and np.allclose(pts[-1], dense[-1])


def test_unitless_drawing_warns_and_units_override(tmp_path):
    path = tmp_path / "u.dxf"
    path.write_text(dxf_text([LINE], units=0))
    with pytest.warns(UserWarning, match=r"does not say its units .* taken as millimetres .* --units inch"):
        assert np.allclose(read_dxf(path).paths[0].vertices[-1], [10, 0])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert np.allclose(read_dxf(path, units="inch").paths[0].vertices[-1], [254, 0])
    with pytest.raises(GeometryError, match="units 'furlong': expected one of"):
        read_dxf(path, units="furlong")


def test_fuzzed_budget_failure_is_a_budget_error():
    with pytest.raises(BudgetError):
        read_svg(fan_out(11))


def test_drawing_larger_than_the_machine_is_refused_unless_forced(tmp_path, run_labkit):
    """A DXF drawn in inches but saying nothing (read as mm) fits; the same in metres does not."""
    path = tmp_path / "plate.dxf"
    path.write_text(dxf_text([[(0, "CIRCLE"), (8, "0"), (10, 0), (20, 0), (40, 0.2)]], units=6))
    out = tmp_path / "o.gcode"
    r = run_labkit(["dxf2gcode", path, "-o", out], time_s=60)
    assert r.code == 1 and not out.exists()
    assert "the job is 400.0 × 400.0 mm, larger than the travel of cbr40-laser (300 × 400 mm) along X" in r.stderr
    assert run_labkit(["dxf2gcode", path, "-o", out, "--machine", "grbl-diode"], time_s=60).code == 0
    r = run_labkit(["dxf2gcode", path, "-o", out, "--units", "mm"], time_s=60)
    assert r.code == 0
