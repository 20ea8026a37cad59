"""Kernels' Python paths (what a small drawing or image runs) give the compiled results:
the numpy twins of flattening and of the distance grid, the greedy fit's Python twin (and the
drawing's chains fitted in one call), the greedy order run on memoryviews (``views=True``),
and the gray and dither scans.
"""

import numpy as np
import pytest

from labkit import _jit
from labkit.geometry import Path, cubics_to_arcs, flatten_cubics, path_distance
from labkit.geometry import measure
from tests.geometry.test_measure import _brute
from tests.test_jit import _both


@pytest.mark.parametrize("seed", range(6))
def test_flattening_twin_gives_the_kernels_points(seed):
    rng = np.random.default_rng(seed)
    halved = 0
    for _ in range(20):
        ctrls = rng.normal(0, rng.uniform(0.1, 60), (int(rng.integers(1, 40)), 4, 2))
        ctrls[0, 1:] = ctrls[0, 0]                       # a curve of one point: one piece
        kwargs = dict(max_depth=int(rng.choice([24, 3, 0])), segment=bool(rng.integers(2)))
        if rng.random() < 0.3:
            kwargs["chord_fraction"] = 0.01
        else:
            kwargs["tol_mm"] = float(rng.choice([0.1, 0.01, 0.001]))
        (pts_py, n_py), (pts_nb, n_nb) = _both(flatten_cubics, ctrls, **kwargs)
        np.testing.assert_array_equal(n_py, n_nb)
        np.testing.assert_array_equal(pts_py, pts_nb)      # the same halving, bit for bit
        halved += len(pts_py) - len(ctrls)
    assert halved > 100


@pytest.mark.parametrize("seed", range(4))
def test_distance_twin_gives_the_kernels_distances(seed):
    """Queries near the paths (answered from the 3 × 3 cells) and far outside the grid (the
    ring search's leftovers), against lines and arcs of both directions."""
    rng = np.random.default_rng(seed)
    paths = [Path.arc(rng.uniform(-20, 20, 2), rng.uniform(0.5, 20), rng.uniform(-3, 3),
                      rng.uniform(-6, 6)) for _ in range(4)]
    paths.append(Path(np.cumsum(rng.normal(0, 2, (300, 2)), axis=0)))
    near = np.vstack([p.sample(0.01) for p in paths]) + rng.normal(0, 0.05, (1, 2))
    q = np.vstack([near, rng.uniform(-300, 300, (200, 2))])
    d_py, d_nb = _both(path_distance, paths, q)
    np.testing.assert_allclose(d_py, d_nb, rtol=0, atol=1e-12)
    np.testing.assert_allclose(d_py, _brute(paths, q), atol=2e-6)
    far = np.abs(q).max(axis=1) > 100
    assert far.sum() > 50 and np.all(d_py[far] > 10)       # the leftovers were measured too


def test_distance_twin_answers_most_queries_from_the_neighbouring_cells(monkeypatch):
    rng = np.random.default_rng(7)
    chain = Path(np.cumsum(rng.normal(0, 1, (500, 2)), axis=0))
    q = chain.sample(0.01)[::3] + rng.normal(0, 0.01, (1, 2))
    left = []
    real = measure._ring_search
    monkeypatch.setattr(measure, "_ring_search", lambda px, *a: left.append(len(px)) or real(px, *a))
    measure._grid_dist.__dict__.pop("_twin", None)         # rebind the twin's names
    try:
        with _jit.forced("python"):
            d = path_distance(chain, q)
    finally:
        measure._grid_dist.__dict__.pop("_twin", None)
    assert d.max() < 0.05
    assert sum(left) < 0.01 * len(q)


