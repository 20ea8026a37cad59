"""Hatch fill against shapely's line–polygon intersections (even-odd and non-zero)."""

import math

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from labkit.errors import GeometryError
from labkit.geometry import Path, hatch, hatch_lines


def _reference_length(rings, spacing, angle, rule):
    """Total length of scan lines inside the rings, from shapely's line ∩ polygon of each ring
    alone (independent of our crossing logic, and free of polygon–polygon overlay, which GEOS
    refuses on nearly touching rings): along each line, the stretches covered by an odd
    number of rings (even-odd) or by any (non-zero, every ring counter-clockwise)."""
    polys = [shapely.affinity.rotate(shapely.Polygon(r), -angle, origin=(0, 0), use_radians=True)
             for r in rings]
    lo = min(p.bounds[1] for p in polys)
    hi = max(p.bounds[3] for p in polys)
    x0 = min(p.bounds[0] for p in polys) - 1
    x1 = max(p.bounds[2] for p in polys) + 1
    total = 0.0
    y = lo + spacing / 2
    while y < hi:
        line = shapely.LineString([(x0, y), (x1, y)])
        events = []
        for p in polys:
            cut = p.intersection(line)
            for piece in getattr(cut, "geoms", [cut]):
                if piece.geom_type == "LineString" and piece.length > 0:
                    xs = sorted(c[0] for c in piece.coords)
                    events += [(xs[0], 1), (xs[-1], -1)]
        events.sort()
        depth, last = 0, None
        for x, step in events:
            inside = depth % 2 == 1 if rule == "evenodd" else depth > 0
            if inside and last is not None:
                total += x - last
            depth += step
            last = x
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
        # angles around c with gaps below π, so the ring is star-shaped about c: simple and
        # counter-clockwise (sorted random angles can leave c outside and cross themselves —
        # seed 300 did — where a polygon reference means nothing)
        t = (np.arange(7) + rng.uniform(0, 0.8, 7)) * (2 * np.pi / 7)
        ring = c + (r * rng.uniform(0.6, 1.0, 7))[:, None] * np.c_[np.cos(t), np.sin(t)]
        rings.append(ring)
    seg = hatch_lines(rings, 0.7, angle_rad=angle, fill_rule=rule)
    got = float(np.hypot(*(seg[:, 1] - seg[:, 0]).T).sum())
    assert got == pytest.approx(_reference_length(rings, 0.7, angle, rule), rel=1e-6, abs=1e-6)


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
