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
