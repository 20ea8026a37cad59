"""Ordering against brute force (small cases) and a naive greedy reference."""

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from labkit.errors import GeometryError
from labkit.geometry import Path, order_paths, order_segments, travel_length


def _naive_greedy(s, e, origin=(0, 0)):
    """O(n²) nearest neighbour over both ends: the reference for the grid search."""
    left = set(range(len(s)))
    pos = np.asarray(origin, float)
    total = 0.0
    while left:
        best = min([(math.dist(pos, s[i]), i, False) for i in left]
                   + [(math.dist(pos, e[i]), i, True) for i in left])
        total += best[0]
        left.remove(best[1])
        pos = s[best[1]] if best[2] else e[best[1]]
    return total


def _optimum(s, e, origin=(0, 0)):
    n = len(s)
    best = np.inf
    for perm in itertools.permutations(range(n)):
        for flips in itertools.product([False, True], repeat=n):
            st_ = np.array([e[i] if f else s[i] for i, f in zip(perm, flips)])
            en_ = np.array([s[i] if f else e[i] for i, f in zip(perm, flips)])
            best = min(best, travel_length(st_, en_, origin))
    return best


@given(st.integers(0, 100_000), st.integers(1, 60))
@settings(max_examples=40, deadline=None)
def test_grid_greedy_equals_naive_greedy(seed, n):
    rng = np.random.default_rng(seed)
    s = rng.uniform(0, 100, (n, 2))
    e = s + rng.normal(0, 5, (n, 2))
    o = order_segments(s, e, improve=False)
    assert o.greedy_travel_mm == pytest.approx(_naive_greedy(s, e), rel=1e-9)
    assert sorted(o.order.tolist()) == list(range(n))


@given(st.integers(0, 100_000), st.integers(2, 5))
@settings(max_examples=25, deadline=None)
def test_against_brute_force_optimum(seed, n):
    rng = np.random.default_rng(seed)
    s = rng.uniform(0, 10, (n, 2))
    e = rng.uniform(0, 10, (n, 2))
    o = order_segments(s, e)
    st_ = np.where(o.reversed[:, None], e[o.order], s[o.order])
    en_ = np.where(o.reversed[:, None], s[o.order], e[o.order])
    assert o.travel_mm == pytest.approx(travel_length(st_, en_), rel=1e-9)
    opt = _optimum(s, e)
    assert opt - 1e-9 <= o.travel_mm <= o.greedy_travel_mm + 1e-9
    # the result is 2-opt optimal: no block reversal (checked exhaustively) shortens it
    for i in range(n):
        for j in range(i, n):
            idx = np.array(list(range(i)) + list(range(j, i - 1, -1)) + list(range(j + 1, n)))
            rev = o.reversed.copy()
            rev[i:j + 1] = ~rev[i:j + 1]
            rev = rev[idx]
            order = o.order[idx]
            st2 = np.where(rev[:, None], e[order], s[order])
            en2 = np.where(rev[:, None], s[order], e[order])
            assert travel_length(st2, en2) >= o.travel_mm - 1e-9


def test_two_opt_shortens_random_segments():
    rng = np.random.default_rng(11)
    s = rng.uniform(0, 100, (3000, 2))
    e = s + rng.normal(0, 1, (3000, 2))
    o = order_segments(s, e)
    assert o.moves > 0
    assert o.travel_mm < 0.9 * o.greedy_travel_mm


def test_closed_items_enter_at_nearest_vertex():
    sq = Path.rectangle(10, 0, 5, 5)
    [p] = order_paths([sq], origin=(16, 6))
    np.testing.assert_allclose(p.start, [15, 5])
    assert p.closed and p.length_mm == pytest.approx(20)


def test_holes_before_parts_even_when_far():
    part = Path.rectangle(0, 0, 100, 100)
    holes = [Path.circle((80, 80), 3), Path.circle((20, 80), 3)]
    engraving = Path([(40, 40), (60, 60)])
    other = Path.rectangle(200, 0, 10, 10)
    out = order_paths([part, other, *holes, engraving], origin=(0, 0))
    idx = {id(p.vertices.base if p.vertices.base is not None else p.vertices): k for k, p in enumerate(out)}
    pos_part = next(k for k, p in enumerate(out) if p.length_mm == pytest.approx(400))
    pos_inside = [k for k, p in enumerate(out) if p.length_mm < 40]
    assert all(k < pos_part for k in pos_inside)
    assert len(out) == 5 and idx


def test_precedence_cycle_and_bad_args():
    with pytest.raises(GeometryError, match="cycle"):
        order_segments([[0, 0], [1, 1]], [[0, 1], [1, 2]], parent=[1, 0])
    with pytest.raises(GeometryError, match="parent must hold"):
        order_segments([[0, 0]], [[0, 1]], parent=[0])
    with pytest.raises(GeometryError, match="differ in shape"):
        order_segments([[0, 0]], [[0, 1], [1, 1]])
    with pytest.raises(GeometryError, match="neighbours must be >= 1"):
        order_segments([[0, 0]], [[0, 1]], neighbours=0)


def test_one_ordering_type_for_chains_and_raster_runs():
    # issue 28 §4: the chain ordering and the raster connection are the same record
    import labkit.raster as raster
    from labkit.geometry.order import Ordering

    m = np.zeros((3, 5), bool)
    m[0, 3:] = m[1, :3] = m[2, 3:] = True
    c = raster.connect(raster.zigzag_segments(m, axis="rows"))
    assert type(c) is Ordering and raster.Connection is Ordering
    assert c.flipped is c.reversed and c.entry.tolist() == [-1, -1, -1] and c.method == "indexed"
    o = order_segments([[10, 0], [1, 0], [5, 0]], [[11, 0], [2, 0], [4, 0]])
    assert o.method == "grid" and o.examined >= 3        # at least one distance a step
