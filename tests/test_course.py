"""The chapters as course material: answers hidden and tagged, and the student edition without them."""

import re
from pathlib import Path

import nbformat
import pytest

from labkit.cli import main
from labkit.course import (APPENDIX_HEADING, APPENDIX_TAG, CHECK_TAG, SOLUTION_TAG, STUB_TAG,
                           mark_chapter, student_edition, write_student_edition)

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = ROOT / "notebooks"
CHAPTERS = sorted(NOTEBOOKS.glob("[0-9][0-9]-*.ipynb"))


def _read(path):
    return nbformat.read(path, as_version=4)


def _tags(cell):
    return cell.get("metadata", {}).get("tags", [])


def _text(cell):
    """A cell's source and the text of its outputs, as a reader would see them."""
    parts = [cell.source]
    for out in cell.get("outputs", []):
        parts.append(out.get("text", ""))
        parts.extend(str(v) for k, v in out.get("data", {}).items() if k.startswith("text/"))
    return "\n".join(parts)


@pytest.mark.parametrize("path", CHAPTERS, ids=lambda p: p.name)
def test_every_solution_is_tagged_hidden_and_shows_no_answer_when_collapsed(path):
    for k, cell in enumerate(_read(path).cells):
        # the test's own reading of what a solution is: a code cell that says "Solution <n>" in a comment
        says_solution = cell.cell_type == "code" and re.search(r"^#\s*Solution\s+\d", cell.source, re.M)
        assert bool(says_solution) == (SOLUTION_TAG in _tags(cell)), f"{path.name} cell {k}"
        if says_solution:
            assert cell.metadata.get("jupyter") == {"source_hidden": True, "outputs_hidden": True}, \
                f"{path.name} cell {k} shows its answer on open"
            assert re.fullmatch(r"# Solution \d+", cell.source.split("\n", 1)[0]), \
                f"{path.name} cell {k}: the first line, seen when collapsed, must only name the exercise"


@pytest.mark.parametrize("path", CHAPTERS, ids=lambda p: p.name)
def test_the_appendix_and_only_the_appendix_is_tagged(path):
    cells = _read(path).cells
    heads = [k for k, c in enumerate(cells) if c.cell_type == "markdown" and APPENDIX_HEADING in c.source]
    assert len(heads) <= 1
    for k, cell in enumerate(cells):
        if heads and k >= heads[0] and "[← index]" not in cell.source:
            assert APPENDIX_TAG in _tags(cell), f"{path.name} cell {k} is in the appendix, untagged"
        else:
            assert APPENDIX_TAG not in _tags(cell), f"{path.name} cell {k} tagged appendix outside it"
    if heads:   # the heading opens its own cell: nothing a student needs shares it
        assert cells[heads[0]].source.startswith(APPENDIX_HEADING)


def test_the_chapters_are_stored_marked():
    for path in CHAPTERS:
        assert mark_chapter(_read(path)) == 0, f"{path.name}: run labkit.course.mark_chapter on it"


def test_student_edition_of_a_hand_made_notebook():
    nb = nbformat.v4.new_notebook()
    kept = nbformat.v4.new_code_cell("x = 2\nprint(x)", execution_count=1,
                                     outputs=[nbformat.v4.new_output("stream", text="2\n")])
    solution = nbformat.v4.new_code_cell("# Solution 3\nprint(x * 21)", execution_count=2,
                                         outputs=[nbformat.v4.new_output("stream", text="42\n")])
    solution.metadata["tags"] = [SOLUTION_TAG]
    heading = nbformat.v4.new_markdown_cell(APPENDIX_HEADING + ": checks")
    check = nbformat.v4.new_code_cell("assert x == 2", execution_count=3)
    heading.metadata["tags"] = check.metadata["tags"] = [APPENDIX_TAG]
    nb.cells = [kept, solution, heading, check]
    edition = student_edition(nb)
    assert [c.source for c in edition.cells] == ["x = 2\nprint(x)", "# Exercise 3: your answer here\n"]
    assert edition.cells[0].outputs == kept.outputs and edition.cells[1].outputs == []
    assert _tags(edition.cells[1]) == [STUB_TAG]
    assert len(nb.cells) == 4      # the teacher's copy is untouched


@pytest.fixture(scope="module")
def edition(tmp_path_factory):
    out = tmp_path_factory.mktemp("student")
    assert main(["course", "student", str(out)]) == 0
    return out


