"""DXF files written by other programs (data/dxf/, data/dxf/ezdxf/): every cut lies on
ezdxf's own dense evaluation of the drawing and every evaluated entity is cut (issue 10 §3),
and each file's rule holds (recover, units, skipped kinds)."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import ezdxf
import numpy as np
import pytest
from ezdxf import recover
from ezdxf.path import make_path
from scipy.spatial import cKDTree

from labkit.geometry import join_chains
from labkit.vector.dxf import INSUNITS_MM, read_dxf

DATA = Path(__file__).resolve().parents[2] / "data" / "dxf"
FILES = sorted(DATA.glob("*.dxf")) + sorted((DATA / "ezdxf").glob("*.[dD][xX][fF]"))
TOL = 0.01
CUT_KINDS = {"LINE", "ARC", "CIRCLE", "ELLIPSE", "LWPOLYLINE", "POLYLINE", "SPLINE"}


def dense(poly, spacing):
    out = [poly[:1]]
    for a, b in zip(poly[:-1], poly[1:]):
        k = max(1, int(math.ceil(np.hypot(*(b - a)) / spacing)))
        out.append(a + np.linspace(0, 1, k + 1)[1:, None] * (b - a))
    return np.vstack(out)


def reference_points(path, spacing):
    """ezdxf's own evaluation of every entity labkit cuts (blocks exploded), in mm."""
    try:
        doc = ezdxf.readfile(path)
    except ezdxf.DXFError:
        doc, _ = recover.readfile(path)
    raw = Path(path).read_bytes().split(b"ENTITIES", 1)[0]
    k = INSUNITS_MM.get(int(doc.header.get("$INSUNITS", 0)), 1.0) if b"$INSUNITS" in raw else 1.0

    def entities(layout):
        for e in layout:
            if e.dxftype() == "INSERT":
                yield from entities(e.virtual_entities())
            elif e.dxftype() in CUT_KINDS:
                if e.dxftype() == "POLYLINE" and not e.is_2d_polyline:
                    continue
                ex = e.dxf.get("extrusion", (0, 0, 1))
                if abs(ex[0]) > 1e-9 or abs(ex[1]) > 1e-9:
                    continue
                yield e

    pts = [dense(np.array([(v.x, v.y) for v in make_path(e).flattening(0.0005)]) * k, spacing)
           for e in entities(doc.modelspace())]
    return np.vstack(pts) if pts else np.zeros((0, 2))


@pytest.mark.parametrize("path", FILES, ids=[f.name for f in FILES])
def test_cuts_lie_on_the_drawing(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        d = read_dxf(path, tol_mm=TOL)
    ref = reference_points(path, TOL / 4)
    ours = [dense(p.sample(TOL / 4), TOL / 4) for p in d.paths]
    assert (len(ref) == 0) == (len(ours) == 0), f"{path.name}: ezdxf draws {len(ref)} points, labkit cuts {len(ours)} paths"
    if not ours:
        return
    ours = np.vstack(ours)
    assert cKDTree(ref).query(ours)[0].max() <= TOL + TOL / 4, "a cut off the drawing"
    assert cKDTree(ours).query(ref)[0].max() <= TOL + TOL / 4, "a drawn entity not cut"


@pytest.mark.parametrize("name,message", [
    ("AC1003_LINE_Example.dxf", "read with ezdxf's recover mode"),
    ("ASCII_R12.dxf", r"skipped 1 entities labkit does not cut \(1 TEXT\)"),
    ("POLI-ALL210_12.DXF", r"30 POLYLINE\(not in the XY plane\), 1 3DFACE"),
    ("R12_with_trash_beyond_EOF.dxf", r"does not say its units .* taken as millimetres"),
    ("cc_dxflib.dxf", r"1 POLYLINE\(3D\)"),
])
def test_each_file_says_what_it_did(name, message):
    with pytest.warns(UserWarning, match=message):
        read_dxf(DATA / "ezdxf" / name)


def test_headerless_file_is_millimetres_not_ezdxf_template_metres():
    """ezdxf gives a file without a HEADER its template's $INSUNITS = 6 (m): the 1.5 radius
    circle would be cut 1.5 m wide. labkit reads what the file says: nothing, so mm."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        d = read_dxf(DATA / "ezdxf" / "R12_with_trash_beyond_EOF.dxf")
    assert np.allclose(d.paths[0].bounds(), [[-1.5, -1.5], [1.5, 1.5]])


def test_openscad_plate_is_three_closed_outlines_of_the_modelled_size():
    """OpenSCAD 2021.01's export of data/dxf/openscad_plate.scad (LINE entities, no units):
    the 60 × 40 mm plate with 4 mm corners, the 12 mm hole and the 5 mm slot with centres
    √(8² + 12²) apart join into three closed loops whose lengths are the model's, less the
    shortfall of OpenSCAD's 48-gon circles (perimeter factor sin(π/48)/(π/48))."""
    with pytest.warns(UserWarning, match=r"does not say its units"):
        d = read_dxf(DATA / "openscad_plate.dxf")
    loops = sorted(join_chains(d.paths), key=lambda p: -p.length_mm)
    assert [p.closed for p in loops] == [True, True, True]
    shrink = math.sin(math.pi / 48) / (math.pi / 48)
    expected = [2 * (52 + 32) + 2 * math.pi * 4 * shrink,
                2 * math.hypot(8, 12) + math.pi * 5 * shrink,
                math.pi * 12 * shrink]
    assert [p.length_mm for p in loops] == pytest.approx(expected, abs=0.02)
    assert np.allclose(loops[0].bounds(), [[-30, -20], [30, 20]], atol=1e-3)
