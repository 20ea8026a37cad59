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

from labkit.errors import GeometryError
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


def hatch_boundaries(hatch, sagitta):
    """ezdxf's own evaluation of a HATCH's boundary loops (construction arcs, ellipses and
    splines flattened by ezdxf.math), in world coordinates."""
    from ezdxf.entities.boundary_paths import ArcEdge, EdgePath, EllipseEdge, LineEdge, SplineEdge
    from ezdxf.math import BSpline, ConstructionArc, bulge_to_arc

    ocs, z = hatch.ocs(), hatch.dxf.elevation.z
    for loop in hatch.paths:
        pts = []
        if not isinstance(loop, EdgePath):
            v = list(loop.vertices)
            for (x0, y0, b), (x1, y1, _) in zip(v, v[1:] + v[:1]):
                if abs(b) > 1e-12:
                    c, a0, a1, r = bulge_to_arc((x0, y0), (x1, y1), b)
                    pts.append(list(ConstructionArc(c, r, math.degrees(a0), math.degrees(a1)).flattening(sagitta)))
                else:
                    pts.append([(x0, y0), (x1, y1)])
        for edge in getattr(loop, "edges", []):
            if isinstance(edge, LineEdge):
                pts.append([edge.start, edge.end])
            elif isinstance(edge, ArcEdge):
                pts.append(list(ConstructionArc(edge.center, abs(edge.radius), edge.start_angle,
                                                edge.end_angle).flattening(sagitta)))
            elif isinstance(edge, EllipseEdge):
                pts.append(list(edge.construction_tool().flattening(sagitta)))
            elif isinstance(edge, SplineEdge) and len(edge.control_points):
                pts.append(list(BSpline(edge.control_points, edge.degree + 1, edge.knot_values,
                                        edge.weights or None).flattening(sagitta)))
        for piece in pts:
            yield np.array([tuple(w)[:2] for w in ocs.points_to_wcs([(p[0], p[1], z) for p in piece])])


def reference_points(path, spacing, units_mm=None):
    """ezdxf's own evaluation of every entity labkit cuts (blocks exploded), seen from above
    (world x, y), in mm; what a WIPEOUT drawn later covers is left out."""
    import shapely
    from ezdxf import reorder

    try:
        doc = ezdxf.readfile(path)
    except ezdxf.DXFError:
        doc, _ = recover.readfile(path)
    raw = Path(path).read_bytes().split(b"ENTITIES", 1)[0]
    k = INSUNITS_MM.get(int(doc.header.get("$INSUNITS", 0)), 1.0) if b"$INSUNITS" in raw else 1.0
    k = units_mm or k

    def entities(layout):
        for e in layout:
            if e.dxftype() == "INSERT":
                yield from entities(e.virtual_entities())
            elif e.dxftype() in CUT_KINDS | {"HATCH", "WIPEOUT"}:
                if e.dxftype() == "POLYLINE" and (e.is_poly_face_mesh or e.is_polygon_mesh):
                    continue
                if e.dxftype() in ("CIRCLE", "ARC") and e.dxf.radius == 0:
                    continue
                yield e

    msp = doc.modelspace()
    order = list(msp.get_redraw_order())
    pts: list[np.ndarray] = []
    for e in entities(reorder.ascending(msp, order) if order else msp):
        if e.dxftype() == "WIPEOUT":
            hole = shapely.Polygon([(v.x * k, v.y * k) for v in e.boundary_path_wcs()])
            pts = [q[~shapely.contains_xy(hole, q[:, 0], q[:, 1])] for q in pts]
            continue
        polys = (hatch_boundaries(e, 0.0005 / k) if e.dxftype() == "HATCH" else
                 [np.array([(v.x, v.y) for v in make_path(e, segments=8).flattening(0.0005 / k)])])
        pts += [dense(q * k, spacing) for q in polys if len(q)]
    pts = [q for q in pts if len(q)]
    return np.vstack(pts) if pts else np.zeros((0, 2))


@pytest.mark.parametrize("path", FILES, ids=[f.name for f in FILES])
def test_cuts_lie_on_the_drawing(path):
    """Every cut lies on ezdxf's evaluation of the drawing and every entity ezdxf evaluates is
    cut (a file labkit refuses is refused with labkit's error, never a traceback)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            d = read_dxf(path, tol_mm=TOL, units=METRES_AS_MM.get(path.name))
    except GeometryError as exc:
        assert path.name in REFUSED and REFUSED[path.name] in str(exc)
        return
    assert path.name not in REFUSED
    ref = reference_points(path, TOL / 4, units_mm=1.0 if path.name in METRES_AS_MM else None)
    ours = [dense(p.sample(TOL / 4), TOL / 4) for p in d.paths]
    assert (len(ref) == 0) == (len(ours) == 0), f"{path.name}: ezdxf draws {len(ref)} points, labkit cuts {len(ours)} paths"
    if not ours:
        return
    ours = np.vstack(ours)
    assert cKDTree(ref).query(ours)[0].max() <= TOL + TOL / 4, "a cut off the drawing"
    assert cKDTree(ours).query(ref)[0].max() <= TOL + TOL / 4, "a drawn entity not cut"


#: Files of data/dxf labkit refuses, and the words of its error.
REFUSED = {"r12_viewport_without_xdata.dxf": "not a readable DXF file (ezdxf: AttributeError"}
#: ezdxf's files drawn in metres, tens of metres across: read as mm (checked at 0.01 mm, a
#: 70 m drawing would be billions of samples).
METRES_AS_MM = {"clockwise_arcs_hatch.dxf": "mm", "wipeout_random.dxf": "mm",
                "circle_radius_le_0.dxf": "mm"}


@pytest.mark.parametrize("name,message", [
    ("AC1003_LINE_Example.dxf", "read with ezdxf's recover mode"),
    ("ASCII_R12.dxf", r"skipped 1 entities labkit does not cut \(1 TEXT\)"),
    ("POLI-ALL210_12.DXF", r"skipped 1 entities labkit does not cut \(1 3DFACE\)"),
    ("R12_with_trash_beyond_EOF.dxf", r"does not say its units .* taken as millimetres"),
    ("circle_radius_le_0.dxf", r"skipped 1 entities that cannot be cut: CIRCLE#2D \(radius 0: a point\)"),
    ("wipeout_random.dxf", r"18 entities lie partly under a WIPEOUT drawn after them; only their "
                           r"visible parts are cut: LINE#2D"),
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
