"""The public API given the wrong thing (issue 25 §5): text, a dict or an array where a program
(Moves) or a machine is expected, and programs with values that are not finite, raise labkit's
own error naming the argument — never an AttributeError from deep inside, never a plan of
864,691,128,455,134 s."""

from __future__ import annotations

import math

import numpy as np
import pytest

from labkit.errors import EmitError, InputError, MotionError
from labkit.gcode import parse
from labkit.gcode.simulate import Envelope, check_bounds, summarize
from labkit.gcode.writer import emit, write_gcode
from labkit.laser.simulate import simulate_burn
from labkit.machine.dobot import check_reach
from labkit.motion import plan
from labkit.motion.blocks import build_blocks
from labkit.toolpath import MoveKind, MovesBuilder

NOT_PROGRAMS = {
    "G-code text": ("G0 X0\nM3 S500\nG1 X10 F600\nM5\n", "got str; G-code text becomes Moves with labkit.gcode.parse"),
    "a dict": ({"x": [0, 10], "y": [0, 0]}, "got dict; a program is built with labkit.toolpath.MovesBuilder"),
    "None": (None, "got NoneType"),
    "an array": (np.zeros((2, 3)), "got ndarray"),
}

ENTRY_POINTS = {
    "emit": (lambda m, tmp: emit(m), EmitError),
    "write_gcode": (lambda m, tmp: write_gcode(tmp / "out.gcode", m), EmitError),
    "summarize": (lambda m, tmp: summarize(m), InputError),
    "check_bounds": (lambda m, tmp: check_bounds(m, Envelope.from_size(100, 100)), InputError),
    "plan": (lambda m, tmp: plan(m), MotionError),
    "build_blocks": (lambda m, tmp: build_blocks(m), MotionError),
    "simulate_burn": (lambda m, tmp: simulate_burn(m, w0_mm=0.1, fth_mj_mm2=200.0), InputError),
    "check_reach": (lambda m, tmp: check_reach(m), InputError),
}


@pytest.mark.parametrize("entry", list(ENTRY_POINTS))
@pytest.mark.parametrize("given", list(NOT_PROGRAMS))
def test_a_program_that_is_not_moves_is_named(entry, given, tmp_path):
    call, kind = ENTRY_POINTS[entry]
    value, said = NOT_PROGRAMS[given]
    with pytest.raises(kind, match=f"^moves must be a labkit.toolpath.Moves, {said}$"):
        call(value, tmp_path)
    assert not (tmp_path / "out.gcode").exists()


def test_a_preview_of_text_is_named(tmp_path):
    from labkit.viz.gcode import save_preview

    with pytest.raises(InputError, match="^moves must be a labkit.toolpath.Moves, got str"):
        save_preview("G1 X10", tmp_path / "p.png")


@pytest.mark.parametrize("machine, said", [
    ({"accel_mm_s2": 500}, "got dict"),
    ([1, 2, 3], "got list"),
    (3.5, "got float"),
])
def test_a_machine_that_is_not_one_is_named(machine, said):
    b = MovesBuilder(feed_mm_min=600)
    b.line(x=10)
    with pytest.raises(MotionError, match=f"^machine must be a MachineSpec, a machine's name or a TOML file, {said}$"):
        plan(b.build(), machine)


def _program():
    b = MovesBuilder(feed_mm_min=600, s_word=500, laser=3)
    b.rapid(x=1, y=1)
    b.line(x=10)
    b.arc_ccw(x=10, y=11, i=0, j=5)
    b.dwell(0.5)
    b.line(x=1)
    return b.build()


@pytest.mark.parametrize("column, row, axis, message", [
    ("end", 1, 0, r"move 1 has a position that is not finite \(end X = nan\)"),
    ("start", 4, 1, r"move 4 has a position that is not finite \(start Y = nan\)"),
    ("centre", 2, 1, r"move 2 has an arc centre that is not finite \(centre Y = nan\)"),
    ("s_word", 1, None, r"move 1 has a power that is not finite \(s_word = nan\)"),
    ("dwell_s", 3, None, r"move 3 has a dwell that is not finite \(dwell_s = nan\)"),
])
def test_plan_of_moves_with_nan_columns_names_the_move_and_column(column, row, axis, message):
    m = _program()
    assert [MoveKind(int(k)) for k in m.kind] == [MoveKind.RAPID, MoveKind.LINE, MoveKind.ARC_CCW,
                                                 MoveKind.DWELL, MoveKind.LINE]
    plan(m)                                     # the program itself plans
    data = getattr(m, column)
    if axis is None:
        data[row] = math.nan
    else:
        data[row, axis] = math.nan
    with pytest.raises(MotionError, match=f"^moves: <moves>: {message}; expected "):
        plan(m)
    with pytest.raises(InputError, match=message):
        summarize(m)


def test_a_parsed_program_names_its_file_and_line(tmp_path):
    m = parse("G0 X0 Y0\nG1 X10 F600\nG1 Y5\n", filename="job.gcode")
    m.end[2, 1] = math.inf
    with pytest.raises(MotionError, match=r"^moves: job.gcode: move 2 \(line 3\) has a position that is not "
                                          r"finite \(end Y = inf\); expected finite coordinates in mm$"):
        plan(m)



_SQUARE = [(0, 0), (10, 0), (10, 10), (0, 10)]


@pytest.mark.parametrize("make, said", [
    (lambda sq: '<svg xmlns="http://www.w3.org/2000/svg"><path d="M0 0 L10 0"/></svg>',
     r"^paths must be a list of labkit.geometry.Path, got str; SVG text becomes Paths with "
     r"labkit.vector.read_svg\(text\).paths$"),
    (lambda sq: {"d": "M0 0 L10 0"}, "^paths must be a list of labkit.geometry.Path, got dict$"),
    (lambda sq: None, "^paths must be a list of labkit.geometry.Path, got NoneType$"),
    (lambda sq: sq, r"^paths must be a list of labkit.geometry.Path, got Path; put a single path in a list: \[path\]$"),
    (lambda sq: [sq, "M0 0 L10 0"], r"^paths\[1\] must be a labkit.geometry.Path, got str$"),
], ids=["SVG text", "a dict", "None", "one Path", "a list holding text"])
@pytest.mark.parametrize("entry", ["build_moves", "prepare_paths"])
def test_a_drawing_that_is_not_paths_is_named(entry, make, said):
    from labkit.errors import GeometryError
    from labkit.geometry import Path
    from labkit.toolpath.build import build_moves, prepare_paths

    square = Path.polyline(_SQUARE, closed=True)
    call = build_moves if entry == "build_moves" else prepare_paths
    call([square])                          # the real thing works
    with pytest.raises(GeometryError, match=said):
        call(make(square))
