"""DXF import against ezdxf's own flattening of each entity (an independent reference)."""

import math
import os

import ezdxf
import ezdxf.path
import numpy as np
import pytest

from labkit.errors import GeometryError, InputError
from labkit.geometry import Path, hausdorff, join_chains
from labkit.vector import read_dxf
from labkit.vector.dxf import bulge_arc

DATA = os.path.join(os.path.dirname(__file__), "..", "..", "data", "dxf")
PARTS = os.path.join(DATA, "parts_mm.dxf")
PLATE = os.path.join(DATA, "plate_in.dxf")


def _reference(entity, k=1.0):
    """Dense polylines of one entity by ezdxf (blocks expanded by ezdxf too)."""
    if entity.dxftype() == "INSERT":
        out = []
        for sub in entity.virtual_entities():
            out += _reference(sub, k)
        return out
    p = ezdxf.path.make_path(entity)
    return [np.array([(v.x, v.y) for v in p.flattening(1e-5)]) * k]


@pytest.mark.parametrize("tol", [0.1, 0.01])
def test_every_entity_within_tolerance(tol):
    with pytest.warns(UserWarning, match="TEXT#"):
        d = read_dxf(PARTS, tol_mm=tol)
    doc = ezdxf.readfile(PARTS)
    checked = 0
    for e in doc.modelspace():
        if e.dxftype() == "TEXT":
            continue
        ours = [p for p in d.paths if p.source == f"{e.dxftype()}#{e.dxf.handle}"]
        assert ours, f"{e.dxftype()} dropped"
        ref = [Path.polyline(q) for q in _reference(e)]
        assert hausdorff(ours, ref) <= tol + 1e-5
        checked += 1
    assert checked == 12


def test_inch_units_and_layers():
    d = read_dxf(PLATE)
    assert {p.layer for p in d.paths} == {"cut"}
    plate = next(p for p in d.paths if not p.is_arc.any())
    np.testing.assert_allclose(np.diff(plate.bounds(), axis=0)[0], [50.8, 25.4])
    hole = next(p for p in d.paths if p.is_arc.any())
    np.testing.assert_allclose(hole.radii_mm(), 6.35)


def test_loose_outline_becomes_one_closed_chain():
    d = read_dxf(PARTS, warn=False)
    cut = [p for p in d.paths if p.layer == "cut"]
    chains = join_chains(cut)
    outline = max(chains, key=lambda c: c.length_mm)
    assert outline.closed
    assert outline.length_mm == pytest.approx(40 + 25 + math.pi * 5 + 30 + 35)


def test_bulge_matches_ezdxf():
    from ezdxf.math import bulge_to_arc

    for b in (0.3, -0.7, 1.0, 2.5):
        c, sweep = bulge_arc((1, 2), (6, 3), b)
        center, start, end, radius = bulge_to_arc((1, 2), (6, 3), b)
        np.testing.assert_allclose(c, [center.x, center.y], atol=1e-12)
        assert abs(sweep) == pytest.approx((end - start) % (2 * math.pi))
        assert math.copysign(1, sweep) == math.copysign(1, b)


def test_errors(tmp_path):
    with pytest.raises(InputError, match="no such file; expected an existing DXF file"):
        read_dxf(tmp_path / "missing.dxf")
    bad = tmp_path / "bad.dxf"
    bad.write_text("this is not a dxf")
    with pytest.raises(GeometryError, match="not a readable DXF file"):
        read_dxf(bad)
    doc = ezdxf.new()
    doc.header["$INSUNITS"] = 3            # miles
    doc.saveas(tmp_path / "miles.dxf")
    with pytest.raises(GeometryError, match=r"\$INSUNITS = 3"):
        read_dxf(tmp_path / "miles.dxf")
    with pytest.raises(GeometryError, match="tol_mm must be a finite number > 0"):
        read_dxf(PARTS, tol_mm=0)


