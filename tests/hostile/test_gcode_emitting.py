"""Hostile Moves for the emitter (issue 9): never garbage digits, never travel with the beam on."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from labkit.errors import EmitError
from labkit.gcode import emit, parse, parse_file
from labkit.toolpath import LaserMode, MoveKind, Moves, MovesBuilder

DATA = Path(__file__).resolve().parents[2] / "data" / "gcode" / "cncjs"


def _cut(x_end, **kw):
    b = MovesBuilder(feed_mm_min=600, s_word=500, laser=LaserMode.CONSTANT, **kw)
    b.rapid(x=1)
    b.line(x=x_end)
    return b.build()


@pytest.mark.parametrize("x, message", [
    (math.inf, r"move 1 \(generated\): X is not finite \(inf\)"),
    (math.nan, r"move 1 \(generated\): X is not finite \(nan\)"),
    (1e16, r"move 1 \(generated\): X 1e\+16 mm cannot be written exactly with 3 decimals "
           r"\(largest 9\.007e\+12 mm\)"),
    (-9.1e15, r"X -9\.1e\+15 mm cannot be written exactly"),
])
def test_unwritable_coordinates_are_refused_not_written_as_garbage(x, message):
    with pytest.raises(EmitError, match=message):
        emit(_cut(x))


def test_large_but_exact_coordinates_round_trip():
    text = emit(_cut(9.0e12))
    assert "G1 X9000000000000 F600" in text
    assert parse(text).end[-1, 0] == 9.0e12


@pytest.mark.parametrize("power, message", [
    (-1.0, r"power S -1\.0 is outside 0…1000"), (math.nan, r"power S nan is outside"),
    (5000.0, r"power S 5000\.0 is outside 0…1000 \(s_max\)"), (math.inf, "power S inf")])
def test_power_outside_the_laser_range_is_refused(power, message):
    b = MovesBuilder(feed_mm_min=600, s_word=power, laser=LaserMode.CONSTANT)
    b.line(x=5)
    with pytest.raises(EmitError, match=message):
        emit(b.build())


@pytest.mark.parametrize("feed", [math.nan, math.inf, 0.0, -5.0, 1e-9])
def test_feed_moves_need_a_finite_positive_feed(feed):
    """1e-9 mm/min would be written F0: a program GRBL refuses (error 22)."""
    b = MovesBuilder(feed_mm_min=feed)
    b.line(x=5)
    with pytest.raises(EmitError, match="feed move without a feed rate the program can state"):
        emit(b.build())


def test_arc_centre_that_is_not_finite_is_refused():
    m = Moves(kind=[MoveKind.ARC_CW], start=[[0, 0, 0]], end=[[10, 0, 0]],
              centre=[[math.nan, 0, 0]], feed_mm_min=[100])
    with pytest.raises(EmitError, match=r"move 0 \(generated\): arc centre X is not finite"):
        emit(m)


# ---- laser safety: travel with the beam on ------------------------------------------------

def _beam_on_during_rapids(text: str, dialect: str) -> int:
    """Rapids read back with M3/M4 and S > 0 in effect (they burn on GRBL with $32=0)."""
    m = parse(text, dialect=dialect)
    rapid = m.kind == MoveKind.RAPID
    return int((rapid & (m.laser != LaserMode.OFF) & (m.s_word > 0)).sum())


def test_grbl_header_says_rapids_rely_on_laser_mode():
    text = emit(_cut(5))
    # the warning is wrapped into comment lines that fit GRBL's line buffer
    header = " ".join(line[1:].strip() for line in text.splitlines()[1:6] if line.startswith(";"))
    assert "$32=1" in header and "$32=0" in header and "every rapid burns" in header
    assert _beam_on_during_rapids(text, "grbl") > 0          # what the header warns about


@pytest.mark.parametrize("dialect", ["grbl", "labkit-fw", "marlin"])
def test_travel_beam_off_writes_no_rapid_with_the_beam_on(dialect):
    # The cuts of a real file (cncjs's jsdc-laser), joined by rapids the way labkit's
    # generators join them: the beam mode stays M3 across travel.
    src = parse_file(DATA / "jsdc-laser.gcode")
    cut = src.laser_on
    m = Moves.from_cuts(src.start[cut], src.end[cut], feed_mm_min=src.feed_mm_min[cut],
                        s_word=src.s_word[cut], s_max=src.s_max)
    assert (m.kind == MoveKind.RAPID).sum() == 5                 # its five travels
    assert _beam_on_during_rapids(emit(m, dialect="grbl"), "grbl") == 5
    safe = emit(m, dialect=dialect, travel_beam_off=True)
    assert _beam_on_during_rapids(safe, dialect) == 0
    back = parse(safe, dialect=dialect)
    # The same cuts, at the same power, in the same order.
    ref = parse(emit(m, dialect=dialect), dialect=dialect)
    np.testing.assert_allclose(back.end[back.laser_on], ref.end[ref.laser_on], atol=1e-3)
    np.testing.assert_allclose(back.s_word[back.laser_on], ref.s_word[ref.laser_on])
    assert "M5 before every rapid" in safe.splitlines()[1]
