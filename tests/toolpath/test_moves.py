"""The Moves model: construction, selection, lengths and boxes against dense samples."""

import math

import numpy as np
import pytest

from labkit.gcode import parse
from labkit.gcode.arcs import moves_polylines
from labkit.toolpath import LaserMode, MoveKind, Moves, MovesBuilder


def test_from_cuts_joins_with_rapids_only_where_needed():
    m = Moves.from_cuts([[0, 0], [2, 0], [5, 5]], [[2, 0], [3, 0], [6, 5]],
                        feed_mm_min=[100, 200, 300], s_word=[1, 2, 3], origin=(0, 0, 0))
    assert [MoveKind(k).name for k in m.kind] == ["LINE", "LINE", "RAPID", "LINE"]
    np.testing.assert_array_equal(m.start[2], [3, 0, 0])
    np.testing.assert_array_equal(m.end[2], [5, 5, 0])
    assert m.feed_mm_min.tolist() == [100, 200, 300, 300]
    assert m.laser_on.tolist() == [True, True, False, True]
    assert m.lengths_mm().sum() == pytest.approx(2 + 1 + math.hypot(2, 5) + 1)


def test_from_cuts_validates_shapes():
    with pytest.raises(ValueError, match=r"shape \(n, 2\) or \(n, 3\)"):
        Moves.from_cuts([0, 1], [1, 2], feed_mm_min=1, s_word=1)
    with pytest.raises(ValueError, match="starts and ends differ in shape"):
        Moves.from_cuts([[0, 0]], [[1, 1], [2, 2]], feed_mm_min=1, s_word=1)


def test_columns_are_checked():
    with pytest.raises(TypeError, match="unknown Moves column"):
        Moves(kind=[0], speed=[1])
    with pytest.raises(ValueError, match="column 'end' has shape"):
        Moves(kind=[0, 1], end=[[1, 2, 3]])
    with pytest.raises(TypeError, match="at least the 'kind' column"):
        Moves(end=[[1, 2, 3]])


def test_selection_concat_copy_equality():
    m = parse("G0 X1\nG1 X2 F10\nG4 P1\nG1 X3")
    assert len(m[1:3]) == 2 and m[-1].end[0, 0] == 3
    assert len(m[m.is_feed]) == 2
    both = Moves.concat([m, m])
    assert len(both) == 8 and both == Moves.concat([m.copy(), m])
    assert m != m[:3]
    assert repr(m) == "<Moves n=4: rapid=1, line=2, dwell=1>"
    assert Moves.concat([]) == Moves.empty()


def test_memory_per_move_is_small():
    m = parse("\n".join(f"G1 X{i} Y{i % 7} F1000 S{i % 1000}" for i in range(1000)))
    assert m.nbytes / len(m) <= 150


def test_lengths_and_bounds_match_dense_polylines():
    m = parse("G0 X10\nG3 X-10 Y0 I-10 J0 F100\nG18 G2 X0 Z10 I10 K0\nG17 G2 X5 Y5 Z12 I5 J-0")
    lengths = m.lengths_mm()
    polylines = moves_polylines(m, tol_mm=1e-5)
    for i, pts in enumerate(polylines):
        dense = np.linalg.norm(np.diff(pts, axis=0), axis=1).sum() if len(pts) > 1 else 0.0
        assert lengths[i] == pytest.approx(dense, rel=1e-6)
    allpts = np.vstack(polylines)
    # Polyline vertices may fall short of an arc extreme by up to the chord tolerance.
    np.testing.assert_allclose(m.bounds(), [allpts.min(axis=0), allpts.max(axis=0)], atol=1.1e-5)


def test_power_in_mw_and_dataframe():
    m = parse("M3 S500\nG1 X1 F100\nG0 X0\nM4 S1000\nG1 X2")
    np.testing.assert_allclose(m.power_mw(2500), [1250, 0, 2500])
    df = m.to_dataframe()
    assert list(df["kind"]) == ["LINE", "RAPID", "LINE"]
    assert df["laser_on"].tolist() == [True, False, True]
    assert df["length_mm"].tolist() == [1, 1, 2]


def test_builder_errors_and_records():
    b = MovesBuilder()
    with pytest.raises(ValueError, match="dwell must be >= 0 s"):
        b.dwell(-1)
    with pytest.raises(ValueError, match="plane must be 17, 18 or 19"):
        b.set(plane=20)
    b.record("pause", "M0")
    m = b.build()
    assert len(m) == 0 and m.records[0].kind == "pause"
    assert Moves.empty().bounds().shape == (2, 3)
    assert MovesBuilder(laser=LaserMode.DYNAMIC).laser == LaserMode.DYNAMIC


def test_the_columns_are_stated_once_and_everything_derives_from_them():
    """Moves' constructor, MOVE_ROW (the parser kernel's row type), BLANK_ROW, the builders
    and the parser all use the one column table of labkit.toolpath.moves."""
    import re
    from pathlib import Path

    import labkit
    from labkit.gcode import parse
    from labkit.toolpath import corners
    from labkit.toolpath.moves import _COLUMNS, BLANK_ROW, MOVE_ROW

    names = tuple(_COLUMNS)
    assert Moves.column_names() == names == MOVE_ROW.names
    for name, (dtype, shape, fill) in _COLUMNS.items():
        assert MOVE_ROW[name].base == np.dtype(dtype) and MOVE_ROW[name].shape == shape
        np.testing.assert_array_equal(BLANK_ROW[name][0], np.full(shape, fill, dtype))
    b = MovesBuilder(feed_mm_min=600)
    b.line(x=1)
    built, parsed = b.build(), parse("G1 X1 F600")
    for m in (built, parsed, Moves.empty()):
        assert tuple(m.columns()) == names
        assert all(getattr(m, n).dtype == np.dtype(_COLUMNS[n][0]) for n in names)
    np.testing.assert_array_equal(built.work_offset, parsed.work_offset)
    assert corners._COLS == names
    # No other module spells the column list out.
    spelled = re.compile(r'"kind",\s*"start",\s*"end",\s*"centre",\s*"plane",\s*"feed_mm_min"')
    root = Path(labkit.__file__).parent
    assert [p.name for p in root.rglob("*.py") if spelled.search(p.read_text("utf-8"))] == []
