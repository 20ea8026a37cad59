"""Write the DXF test drawings of labkit (run: .venv/bin/python data/dxf/make_dxf.py).

Every entity type labkit reads, in mm and in inches, plus a block reference
with a non-uniform scale and a TEXT that must be skipped with a warning.
"""

import math
from pathlib import Path

import ezdxf

HERE = Path(__file__).parent


def _parts(msp):
    msp.add_line((0, 0), (40, 0), dxfattribs={"layer": "cut"})
    msp.add_line((40, 0), (40, 25), dxfattribs={"layer": "cut"})
    msp.add_arc((30, 25), 10, 0, 90, dxfattribs={"layer": "cut"})          # (40,25) → (30,35)
    msp.add_line((30, 35), (0, 35), dxfattribs={"layer": "cut"})
    msp.add_line((0, 35), (0, 0), dxfattribs={"layer": "cut"})
    msp.add_circle((12, 15), 5, dxfattribs={"layer": "holes"})
    msp.add_ellipse((28, 12), major_axis=(6, 3), ratio=0.4, dxfattribs={"layer": "holes"})
    msp.add_ellipse((60, 10), major_axis=(0, 8), ratio=0.5, start_param=0.3, end_param=4.0,
                    dxfattribs={"layer": "engrave"})
    msp.add_lwpolyline([(50, 20, 0, 0, 0.5), (70, 20, 0, 0, 0), (70, 35, 0, 0, -1.0), (50, 35, 0, 0, 0)],
                       format="xyseb", close=True, dxfattribs={"layer": "cut"})
    pl = msp.add_polyline2d([(80, 0), (95, 0), (95, 15)], dxfattribs={"layer": "engrave"})
    pl.vertices[0].dxf.bulge = 0.3
    msp.add_spline(fit_points=[(80, 20), (85, 30), (92, 22), (100, 34)], dxfattribs={"layer": "engrave"})
    msp.add_text("labkit", dxfattribs={"layer": "notes", "insert": (0, -10)})


