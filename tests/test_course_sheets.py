"""make sheets: the printable material, built from the chapters and checked for what each must (not) hold."""

import re
import sys
from pathlib import Path

import nbformat
import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))
import course_sheets as sheets  # noqa: E402

from labkit.grade import EXERCISES, grade  # noqa: E402


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    out = tmp_path_factory.mktemp("sheets")
    sheets.build(out)
    return out


def _text(path):
    return re.sub(r"<[^>]+>", " ", path.read_text(encoding="utf-8"))


def test_the_exercise_sheet_has_every_exercise_and_no_answer(built):
    sheet, key = _text(built / "exercise-sheet.html"), _text(built / "answer-key.html")
    assert "OD 4 is NOT enough" in key and "OD 4 is NOT enough" not in sheet   # chapter 23's answer
    assert "Solution 1" in key and "Solution" not in sheet
    for path in sheets._chapters():
        assert sheets._title(nbformat.read(path, as_version=4)).split(" · ")[1][:20] in sheet


def test_one_handout_per_lesson_with_the_take_aways_of_its_chapters(built):
    lessons = sheets.lessons()
    assert [le["number"] for le in lessons] == list(range(1, 9))
    seven = _text(built / "handout-lesson-7.html")
    assert "Characterising the laser" in seven and "what to take away" in seven
    assert "16 · Cut width" in seven


def test_the_marking_scheme_covers_every_exercise_and_the_graders_checks(built):
    scheme = _text(built / "marking-scheme.html")
    for path in sheets._chapters():
        nb = nbformat.read(path, as_version=4)
        start, _ = sheets._section(nb, "Exercises")
        for number in re.findall(r"^(\d+)\.\s", sheets._from_heading(nb.cells[start].source, "Exercises"), re.M):
            assert f"{path.name[:2]}-{number}" in scheme
    # the checks listed for a graded exercise are those the grader runs
    names = [c.name for c in grade("16-1", "G0 X10 Y10\nM4 S718.6 F900\nG1 X30\nM5").checks]
    assert names == sheets._checks_of("16-1")
    assert all(key in scheme for key in EXERCISES)


def test_the_capstone_rubric_has_four_levels_for_each_criterion(built):
    rubric = (built / "capstone-rubric.html").read_text(encoding="utf-8")
    rows = re.findall(r"<tr>(.*?)</tr>", rubric, re.S)
    assert len(rows) == 1 + 4 and all(len(re.findall(r"<t[dh]", r)) == 5 for r in rows)
    weights = [int(w) for w in re.findall(r"\((\d+) %\)", _text(built / "capstone-rubric.html"))]
    assert sum(weights) == 100
