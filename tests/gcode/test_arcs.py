"""Arc centres, sweeps, flattening and the mid-arc point, against closed forms and GRBL."""

import math

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from labkit.errors import GeometryError
from labkit.gcode import arcs, parse
from labkit.geometry.circle import chord_segments, grbl_segments, orientation, sweep_angle

pt = st.tuples(st.floats(-100, 100), st.floats(-100, 100))


def test_laserapp_appendix_a_two_centres_by_hand():
    # P1 (0, 0), P2 (8, 0), R 5: Q = 8, P3 (4, 0), H = sqrt(25 - 16) = 3,
    # C = P3 ± 3·((0 − 0)/8, (8 − 0)/8) = (4, ±3).
    c = arcs.centres_from_radius([0, 0], [8, 0], 5)
    np.testing.assert_allclose(c, [[4, 3], [4, -3]])
    # G3 (CCW) with R > 0 takes the short arc: centre above the chord.
    np.testing.assert_allclose(arcs.centre_from_radius([0, 0], [8, 0], 5, clockwise=False), [4, 3])
    np.testing.assert_allclose(arcs.centre_from_radius([0, 0], [8, 0], -5, clockwise=False), [4, -3])
    np.testing.assert_allclose(arcs.centre_from_radius([0, 0], [8, 0], 5, clockwise=True), [4, -3])


@given(pt, pt, st.floats(0.2, 3.0), st.booleans(), st.booleans())
def test_radius_rule_sweep_is_short_for_positive_r(p1, p2, factor, cw, negative):
    q = math.dist(p1, p2)
    assume(q > 1e-3)
    r = 0.5 * q * (1 + factor) * (-1 if negative else 1)
    both = arcs.centres_from_radius(p1, p2, r)
    for c in both:
        assert math.dist(c, p1) == pytest.approx(abs(r), rel=1e-9, abs=1e-9)
        assert math.dist(c, p2) == pytest.approx(abs(r), rel=1e-9, abs=1e-9)
    chosen = arcs.centre_from_radius(p1, p2, r, cw)
    sweep = abs(sweep_angle(p1, p2, chosen, cw))
    assert (sweep < math.pi + 1e-9) if r > 0 else (sweep > math.pi - 1e-9)


@given(pt, pt, st.floats(0.01, 3.0), st.booleans(), st.booleans())
def test_parser_r_centres_match_the_laserapp_rule(p1, p2, factor, cw, negative):
    # The compiled parser decides by "left of the chord"; arcs.py by comparing sweeps.
    p1 = tuple(round(v, 6) for v in p1)
    p2 = tuple(round(v, 6) for v in p2)
    q = math.dist(p1, p2)
    assume(q > 1e-2)
    r = round(0.5 * q * (1 + factor), 6) * (-1 if negative else 1)
    text = (f"G0 X{p1[0]:.6f} Y{p1[1]:.6f}\n"
            f"G{2 if cw else 3} X{p2[0]:.6f} Y{p2[1]:.6f} R{r:.6f} F100")
    m = parse(text)
    np.testing.assert_allclose(m.centre[1, :2], arcs.centre_from_radius(p1, p2, r, cw), atol=1e-7)


def test_r_errors():
    with pytest.raises(GeometryError, match="full circle cannot be given by R"):
        arcs.centres_from_radius([1, 1], [1, 1], 5)
    with pytest.raises(GeometryError, match="smaller than half the chord"):
        arcs.centres_from_radius([0, 0], [10, 0], 4.9)
    np.testing.assert_allclose(arcs.centres_from_radius([0, 0], [10, 0], 4.9999, r_tol_mm=1e-3),
                               [[5, 0], [5, 0]])


def test_grbl_radius_tolerance_examples():
    assert arcs.radius_mismatch([10, 0], [0, 10.006], [0, 0]) == (False, 0.006)   # < 0.1 % of 10
    assert arcs.radius_mismatch([10, 0], [0, 10.011], [0, 0])[0] is True


@pytest.mark.parametrize("radius", [0.1, 1.0, 5.0, 25.0, 400.0])
@pytest.mark.parametrize("tol", [0.002, 0.01, 0.05])
def test_chord_count_against_grbls_formula_and_the_sagitta(radius, tol):
    if tol >= radius:
        return
    sweep = 1.7 * math.pi
    ours = chord_segments(radius, sweep, tol)
    grbl = grbl_segments(radius, sweep, tol)
    assert grbl <= ours <= grbl + 1
    sagitta = radius * (1 - math.cos(sweep / ours / 2))
    assert sagitta <= tol * (1 + 1e-9)
    if ours > 1:       # one chord fewer would break the tolerance: ours is the fewest
        assert radius * (1 - math.cos(sweep / (ours - 1) / 2)) > tol


def test_arc_polyline_stays_on_the_circle_and_within_tolerance():
    pts = arcs.arc_polyline([10, 0, 0], [0, 10, 0], [0, 0, 0], False, tol_mm=0.01)
    assert np.allclose(np.hypot(pts[:, 0], pts[:, 1]), 10)
    mids = 0.5 * (pts[1:] + pts[:-1])
    assert (10 - np.hypot(mids[:, 0], mids[:, 1])).max() <= 0.01
    np.testing.assert_array_equal(pts[0], [10, 0, 0])
    np.testing.assert_array_equal(pts[-1], [0, 10, 0])


@given(st.floats(0.5, 50), st.floats(0, 2 * math.pi), st.floats(0.05, 6.2), st.booleans(),
       st.floats(-20, 20), st.floats(-20, 20))
def test_mid_arc_point_is_half_way_along_the_arc(r, a0, turn, cw, cx, cy):
    c = np.array([cx, cy])
    a1 = a0 - turn if cw else a0 + turn
    s = c + r * np.array([math.cos(a0), math.sin(a0)])
    e = c + r * np.array([math.cos(a1), math.sin(a1)])
    mid = arcs.mid_arc_point(s, e, c, cw)
    half = a0 - turn / 2 if cw else a0 + turn / 2
    np.testing.assert_allclose(mid, c + r * np.array([math.cos(half), math.sin(half)]), atol=1e-7 * r)
    assert orientation(s, mid, e) == (-1 if cw else 1)


def test_mid_arc_point_on_vertical_chords_and_its_errors():
    # Centre left of the vertical chord x = 5: CCW is the short way round (through x = 6),
    # CW the long way (through x = -4).
    np.testing.assert_allclose(arcs.mid_arc_point([5, -3], [5, 3], [1, 0], clockwise=False), [6, 0])
    np.testing.assert_allclose(arcs.mid_arc_point([5, -3], [5, 3], [1, 0], clockwise=True), [-4, 0])
    with pytest.raises(GeometryError, match="start and end coincide"):
        arcs.mid_arc_point([1, 0], [1, 0], [0, 0], True)


def test_arc_angles_and_full_circles():
    a0, sweep = arcs.arc_angles([0, -2], [0, -2], [0, 0], clockwise=False)
    assert a0 == pytest.approx(-math.pi / 2)
    assert sweep == pytest.approx(2 * math.pi)


def test_helix_polyline_rises_linearly():
    pts = arcs.arc_polyline([0, 5, 0], [0, 5, 3], [0, 0, 0], True, plane=17, tol_mm=0.05)
    turned = np.unwrap(np.arctan2(pts[:, 1], pts[:, 0]))
    np.testing.assert_allclose(pts[:, 2], 3 * (turned[0] - turned) / (2 * math.pi), atol=1e-9)