@pytest.mark.parametrize("insunits, size, expect", [
    (6, 100.0, r"100,000 mm across with its units taken as m, implausibly large .* drawn in mm, give --units mm"),
    (4, 0.5, r"0\.5 mm across with its units taken as mm, implausibly small .* drawn in inch, give --units inch"),
    (4, 100.0, None),
])
def test_implausible_extents_warn_with_the_unit_to_try(tmp_path, insunits, size, expect):
    """A 100-unit part whose file says metres (a 100 m laser job), or a half-unit part in a
    file that says mm, is drawn in other units: the warning says which unit was assumed and
    which one brings the part to a laser-sized drawing. A plausible drawing is silent, and
    --units silences the check (the user has said)."""
    import warnings

    doc = ezdxf.new()
    doc.header["$INSUNITS"] = insunits
    doc.modelspace().add_lwpolyline([(0, 0), (size, 0), (size, size / 2)], close=True)
    path = tmp_path / "part.dxf"
    doc.saveas(path)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        d = read_dxf(path)
    messages = [str(w.message) for w in caught]
    if expect is None:
        assert not messages
    else:
        assert any(__import__("re").search(expect, m) for m in messages), messages
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        read_dxf(path, units="mm")
    assert d.paths


def _de_boor(t, c, p, u):
    """C(u) by the Cox–de Boor recursion, written out (independent of scipy and ezdxf)."""
    k = int(np.searchsorted(t, u, side="right") - 1)
    k = min(max(k, p), len(c) - 1)
    d = [c[j + k - p].astype(float) for j in range(p + 1)]
    for r in range(1, p + 1):
        for j in range(p, r - 1, -1):
            a = (u - t[j + k - p]) / (t[j + 1 + k - r] - t[j + k - p])
            d[j] = (1 - a) * d[j - 1] + a * d[j]
    return d[p]


def test_closed_periodic_spline_as_qcad_writes_it(tmp_path):
    """QCAD writes a closed spline as a periodic one: uniform knots and the first p control
    points repeated at the end, flags closed | periodic. Only [t_p, t_n] is the curve; the
    knot vector's ends are not (evaluated there, a tail once reached 1,190 mm from a 100 mm
    drawing). The flattened loop closes on itself, lies in the control points' convex hull
    (a B-spline's own bound) and within the tolerance of a Cox–de Boor evaluation."""
    p, tol = 3, 0.01
    ring = np.array([[0, 0], [60, -10], [100, 20], [90, 70], [40, 90], [-10, 60], [-20, 20.0]])
    ctrl = np.vstack([ring, ring[:p]])
    knots = np.arange(len(ctrl) + p + 1, dtype=float)
    doc = ezdxf.new()
    doc.header["$INSUNITS"] = 4
    s = doc.modelspace().add_spline(dxfattribs={"flags": 1 | 2 | 8})
    s.dxf.degree = p
    s.control_points = [(x, y, 0) for x, y in ctrl]
    s.knots = knots
    path = tmp_path / "qcad_closed.dxf"
    doc.saveas(path)
    (drawn,) = read_dxf(path, tol_mm=tol).paths
    pts = drawn.sample(tol / 10)
    assert np.allclose(pts[0], pts[-1], atol=1e-9)
    import shapely

    hull = shapely.MultiPoint(ring).convex_hull.buffer(1e-9)
    assert hull.covers(shapely.LineString(pts))
    u = np.linspace(knots[p], knots[len(ctrl)], 4001)
    ref = np.array([_de_boor(knots, ctrl, p, x) for x in u])
    assert hausdorff(Path(pts), Path(ref)) <= tol


# --- issue 27: DXF as the CAD program that wrote it draws it ---------------------------------

def _read(name, **kw):
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return read_dxf(os.path.join(DATA, name), **kw)


def test_floor_plan_with_degenerate_closed_paths_builds_a_job():
    """data/dxf/degenerate_room_r2004.dxf (written by make_dxf.py, the smallest equivalent of
    an AutoCAD 2004 floor plan that ended in shapely's "A linearring requires at least 4
    coordinates"): a 1e-6 mm LINE, shorter than the join tolerance, is joined shut into a
    closed path of no area; two closed polylines of two distinct vertices enclose none either.
    The job builds with fill and kerf; the doors are cut there and back as drawn (2 × 30 mm
    each), the stray line is nothing to cut, the walls and fixture are outlines."""
    from labkit.toolpath.build import prepare_paths

    d = _read("degenerate_room_r2004.dxf")
    for opts in ({}, {"fill": True, "fill_spacing_mm": 1.0}, {"kerf_mm": 0.2}):
        out = prepare_paths(d.paths, **opts)
        doors = [p for p in out if p.layer == "doors"]
        assert sorted(round(p.length_mm, 9) for p in doors) == [60.0, 60.0]
        assert not any(p.closed for p in doors)
        assert {p.layer for p in out if p.closed} == {"walls", "fixtures"}


