"""Write the small STL models of data/stl (run from the repository root:
``python data/stl/make_stl.py``). Both are closed meshes of revolution made by
:func:`labkit.toolpath.sections.revolved_mesh`, so their sections have closed forms.

- ``dome.stl``: a hemisphere of radius 5 mm on the XY plane, 24 profile points on the
  quarter circle, 48 sides (section at height z: a regular 48-gon).
- ``stepped_pyramid.stl``: three square steps 1 mm high, half-diagonals 6, 4 and 2 mm
  (squares of side 8.485, 5.657, 2.828 mm), sides along X and Y.
"""

import math
from pathlib import Path

import numpy as np
import trimesh

from labkit.toolpath.sections import revolved_mesh

HERE = Path(__file__).parent


def dome():
    th = np.linspace(0.0, math.pi / 2, 24)
    prof = np.vstack([[0.0, 0.0], np.c_[5.0 * np.cos(th), 5.0 * np.sin(th)]])
    prof[-1, 0] = 0.0                        # the pole on the axis exactly
    return revolved_mesh(prof, 48)


def stepped_pyramid():
    prof = [(0, 0), (6, 0), (6, 1), (4, 1), (4, 2), (2, 2), (2, 3), (0, 3)]
    return revolved_mesh(prof, 4, phase_rad=math.pi / 4)


def main():
    for name, mesh in (("dome", dome()), ("stepped_pyramid", stepped_pyramid())):
        tm = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
        assert tm.is_watertight and tm.is_winding_consistent and tm.volume > 0
        tm.export(HERE / f"{name}.stl")          # binary STL
        print(f"{name}.stl: {len(mesh.faces)} triangles, volume {tm.volume:.4f} mm³")


if __name__ == "__main__":
    main()
