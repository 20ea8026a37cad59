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
