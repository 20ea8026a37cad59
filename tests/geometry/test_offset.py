"""Kerf offsets against exact offsets of simple shapes."""

import math

import numpy as np
import pytest

from labkit.errors import GeometryError
from labkit.geometry import Path, hausdorff, offset_paths
from labkit.geometry.arcfit import G1_TOL_RAD
from labkit.geometry.biarc import tangent_angles


@pytest.mark.parametrize("d", [0.1, 1.5, -2.0])
def test_circle_offsets_to_concentric_arcs(d):
    [p] = offset_paths([Path.circle((3, 4), 10)], d, tol_mm=0.01)
    assert p.is_arc.all() and p.n_segments == 2
    assert hausdorff(p, Path.circle((3, 4), 10 + d)) <= 0.01


def test_square_round_join_is_the_exact_rounded_square():
    w, h, d = 20.0, 10.0, 1.5
    [p] = offset_paths([Path.rectangle(0, 0, w, h)], d, tol_mm=0.005)
    assert p.signed_area_mm2() == pytest.approx(w * h + 2 * d * (w + h) + math.pi * d * d, abs=0.05)
    # exactly four sides and four corner arcs of radius d, meeting tangentially
    assert p.n_segments == 8 and int(p.is_arc.sum()) == 4
    np.testing.assert_allclose(p.radii_mm()[p.is_arc], d, atol=0.005)
    assert tangent_angles(p).max() <= G1_TOL_RAD + 1e-9
    # every point of the result lies on a side or on a corner circle of the exact rounded square
    pts = p.sample(0.001)
    on_side = np.minimum.reduce([
        np.where((pts[:, 0] >= 0) & (pts[:, 0] <= w), np.minimum(np.abs(pts[:, 1] + d), np.abs(pts[:, 1] - h - d)), np.inf),
        np.where((pts[:, 1] >= 0) & (pts[:, 1] <= h), np.minimum(np.abs(pts[:, 0] + d), np.abs(pts[:, 0] - w - d)), np.inf),
        *[np.abs(np.hypot(pts[:, 0] - cx, pts[:, 1] - cy) - d) for cx, cy in [(0, 0), (w, 0), (w, h), (0, h)]]])
    assert on_side.max() <= 0.005 + 1e-9


def test_square_miter_and_inward():
    [p] = offset_paths([Path.rectangle(0, 0, 20, 10)], 1.0, join="miter")
    assert hausdorff(p, Path.rectangle(-1, -1, 22, 12)) <= 1e-9
    [q] = offset_paths([Path.rectangle(0, 0, 20, 10)], -1.0)
    assert hausdorff(q, Path.rectangle(1, 1, 18, 8)) <= 1e-9


def test_hole_shrinks_when_part_grows():
    part = Path.rectangle(0, 0, 40, 40)
    hole = Path.circle((20, 20), 8)
    out = offset_paths([part, hole], 0.5)
    areas = sorted(p.signed_area_mm2() for p in out)
    assert areas[0] == pytest.approx(-math.pi * 7.5**2, rel=1e-3)      # hole ring runs clockwise
    assert areas[1] == pytest.approx(41 * 41 - (4 - math.pi) * 0.25, rel=1e-4)


def test_vanishing_region_gives_nothing():
    assert offset_paths([Path.circle((0, 0), 1)], -2) == []


def test_errors():
    with pytest.raises(GeometryError, match="closed paths"):
        offset_paths([Path([(0, 0), (1, 0)])], 1)
    with pytest.raises(GeometryError, match="join must be"):
        offset_paths([Path.circle((0, 0), 1)], 1, join="square")
    with pytest.raises(GeometryError, match="tol_mm must be > 0"):
        offset_paths([Path.circle((0, 0), 1)], 1, tol_mm=0)
    with pytest.raises(GeometryError, match="finite"):
        offset_paths([Path.circle((0, 0), 1)], float("nan"))


def test_nonzero_region_respects_ring_direction():
    from labkit.geometry.offset import region

    outer = Path.circle((0, 0), 10, fill_rule="nonzero")
    same = Path.circle((0, 0), 5)
    opposite = Path.circle((0, 0), 5, ccw=False)
    assert region([outer, same]).area == pytest.approx(math.pi * 100, rel=1e-3)
    assert region([outer, opposite]).area == pytest.approx(math.pi * 75, rel=1e-3)
    island = Path.circle((0, 0), 2)                 # back to +1 inside the hole
    assert region([outer, opposite, island]).area == pytest.approx(math.pi * 79, rel=1e-3)
    assert region([outer, same], fill_rule="evenodd").area == pytest.approx(math.pi * 75, rel=1e-3)


def test_a_ring_the_fit_closes_to_a_point_is_dropped():
    """A sliver of a region (a triangle with 0.04 mm sides, from the kerf offset of a generated
    drawing) that the 0.08 mm fit closes to a single point is not a ring to cut: it made a
    closed path of no length, which a two-layer job sampled into a 3-point polygon and shapely
    refused (a traceback). The square beside it stays, exactly."""
    import shapely

    from labkit.geometry.offset import region_paths

    sliver = [(101.93995737467502, 150.8478917789904), (101.97491551863833, 150.87026170981375),
              (101.94419432124297, 150.88050757271282)]
    square = shapely.Polygon([(0, 0), (10, 0), (10, 10), (0, 10)])
    out = region_paths(shapely.MultiPolygon([square, shapely.Polygon(sliver)]), 0.1, sample_tol_mm=0.02)
    assert len(out) == 1
    assert out[0].length_mm == 40.0 and out[0].closed
