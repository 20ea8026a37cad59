"""Biarcs: the primitive against closed forms, the fit against dense svgelements samples,
tangent continuity at every joint, degenerate cubics, and block counts against the greedy fit."""

import math

import numpy as np
import pytest
import svgelements as se
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from labkit.errors import GeometryError
from labkit.geometry import Path, cubics_to_arcs, fit_arcs, flatten_cubic, hausdorff
from labkit.geometry.arcfit import G1_TOL_RAD
from labkit.geometry.biarc import LINE_SAGITTA_MM, MAX_JOINT_REACH, arc_from_tangent, biarc, tangent_angles

coord = st.floats(-60, 60)
point = st.tuples(coord, coord)


def _dense(ctrls, n=4001):
    out = []
    for c in ctrls:
        # svgelements evaluates the curve itself (npoint: the same points as point(t) one by one)
        out.append(se.CubicBezier(*[complex(*p) for p in c]).npoint(np.linspace(0, 1, n)))
    return np.vstack(out)


def _kinks_ok(p):
    return p.n_segments < 2 or tangent_angles(p).max() <= G1_TOL_RAD + 1e-9


def _sharpest_turn(ctrl, stretch_mm, n=4001):
    """Largest change of direction (rad) of the cubics (n, 4, 2) within any stretch of arc
    length ``stretch_mm`` — large for hairpins and cusps at that scale, whatever the speed."""
    pts = np.vstack([_dense([c], n) for c in np.asarray(ctrl).reshape(-1, 4, 2)])
    seg = np.diff(pts, axis=0)
    length = np.hypot(*seg.T)
    keep = length > 1e-12
    seg, length = seg[keep], length[keep]
    if len(seg) < 2:
        return 0.0
    heading = np.unwrap(np.arctan2(seg[:, 1], seg[:, 0]))
    s = np.concatenate([[0.0], np.cumsum(length)])[:-1]
    j = np.searchsorted(s, s + stretch_mm, side="right") - 1
    # max |heading[k] - heading[i]| for i <= k <= j(i), by brute force over the window ends
    worst = 0.0
    for i in range(0, len(seg), max(1, len(seg) // 800)):
        window = heading[i:j[i] + 1]
        worst = max(worst, float(window.max() - window.min()))
    return worst


def test_quarter_circle_tangents_give_the_circle():
    p = biarc((10, 0), (0, 1), (0, 10), (-1, 0))
    np.testing.assert_allclose(p.centres, 0, atol=1e-12)
    np.testing.assert_allclose(p.radii_mm(), 10)
    assert p.sweeps.sum() == pytest.approx(math.pi / 2)


@given(point, point, st.floats(-3.1, 3.1), st.floats(-3.1, 3.1))
@settings(max_examples=200, deadline=None)
def test_biarc_meets_ends_and_tangents_with_a_common_joint_tangent(p0, p1, a0, a1):
    p0, p1 = np.array(p0), np.array(p1)
    assume(np.hypot(*(p1 - p0)) > 1e-3)
    t0, t1 = np.array([math.cos(a0), math.sin(a0)]), np.array([math.cos(a1), math.sin(a1)])
    try:
        p = biarc(p0, t0, p1, t1)
    except GeometryError:
        assume(False)
    np.testing.assert_allclose(p.start, p0)
    np.testing.assert_allclose(p.end, p1)
    # exactly G1, unless an arc bowing at most LINE_SAGITTA_MM was written as its chord:
    # that leaves half its sweep, at most 4·LINE_SAGITTA_MM / chord
    lines = p.lengths_mm()[~p.is_arc]
    bound = 1e-6 + (4 * LINE_SAGITTA_MM / lines.min() if len(lines) else 0.0)
    # no detours: a biarc is never much longer than the way round its tangent lines
    assert p.lengths_mm().sum() <= 2 * math.pi * np.hypot(*(p1 - p0)) * MAX_JOINT_REACH
    assert tangent_angles(p).max(initial=0) <= bound
    # the start and end tangents are the given ones (arcs: perpendicular to the radius)
    for i, t, v in ((0, t0, p.vertices[0]), (-1, t1, p.vertices[-1])):
        if p.sweeps[i] == 0:
            continue                      # a flat arc written as its chord (see above)
        r = v - p.centres[i]
        tan = np.sign(p.sweeps[i]) * np.array([-r[1], r[0]]) / np.hypot(*r)
        assert np.dot(tan, t) == pytest.approx(1.0, abs=1e-6)


def test_arc_from_tangent_closed_form():
    c, s = arc_from_tangent((0, 0), (1, 0), (2, 2))       # quarter circle about (0, 2)
    np.testing.assert_allclose(c, [0, 2], atol=1e-12)
    assert s == pytest.approx(math.pi / 2)
    c, s = arc_from_tangent((0, 0), (1, 0), (5, 0))
    assert s == 0 and np.isnan(c).all()


cubics = st.lists(point, min_size=4, max_size=4).map(np.array)


@given(cubics, st.sampled_from([0.1, 0.01]))
@settings(max_examples=60, deadline=None)
def test_random_cubic_within_tolerance_and_g1(ctrl, tol):
    assume(np.ptp(ctrl, axis=0).max() > 1e-2)
    p = cubics_to_arcs(ctrl[None], tol, method="biarc")
    np.testing.assert_allclose(p.start, ctrl[0])
    np.testing.assert_allclose(p.end, ctrl[-1])
    assert p.deviation_mm <= tol
    assert hausdorff(p, Path.polyline(_dense([ctrl]))) <= tol
    # a cusp (the speed vanishing inside the cubic) is the only place a kink may stay
    from labkit.geometry._biarcfit import _inflections, _piece_tangent
    roots = np.empty(2)
    cusps = [t for t in roots[:_inflections(ctrl, roots)]
             if np.dot(_piece_tangent(ctrl, 0, t, True), _piece_tangent(ctrl, t, 1, False)) < 0.99]
    # G1 is owed only where the curve bends gently at the tolerance's scale: a hairpin or a
    # spike turning more than 60° within 2·tol may come out as a corner and lie within tol.
    if not cusps and _sharpest_turn(ctrl, 2 * tol) < math.radians(60):
        assert _kinks_ok(p)


@given(st.lists(point, min_size=3, max_size=6), st.sampled_from([0.1, 0.01]))
@settings(max_examples=30, deadline=None)
def test_g1_chain_of_cubics_stays_g1(pts, tol):
    """A smooth chain (handles mirrored at every joint, as SVG's S command draws it)."""
    pts = np.array(pts)
    d = np.diff(pts, axis=0)
    assume(np.min(np.hypot(*d.T)) > 1.0)
    # chains that (nearly) double back on themselves are left out (known gap: the fit can leave
    # a zero-length segment there, or, as in test_known_gap_near_reversal, a short straight
    # piece meeting an arc 1.02° off tangent)
    cos = np.sum(d[:-1] * d[1:], axis=1) / (np.hypot(*d[:-1].T) * np.hypot(*d[1:].T))
    assume(np.all(cos > -0.8))
    ctrl = []
    handle = (pts[1] - pts[0]) / 3
    for a, b in zip(pts[:-1], pts[1:]):
        out_h = a + handle
        in_h = b - (b - a) / 3
        ctrl.append([a, out_h, in_h, b])
        handle = b - in_h                                 # mirrored: the joint is smooth
    ctrl = np.array(ctrl)
    p = cubics_to_arcs(ctrl, tol, method="biarc")
    assert hausdorff(p, Path.polyline(_dense(ctrl, 1001))) <= tol
    from labkit.geometry._biarcfit import _inflections, _piece_tangent
    roots = np.empty(2)
    assume(all(np.dot(_piece_tangent(c, 0, t, True), _piece_tangent(c, t, 1, False)) >= 0.99
               for c in ctrl for t in roots[:_inflections(c, roots)]))
    assume(_sharpest_turn(ctrl, 2 * tol) < math.radians(60))   # see test_random_cubic_within_tolerance_and_g1
    assert _kinks_ok(p)


def test_straight_cubic_is_one_line():
    p = cubics_to_arcs([[[0, 0], [1, 1], [2, 2], [5, 5]]], 0.01, method="biarc")
    assert p.n_segments == 1 and not p.is_arc.any()


def test_zero_length_handles_and_cusp():
    # coincident first control point: the tangent comes from the next one
    p = cubics_to_arcs([[[0, 0], [0, 0], [10, 10], [20, 0]]], 0.01, method="biarc")
    assert hausdorff(p, Path.polyline(_dense([[[0, 0], [0, 0], [10, 10], [20, 0]]]))) <= 0.01
    assert _kinks_ok(p)
    # a cusp: the curve stops and turns back; the kink there is real, the rest stays smooth
    cusp = np.array([[0, 0], [10, 10], [0, 10], [10, 0]], float)
    q = cubics_to_arcs(cusp[None], 0.01, method="biarc")
    assert hausdorff(q, Path.polyline(_dense([cusp]))) <= 0.01
    assert np.sum(tangent_angles(q) > G1_TOL_RAD + 1e-9) <= 1
    # a straight cubic that runs past its end and back
    back = np.array([[0, 0], [20, 0], [20, 0], [10, 0]], float)
    b = cubics_to_arcs(back[None], 0.01, method="biarc")
    assert hausdorff(b, Path.polyline(_dense([back]))) <= 0.01


def test_circle_cubics_come_back_as_arcs_of_that_circle():
    k = 4 / 3 * math.tan(math.pi / 8)
    quarters = []
    for i in range(4):
        a0, a1 = i * math.pi / 2, (i + 1) * math.pi / 2
        s, e = np.array([math.cos(a0), math.sin(a0)]), np.array([math.cos(a1), math.sin(a1)])
        quarters.append([s * 30, (s + k * np.array([-s[1], s[0]])) * 30, (e - k * np.array([-e[1], e[0]])) * 30,
                         e * 30])
    p = cubics_to_arcs(np.array(quarters), 0.01, method="biarc")
    assert p.n_segments == 2 and p.is_arc.all()
    # the four cubics stray 0.027 % of r (0.0081 mm) from the true circle
    assert hausdorff(p, Path.circle((0, 0), 30)) <= 0.01 + 0.0082


def test_blocks_against_lines_and_the_greedy_fit():
    """Both fits use far fewer blocks than lines; tangent continuity costs the biarc fit
    blocks against the greedy fit (whose joints may kink within the tolerance), but not
    more than half as many again. Counts on 20 seeded random cubics, measured."""
    rng = np.random.default_rng(7)
    ctrls = [rng.uniform(0, 50, (1, 4, 2)) for _ in range(20)]
    lines = sum(len(flatten_cubic(c[0], tol_mm=0.01)) - 1 for c in ctrls)
    counts = {}
    for tol in (0.01, 0.001):
        bi = sum(cubics_to_arcs(c, tol, method="biarc").n_segments for c in ctrls)
        greedy = sum(cubics_to_arcs(c, tol, method="greedy").n_segments for c in ctrls)
        counts[tol] = (bi, greedy)
        assert greedy <= bi <= 1.5 * greedy
    assert counts[0.01][0] < 0.3 * lines and counts[0.01][1] < 0.3 * lines


def test_polyline_circle_and_polygon():
    t = np.linspace(0, np.pi, 200)
    p = fit_arcs(np.c_[10 * np.cos(t), 10 * np.sin(t)], 0.001, method="biarc")
    assert p.n_segments == 1 and p.radii_mm()[0] == pytest.approx(10, abs=1e-3)
    hexagon = np.array([[math.cos(a), math.sin(a)] for a in np.linspace(0, 2 * math.pi, 7)]) * 10
    h = fit_arcs(hexagon, 0.1, closed=True, method="biarc")
    assert h.n_segments == 6 and not h.is_arc.any()


def test_a_polyline_is_measured_on_its_own_segments():
    """The biarc fit of a polyline measures against the polyline itself (its segments as
    straight cubics, which trace each segment at uniform speed), not against the curved
    chain that carries its tangents: a zig-zag whose tangent chain bulges is still fitted
    within tolerance of the zig-zag, checked by an independent distance measure."""
    from labkit.geometry import _biarcfit
    from labkit.geometry.arcfit import _straight_cubics

    rng = np.random.default_rng(7)
    p = np.cumsum(rng.uniform(-5, 5, (40, 2)), axis=0)
    cubics = _straight_cubics(p)
    t = rng.uniform(0, 1, (len(p) - 1, 1))
    u = 1 - t
    on_cubic = (u ** 3 * cubics[:, 0] + 3 * u * u * t * cubics[:, 1] + 3 * u * t * t * cubics[:, 2]
                + t ** 3 * cubics[:, 3])
    np.testing.assert_allclose(on_cubic, p[:-1] + t * (p[1:] - p[:-1]), atol=1e-12)
    fit = fit_arcs(p, 0.05, method="biarc")
    polyline = Path(p)
    assert hausdorff(fit, polyline) <= 0.05 + 1e-9
    assert fit.deviation_mm <= 0.05
    # the kernels take the curve and the tangent chain as two arrays, never a mode flag
    import inspect
    for name in ("fit_cubic_chain", "_search", "_chain_fit", "_sample_chain"):
        params = inspect.signature(getattr(_biarcfit, name).py_func).parameters
        assert "linear" not in params and "shape" in params, name


def test_errors():
    with pytest.raises(GeometryError, match="end points coincide"):
        biarc((1, 1), (1, 0), (1, 1), (0, 1))
    with pytest.raises(GeometryError, match="tangents t0 and t1 must be non-zero"):
        biarc((0, 0), (0, 0), (1, 1), (0, 1))
    with pytest.raises(GeometryError, match="no biarc joins"):
        biarc((0, 0), (1, 0), (-5, 0), (1, 0))
    with pytest.raises(GeometryError, match="tangent must be a non-zero"):
        arc_from_tangent((0, 0), (0, 0), (1, 0))
    with pytest.raises(GeometryError, match="method must be one of"):
        cubics_to_arcs(np.zeros((1, 4, 2)) + [[0, 0], [1, 1], [2, 1], [3, 0]], 0.1, method="nurbs")


@pytest.mark.xfail(strict=True, reason="known gap: near a reversal the biarc fit ends an arc in a "
                   "0.33 mm straight piece 1.02° off tangent (G1 tolerance 1°); found by CI's "
                   "hypothesis run 2026-11-24 — strict, so a fix shows up here")
def test_known_gap_near_reversal():
    pts = np.array([(0.0, 35.0625), (0.0, 0.1875), (1.9375, 0.0), (-3.71875, 16.3359375),
                    (23.6875, -4.0), (0.0, -2.0)])
    ctrl, handle = [], (pts[1] - pts[0]) / 3
    for a, b in zip(pts[:-1], pts[1:]):
        in_h = b - (b - a) / 3
        ctrl.append([a, a + handle, in_h, b])
        handle = b - in_h
    p = cubics_to_arcs(np.array(ctrl), 0.01, method="biarc")
    assert _kinks_ok(p)


def test_readable_biarc_equals_the_compiled_kernel():
    """labkit.geometry.biarc (plain numpy, for chapter 03) and the fit's compiled kernel
    (geometry._biarcfit._biarc) build the same biarc — or both refuse — on 2,000 random ends."""
    from labkit.errors import GeometryError
    from labkit.geometry._biarcfit import _biarc, _emit

    rng = np.random.default_rng(7)
    built = refused = 0
    for _ in range(2000):
        p0, p1 = rng.uniform(-10, 10, (2, 2))
        a0, a1 = rng.uniform(-np.pi, np.pi, 2)
        t0, t1 = np.array([np.cos(a0), np.sin(a0)]), np.array([np.cos(a1), np.sin(a1)])
        out = np.empty(8)
        ok = _biarc(*p0, *t0, *p1, *t1, out)
        try:
            mine = biarc(p0, t0, p1, t1)
        except GeometryError:
            assert not ok
            refused += 1
            continue
        assert ok
        verts, centres, sweeps = np.empty((3, 2)), np.empty((2, 2)), np.empty(2)
        verts[0] = p0
        k = _emit(out, *p0, *p1, verts, centres, sweeps, 0)
        assert np.allclose(mine.vertices, verts[:k + 1], rtol=0, atol=1e-9)
        assert np.allclose(mine.sweeps, sweeps[:k], rtol=0, atol=1e-9)
        assert np.allclose(mine.centres, centres[:k], rtol=0, atol=1e-6, equal_nan=True)
        built += 1
    assert built > 1500 and refused > 0
