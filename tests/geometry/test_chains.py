"""Chain detection against a brute-force reference on shuffled, flipped pieces."""

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from labkit.errors import GeometryError
from labkit.geometry import Path, join_chains


def _pieces(rng, shapes):
    pieces = []
    for pts, closed in shapes:
        if closed:
            pts = np.vstack([pts, pts[:1]])
        for a, b in zip(pts[:-1], pts[1:]):
            p = Path([a, b])
            pieces.append(p.reversed() if rng.random() < 0.5 else p)
    rng.shuffle(pieces)
    return pieces


def _brute_components(pieces, tol):
    """Reference: connected components of pieces linked by any pair of ends within tol (O(n²))."""
    n = len(pieces)
    comp = list(range(n))
    for i, j in itertools.combinations(range(n), 2):
        ends_i = (pieces[i].start, pieces[i].end)
        ends_j = (pieces[j].start, pieces[j].end)
        if any(np.hypot(*(a - b)) <= tol for a in ends_i for b in ends_j):
            ci, cj = comp[i], comp[j]
            comp = [ci if c == cj else c for c in comp]
    return sorted(sorted(round(pieces[k].length_mm, 9) for k in range(n) if comp[k] == c)
                  for c in set(comp))


@given(st.integers(0, 10_000), st.integers(1, 5))
@settings(max_examples=40, deadline=None)
def test_matches_brute_force(seed, n_shapes):
    rng = np.random.default_rng(seed)
    shapes = []
    for k in range(n_shapes):
        m = int(rng.integers(2, 6))
        pts = rng.uniform(0, 10, (m, 2)) + 100 * k        # shapes far apart: simple chains
        shapes.append((pts, bool(rng.random() < 0.5) and m >= 3))
    pieces = _pieces(rng, shapes)
    chains = join_chains(pieces, tol_mm=1e-6)
    assert len(chains) == n_shapes
    got = sorted(sorted(round(float(x), 9) for x in c.lengths_mm()) for c in chains)
    assert got == _brute_components(pieces, 1e-6)
    for c, (pts, closed) in zip(sorted(chains, key=lambda c: c.bounds()[0, 0]),
                                sorted(shapes, key=lambda s: s[0][:, 0].min())):
        assert c.closed == closed
        assert np.all(np.diff(c.vertices, axis=0).any(axis=1))       # joined end to end


def test_gaps_within_tolerance_are_closed():
    pieces = [Path([(0, 0), (10, 0)]), Path([(10.0004, 0), (10, 10)]), Path([(10, 10), (0.0003, 0)])]
    chains = join_chains(pieces, tol_mm=1e-3)
    assert len(chains) == 1 and chains[0].closed
    assert len(join_chains(pieces, tol_mm=1e-4)) == 2          # only the exact join at (10, 10)


def test_branch_point_ends_chains():
    star = [Path([(0, 0), (10, 0)]), Path([(0, 0), (0, 10)]), Path([(0, 0), (-10, 0)])]
    chains = join_chains(star)
    assert len(chains) == 3 and not any(c.closed for c in chains)


def test_layers_are_kept_apart():
    a = Path([(0, 0), (1, 0)], layer="red")
    b = Path([(1, 0), (2, 0)], layer="blue")
    assert len(join_chains([a, b])) == 2
    assert len(join_chains([a, b], by_layer=False)) == 1


def test_arcs_survive_reversal():
    arc = Path.arc((0, 0), 5, 0, np.pi)
    line = Path([(-5, 0), (5, 0)])
    [chain] = join_chains([arc.reversed(), line])
    assert chain.closed
    assert abs(chain.signed_area_mm2()) == pytest.approx(np.pi * 25 / 2)


def test_negative_tolerance():
    with pytest.raises(GeometryError, match="tol_mm must be >= 0"):
        join_chains([Path([(0, 0), (1, 0)])], tol_mm=-1)
