"""The modal state's one home (issue 28 §1): ModalState read from the interpreter, restate
written back as G-code and run again by the interpreter, and the line-by-line Interpreter
against the whole-text parse."""

from pathlib import Path

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from dataclasses import replace

from labkit.errors import InputError
from labkit.gcode import Interpreter, ModalState, get_dialect, modal_trace, parse, parse_with_states, restate
from labkit.gcode.state import line_states
from labkit.toolpath import Moves

DATA = Path(__file__).resolve().parents[2] / "data" / "gcode" / "cncjs"
GRBL = get_dialect("grbl")


def test_state_read_by_hand():
    """Each field after a short program worked by hand (GRBL's rules: G20 scales F and the
    axis words, G92 X0 makes the position read 0, M9 clears coolant, M2 resets the modes
    but keeps G92)."""
    trace, lines = line_states("G20 G91 G18\nG10 L2 P2 X1\nG55 G93 M8\nG1 X1 F2\nG92 X0\n"
                               "G43.1 Z0.5\nM9 M4 S300\nG94 F10\nM2\n")
    assert lines[0] == "G20 G91 G18" and len(trace) == 9
    s = ModalState.at(trace, 3)
    assert (s.units, s.distance, s.plane, s.coord_system, s.feed_mode) == (20, 91, 18, 55, 93)
    assert s.coolant == (8,) and s.coord_origins[1] == (25.4, 0.0, 0.0)
    assert s.position == (25.4, 0.0, 0.0) and np.isnan(s.feed_mm_min)   # G93: F is per move
    s = ModalState.at(trace, 7)
    assert s.g92 == (0.0, 0.0, 0.0)             # G92 X0 where the G55 origin is: no shift
    assert s.work_position.tolist() == pytest.approx([0.0, 0.0, -12.7])
    assert s.tool_offset == pytest.approx(12.7) and s.coolant == () and s.laser == 4
    assert s.feed_mode == 94 and s.feed_mm_min == pytest.approx(254.0)
    end = ModalState.at(trace, 8)
    assert (end.motion, end.plane, end.distance, end.coord_system, end.laser) == (1, 17, 90, 54, 5)
    assert end.units == 20 and end.g92 == s.g92 and end.tool_offset == s.tool_offset


def test_state_agrees_with_the_teaching_table():
    text = (DATA / "jsdc-laser.gcode").read_text()
    trace, _ = line_states(text)
    table = modal_trace(text, offsets=True)
    for row in (0, 10, 500, len(table) - 1):
        s, t = ModalState.at(trace, row), table.iloc[row]
        assert f"G{s.units}" == t["units"] and f"G{s.distance}" == t["distance"]
        assert f"G{s.plane}" == t["plane"] and f"G{s.coord_system}" == t["coords"]
        assert f"M{s.laser}" == t["laser"] and s.s_word == t["S"]
        assert s.position == (t["x"], t["y"], t["z"])
        assert s.work_position.tolist() == [t["wx"], t["wy"], t["wz"]]


def test_syncing_names_the_lines_grbl_runs_only_on_an_empty_planner():
    # GRBL 1.1 synchronises on a dwell, G10, G28/G30, G92, program stops and ends, and
    # spindle (laser) or coolant changes; a rejected line runs nothing at all
    lines = ["G1 X1 F100", "G4 P0.5", "G10 L20 P0 X0", "G28.1", "G92 X0", "M0", "M3 S100",
             "M8", "M9", "G40", "S200", "G1 X1 X2", "$H", "G90 G21"]
    trace, _ = line_states("\n".join(lines))
    assert trace["syncing"].tolist() == [False, True, True, True, True, True, True, True, True,
                                         False, False, False, False, False]