def test_ellipse_ratio_above_one_is_drawn_with_the_longer_minor_axis():
    """data/dxf/ellipse_ratio_1.99.dxf: major axis (10, 0), ratio 1.99 — the minor axis
    ratio · (Z × major) = (0, 19.9) is the longer one; ezdxf draws it so, and so does AutoCAD."""
    d = _read("ellipse_ratio_1.99.dxf")
    ellipse = next(p for p in d.paths if p.source.startswith("ELLIPSE"))
    np.testing.assert_allclose(ellipse.bounds(), [[20, 10.1], [40, 49.9]], atol=0.011)
    doc = ezdxf.readfile(os.path.join(DATA, "ellipse_ratio_1.99.dxf"))
    ref = [Path.polyline(q) for q in _reference(doc.modelspace().query("ELLIPSE")[0])]
    assert hausdorff([ellipse], ref) <= 0.01 + 1e-5


def test_insert_with_z_scale_zero_is_placed_in_plan():
    """data/dxf/insert_zscale_0.dxf: two inserts of a 10 mm square with an r = 3 mm circle at
    scale 1.5 × 1.5 × 0 (as LibreCAD writes flat inserts): the z scale moves nothing in x or
    y, so each is a 15 mm square around an r = 4.5 mm circle at (10, 10) and (40, 10)."""
    d = _read("insert_zscale_0.dxf")
    circles = sorted((p for p in d.paths if p.is_arc.all()), key=lambda p: p.start[0])
    squares = sorted((p for p in d.paths if not p.is_arc.any()), key=lambda p: p.start[0])
    for x, circle, square in zip((10, 40), circles, squares):
        np.testing.assert_allclose(circle.radii_mm(), 4.5, atol=1e-9)
        np.testing.assert_allclose(circle.bounds(), [[x - 4.5, 5.5], [x + 4.5, 14.5]], atol=1e-9)
        np.testing.assert_allclose(square.bounds(), [[x - 7.5, 2.5], [x + 7.5, 17.5]], atol=1e-9)
    assert len(circles) == len(squares) == 2


def test_hatch_boundaries_are_closed_outlines_and_fill_when_asked():
    """data/dxf/hatch_outlines.dxf: a 50 × 30 mm hatch with a half-disc hole (r = 8) and an
    elliptical hole (5 × 2.5), and an associative hatch whose boundary is a polyline the
    drawing also holds. The first hatch is three closed outlines of the boundary's lengths;
    the second is cut once, by its polyline; --fill hatches inside the plate and not in
    the holes."""
    import shapely

    from labkit.toolpath.build import prepare_paths

    d = _read("hatch_outlines.dxf")
    hatch = [p for p in d.paths if p.source.startswith("HATCH")]
    assert all(p.closed for p in hatch) and len(hatch) == 3
    ellipse_perimeter = math.pi * (22.5 - math.sqrt(17.5 * 12.5))   # Ramanujan, a = 5, b = 2.5
    lengths = sorted(p.length_mm for p in hatch)
    assert lengths == pytest.approx(sorted([160.0, math.pi * 8 + 16, ellipse_perimeter]), abs=0.02)
    assert sum(p.source.startswith("LWPOLYLINE") for p in d.paths) == 1
    assert {p.source.split("#")[0] for p in d.paths} == {"HATCH", "LWPOLYLINE"}
    filled = [p for p in prepare_paths(hatch, fill=True, fill_spacing_mm=0.5) if not p.closed]
    lines = shapely.MultiLineString([p.vertices for p in filled])
    holes = shapely.union_all([shapely.Polygon(p.sample(0.001)) for p in hatch[1:]]).buffer(-0.01)
    assert lines.length > 0.9 * (1500 - 0.5 * math.pi * 64 - math.pi * 12.5) / 0.5
    assert lines.intersection(holes).length == pytest.approx(0.0, abs=1e-6)


