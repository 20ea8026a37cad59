"""Hatch fill against shapely's line–polygon intersections (even-odd and non-zero)."""

import math

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from labkit.errors import GeometryError
from labkit.geometry import Path, hatch, hatch_lines


def _reference_length(polys_region, spacing, angle, lo, hi):
    """Total length of scan lines clipped by shapely (independent of our crossing logic)."""
    c, s = math.cos(angle), math.sin(angle)
    total = 0.0
    rot = shapely.affinity.rotate(polys_region, -angle, origin=(0, 0), use_radians=True)
    y0 = rot.bounds[1] + spacing / 2
    y = y0
    while y < rot.bounds[3]:
        line = shapely.LineString([(rot.bounds[0] - 1, y), (rot.bounds[2] + 1, y)])
        total += rot.intersection(line).length
        y += spacing
    return total


@given(st.integers(0, 10_000), st.floats(0, math.pi), st.sampled_from(["evenodd", "nonzero"]))
@settings(max_examples=30, deadline=None)
def test_total_length_matches_shapely(seed, angle, rule):
    rng = np.random.default_rng(seed)
    rings = []
    for _ in range(3):
        c = rng.uniform(0, 30, 2)
        r = rng.uniform(3, 12)
        t = np.sort(rng.uniform(0, 2 * np.pi, 7))
        ring = c + (r * rng.uniform(0.6, 1.0, 7))[:, None] * np.c_[np.cos(t), np.sin(t)]
        rings.append(ring)
    polys = [shapely.Polygon(r) for r in rings]
    if rule == "nonzero":           # all rings CCW: non-zero = union
        region = shapely.union_all(polys)
    else:
        region = polys[0]
        for p in polys[1:]:
            region = shapely.symmetric_difference(region, p)
    seg = hatch_lines(rings, 0.7, angle_rad=angle, fill_rule=rule)
    got = float(np.hypot(*(seg[:, 1] - seg[:, 0]).T).sum())
    assert got == pytest.approx(_reference_length(region, 0.7, angle, None, None), rel=1e-6, abs=1e-6)


def test_nonzero_and_evenodd_differ_on_nested_same_direction():
    outer = Path.rectangle(0, 0, 10, 10)
    inner = Path.rectangle(3, 3, 4, 4)            # same direction (CCW)
    ev = sum(p.length_mm for p in hatch([outer, inner], 1.0, fill_rule="evenodd"))
    nz = sum(p.length_mm for p in hatch([outer, inner], 1.0, fill_rule="nonzero"))
    assert ev == pytest.approx(100 - 16)
    assert nz == pytest.approx(100)
    nz_hole = sum(p.length_mm for p in hatch([outer, inner.reversed()], 1.0, fill_rule="nonzero"))
    assert nz_hole == pytest.approx(84)


def test_bidirectional_alternates():
    seg = hatch_lines([np.array([[0, 0], [10, 0], [10, 3], [0, 3]])], 1.0)
    dx = seg[:, 1, 0] - seg[:, 0, 0]
    assert (np.sign(dx) == [1, -1, 1]).all()
    one_way = hatch_lines([np.array([[0, 0], [10, 0], [10, 3], [0, 3]])], 1.0, bidirectional=False)
    assert (one_way[:, 1, 0] > one_way[:, 0, 0]).all()


def test_circle_hatch_length():
    lines = hatch([Path.circle((0, 0), 10)], 0.1, angle_rad=0.3, tol_mm=1e-4)
    assert sum(p.length_mm for p in lines) == pytest.approx(math.pi * 100 / 0.1, rel=2e-3)


def test_errors():
    with pytest.raises(GeometryError, match="spacing_mm must be > 0"):
        hatch_lines([np.zeros((3, 2))], 0)
    with pytest.raises(GeometryError, match="fill_rule"):
        hatch_lines([np.zeros((3, 2))], 1, fill_rule="winding")
    assert hatch([Path([(0, 0), (1, 1)])], 1.0) == []