def test_student_edition_has_every_chapter_valid_and_no_answer(edition):
    written = sorted(edition.glob("*.ipynb"))
    assert [p.name for p in written] == [p.name for p in sorted(NOTEBOOKS.glob("*.ipynb"))]
    assert (edition / "handouts" / "laser-lab-checklist.md").is_file()
    assert (edition / "PREREQUISITES.md").is_file() and not (edition / "TEACHING.md").exists()
    for path in written:
        source, student = _read(NOTEBOOKS / path.name), _read(path)
        nbformat.validate(student)
        student_text = "\n".join(_text(c) for c in student.cells)
        kept_text = "\n".join(_text(c) for c in source.cells
                              if not {SOLUTION_TAG, APPENDIX_TAG} & set(_tags(c)))
        removed = [c for c in source.cells if {SOLUTION_TAG, APPENDIX_TAG} & set(_tags(c))]
        assert not any({SOLUTION_TAG, APPENDIX_TAG} & set(_tags(c)) for c in student.cells)
        # every distinctive line of a solution or appendix (source or printed output) is gone
        for cell in removed:
            for line in _text(cell).splitlines():
                line = line.strip()
                if len(line) >= 12 and line not in kept_text:
                    assert line not in student_text, f"{path.name}: {line!r} survived"
        # one stub per solution, and the remaining cells keep their outputs — but for the check
        # cells of graded exercises, whose stored output is the model answer's report
        n_solutions = sum(SOLUTION_TAG in _tags(c) for c in source.cells)
        assert sum(STUB_TAG in _tags(c) for c in student.cells) == n_solutions
        kept = lambda c: c.cell_type == "code" and not {SOLUTION_TAG, APPENDIX_TAG, STUB_TAG} & set(_tags(c))  # noqa: E731
        assert [c.outputs if CHECK_TAG not in _tags(c) else [] for c in source.cells if kept(c)] == \
            [c.outputs for c in student.cells if kept(c)]


def test_graded_exercises_have_a_check_cell_that_works_in_the_student_edition(edition, capsys):
    from labkit.grade import EXERCISES, check_exercise, grade

    seen = {}
    for path in sorted(edition.glob("*.ipynb")):
        teacher, student = _read(NOTEBOOKS / path.name).cells, _read(path).cells
        for k, cell in enumerate(student):
            if CHECK_TAG not in _tags(cell):
                continue
            key = re.search(r'check_exercise\("([0-9]+-[0-9]+)", (answer_[0-9]+)\)', cell.source)
            assert key, f"{path.name} cell {k}: a check cell names its exercise and answer"
            seen[key.group(1)] = path.name
            assert cell.outputs == []
            # the stub before it assigns the empty program the check cell reads
            stub = student[k - 1]
            assert STUB_TAG in _tags(stub) and f"{key.group(2)} = " in stub.source
            namespace = {}
            exec(stub.source, namespace)
            assert grade(key.group(1), namespace[key.group(2)]).checks[0].detail.startswith(
                "the program is empty")
            check_exercise(key.group(1), namespace[key.group(2)])      # what the student sees
            assert "the program is empty" in capsys.readouterr().out
            # in the teacher's chapter the model answer before it passes, and its report is stored
            (source_cell,) = [c for c in teacher if c.source == cell.source]
            model = teacher[teacher.index(source_cell) - 1]
            namespace = {}
            exec(model.source, namespace)
            assert grade(key.group(1), namespace[key.group(2)]).passed
            assert "PASSED" in source_cell.outputs[0]["text"]
    capsys.readouterr()
    assert sorted(seen) == sorted(EXERCISES) and len(seen) >= 6


def test_chapter_23_answer_is_not_in_the_edition(edition):
    # a hand-picked answer from the rebuilt eyewear exercise
    assert "OD 4 is NOT enough" in (NOTEBOOKS / "23-laser-safety-and-materials.ipynb").read_text()
    assert "OD 4 is NOT enough" not in (edition / "23-laser-safety-and-materials.ipynb").read_text()


def test_student_edition_refuses_bad_folders(tmp_path, capsys):
    assert main(["course", "student", str(NOTEBOOKS)]) == 1
    assert "chapters' own folder" in capsys.readouterr().err
    assert main(["course", "student", str(tmp_path / "out"), "--source", str(tmp_path / "none")]) == 1
    assert "no such folder" in capsys.readouterr().err
    (tmp_path / "empty").mkdir()
    assert main(["course", "student", str(tmp_path / "out"), "--source", str(tmp_path / "empty")]) == 1
    assert "no notebooks" in capsys.readouterr().err
    (tmp_path / "bad").mkdir()
    (tmp_path / "bad" / "x.ipynb").write_text("{not json")
    with pytest.raises(Exception, match="not a readable notebook"):
        write_student_edition(tmp_path / "bad", tmp_path / "out")


def test_the_printable_checklist_is_chapter_23s():
    handout = (NOTEBOOKS / "handouts" / "laser-lab-checklist.md").read_text()
    cells = _read(NOTEBOOKS / "23-laser-safety-and-materials.ipynb").cells
    (cell,) = [c for c in cells if "handouts/laser-lab-checklist.md" in c.source]
    assert handout.split("\n", 1)[1].strip() in cell.source
