"""The course's chapters as teaching material: which cells are answers, and the student edition.

Cells are marked with Jupyter **cell tags** (``metadata.tags``), the mechanism that
nbconvert's ``TagRemovePreprocessor``, Jupyter Book and JupyterLab all read:

``solution``
    a worked answer to an exercise: a code cell whose first line is ``# Solution N``. It is
    stored collapsed — ``jupyter.source_hidden`` and ``jupyter.outputs_hidden`` — so neither
    the answer nor its printed result shows when the chapter opens; the first line names the
    exercise and nothing else.
``appendix``
    a cell of the chapter's "Appendix — for researchers": the verification a student does not
    need, from its heading to the end (the navigation line after it stays).
``autograde``
    a check cell: it runs the student's program for a graded exercise on the virtual machine
    (:func:`labkit.grade.check_exercise`). It stays in the student edition without its stored
    output (the teacher's run of the model answer); the solution cell before it that assigns
    the program (``answer_N = "..."``) becomes a stub assigning an empty program.

nbgrader's markup (``### BEGIN SOLUTION`` inside a cell, its own metadata and an ``assign``
step) was considered and not used: the chapters' answers are whole cells that follow the
exercise list rather than blanks inside an exercise's code, the appendices are not graded
work, and nbgrader would add a course database and a pinned Jupyter stack to a toolkit that
only needs to drop and stub cells. Plain tags keep the chapters readable by every Jupyter tool.

:func:`student_edition` removes the tagged cells (and so their outputs), puts a stub to fill
in where each answer was, and keeps every other cell with its stored outputs;
:func:`write_student_edition` does that for every chapter of a folder (``labkit course
student DIR``, ``make student STUDENT_DIR=DIR``).
"""

from __future__ import annotations

import copy
import re
import shutil
from pathlib import Path

__all__ = ["APPENDIX_HEADING", "APPENDIX_TAG", "CHECK_TAG", "SOLUTION_TAG", "STUB_TAG", "mark_chapter",
           "student_edition", "write_student_edition"]

SOLUTION_TAG = "solution"
APPENDIX_TAG = "appendix"
STUB_TAG = "exercise-stub"
CHECK_TAG = "autograde"
APPENDIX_HEADING = "## Appendix — for researchers"
#: folders beside the chapters that their links and pictures need
SUPPORT_FOLDERS = ("figures", "handouts")
#: pages for students beside the chapters (the teacher's guide stays out)
SUPPORT_PAGES = ("PREREQUISITES.md", "FURTHER-READING.md")

_SOLUTION_FIRST_LINE = re.compile(r"#\s*Solution\s+(\d+)\b\s*[:.]?\s*(.*)")
#: a solution cell that hands a program to a check cell: ``answer_N = ...`` on a line of its own
_ANSWER_ASSIGNMENT = re.compile(r"^(answer_\d+)\s*=", re.M)


def _tags(cell) -> list:
    return cell.setdefault("metadata", {}).setdefault("tags", [])


def _is_navigation(cell) -> bool:
    return cell.cell_type == "markdown" and cell.source.lstrip("-\n ").startswith("[← index]")


def solution_number(cell) -> int | None:
    """The exercise a solution cell answers (its ``# Solution N`` first line), else None."""
    if cell.cell_type != "code":
        return None
    match = _SOLUTION_FIRST_LINE.fullmatch(cell.source.split("\n", 1)[0].strip())
    return int(match.group(1)) if match else None


def mark_chapter(nb) -> int:
    """Tag and hide a chapter's solution and appendix cells, in place.

    A markdown cell holding the appendix heading after other text is split in two there.
    A solution's first line keeps only ``# Solution N``; anything after it on that line
    moves to a comment line of its own, so a collapsed cell shows no answer.

    Parameters
    ----------
    nb : nbformat.NotebookNode
        A chapter (nbformat 4).

    Returns
    -------
    int
        How many cells were changed or added (0: the chapter was already marked).
    """
    import nbformat

    changed = 0
    cells = []
    for cell in nb.cells:
        at = cell.source.find(APPENDIX_HEADING) if cell.cell_type == "markdown" else -1
        if at > 0:
            before = copy.deepcopy(cell)
            before.source = cell.source[:at].rstrip()
            cells += [before, nbformat.v4.new_markdown_cell(cell.source[at:])]
            changed += 2
        else:
            cells.append(cell)
    in_appendix = False
    for cell in cells:
        if cell.cell_type == "markdown" and cell.source.startswith(APPENDIX_HEADING):
            in_appendix = True
        number = solution_number(cell)
        if number is not None:
            first, _, rest = cell.source.partition("\n")
            answer = _SOLUTION_FIRST_LINE.fullmatch(first.strip()).group(2)
            wanted_source = f"# Solution {number}" + (f"\n# {answer}" if answer else "") + (f"\n{rest}" if rest else "")
            hidden = {"source_hidden": True, "outputs_hidden": True}
            if (cell.source != wanted_source or SOLUTION_TAG not in _tags(cell)
                    or cell.metadata.get("jupyter") != hidden):
                cell.source = wanted_source
                if SOLUTION_TAG not in _tags(cell):
                    _tags(cell).append(SOLUTION_TAG)
                cell.metadata["jupyter"] = hidden
                changed += 1
        elif _is_navigation(cell):
            if APPENDIX_TAG in _tags(cell):
                _tags(cell).remove(APPENDIX_TAG)
                changed += 1
        elif in_appendix and APPENDIX_TAG not in _tags(cell):
            _tags(cell).append(APPENDIX_TAG)
            changed += 1
    for cell in cells:          # no empty tag lists left behind
        if cell.metadata.get("tags") == []:
            del cell.metadata["tags"]
    nb.cells = cells
    return changed


