"""The autograder: a student's program run on the virtual machine and checked as a teacher would.

Every check is shown failing on a hand-written wrong answer (and only the checks that answer
gets wrong fail); the figures it measures are held to closed forms: coverage and stray length
of hand-drawn burns, the trapezoidal move time, the dose model's width worked out by hand.
"""

import csv
import math
import re

import nbformat
import numpy as np
import pytest

from labkit.cli import main
from labkit.errors import InputError
from labkit.geometry.path import Path
from labkit.grade import (EXERCISES, Exercise, answers_in_notebook, check_exercise,
                          drawing_from_gcode, grade, grade_folder)

# hand-written model answers (the chapters' check cells carry the same programs)
RIGHT_22_2 = "G21 G90\nG0 X50 Y40\nG10 L20 P2 X0 Y0\nG55\nM3 S300 F600\nG1 X10\nG1 Y10\nG1 X0\nG1 Y0\nM5\n"
# the exercise's own broken program: G10 L20 P2 sets G55's origin, the cut runs in G54
BROKEN_22_2 = "G21 G90\nG0 X50 Y40\nG10 L20 P2 X0 Y0\nM3 S300 F600\nG1 X10\nG1 Y10\nG1 X0\nG1 Y0\nM5\n"
RIGHT_16_1 = "G21 G90\nG0 X10 Y10\nM4 S718.6 F900\nG1 X30\nM5\n"


def failed(g):
    return [c.name for c in g.checks if not c.passed]


def test_model_answers_pass_every_check():
    for key, program in [("22-2", RIGHT_22_2), ("16-1", RIGHT_16_1),
                         ("21-2", "G21 G90 G0 X0 Y0\nM3 S300\nG3 X0 Y0 I5 J0 F300\nM5\n"),
                         ("02-2", "G1 X0 Y0 F100\nG2 X10 Y0 I5 J0\n"),
                         ("05-2", "G0 X9.9 Y9.9\nM4 S800 F600\nG1 X30.1\nY30.1\nX9.9\nY9.9\nM5\n")]:
        g = grade(key, program)
        assert g.passed, g.summary()


def test_check_fails_on_a_program_grbl_refuses_and_nothing_else_runs():
    g = grade("21-2", "G21 G90 G0 X0 Y0\nM3 S300\nG3 X0 Y0 R5 F300\nM5\n")   # the exercise's program
    assert [c.name for c in g.checks] == ["check"] and not g.passed
    assert "answer:3:" in g.checks[0].detail
    g = grade("22-2", '"""\n"""'.strip('"\n'))
    assert failed(g) == ["check"] and "empty" in g.checks[0].detail


def test_wrong_offset_burns_elsewhere_drawing_and_nothing_else_fail():
    g = grade("22-2", BROKEN_22_2)
    assert failed(g) == ["drawing", "nothing else"]
    # the broken program cuts from (50, 40) to (10, 40), (10, 10), (0, 10), (0, 0): 90 mm, of
    # which only the first 0.05 mm lies on the target (its corner at (50, 40))
    assert g.figures["coverage"] < 0.01 and g.figures["stray_mm"] == pytest.approx(90.0, abs=0.1)


def test_work_area_names_the_line_that_leaves_it():
    g = grade("22-2", "G21 G90\nG0 X50 Y40\nM3 S300 F600\nG1 X60\nY50\nX50\nY40\nG0 X-5\nM5\n")
    assert failed(g) == ["work area"]
    assert "line 8 (G0X-5)" in g.checks[2].detail and "X-5.000" in g.checks[2].detail


def test_coverage_and_stray_are_measured_lengths():
    # two of the square's four sides (exactly half of it), then a 3 mm burn away from it
    g = grade("22-2", "G21 G90\nG0 X50 Y40\nM3 S300 F600\nG1 X60\nY50\nG0 X70 Y70\nG1 X73\nM5\n")
    assert failed(g) == ["drawing", "nothing else"]
    assert g.figures["coverage"] == pytest.approx(0.5, abs=0.01)
    assert g.figures["stray_mm"] == pytest.approx(3.0, abs=0.03)
    # the stray is sampled in the middle of pieces of at most 0.02 mm (grade's sampling step):
    # its first sample lies within half a step of where it starts, (70, 70), and is printed to
    # 0.01 mm (how far in depends on where the machine's ticks cut the move)
    x, y = (float(v) for v in re.search(r"first at X([\d.]+) Y([\d.]+)", g.checks[4].detail).groups())
    assert math.hypot(x - 70.0, y - 70.0) <= 0.02 / 2 + 0.005


