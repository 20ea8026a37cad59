"""Planar sections ([MicroCAM] §6.1.3.6): loops against closed forms and trimesh's own section;
the pocketed job stays inside each section and covers it."""

import math
from pathlib import Path as FsPath

import numpy as np
import pytest
import shapely
import trimesh

from labkit.cli import main
from labkit.errors import GeometryError, InputError
from labkit.gcode import emit, parse, parse_file
from labkit.toolpath.sections import (loop_area_mm2, read_mesh, revolved_mesh, section_levels,
                                      section_loops, section_toolpath, simplify_loop)

STL = FsPath(__file__).parents[2] / "data" / "stl"


def _regular_polygon_area(n, r):
    return 0.5 * n * r * r * math.sin(2 * math.pi / n)


@pytest.mark.parametrize("z", [-0.99, -0.3, 0.0, 0.41, 0.999])
def test_box_section_is_its_rectangle(z):
    loops = section_loops(trimesh.creation.box(extents=(3, 5, 2)), z)
    assert len(loops) == 1
    assert loop_area_mm2(loops[0]) == pytest.approx(15.0, abs=1e-12)          # CCW: positive
    assert np.allclose(np.abs(loops[0]).max(axis=0), [1.5, 2.5])


@pytest.mark.parametrize("sections,z", [(8, 0.5), (32, 1.7), (64, 3.2)])
def test_cone_section_is_a_scaled_regular_polygon(sections, z):
    r, h = 3.0, 4.0
    cone = trimesh.creation.cone(radius=r, height=h, sections=sections)
    loops = section_loops(cone, z)
    assert len(loops) == 1
    rz = r * (1 - z / h)
    assert loop_area_mm2(loops[0]) == pytest.approx(_regular_polygon_area(sections, rz), rel=1e-12)
    assert np.allclose(np.hypot(*loops[0].T).max(), rz, atol=1e-12)


def test_revolved_mesh_sections_match_the_interpolated_polygon():
    prof = np.array([(0, 0), (6, 0), (6, 1), (4, 1), (4, 2), (2, 2), (2, 3), (0, 3)], float)
    mesh = revolved_mesh(prof, 4, phase_rad=math.pi / 4)
    for z, half_diag in [(0.5, 6), (1.5, 4), (2.5, 2)]:
        (loop,) = section_loops(mesh, z)
        assert loop_area_mm2(loop) == pytest.approx(2 * half_diag ** 2, rel=1e-12)


def test_sphere_sections_converge_to_the_circle():
    R, z = 5.0, 1.3
    exact = math.pi * (R * R - z * z)
    errors = []
    for sub in (2, 3, 4, 5):
        loops = section_loops(trimesh.creation.icosphere(subdivisions=sub, radius=R), z)
        assert len(loops) == 1
        errors.append(abs(loop_area_mm2(loops[0]) - exact) / exact)
    assert errors[-1] < 1e-3
    assert all(b < a / 2.5 for a, b in zip(errors, errors[1:]))                # ~4× per subdivision


def test_torus_gives_an_outer_ring_and_a_hole():
    torus = trimesh.creation.torus(major_radius=4, minor_radius=1, major_sections=64, minor_sections=32)
    loops = section_loops(torus, 0.0)
    areas = sorted(loop_area_mm2(lp) for lp in loops)
    assert len(loops) == 2 and areas[0] < 0 < areas[1]                          # hole clockwise
    assert sum(areas) == pytest.approx(math.pi * (25 - 9), rel=0.01)


def _canonical(segments):
    """Segments as rows (x0, y0, x1, y1) with the smaller end first, rows sorted."""
    s = np.round(segments, 9)
    swap = (s[:, 1, 0] < s[:, 0, 0]) | ((s[:, 1, 0] == s[:, 0, 0]) & (s[:, 1, 1] < s[:, 0, 1]))
    s = np.where(swap[:, None, None], s[:, ::-1], s).reshape(-1, 4)
    return s[np.lexsort(s.T[::-1])]


@pytest.mark.parametrize("mesh,levels", [
    (trimesh.creation.icosphere(subdivisions=3, radius=5), [-4.2, -1.0, 0.0, 2.5, 4.9]),
    (trimesh.creation.torus(major_radius=4, minor_radius=1), [-0.8, 0.0, 0.5]),
    (trimesh.creation.cone(radius=3, height=4, sections=24), [0.1, 2.0, 3.9]),
    (trimesh.creation.uv_sphere(radius=2, count=[16, 16]), [0.0, 1.0]),     # rings of vertices on z = 0
])
def test_loops_equal_trimesh_mesh_plane(mesh, levels):
    for z in levels:
        loops = section_loops(mesh, z)
        ours = np.concatenate([np.stack([lp[:-1], lp[1:]], axis=1) for lp in loops])
        theirs = trimesh.intersections.mesh_plane(mesh, [0, 0, 1], [0, 0, z])[:, :, :2]
        theirs = theirs[np.linalg.norm(theirs[:, 0] - theirs[:, 1], axis=1) > 1e-12]
        assert len(ours) == len(theirs)
        assert np.allclose(_canonical(ours), _canonical(theirs), atol=1e-9)
        section = mesh.section(plane_origin=[0, 0, z], plane_normal=[0, 0, 1])
        if section is not None and len(loops) == 1:      # (nesting in trimesh needs rtree)
            assert sum(loop_area_mm2(lp) for lp in loops) == pytest.approx(section.to_2D()[0].area, rel=1e-9)