def test_flags_name_what_each_line_states():
    # worked by hand from GRBL's modal groups: group 6 (G20 G21) the units, group 3 (G90 G91)
    # the distance mode, group 12 (G54…G59) the coordinate system; G53 is non-modal (its axis
    # words are machine positions). A state kept from an earlier line is not stated again,
    # G90.1 is the arc-centre group, and a rejected or $ line states nothing.
    lines = ["G21", "G91 G1 X1 F100", "G55", "G53 G0 X0", "G90.1", "G20 G20", "$G", "X2",
             "G0 G54 G90 G20 Y1"]
    trace, _ = line_states("\n".join(lines))
    assert trace["states_units"].tolist() == [True, False, False, False, False, False, False,
                                              False, True]
    assert trace["states_distance"].tolist() == [False, True, False, False, False, False, False,
                                                 False, True]
    assert trace["states_coord_system"].tolist() == [False, False, True, False, False, False,
                                                     False, False, True]
    assert trace["machine_coords"].tolist() == [False, False, False, True, False, False, False,
                                                False, False]
    assert trace["coord_system"][[2, 8]].tolist() == [55, 54]


def _same(a: ModalState, b: ModalState, *, motion=True):
    assert np.allclose(a.position, b.position, atol=1e-9, rtol=0)
    assert np.allclose(a.work_offset, b.work_offset, atol=1e-9, rtol=0)
    assert (a.plane, a.units, a.distance, a.arc_centres, a.feed_mode, a.coord_system) == \
        (b.plane, b.units, b.distance, b.arc_centres, b.feed_mode, b.coord_system)
    assert (a.s_word, a.laser, a.coolant) == (b.s_word, b.laser, b.coolant)
    assert a.feed_mm_min == pytest.approx(b.feed_mm_min, rel=1e-12, nan_ok=True)
    if motion and a.motion in (0, 1, 80):
        assert a.motion == b.motion


_line = st.one_of(
    st.builds(lambda x, y: f"G1 X{x} Y{y} F{abs(x) + 50}", st.integers(-50, 50), st.integers(-50, 50)),
    st.builds(lambda x, z: f"G0 X{x} Z{z}", st.integers(-50, 50), st.integers(-5, 5)),
    st.builds(lambda x, y: f"G92 X{x} Y{y}", st.integers(-9, 9), st.integers(-9, 9)),
    st.builds(lambda p, x: f"G10 L2 P{p} X{x}", st.integers(1, 6), st.integers(-9, 9)),
    st.builds(lambda g: f"G{g}", st.sampled_from([54, 55, 56, 59])),
    st.builds(lambda z: f"G43.1 Z{z}", st.integers(-3, 3)),
    st.sampled_from(["G90", "G91", "G20", "G21", "G17", "G18", "G19", "G90.1", "G91.1", "G93 G1 X1 F2",
                     "G94 F300", "M3 S200", "M4 S900", "M5", "M7", "M8", "M9", "G80", "G49", "G92.1",
                     "G4 P0.1"]),
)


@settings(max_examples=40, deadline=None)
@given(st.lists(_line, min_size=1, max_size=25), st.data())
def test_restate_brings_a_fresh_controller_to_the_state(lines, data):
    """The preamble, run by the interpreter from power-on, gives the state back: every
    field the parser keeps, the work offset (restated as one G92) and the position."""
    trace, _ = line_states("\n".join(lines))
    row = data.draw(st.integers(0, len(lines) - 1))
    want = ModalState.at(trace, row)
    # G1 in effect with no feed (after G93, or G94 without F) cannot be restated: GRBL
    # refuses a G1 without a feed rate, even a zero-length one
    assume(not (want.motion == 1 and np.isnan(want.feed_mm_min)))
    it = Interpreter()
    for line in restate(want, "grbl"):
        _, error = it.feed(line)
        assert error is None, (line, error)
    _same(it.state, want)


@settings(max_examples=40, deadline=None)
@given(st.lists(_line, min_size=1, max_size=25), st.data())
def test_restate_after_a_reset_keeps_the_controllers_origins(lines, data):
    """On the controller that ran the program, after a soft reset (origins kept, G92 and the
    tool offset cleared, the head elsewhere), the resume preamble gives back the work offset,
    the work position and the modes."""
    trace, _ = line_states("\n".join(lines))
    want = ModalState.at(trace, data.draw(st.integers(0, len(lines) - 1)))
    reset = ModalState(position=(3.0, 4.0, 0.0), coord_origins=want.coord_origins)
    it = Interpreter(state=reset)
    for line in restate(want, "grbl", origins_kept=True):
        _, error = it.feed(line)
        assert error is None, (line, error)
    assert np.allclose(it.state.work_position, want.work_position, atol=1e-4, rtol=0)
    assert np.allclose(it.state.work_offset, want.work_offset, atol=1e-4, rtol=0)
    got = it.state
    if want.motion in (0, 1, 80):
        assert got.motion == want.motion
    assert (got.plane, got.units, got.distance, got.arc_centres, got.feed_mode, got.coord_system,
            got.s_word, got.laser, got.coolant) == \
        (want.plane, want.units, want.distance, want.arc_centres, want.feed_mode, want.coord_system,
         want.s_word, want.laser, want.coolant)