def test_time_is_the_trapezoid_and_a_slow_program_fails():
    # 20 mm at 900 mm/min (15 mm/s) from rest to rest with 1000 mm/s²: t = L/v + v/a
    g = grade("16-1", RIGHT_16_1)
    line_s = 20 / 15 + 15 / 1000
    # first the rapid from the work origin to (10, 10): along 45° the per-axis 100 mm/s and
    # 1000 mm/s² allow 141.4 mm/s and 1414 mm/s², which 14.14 mm just reaches: t = 2·sqrt(L/a)
    rapid_s = 2 * math.sqrt(math.hypot(10, 10) / (1000 * math.sqrt(2)))
    # the machine advances a 0.02 s tick per poll and a poll passes with each line written:
    # the first two lines (G21 G90, then the rapid itself) cost two ticks before motion starts
    assert 0 <= g.figures["time_s"] - (line_s + rapid_s) <= 2 * 0.02 + 1e-9
    slow = RIGHT_16_1.replace("F900", "F100")
    assert "time" in failed(grade("16-1", slow))


def test_width_is_the_dose_model_worked_by_hand_and_a_wrong_power_fails():
    g = grade("16-1", RIGHT_16_1)
    p_mw = 718.6 / 1000 * 5500                   # S of S1000 at the machine's 5500 mW
    peak = math.sqrt(2 / math.pi) * p_mw / (15.0 * 0.12)       # mJ/mm², v = 15 mm/s
    assert g.figures["width_mm"] == pytest.approx(0.12 * math.sqrt(2 * math.log(peak / 200)), abs=1e-3)
    assert failed(grade("16-1", RIGHT_16_1.replace("S718.6", "S500"))) == ["width"]


def test_speed_fails_when_the_width_is_right_at_another_feed():
    # twice the power at twice the feed: the same P/v, so the same dose-model width
    g = grade("16-1", RIGHT_16_1.replace("S718.6 F900", "S1000 F1252.4"))
    assert failed(g) == ["speed"]
    assert g.figures["width_mm"] == pytest.approx(0.25, abs=0.005)


def test_beam_left_on_or_armed_fails():
    on = grade("22-2", RIGHT_22_2.replace("M5\n", ""))           # M3 stays on at rest
    assert failed(on) == ["beam off"] and "still on" in on.checks[-1].detail
    armed = grade("16-1", RIGHT_16_1.replace("M5\n", ""))        # M4: dark at rest, but armed
    assert failed(armed) == ["beam off"] and "M4 S718.6 still in effect" in armed.checks[-1].detail
    assert grade("16-1", RIGHT_16_1.replace("M5", "M2")).passed    # program end: GRBL's M5


def test_kerf_exercise_fails_without_compensation():
    g = grade("05-2", "G0 X10 Y10\nM4 S800 F600\nG1 X30\nY30\nX10\nY10\nM5\n")
    assert failed(g) == ["drawing", "nothing else"]


def test_01_3_the_unchanged_program_fails_on_speed():
    original = ("G21 G90\nM3 S600\nG0 X15 Y5\nG1 X30 F1200\nX35\nG91 G3 X5 Y5 I0 J5\nG1 Y20\n"
                "G3 X-5 Y5 I-5 J0\nG90 G1 X15\nG3 X10 Y30 I0 J-5\nG1 Y10\nG3 X15 Y5 I5 J0\nM5\n")
    assert failed(grade("01-3", original)) == ["speed"]
    assert failed(grade("01-3", original.replace("F1200", "F600"))) == ["width"]   # feed alone: wider
    assert grade("01-3", original.replace("S600", "S300").replace("F1200", "F600")).passed


