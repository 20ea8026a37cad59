"""Paths → Moves: lengths, passes, Z steps, travel with the beam off, and G-code round trip."""

import math

import numpy as np
import pytest

from labkit.errors import GeometryError
from labkit.geometry import Path, hausdorff, total_length
from labkit.toolpath import LaserMode, MoveKind
from labkit.toolpath.build import LayerSettings, build_moves, prepare_paths


def _cut_paths(moves):
    """Rebuild the cut geometry from Moves (independent of build_moves' bookkeeping)."""
    out = []
    for k in np.flatnonzero(moves.laser_on):
        s, e, c = moves.start[k, :2], moves.end[k, :2], moves.centre[k, :2]
        if moves.kind[k] == MoveKind.LINE:
            out.append(Path([s, e]))
        else:
            sweep = float(moves.sweep_rad()[k])      # ±2π: a full circle in one move
            out.append(Path.arc(c, math.hypot(*(s - c)), math.atan2(*(s - c)[::-1]), sweep))
    return out


def test_cut_length_equals_path_length_and_geometry_survives():
    paths = [Path.rectangle(0, 0, 20, 10), Path.circle((40, 5), 4), Path.arc((60, 0), 5, 0, 2.0)]
    m = build_moves(paths, LayerSettings(feed_mm_min=900, s_word=500))
    assert m.lengths_mm()[m.laser_on].sum() == pytest.approx(total_length(paths))
    assert hausdorff(_cut_paths(m), paths) < 1e-9
    assert not m.laser_on[m.kind == MoveKind.RAPID].any()
    assert set(m.feed_mm_min[m.laser_on]) == {900}


def test_per_layer_settings_and_passes_with_z_steps():
    red = Path.rectangle(0, 0, 10, 10, layer="red")
    blue = Path.circle((30, 5), 3, layer="blue")
    settings = {"red": LayerSettings(feed_mm_min=300, s_word=1000, passes=3, z_step_mm=0.5),
                "blue": LayerSettings(feed_mm_min=2000, s_word=200, laser=LaserMode.DYNAMIC)}
    m = build_moves([blue, red], settings)
    cut = m.laser_on
    red_rows = cut & (m.feed_mm_min == 300)
    assert red_rows.sum() == 3 * 4
    assert sorted(set(m.start[red_rows, 2])) == [-1.0, -0.5, 0.0]
    assert m.lengths_mm()[red_rows].sum() == pytest.approx(3 * 40)
    blue_rows = cut & (m.feed_mm_min == 2000)
    assert set(m.laser[blue_rows]) == {LaserMode.DYNAMIC} and set(m.s_word[blue_rows]) == {200}
    assert np.flatnonzero(blue_rows).max() < np.flatnonzero(red_rows).min()   # blue came first


def test_default_for_unknown_layers():
    m = build_moves([Path.rectangle(0, 0, 1, 1, layer="x")], {"y": LayerSettings(feed_mm_min=1)},
                    default=LayerSettings(feed_mm_min=777))
    assert set(m.feed_mm_min[m.laser_on]) == {777}


def test_emitted_gcode_parses_back_to_the_same_cuts():
    from labkit.gcode import emit, parse

    paths = [Path.rectangle(0, 0, 20, 10), Path.circle((40, 5), 4)]
    m = build_moves(paths, LayerSettings(feed_mm_min=1200, s_word=700))
    back = parse(emit(m, tol_mm=1e-4))
    assert back.lengths_mm()[back.laser_on].sum() == pytest.approx(total_length(paths), abs=1e-3)
    assert hausdorff(_cut_paths(back), paths) < 1e-3


def test_prepare_kerf_fill_and_order():
    part = Path.rectangle(0, 0, 30, 20)
    hole = Path.circle((15, 10), 4)
    out = prepare_paths([hole, part], kerf_mm=0.2, fill=True, fill_spacing_mm=1.0)
    fill = [p for p in out if not p.closed]
    contours = [p for p in out if p.closed]
    assert out.index(contours[0]) > out.index(fill[-1])               # contours after fill
    areas = [abs(p.signed_area_mm2()) for p in contours]
    assert areas[0] == pytest.approx(math.pi * 3.9**2, rel=1e-3)      # hole first, shrunk
    assert areas[1] == pytest.approx(30.2 * 20.2 - (4 - math.pi) * 0.01, rel=1e-4)
    expected_fill = 30.2 * 20.2 - math.pi * 3.9**2
    assert sum(p.length_mm for p in fill) == pytest.approx(expected_fill, rel=0.03)


def test_prepare_joins_loose_pieces():
    pieces = [Path([(0, 0), (10, 0)]), Path([(10, 10), (10, 0)]), Path([(0, 10), (10, 10)]),
              Path([(0, 0), (0, 10)])]
    out = prepare_paths(pieces)
    assert len(out) == 1 and out[0].closed


def test_errors():
    with pytest.raises(GeometryError, match="feed_mm_min must be > 0"):
        LayerSettings(feed_mm_min=0)
    with pytest.raises(GeometryError, match="passes must be an integer >= 1"):
        LayerSettings(passes=0)
    with pytest.raises(GeometryError, match="z_step_mm must be >= 0"):
        LayerSettings(z_step_mm=-1)
    with pytest.raises(GeometryError, match="s_word must be >= 0"):
        LayerSettings(s_word=-5)
    with pytest.raises(GeometryError, match="origin must be"):
        build_moves([Path.rectangle(0, 0, 1, 1)], origin=(0, 0))
    with pytest.raises(GeometryError, match="kerf_mm must be >= 0"):
        prepare_paths([Path.rectangle(0, 0, 1, 1)], kerf_mm=-0.1)
    assert len(build_moves([])) == 0