def test_restate_refuses_an_offset_the_dialect_cannot_say():
    trace, _ = line_states("G0 X5\nG92 X0\n", dialect="grbl")
    with pytest.raises(InputError, match="no G92 to restate it"):
        restate(ModalState.at(trace, 1), replace(GRBL, name="no-g92",
                                                 g_codes=tuple(g for g in GRBL.g_codes if g != 92.0)))


@pytest.mark.parametrize("name", ["jsdc-laser.gcode", "tball-engrave-laser.gcode"])
def test_interpreter_line_by_line_gives_the_parse_of_the_whole_text(name):
    text = (DATA / name).read_text()
    whole = parse(text)
    it = Interpreter()
    got = []
    for line in text.splitlines():
        moves, error = it.feed(line)
        assert error is None
        got.append(moves)
    joined = Moves.concat(got)
    assert len(joined) == len(whole)
    for col in ("kind", "start", "end", "centre", "work_offset", "feed_mm_min", "s_word", "laser",
                "plane", "dwell_s"):
        assert np.array_equal(getattr(joined, col), getattr(whole, col), equal_nan=True), col


def test_interpreter_keeps_the_state_of_a_rejected_line_and_says_why():
    it = Interpreter(state=ModalState(units=20))
    moves, error = it.feed("G1 X1")                        # no feed rate yet
    assert len(moves) == 0 and error.code == 22 and it.state == ModalState(units=20)
    moves, error = it.feed("G1 X1 F10")
    assert error is None and moves.end[0].tolist() == [25.4, 0.0, 0.0]
    with pytest.raises(ValueError, match="one line"):
        it.feed("G0 X1\nG0 X2")


def test_trace_as_python_equals_compiled():
    """The trace's per-line flags and state, both ways the interpreter runs (a twin of
    tests/test_jit.py's parse check, for what only the trace carries)."""
    from labkit import _jit

    text = (DATA / "jsdc-laser.gcode").read_text()[:20_000] + (
        "G20 G91 G55\nG53 G0 X1\nG10 L2 P1 X3\nG43.1 Z1\nG1 X1 X2\nM2\n")
    with _jit.forced("python"):
        a, _ = line_states(text)
    with _jit.forced("compiled"):
        b, _ = line_states(text)
    for name in a.dtype.names:
        assert np.array_equal(a[name], b[name], equal_nan=a[name].dtype.kind == "f"), name
    assert a["states_units"].any() and a["machine_coords"].any() and a["sets_offsets"].any()


@pytest.mark.parametrize("text, lenient", [
    ((DATA / "jsdc-laser.gcode").read_text(), False),
    ((DATA / "Circle_Diamond_Square_Calibration.gcode").read_text(), True),   # a line GRBL refuses
    ("G21\r\nG1 X1 F100\rG91 X2\n\nG1 X1 X2\nM5", True),                       # CRLF, lone CR, no last end
    ("", False),
])
def test_one_reading_gives_the_parse_and_the_line_states(text, lenient):
    """parse_with_states (labkit stream's one reading) equals parse and line_states run apart."""
    moves, trace = parse_with_states(text, lenient=lenient)
    alone = parse(text, lenient=lenient)
    states, lines = line_states(text)
    assert len(trace) == len(lines) == len(states)
    for name in trace.dtype.names:
        assert np.array_equal(trace[name], states[name], equal_nan=trace[name].dtype.kind == "f"), name
    assert len(moves) == len(alone) and len(moves.diagnostics) == len(alone.diagnostics)
    for col in Moves.column_names():
        assert np.array_equal(getattr(moves, col), getattr(alone, col), equal_nan=True), col
    if lenient:
        assert moves.diagnostics