def test_entities_in_other_planes_are_cut_as_seen_from_above():
    """data/dxf/plan_view_3d.dxf: a 3-D POLYLINE is its vertices' x, y; a circle of r = 10 in
    a plane tilted 30° about x is an ellipse of semi-axes 10 and 10·cos 30°; a circle seen
    edge-on (extrusion +X: its OCS centre (100, 0, 0) is world (0, 100, 0)) is a 10 mm line."""
    d = _read("plan_view_3d.dxf")
    by = {p.source: p for p in d.paths}
    poly = next(p for s, p in by.items() if s.startswith("POLYLINE"))
    np.testing.assert_allclose(poly.vertices, [[0, 0], [30, 0], [30, 20], [0, 20], [0, 0]])
    circles = [p for s, p in by.items() if s.startswith("CIRCLE")]
    tilted = next(p for p in circles if p.closed)
    (x0, y0), (x1, y1) = tilted.bounds()
    assert (x1 - x0, y1 - y0) == pytest.approx((20.0, 20 * math.cos(math.pi / 6)), abs=0.011)
    edge_on = next(p for p in circles if not p.closed)
    np.testing.assert_allclose(edge_on.bounds(), [[0, 95], [0, 105]], atol=0.011)


def test_lines_under_a_wipeout_are_cut_only_where_drawn(tmp_path):
    """A 40 mm square, a WIPEOUT covering [10, 20] × [−5, 5] (across the bottom side), then a
    line drawn after it through the same place: the square loses 10 mm of its bottom side,
    the later line is kept whole (draw order, as ezdxf's drawing add-on paints it)."""
    doc = ezdxf.new("R2010")
    doc.header["$INSUNITS"] = 4
    msp = doc.modelspace()
    msp.add_lwpolyline([(0, 0), (40, 0), (40, 40), (0, 40)], close=True)
    msp.add_wipeout([(10, -5), (20, -5), (20, 5), (10, 5)])
    msp.add_line((0, 2), (40, 2))
    doc.saveas(tmp_path / "w.dxf")
    with pytest.warns(UserWarning, match=r"1 entities lie partly under a WIPEOUT .*LWPOLYLINE#"):
        d = read_dxf(tmp_path / "w.dxf")
    square = [p for p in d.paths if p.source.startswith("LWPOLYLINE")]
    assert sum(p.length_mm for p in square) == pytest.approx(150.0, abs=1e-6)
    line = next(p for p in d.paths if p.source.startswith("LINE"))
    assert line.length_mm == 40.0
    assert d.clipped == [square[0].source]


def test_spline_evaluation_matches_scipy_bspline():
    """The B-spline evaluation spline_points flattens with (de Boor, all parameters at once) gives
    scipy's BSpline values to 1e-13 of the control points' size: degrees 1-5, clamped and
    unclamped knot vectors, repeated knots, rational weights, the range's ends and its knots."""
    from scipy.interpolate import BSpline

    from labkit.vector.dxf import _de_boor

    rng = np.random.default_rng(0)
    checked = 0
    for _ in range(1500):
        p = int(rng.integers(1, 6))
        n = int(rng.integers(p + 1, p + 12))
        inner = np.sort(rng.uniform(0, 1, n - p - 1))
        if len(inner) > 1 and rng.random() < 0.3:
            inner[1] = inner[0]
        t = (np.r_[np.zeros(p + 1), inner, np.ones(p + 1)] if rng.random() < 0.5
             else np.sort(rng.uniform(-1, 2, n + p + 1)))
        if not t[n] > t[p]:
            continue
        c = np.column_stack([rng.normal(0, 50, (n, 2)) * (w := rng.uniform(0.2, 3, n))[:, None], w])
        u = np.r_[t[p], np.sort(rng.uniform(t[p], t[n], 40)), t[n], t[(t >= t[p]) & (t <= t[n])]]
        want = BSpline(t, c, p, extrapolate=False)(u)
        np.testing.assert_allclose(_de_boor(t, c, p, u), want, rtol=0, atol=1e-13 * 150)
        checked += 1
    assert checked > 1000