def _greedy_curves(seed, tol):
    """Dense samples of random cubic chains, as cubics_to_arcs hands them to the greedy fit."""
    from labkit.geometry.arcfit import sampling_share

    rng = np.random.default_rng(seed)
    curves = []
    for _ in range(12):
        ctrls = rng.normal(0, rng.uniform(1, 40), (int(rng.integers(1, 30)), 4, 2))
        ctrls[1:, 0] = ctrls[:-1, 3]                       # a chain
        if rng.random() < 0.3:                             # straight runs and sharp corners too
            ctrls[:, 1:3] = ctrls[:, [0, 3]] * [[2 / 3], [1 / 3]] + ctrls[:, [3, 0]] * [[1 / 3], [2 / 3]]
        flat, _ = sampling_share(tol)
        pts, _ = flatten_cubics(ctrls, flat)
        p = np.vstack([ctrls[:1, 0], pts])
        keep = np.concatenate(([True], np.any(np.diff(p, axis=0) != 0, axis=1)))
        curves.append(np.ascontiguousarray(p[keep]))
    return curves


@pytest.mark.parametrize("tol", [0.1, 0.01])
@pytest.mark.parametrize("seed", range(3))
def test_greedy_fit_twin_gives_the_kernels_own_code_bit_for_bit(tol, seed):
    """The greedy fit's Python twin (its tests written out, the samples as lists of floats) gives
    what the kernel's own code gives run as Python, bit for bit — runs, centres, sweeps, miss —
    and the compiled runs (centres and sweeps to rounding: numba's libm hypot, not Python's)."""
    from labkit.geometry._greedyfit import _fit_runs_python, fit_runs

    arcs = 0
    for p in _greedy_curves(seed, tol):
        for allow_arcs in (True, False):
            twin = _fit_runs_python(p, tol, allow_arcs)
            with _jit.forced("python"):
                _jit._python_depth[0] += 1                 # fit_runs' own code, not its twin
                try:
                    own = fit_runs.py_func(p, tol, allow_arcs)
                finally:
                    _jit._python_depth[0] -= 1
            with _jit.forced("compiled"):
                compiled = fit_runs(p, tol, allow_arcs)
            for k in range(3):
                np.testing.assert_array_equal(twin[k], own[k])
            assert twin[3] == own[3]
            np.testing.assert_array_equal(twin[0], compiled[0])
            np.testing.assert_allclose(twin[1], compiled[1], rtol=0, atol=1e-9)
            np.testing.assert_allclose(twin[2], compiled[2], rtol=0, atol=1e-12)
            assert twin[3] == pytest.approx(compiled[3], abs=1e-12)
            arcs += int(np.sum(twin[2] != 0))
    assert arcs > 50


@pytest.mark.parametrize("tol", [0.1, 0.01])
def test_greedy_fit_of_many_curves_in_one_call_gives_each_curves_runs(tol):
    """fit_runs_many (a drawing's curves in one call) gives fit_runs' runs of each curve, as
    Python and compiled; curves of fewer than two samples give none."""
    from labkit.geometry._greedyfit import fit_runs, fit_runs_many

    curves = _greedy_curves(7, tol) + [np.zeros((1, 2))]
    curves.insert(3, np.zeros((1, 2)))
    starts = np.concatenate([[0], np.cumsum([len(c) for c in curves])])
    p = np.ascontiguousarray(np.vstack(curves))
    for how in ("python", "compiled"):
        with _jit.forced(how):
            ends, centres, sweeps, counts, worst = fit_runs_many(p, starts, tol, True)
            k = 0
            for c, q in enumerate(curves):
                if len(q) < 2:
                    assert counts[c] == 0 and worst[c] == 0.0
                    continue
                e, cen, sw, w = fit_runs(q, tol, True)
                assert counts[c] == len(e)
                np.testing.assert_array_equal(ends[k:k + len(e)], e + starts[c])
                np.testing.assert_array_equal(centres[k:k + len(e)], cen)
                np.testing.assert_array_equal(sweeps[k:k + len(e)], sw)
                assert worst[c] == w
                k += len(e)
            assert k == len(ends)