def odd_entities():
    """Drawings with the odd entities CAD programs write (issue 27), each in a file of its own."""
    doc = ezdxf.new("R2004")                          # a floor plan with a stray 1 nm LINE (shorter
    doc.header["$INSUNITS"] = 4                       # than the join tolerance: joined shut) and
    msp = doc.modelspace()                            # closed polylines of two vertices
    msp.add_line((60, 75), (60 + 1e-6, 75), dxfattribs={"layer": "doors"})
    msp.add_lwpolyline([(0, 0), (200, 0), (200, 150), (0, 150)], close=True, dxfattribs={"layer": "walls"})
    msp.add_lwpolyline([(40, 0), (70, 0)], close=True, dxfattribs={"layer": "doors"})
    msp.add_lwpolyline([(120, 150), (150, 150), (150, 150)], close=True, dxfattribs={"layer": "doors"})
    msp.add_circle((100, 75), 10, dxfattribs={"layer": "fixtures"})
    doc.saveas(HERE / "degenerate_room_r2004.dxf")

    doc = ezdxf.new("R2010")                          # ratio above 1: the minor axis is the longer
    doc.header["$INSUNITS"] = 4
    msp = doc.modelspace()
    msp.add_ellipse((30, 30), major_axis=(10, 0), ratio=0.5)
    msp.add_line((0, 0), (60, 0))
    doc.saveas(HERE / "ellipse_ratio_1.99.dxf")
    text = (HERE / "ellipse_ratio_1.99.dxf").read_text()       # ezdxf writes no ratio above 1
    assert text.count("\n 40\n0.5\n") == 1
    (HERE / "ellipse_ratio_1.99.dxf").write_text(text.replace("\n 40\n0.5\n", "\n 40\n1.99\n"))

    doc = ezdxf.new("R2010")                          # LibreCAD writes z scale 0 for flat inserts
    doc.header["$INSUNITS"] = 4
    blk = doc.blocks.new("BOLT")
    blk.add_circle((0, 0), 3)
    blk.add_lwpolyline([(-5, -5), (5, -5), (5, 5), (-5, 5)], close=True)
    msp = doc.modelspace()
    for x in (10, 40):
        msp.add_blockref("BOLT", (x, 10), dxfattribs={"xscale": 1.5, "yscale": 1.5, "zscale": 0.0})
    doc.saveas(HERE / "insert_zscale_0.dxf")

    doc = ezdxf.new("R2010")                          # hatches: a plate with a hole, and one
    doc.header["$INSUNITS"] = 4                       # associative to a polyline drawn as well
    msp = doc.modelspace()
    hatch = msp.add_hatch(dxfattribs={"layer": "engrave"})
    hatch.paths.add_polyline_path([(0, 0), (50, 0), (50, 30), (0, 30)], is_closed=True)
    edges = hatch.paths.add_edge_path()
    edges.add_arc((25, 15), 8, 0, 180)
    edges.add_line((17, 15), (33, 15))
    edges = hatch.paths.add_edge_path()
    edges.add_ellipse((40, 8), major_axis=(5, 0), ratio=0.5)
    outline = msp.add_lwpolyline([(60, 0), (90, 0), (90, 20, 0.5), (60, 20)], format="xyb", close=True)
    linked = msp.add_hatch(dxfattribs={"layer": "engrave", "associative": 1})
    path = linked.paths.add_polyline_path(list(outline.get_points("xyb")), is_closed=True)
    path.source_boundary_objects = [outline.dxf.handle]
    doc.saveas(HERE / "hatch_outlines.dxf")

    doc = ezdxf.new("R2010")                          # plan view of entities in other planes
    doc.header["$INSUNITS"] = 4
    msp = doc.modelspace()
    msp.add_polyline3d([(0, 0, 0), (30, 0, 5), (30, 20, 10), (0, 20, 5)], close=True)
    tilt = (0, -0.5, 0.8660254037844387)             # 30° about x
    msp.add_circle((50, 15, 3), 10, dxfattribs={"extrusion": tilt})
    msp.add_arc((80, 10, 0), 8, 20, 250, dxfattribs={"extrusion": (0.6, 0, 0.8)})
    pl = msp.add_polyline2d([(0, 40), (30, 40), (30, 60)], dxfattribs={"extrusion": tilt})
    pl.vertices[0].dxf.bulge = 0.4
    msp.add_lwpolyline([(40, 40, 0.0), (60, 40, -0.6), (60, 55, 0.0)], format="xyb",
                       dxfattribs={"extrusion": (0, 0.6, 0.8), "elevation": 4})
    msp.add_circle((100, 0, 0), 5, dxfattribs={"extrusion": (1, 0, 0)})          # seen edge-on
    doc.saveas(HERE / "plan_view_3d.dxf")


def main():
    doc = ezdxf.new("R2010")
    doc.header["$INSUNITS"] = 4                       # mm
    msp = doc.modelspace()
    _parts(msp)
    blk = doc.blocks.new("RING")
    blk.add_circle((0, 0), 4)
    blk.add_arc((0, 0), 6, 30, 150)
    msp.add_blockref("RING", (120, 20), dxfattribs={"xscale": 2.0, "yscale": 1.0, "rotation": 30,
                                                     "layer": "engrave"})
    doc.saveas(HERE / "parts_mm.dxf")

    doc = ezdxf.new("R2010")
    doc.header["$INSUNITS"] = 1                       # inches
    msp = doc.modelspace()
    msp.add_lwpolyline([(0, 0), (2, 0), (2, 1), (0, 1)], close=True, dxfattribs={"layer": "cut"})
    msp.add_circle((1, 0.5), 0.25, dxfattribs={"layer": "cut"})
    doc.saveas(HERE / "plate_in.dxf")
    print("wrote", HERE / "parts_mm.dxf", HERE / "plate_in.dxf", math.pi)
    odd_entities()


if __name__ == "__main__":
    main()
