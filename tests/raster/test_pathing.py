"""Zig-zag and spiral paths cover exactly the marked pixels; greedy connection, both ways, same order."""

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from skimage import data

from labkit.errors import RasterError
from labkit.raster import (Segments, burn_map, connect, label_islands, scan_order, segments_to_moves,
                           spiral_segments, zigzag_segments)
from labkit.toolpath import MoveKind


def _random_masks(seed=0, n=12):
    rng = np.random.default_rng(seed)
    for k in range(n):
        shape = tuple(rng.integers(1, 40, size=2))
        yield rng.random(shape) < rng.uniform(0.1, 0.9)


def _assert_exact_cover(segs, mask, pixel_mm=0.25):
    moves = segments_to_moves(segs, pixel_mm=pixel_mm, feed_mm_min=1000, s_word=700)
    count, power = burn_map(moves, mask.shape, pixel_mm)
    assert np.array_equal(count, mask.astype(np.int64))       # every marked pixel once, nothing else
    assert np.array_equal(power, 700.0 * mask)
    rapid = moves.kind == MoveKind.RAPID
    assert not moves.laser_on[rapid].any()                       # laser never on during travel
    assert np.all(moves.laser_on[~rapid])
    return moves


def _horse():
    return ~data.horse()


@pytest.mark.parametrize("axis, direction, ends", list(itertools.product(
    ["rows", "columns", "auto"], ["bidirectional", "unidirectional"], ["edge", "centre"])))
def test_zigzag_exact_cover(axis, direction, ends):
    for mask in itertools.chain(_random_masks(1), [_horse()]):
        segs = zigzag_segments(mask, axis=axis, direction=direction, ends=ends)
        ordered = segs.reordered(connect(segs))
        _assert_exact_cover(ordered, mask)


def _runs_by_hand(mask, axis):
    """Every run of marked pixels, line after line, read one pixel at a time."""
    lines = mask.T if axis == "columns" else mask
    runs = []
    for i, line in enumerate(lines):
        j = 0
        while j < len(line):
            if line[j]:
                j0 = j
                while j < len(line) and line[j]:
                    j += 1
                runs.append((i, j0, j))
            j += 1
    return runs