@pytest.mark.parametrize("tol", [0.1, 0.01])
def test_chains_fitted_together_are_the_chains_fitted_one_by_one(tol):
    """cubic_chains_to_arcs (a drawing's chains in one flattening and one fitting call) gives
    the Paths cubics_to_arcs gives chain by chain, in both modes."""
    from labkit.geometry import cubic_chains_to_arcs

    rng = np.random.default_rng(3)
    chains = []
    for _ in range(15):
        c = rng.normal(0, rng.uniform(1, 30), (int(rng.integers(1, 12)), 4, 2))
        c[1:, 0] = c[:-1, 3]
        chains.append(c)
    chains.append(np.array([[[1.0, 1.0], [1.0, 1.0], [1.0, 1.0], [2.0, 1.0]]]))   # repeated points
    for how in ("python", "compiled"):
        with _jit.forced(how):
            together = cubic_chains_to_arcs(chains, tol, layer="L")
            alone = [cubics_to_arcs(c, tol, layer="L") for c in chains]
        for a, b in zip(together, alone):
            for name in ("vertices", "centres", "sweeps"):
                np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
            assert a.deviation_mm == b.deviation_mm and a.layer == "L"
    with pytest.raises(Exception, match="all points coincide"):
        cubic_chains_to_arcs([np.zeros((1, 4, 2))], tol)


def test_greedy_order_on_memoryviews_gives_the_compiled_order():
    """The greedy grid search (``views=True``) as Python: the compiled order, reversals and
    travel, on float segments with parents (containment) and on a raster's integer runs."""
    from labkit.geometry import order_segments
    from labkit.raster.pathing import connect, zigzag_segments

    rng = np.random.default_rng(5)
    starts = rng.uniform(0, 200, (400, 2))
    ends = starts + rng.normal(0, 5, (400, 2))
    a, b = _both(order_segments, starts, ends, improve=False)
    np.testing.assert_array_equal(a.order, b.order)
    np.testing.assert_array_equal(a.reversed, b.reversed)
    assert a.travel_mm == b.travel_mm
    mask = rng.random((120, 90)) < 0.3
    segs = zigzag_segments(mask)
    a, b = _both(connect, segs)
    assert len(segs) > 1000
    np.testing.assert_array_equal(a.order, b.order)
    np.testing.assert_array_equal(a.flipped, b.flipped)
    assert a.examined == b.examined


def test_two_opt_as_python_gives_the_compiled_tour():
    """The 2-opt improvement (``_two_opt``, run as Python up to its python_below of 150,000
    elements) as Python: the compiled tour, reversals, travel and move count, on open segments
    and closed loops with parents (containment) and on open segments alone, 2,000 items."""
    from labkit.geometry import order_segments

    rng = np.random.default_rng(6)
    starts = rng.uniform(0, 300, (1500, 2))
    ends = starts + rng.normal(0, 4, (1500, 2))
    loops = [c + rng.uniform(1, 6) * np.c_[np.cos(a), np.sin(a)]
             for c, a in zip(rng.uniform(0, 300, (500, 2)), [np.linspace(0, 6, 7)] * 500)]
    parent = np.full(2000, -1)
    parent[rng.choice(1500, 300, replace=False)] = 1500 + rng.integers(0, 500, 300)
    for kwargs in ({"closed_points": loops, "parent": parent}, {}):
        a, b = _both(order_segments, starts, ends, improve=True, **kwargs)
        np.testing.assert_array_equal(a.order, b.order)
        np.testing.assert_array_equal(a.reversed, b.reversed)
        assert a.travel_mm == b.travel_mm
        greedy = order_segments(starts, ends, improve=False, **kwargs)
        assert a.travel_mm < greedy.travel_mm          # the 2-opt did move items