def student_edition(nb):
    """The student's copy of a chapter: answers and appendix out, a stub per exercise.

    Parameters
    ----------
    nb : nbformat.NotebookNode
        A marked chapter (see :func:`mark_chapter`); it is not modified.

    Returns
    -------
    nbformat.NotebookNode
        A new notebook: every cell tagged ``solution`` is replaced by an empty code cell
        tagged ``exercise-stub`` ("# Exercise N: your answer here"; for a solution that
        assigns a graded program, the same assignment of an empty program), every cell
        tagged ``appendix`` is dropped with its outputs, cells tagged ``autograde`` lose
        their outputs, and the other cells keep their outputs.
    """
    import nbformat

    edition = copy.deepcopy(nb)
    cells = []
    for cell in edition.cells:
        tags = cell.get("metadata", {}).get("tags", [])
        if SOLUTION_TAG in tags:
            number = solution_number(cell)
            label = f"Exercise {number}" if number is not None else "Exercise"
            answer = _ANSWER_ASSIGNMENT.search(cell.source)
            if answer:
                text = (f"# {label}: your program here, between the quotes; the cell below runs it "
                        f"on the virtual machine\n{answer.group(1)} = \"\"\"\n\"\"\"\n")
            else:
                text = f"# {label}: your answer here\n"
            stub = nbformat.v4.new_code_cell(text)
            stub.metadata["tags"] = [STUB_TAG]
            cells.append(stub)
        elif CHECK_TAG in tags:
            cell.outputs, cell.execution_count = [], None
            cells.append(cell)
        elif APPENDIX_TAG not in tags:
            cells.append(cell)
    edition.cells = cells
    nbformat.validate(edition)
    return edition


def write_student_edition(source_dir, out_dir) -> list[Path]:
    """Write the student edition of every chapter in ``source_dir`` into ``out_dir``.

    Parameters
    ----------
    source_dir : str or os.PathLike
        The folder of chapters (``*.ipynb``), e.g. the repository's ``notebooks/``.
    out_dir : str or os.PathLike
        Where the edition goes; created if missing; must not be ``source_dir`` itself.
        The chapters' ``figures/`` and ``handouts/`` folders and the students' pages
        (prerequisites, further reading) are copied beside them.

    Returns
    -------
    list of pathlib.Path
        The notebooks written, in name order.

    Raises
    ------
    labkit.errors.InputError
        The source folder is missing or holds no notebooks, the output folder is the source
        folder or an existing file, or a chapter is not a readable notebook.
    """
    import nbformat

    from labkit._files import atomic_output
    from labkit.errors import InputError

    source, out = Path(source_dir), Path(out_dir)
    if not source.is_dir():
        raise InputError(f"{source}: no such folder of chapters")
    chapters = sorted(source.glob("*.ipynb"))
    if not chapters:
        raise InputError(f"{source}: no notebooks (*.ipynb) in this folder")
    if out.exists() and not out.is_dir():
        raise InputError(f"{out}: exists and is not a folder; the student edition needs a folder")
    if out.resolve() == source.resolve():
        raise InputError(f"{out}: is the chapters' own folder; the student edition must go elsewhere")
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for path in chapters:
        try:
            nb = nbformat.read(path, as_version=4)
        except (ValueError, KeyError, nbformat.reader.NotJSONError) as exc:
            raise InputError(f"{path}: not a readable notebook ({exc})") from None
        edition = student_edition(nb)
        target = out / path.name
        with atomic_output(target, "w", encoding="utf-8") as fh:
            fh.write(nbformat.writes(edition))
        written.append(target)
    for name in SUPPORT_FOLDERS:
        if (source / name).is_dir():
            shutil.copytree(source / name, out / name, dirs_exist_ok=True)
    for name in SUPPORT_PAGES:
        if (source / name).is_file():
            shutil.copy(source / name, out / name)
    return written