@pytest.mark.parametrize("band_pixels", [1, 7, 64, 1 << 22])
@pytest.mark.parametrize("axis", ["rows", "columns"])
def test_zigzag_runs_are_the_same_whatever_the_band(monkeypatch, axis, band_pixels):
    # runs are found a band of rows at a time: a run that crosses a band's edge (columns)
    # or a band of one row must come out as one run, in scan order
    from labkit.raster import pathing
    monkeypatch.setattr(pathing, "_BAND_PIXELS", band_pixels)
    masks = list(_random_masks(7, n=20)) + [np.zeros((3, 4), bool), np.ones((5, 1), bool),
                                            np.ones((1, 6), bool)]
    for mask in masks:
        segs = zigzag_segments(mask, axis=axis, direction="unidirectional", ends="centre")
        if axis == "rows":          # half-pixel units: x = 2c + 1, y = 2(H - r) - 1
            got = [(int(mask.shape[0] - (y + 1) // 2), int(x0 - 1) // 2, int(x1 + 1) // 2)
                   for (x0, y), (x1, _) in zip(segs.starts, segs.ends)]
        else:                       # columns run bottom → top: stop row from the start y
            got = [(int(x - 1) // 2, int(mask.shape[0] - (y1 + 1) // 2),
                    int(mask.shape[0] - (y0 + 1) // 2) + 1)
                   for (x, y0), (_, y1) in zip(segs.starts, segs.ends)]
        assert got == _runs_by_hand(mask, axis)


def test_zigzag_edge_runs_are_pixel_long_and_unidirectional_goes_one_way():
    mask = _horse()
    segs = zigzag_segments(mask, axis="rows", direction="unidirectional")
    lengths_px = (segs.ends[:, 0] - segs.starts[:, 0]) / 2
    assert lengths_px.sum() == mask.sum() and (lengths_px >= 1).all()
    conn = connect(segs)
    assert not conn.flipped.any()
    cols = zigzag_segments(mask, axis="columns", direction="unidirectional")
    assert (cols.ends[:, 1] > cols.starts[:, 1]).all()  # bottom → top


@pytest.mark.parametrize("ends", ["edge", "centre"])
def test_spiral_exact_cover(ends):
    for mask in itertools.chain(_random_masks(2), [_horse(), data.binary_blobs(128, rng=3)]):
        segs = spiral_segments(mask, ends=ends)
        _assert_exact_cover(segs.reordered(connect(segs)), mask)


def test_spiral_walk_is_clockwise_from_the_bottom_left():
    mask = np.ones((4, 5), dtype=bool)
    segs = spiral_segments(mask, ends="centre")
    pl = segs.polyline(0) // 2              # (column, row from the bottom)
    assert pl[0].tolist() == [0, 0]
    headings = np.sign(np.diff(pl, axis=0)).tolist()
    # up the left side, right along the top, down the right, left along the bottom, then up inside
    assert headings[:5] == [[0, 1], [1, 0], [0, -1], [-1, 0], [0, 1]]
    assert len(segs) == 1


def test_spiral_seed_dead_end_makes_a_new_sub_segment():
    # A "T": walking up the stem, the walk tries left first, so it turns left along the bar and
    # dead-ends at its left tip, leaving the right arm for a second sub-segment (seed Fig. 3.19–3.20).
    mask = np.array([[1, 1, 1, 1, 1],
                     [0, 0, 1, 0, 0],
                     [0, 0, 1, 0, 0]], dtype=bool)
    segs = spiral_segments(mask, ends="centre")
    assert len(segs) == 2
    first, second = segs.polyline(0) // 2, segs.polyline(1) // 2
    assert first.tolist() == [[2, 0], [2, 2], [0, 2]]      # stem up, turn left, to the tip
    assert second.tolist() == [[3, 2], [4, 2]]             # the right arm, from its bottom-left pixel


def test_spiral_lone_pixel_gets_a_one_pixel_burn():
    mask = np.zeros((3, 3), bool); mask[1, 1] = True
    edge = spiral_segments(mask)
    assert edge.points.tolist() == [[2, 3], [4, 3]]
    centre = spiral_segments(mask, ends="centre")
    assert centre.points.tolist() == [[3, 3], [3, 3]]


def test_spiral_per_island_equals_whole_image():
    mask = data.binary_blobs(96, volume_fraction=0.4, rng=5)
    whole = spiral_segments(mask)
    labels, n = label_islands(mask)
    per_island = []
    for k in range(1, n + 1):
        s = spiral_segments(labels == k)
        per_island += [tuple(map(tuple, s.polyline(i))) for i in range(len(s))]
    ours = [tuple(map(tuple, whole.polyline(i))) for i in range(len(whole))]
    assert sorted(ours) == sorted(per_island)


def test_spiral_vertices_are_marked_centres_and_moves_are_axis_aligned():
    mask = _horse()
    segs = spiral_segments(mask, ends="centre")
    a, b = segs.cuts()
    assert np.all((a[:, 0] == b[:, 0]) | (a[:, 1] == b[:, 1]))
    col, row_up = segs.points[:, 0] // 2, segs.points[:, 1] // 2
    assert mask[mask.shape[0] - 1 - row_up, col].all()


def _brute_force_greedy(starts, ends, reversible, origin=(0, 0)):
    """Independent O(n²) greedy by explicit key tuples (distance², index, reversed)."""
    left = set(range(len(starts)))
    pos = origin
    order, flips = [], []
    while left:
        keys = []
        for i in left:
            keys.append(((starts[i][0] - pos[0]) ** 2 + (starts[i][1] - pos[1]) ** 2, i, False))
            if reversible:
                keys.append(((ends[i][0] - pos[0]) ** 2 + (ends[i][1] - pos[1]) ** 2, i, True))
        _, i, f = min(keys)
        order.append(i); flips.append(f); left.remove(i)
        pos = starts[i] if f else ends[i]
    return order, flips


@given(st.lists(st.tuples(st.integers(0, 12), st.integers(0, 12), st.integers(0, 12), st.integers(0, 12)),
                min_size=1, max_size=40), st.booleans())
@settings(max_examples=150, deadline=None)
def test_greedy_methods_agree_with_brute_force(rows, reversible):
    # small coordinates: many equal distances, so the tie rules are exercised
    pts = np.array(rows, dtype=np.int64).reshape(-1, 2, 2)
    segs = Segments(pts.reshape(-1, 2), np.arange(0, 2 * len(rows) + 1, 2), (7, 7), reversible)
    expect = _brute_force_greedy(pts[:, 0].tolist(), pts[:, 1].tolist(), reversible)
    for method in ("reference", "indexed"):
        c = connect(segs, method=method)
        assert (c.order.tolist(), c.flipped.tolist()) == expect


def test_indexed_equals_reference_on_images_with_less_work():
    for mask in (_horse(), data.binary_blobs(256, volume_fraction=0.3, rng=1)):
        for segs in (zigzag_segments(mask), spiral_segments(mask)):
            ref = connect(segs, method="reference")
            idx = connect(segs, method="indexed")
            assert np.array_equal(ref.order, idx.order) and np.array_equal(ref.flipped, idx.flipped)
            n, e = len(segs), 2 if segs.reversible else 1
            assert ref.examined == e * n * (n + 1) // 2       # the seed's quadratic count
            assert idx.examined < ref.examined / 5


def test_scan_order_boustrophedon():
    mask = np.ones((3, 4), bool)
    segs = zigzag_segments(mask, axis="rows")
    c = scan_order(segs)
    moves = _assert_exact_cover(segs.reordered(c), mask)
    xs = moves.end[moves.kind == MoveKind.LINE][:, 0].tolist()
    assert xs == [1.0, 0.0, 1.0]  # right, left, right (0.25 mm pixels)
    uni = zigzag_segments(mask, axis="rows", direction="unidirectional")
    assert not scan_order(uni).flipped.any()
    assert connect(segs, method="scan").method == "scan"


def test_pathing_errors():
    m = np.ones((2, 2), bool)
    with pytest.raises(RasterError, match="axis must be"):
        zigzag_segments(m, axis="diagonal")
    with pytest.raises(RasterError, match="direction must be"):
        zigzag_segments(m, direction="both")
    with pytest.raises(RasterError, match="ends must be one of"):
        spiral_segments(m, ends="middle")
    with pytest.raises(RasterError, match="method must be"):
        connect(zigzag_segments(m), method="tsp")
    with pytest.raises(RasterError, match="origin must be"):
        connect(zigzag_segments(m), origin=(-1, 0))
    with pytest.raises(RasterError, match="boolean array"):
        spiral_segments(np.ones((2, 2)))


def test_empty_mask():
    m = np.zeros((5, 5), bool)
    for segs in (zigzag_segments(m), spiral_segments(m)):
        assert len(segs) == 0
        c = connect(segs)
        assert len(c.order) == 0
        assert len(segments_to_moves(segs, pixel_mm=0.1, feed_mm_min=100, s_word=10)) == 0
