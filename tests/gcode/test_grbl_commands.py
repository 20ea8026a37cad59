"""One test per GRBL 1.1 command labkit runs, against GRBL's documented behaviour.

Sources (read, not copied): GRBL 1.1's ``doc/markdown/commands.md`` and ``jogging.md``, and
the rules of its ``gcode.c``: G92 makes the current position the given work coordinates;
G10 L2 P<n> sets system n's origin in machine coordinates, L20 makes the current position the
given work coordinates of system n (P0 = the active one); G28/G30 rapid through the optional
intermediate point to the position stored by G28.1/G30.1, only on the named axes when any is
named; G53 moves in machine coordinates for its block only; G43.1 Z offsets Z; G93 takes F as
1/minutes per move. labkit starts from GRBL's power-on state with all stored origins at 0
(GRBL keeps them in EEPROM; a program cannot assume them otherwise).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from labkit.errors import GcodeError
from labkit.gcode import emit, parse
from labkit.toolpath import LaserMode, MoveKind


def machine(m):
    return m.end.tolist()


def work(m):
    return m.work_end.tolist()


def test_g92_makes_the_current_position_the_given_work_coordinates():
    m = parse("G0 X10 Y20\nG92 X0 Y0\nG0 X5 Y5\nG91 G0 X1\nG90 G92.1\nG0 X5")
    assert machine(m) == [[10, 20, 0], [15, 25, 0], [16, 25, 0], [5, 25, 0]]
    assert work(m) == [[10, 20, 0], [5, 5, 0], [6, 5, 0], [5, 25, 0]]
    # G92 with one axis keeps the others' offsets; in inches the value is in inches.
    m = parse("G0 X10 Y10\nG92 X2\nG20 G92 Y1\nG21 G0 X0 Y0")
    assert machine(m)[-1] == pytest.approx([8, 10 - 25.4, 0])


def test_g54_to_g59_with_g10_l2_and_l20():
    m = parse("G10 L2 P1 X5 Y5\n"          # G54 origin at machine (5, 5)
              "G10 L2 P3 X100\n"           # G56 origin X at machine 100
              "G0 X0 Y0\n"                 # G54 work (0, 0) = machine (5, 5)
              "G56 G0 X1\n"                # G56: machine X 101, Y of G56 is 0 -> Y stays
              "G0 Y1\n"
              "G10 L20 P0 X0\n"            # current position is X0 in the active G56
              "G0 X2\n"
              "G54 G0 X0 Y0\n")
    assert machine(m) == [[5, 5, 0], [101, 5, 0], [101, 1, 0], [103, 1, 0], [5, 5, 0]]
    assert work(m) == [[0, 0, 0], [1, 5, 0], [1, 1, 0], [2, 1, 0], [0, 0, 0]]
    np.testing.assert_array_equal(m.work_offset[3], [101, 0, 0])
    # M2 resets to G54 (GRBL's program end), offsets stay stored.
    m = parse("G10 L2 P2 X50\nG55\nM2\nG0 X1\nG55 G0 X1")
    assert machine(m) == [[1, 0, 0], [51, 0, 0]]


def test_g28_and_g30_go_to_the_stored_positions():
    m = parse("G0 X5 Y6 Z7\nG28.1\nG0 X1 Y2 Z3\nG30.1\n"
              "G0 X20 Y20 Z20\nG28\n"             # straight to the stored position
              "G0 X20 Y20 Z20\nG28 Z25\n"         # via Z25, then only Z home
              "G30 G91 X-1\n")                    # via X-1 relative, then X to G30's X
    assert machine(m) == [[5, 6, 7], [1, 2, 3], [20, 20, 20], [5, 6, 7], [20, 20, 20],
                          [20, 20, 25], [20, 20, 7], [19, 20, 7], [1, 20, 7]]
    assert (m.kind == MoveKind.RAPID).all()
    # Without G28.1 the stored position is GRBL's cleared EEPROM value, 0.
    assert machine(parse("G0 X3\nG28"))[-1] == [0, 0, 0]


def test_g53_moves_in_machine_coordinates_for_one_block():
    m = parse("G10 L2 P1 X10 Y10\nG0 X0 Y0\nG53 G0 X1 Y1\nG0 X1 Y1\nG53 X2 G1 F100")
    assert machine(m) == [[10, 10, 0], [1, 1, 0], [11, 11, 0], [2, 11, 0]]
    assert work(m)[1] == [-9, -9, 0]                  # where the head is, in work coordinates
    with pytest.raises(GcodeError, match="error 30: G53 needs G0 or G1"):
        parse("G2 X2 Y0 I1 F10\nG53 X0")


def test_g43_1_dynamic_tool_length_offset_and_g49():
    m = parse("G43.1 Z2.5\nG0 Z0\nG49\nG0 Z0")
    assert machine(m) == [[0, 0, 2.5], [0, 0, 0]]
    assert work(m) == [[0, 0, 0], [0, 0, 0]]


def test_g80_cancels_motion_and_g93_is_inverse_time():
    assert len(parse("G1 X1 F100\nG80\nG4 P0")) == 2
    m = parse("G93 G1 X10 F2\nG2 X0 Y0 I-5 F1\nG94 G1 X1 F300")
    # F2 = a move of 1/2 minute: 10 mm -> 20 mm/min; a 5 mm half circle in one minute.
    assert m.feed_mm_min.tolist() == pytest.approx([20.0, 5 * math.pi, 300.0])
    with pytest.raises(GcodeError, match="error 22"):
        parse("G93 G1 X1 F1\nG1 X2")                   # F is not modal in G93
    with pytest.raises(GcodeError, match="error 22"):
        parse("G1 X1 F100\nG93\nG94\nG1 X2")            # back in G94 the feed is undefined


def test_g38_probe_is_recorded_with_the_beam_off():
    m = parse("M3 S500\nG38.2 Z-5 F100\nG0 Z0")
    assert [(r.kind, r.value, r.index) for r in m.records] == [("probe", 38.2, 0)]
    assert m.kind[0] == MoveKind.LINE and m.laser[0] == LaserMode.OFF
    # The position after a probe is taken as its target (no contact): documented.
    assert machine(m)[0] == [0, 0, -5]


def test_t_m6_m7_g61_as_grbl_treats_them():
    assert len(parse("T5\nG61\nG40\nG91.1\nM8\nM9\nG1 X1 F10")) == 1
    for line, code in (("M6", 20), ("M7", 20), ("T256", 38), ("G90.1", 20)):
        with pytest.raises(GcodeError, match=f"error {code}"):
            parse(line)
    assert len(parse("M7\nT5 M6", dialect="labkit-fw", lenient=True).diagnostics) == 1


def test_marlin_printer_files_parse():
    text = ("M82\nM104 S200\nM140 S60\nM190 S60\nM109 S200\nG28\nG92 E0\nG1 Z0.3 F3000\n"
            "G1 X10 Y5 E1.5 F1200\nM106 S128\nM107\nM83\nG92 X0 E0\nG1 X2 E0.1\nG28 X0\nM84\n")
    m = parse(text, dialect="marlin")
    assert [r.kind for r in m.records].count("printer") == 7
    values = [r.value for r in m.records if r.kind == "printer"]
    assert math.isnan(values[0]) and values[1:5] == [200.0, 60.0, 60.0, 200.0]
    assert machine(m) == [[0, 0, 0], [0, 0, 0.3], [10, 5, 0.3], [12, 5, 0.3], [0, 5, 0.3]]
    assert work(m)[3] == [2, 5, 0.3]
    # Temperatures are not laser power; M106 S128 is (the fan output used as a laser).
    assert m.s_word.tolist() == [0, 0, 0, 128, 128]


def test_emitted_programs_carry_machine_positions_and_read_back():
    m = parse("G10 L2 P1 X5\nG0 X0\nG1 X10 F100")
    back = parse(emit(m))
    np.testing.assert_allclose(back.end, m.end)