@pytest.mark.parametrize("mode", ["gray", "dither"])
def test_gray_and_dither_kernels_as_python_give_the_compiled_moves(mode):
    """The scan-line and error-diffusion kernels run as Python below their python_below (a
    small photo no longer loads numba): the same moves as compiled, on a real photograph."""
    from skimage import data

    from labkit.raster.engrave import RasterSettings, image_to_job
    from labkit.raster.io import RasterImage

    photo = data.camera()[::8, ::8]                      # scikit-image's camera, 64 × 64
    img = RasterImage(photo, None, "camera", 1.0)
    settings = RasterSettings(mode=mode, beam_mm=0.1, width_mm=6.4)
    a, b = _both(image_to_job, img, settings)
    assert len(a.moves) > 1000
    for name in a.moves.column_names():
        x, y = np.asarray(getattr(a.moves, name)), np.asarray(getattr(b.moves, name))
        assert np.array_equal(x, y, equal_nan=x.dtype.kind == "f"), name


def test_views_hand_contiguous_arrays_to_python_as_memoryviews():
    """``views=True``: C-contiguous arrays arrive as memoryviews (Python floats and ints on
    indexing, writes land in the caller's array); a strided one stays an array; compiled,
    the same results."""
    @_jit.jit(views=True, cache=False)
    def scale_rows(p, out):
        for i in range(p.shape[0]):
            out[i] = 2.0 * p[i, 0] + p[i, 1]
        return out

    p = np.arange(12.0).reshape(6, 2)
    converted = [_jit._as_view(a) for a in (p, np.zeros(6), p[::2], np.zeros(0))]
    assert [type(a).__name__ for a in converted] == ["memoryview", "memoryview", "ndarray", "ndarray"]
    assert type(converted[0][1, 1]) is float
    out_py, out_nb = np.zeros(6), np.zeros(6)
    with _jit.forced("python"):
        scale_rows(p, out_py)
    with _jit.forced("compiled"):
        scale_rows(p, out_nb)
    np.testing.assert_array_equal(out_py, 2.0 * p[:, 0] + p[:, 1])    # written through the view
    np.testing.assert_array_equal(out_py, out_nb)


def test_distance_twin_in_chunks_gives_the_same_distances(monkeypatch):
    """Many segments in few cells (a dense detail far from the rest): the twin measures its
    pairs in chunks, with the distances it gives in one go and the compiled kernel's."""
    rng = np.random.default_rng(3)
    dense = Path(np.cumsum(rng.normal(0, 0.01, (3000, 2)), axis=0))
    paths = [dense, Path([(1000, 1000), (1001, 1000)])]
    q = np.vstack([dense.sample(0.001) + 0.003, rng.uniform(-1, 1, (2000, 2))])
    got = {}
    for pairs in (1000, 1 << 20):
        monkeypatch.setattr(measure, "_PAIRS_AT_ONCE", pairs)
        measure._grid_dist.__dict__.pop("_twin", None)     # the twin reads the module's names
        with _jit.forced("python"):
            got[pairs] = path_distance(paths, q)
    measure._grid_dist.__dict__.pop("_twin", None)
    with _jit.forced("compiled"):
        compiled = path_distance(paths, q)
    np.testing.assert_array_equal(got[1000], got[1 << 20])
    np.testing.assert_allclose(got[1000], compiled, rtol=0, atol=1e-12)


def test_flattening_twin_in_chunks_gives_the_same_points(monkeypatch):
    from labkit.geometry import bezier

    ctrls = np.random.default_rng(4).normal(0, 20, (100, 4, 2))
    monkeypatch.setattr(bezier, "_CURVES_AT_ONCE", 7)
    bezier._flatten_kernel.__dict__.pop("_twin", None)     # the twin reads the module's names
    try:
        (pts_py, n_py), (pts_nb, n_nb) = _both(flatten_cubics, ctrls, 0.01)
    finally:
        bezier._flatten_kernel.__dict__.pop("_twin", None)
    np.testing.assert_array_equal(n_py, n_nb)
    np.testing.assert_array_equal(pts_py, pts_nb)