def test_a_circle_is_one_full_circle_move_and_co_circular_arcs_merge():
    """A closed circle (two half arcs, or the four quarter arcs an SVG path draws) is cut
    as one G2/G3 back to its start; co-circular neighbours short of a turn merge."""
    quarters = Path([[5, 0], [0, 5], [-5, 0], [0, -5], [5, 0]], [[0, 0]] * 4, [math.pi / 2] * 4, closed=True)
    three = Path([[5, 0], [0, 5], [-5, 0], [0, -5]], [[0, 0]] * 3, [math.pi / 2] * 3)
    for p, sweeps in ((Path.circle((0, 0), 5), [2 * math.pi]), (quarters, [2 * math.pi]),
                      (three, [1.5 * math.pi])):
        m = build_moves([p], LayerSettings(), origin=(5, 0, 0))
        assert m.sweep_rad().tolist() == pytest.approx(sweeps)
        assert m.lengths_mm().sum() == pytest.approx(p.length_mm)
        assert hausdorff(_cut_paths(m), [p]) < 1e-9
    # arcs of different circles stay apart
    two = Path([[5, 0], [0, 5], [-5, 0]], [[0, 0], [0, 0.5]], [math.pi / 2, math.pi / 2])
    assert len(build_moves([two], LayerSettings(), origin=(5, 0, 0))) == 2


def test_kerf_and_order_judge_holes_across_layers():
    """A hole drawn on its own layer (a CAD habit) is still a hole: its path moves inwards by
    kerf/2, and its layer is cut before the outline that would free the part from the sheet."""
    outline = Path.rectangle(0, 0, 40, 30, layer="cut")
    hole = Path.circle((20, 15), 5, layer="holes")
    mark = Path.polyline([(5, 5), (10, 5)], layer="engrave")          # work inside the part too
    out = prepare_paths([outline, hole, mark], kerf_mm=0.4)
    by_layer = {p.layer: p for p in out}
    assert np.allclose(np.ptp(by_layer["cut"].bounds(), axis=0), [40.4, 30.4], atol=1e-3)
    assert np.allclose(np.ptp(by_layer["holes"].bounds(), axis=0), [9.6, 9.6], atol=1e-3)
    assert [p.layer for p in out][-1] == "cut"          # the outline last, after hole and engraving
    # same answer as offsetting the part as one region on one layer (the reference)
    one = prepare_paths([outline, Path.circle((20, 15), 5, layer="cut")], kerf_mm=0.4)
    assert sorted(round(float(np.ptp(p.bounds()[:, 0])), 6) for p in one) == sorted(
        round(float(np.ptp(p.bounds()[:, 0])), 6) for p in out if p.closed)


def test_unrelated_layers_keep_first_seen_order():
    a = Path.rectangle(0, 0, 10, 10, layer="a")
    b = Path.rectangle(20, 0, 10, 10, layer="b")
    assert [p.layer for p in prepare_paths([a, b], kerf_mm=0.2)] == ["a", "b"]
    assert [p.layer for p in prepare_paths([b, a], kerf_mm=0.2)] == ["b", "a"]


def _line_unless_area_one_by_one(p, tol_mm):
    """prepare_paths' test of a chain as it was written, one chain at a time."""
    if not p.length_mm > 0:
        return None
    if not p.closed:
        return p
    d = p.sample(tol_mm) - p.vertices[0]
    far = d[int(np.argmax(np.hypot(d[:, 0], d[:, 1])))]
    if np.any(d[:, 0] * far[1] - d[:, 1] * far[0] != 0):
        return p
    return p.with_geometry(p.vertices, p.centres, p.sweeps, closed=False)


def test_chains_without_area_are_found_for_all_chains_at_once():
    """The vectorised test of every chain (no length: dropped; closed with no area: cut open)
    decides each chain as the one-by-one test did: outlines, arcs, lines there and back
    (straight, diagonal, through the start), points, open paths."""
    from labkit.toolpath.build import _lines_unless_area

    rng = np.random.default_rng(2)
    chains = []
    for _ in range(300):
        kind = rng.integers(6)
        a, b = rng.normal(0, 20, 2), rng.normal(0, 20, 2)
        if kind == 0:                                  # a line there and back, closed
            chains.append(Path([a, b, a], closed=True))
        elif kind == 1:                                # collinear, through the start
            chains.append(Path([a, a + (b - a) * 0.3, b, a], closed=True))
        elif kind == 2:                                # a point
            chains.append(Path([a, a], closed=False))
        elif kind == 3:                                # open polyline
            chains.append(Path(rng.normal(0, 10, (int(rng.integers(2, 6)), 2))))
        elif kind == 4:                                # a circle or an arc and its chord
            chains.append(Path.circle(a, float(rng.uniform(0.001, 20))))
        else:
            chains.append(Path(rng.normal(0, 10, (4, 2)), closed=True))
    for tol in (0.1, 0.01):
        want = [q for q in (_line_unless_area_one_by_one(p, tol) for p in chains) if q is not None]
        got = _lines_unless_area(chains, tol)
        assert [(q.closed, q.vertices.tobytes()) for q in got] == [(q.closed, q.vertices.tobytes()) for q in want]
        assert sum(not q.closed for q in got) > sum(not p.closed for p in chains if p.length_mm > 0)