def test_feed_exercise_fails_on_the_wrong_arc():
    # R6: a flatter arc between the same ends, 1 mm below the half circle's top
    assert "drawing" in failed(grade("02-2", "G1 X0 Y0 F100\nG2 X10 Y0 R6\n"))
    assert "drawing" in failed(grade("02-2", "G1 X0 Y0 F100\nG3 X10 Y0 R5\n"))   # under, not over


def test_drawing_from_gcode_is_exact():
    d = drawing_from_gcode("G0 X10 Y10\nM3 S500 F600\nG1 X20\nG2 X30 Y10 I5 J0\nG0 X0\nM5")
    assert [p.length_mm for p in d] == pytest.approx([10.0, 5 * math.pi])
    np.testing.assert_allclose(d[1].bounds(), [[20, 10], [30, 15]], atol=1e-9)


def test_bad_input_gets_a_clear_error(capsys):
    with pytest.raises(InputError, match="no graded exercise '99-9'"):
        grade("99-9", "G1 X1")
    with pytest.raises(InputError, match="G-code text"):
        grade("22-2", 42)
    with pytest.raises(InputError, match="min_coverage"):
        Exercise("0-1", "x", min_coverage=0)
    assert check_exercise("22-2", None) is None
    assert 'answer_2 = """..."""' in capsys.readouterr().out
    assert check_exercise("nope", "G1") is None
    assert "no graded exercise" in capsys.readouterr().out


def test_at_least_six_exercises_across_the_course():
    chapters = {k.split("-")[0] for k in EXERCISES}
    assert len(EXERCISES) >= 6 and len(chapters) >= 5


def _notebook_with(answer):
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_code_cell(f"answer_2 = '''{answer}'''"),
                nbformat.v4.new_code_cell('from labkit.grade import check_exercise\n'
                                          'check_exercise("22-2", answer_2);')]
    return nb


def test_grade_folder_reports_and_csv(tmp_path, capsys):
    subs = tmp_path / "subs"
    (subs / "alice").mkdir(parents=True)
    (subs / "alice" / "22-2.gcode").write_text(RIGHT_22_2)
    (subs / "alice" / "16-1.nc").write_text(RIGHT_16_1.replace("S718.6", "S500"))
    (subs / "bob").mkdir()
    (subs / "bob" / "22-2.gcode").write_text(BROKEN_22_2)
    nbformat.write(_notebook_with(RIGHT_22_2), subs / "carol.ipynb")
    assert answers_in_notebook(subs / "carol.ipynb") == {"22-2": RIGHT_22_2}
    assert main(["course", "grade", str(subs)]) == 0
    table = capsys.readouterr().out
    assert "alice" in table and "reports and grades.csv written" in table
    out = subs / "grades"
    rows = list(csv.DictReader(open(out / "grades.csv")))
    by = {(r["student"], r["exercise"]): r for r in rows}
    assert by["alice", "22-2"]["passed"] == "1" and by["carol", "22-2"]["passed"] == "1"
    assert by["alice", "16-1"]["failed"] == "width"
    assert by["bob", "22-2"]["failed"] == "drawing nothing_else"
    assert by["bob", "16-1"]["failed"] == "no answer"
    assert len(rows) == 3 * len(EXERCISES)
    report = (out / "bob.txt").read_text()
    assert "Exercises passed: 0 of" in report and "[--] drawing" in report
    assert (out / "alice.txt").read_text().count("PASSED") == 1


def test_grade_folder_refuses_bad_folders(tmp_path):
    with pytest.raises(InputError, match="no such folder"):
        grade_folder(tmp_path / "none", tmp_path / "out")
    (tmp_path / "empty").mkdir()
    with pytest.raises(InputError, match="no submissions"):
        grade_folder(tmp_path / "empty", tmp_path / "out")
    (tmp_path / "s" / "x").mkdir(parents=True)
    (tmp_path / "file").write_text("")
    with pytest.raises(InputError, match="not a folder"):
        grade_folder(tmp_path / "s", tmp_path / "file")
    (tmp_path / "s" / "x" / "broken.ipynb").write_text("{not json")
    with pytest.raises(InputError, match="not a readable notebook"):
        grade_folder(tmp_path / "s", tmp_path / "out")