def test_simplify_keeps_within_tolerance_and_drops_shallow_turns():
    (loop,) = section_loops(trimesh.creation.icosphere(subdivisions=5, radius=5), 0.7)
    for max_deg, tol in [(5, 0.01), (20, 0.05), (45, 0.002)]:
        s = simplify_loop(loop, max_deg, tol)
        assert len(s) < len(loop)
        dev = shapely.LineString(loop).hausdorff_distance(shapely.LineString(s))
        assert dev <= tol + 1e-12
    sq = simplify_loop(section_loops(trimesh.creation.box(extents=(2, 2, 2)), 0.0)[0], 1, 0.0)
    assert len(sq) == 5


def test_levels_top_down_and_bottom_up():
    assert section_levels(0, 3, 1).tolist() == [2.5, 1.5, 0.5]
    assert section_levels(0, 3, 1, top_down=False).tolist() == [0.5, 1.5, 2.5]
    with pytest.raises(GeometryError, match="step_mm"):
        section_levels(0, 1, 0)


def test_job_stays_inside_each_section_and_covers_it():
    mesh = read_mesh(STL / "dome.stl")
    beam = 0.4
    moves, levels = section_toolpath(mesh, 1.0, beam, tol_mm=0.002)
    assert [round(lv["z_mm"], 6) for lv in levels] == [4.5, 3.5, 2.5, 1.5, 0.5]
    for lv in levels:
        region = shapely.union_all([shapely.Polygon(lp) for lp in lv["loops"]])
        exact = 48 / 2 * math.sin(2 * math.pi / 48) * 25          # polygon area bound at z = 0
        assert region.area <= exact
        cut = moves[moves.laser_on & np.isclose(moves.end[:, 2], lv["z_mm"])]
        assert len(cut)
        pts = np.vstack([cut.start[:, :2], cut.end[:, :2]])
        # every cut point at least a beam radius inside the section (within the tolerances)
        depth = np.array([region.exterior.distance(shapely.Point(p)) if region.geom_type == "Polygon"
                          else region.boundary.distance(shapely.Point(p)) for p in pts])
        assert depth.min() >= beam / 2 - 0.005
        assert shapely.contains_xy(region, pts[:, 0], pts[:, 1]).all()
        # the beam swept along the rings covers the section but for the cusps between rings
        swept = shapely.union_all([shapely.LineString([a, b]).buffer(beam / 2)
                                   for a, b in zip(cut.start[:, :2], cut.end[:, :2])])
        assert swept.intersection(region).area >= 0.9 * region.area
    # the beam is off on every move between rings and levels
    assert not moves.laser_on[moves.kind == 0].any()
    back = parse(emit(moves))
    assert np.allclose(back.end, moves.end, atol=1e-3)


def test_command_writes_the_job(tmp_path, capsys):
    out = tmp_path / "p.gcode"
    assert main(["slice", str(STL / "stepped_pyramid.stl"), "--step", "1", "--beam", "0.5",
                 "-o", str(out)]) == 0
    m = parse_file(str(out))
    assert sorted(set(np.round(m.end[m.laser_on, 2], 6).tolist())) == [0.5, 1.5, 2.5]
    assert "3 levels" in capsys.readouterr().out
    bad = tmp_path / "bad.stl"
    bad.write_text("solid nothing\nendsolid nothing\n")
    assert main(["slice", str(bad), "--step", "1", "--beam", "0.5", "-o", str(out)]) == 1
    assert "bad.stl" in capsys.readouterr().err


def test_open_meshes_are_refused(tmp_path):
    box = trimesh.creation.box(extents=(1, 1, 1))
    open_box = trimesh.Trimesh(box.vertices, box.faces[:-1], process=False)
    with pytest.raises(GeometryError, match="does not close into loops"):
        section_loops(open_box, 0.1)
    path = tmp_path / "open.stl"
    open_box.export(path)
    with pytest.raises(InputError, match="not closed"):
        read_mesh(path)
    with pytest.raises(InputError, match="no such file"):
        read_mesh(tmp_path / "missing.stl")
