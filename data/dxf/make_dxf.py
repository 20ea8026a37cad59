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


if __name__ == "__main__":
    main()
