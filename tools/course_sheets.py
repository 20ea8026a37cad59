"""Printable course material from the chapters, as HTML (nbconvert): ``make sheets``.

Written into one folder (default ``build/sheets``):

``exercise-sheet.html``
    every chapter's exercises, without answers (from the student edition).
``answer-key.html``
    every chapter's exercises with the solution cells, code and printed results.
``handout-lesson-N.html``
    one page per lesson of TEACHING.md's eight-lesson plan: what to do before class, in class
    and as homework, and the "What to take away" of each chapter the lesson works in.
``marking-scheme.html``
    points per exercise: for the exercises the virtual machine checks, a point per check it
    runs (:mod:`labkit.grade`); for the others, the three parts a teacher marks.
``capstone-rubric.html``
    the capstone project's criteria (TEACHING.md's weights) at four levels.

Usage::

    python tools/course_sheets.py [OUT]
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

import nbformat
from nbconvert import HTMLExporter

from labkit.course import SOLUTION_TAG, student_edition
from labkit.grade import EXERCISES

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = ROOT / "notebooks"
TEACHING = NOTEBOOKS / "TEACHING.md"


def _chapters():
    return [p for p in sorted(NOTEBOOKS.glob("[0-9][0-9]-*.ipynb")) if not p.name.startswith("00")]


def _title(nb) -> str:
    return nb.cells[0].source.split("\n", 1)[0].lstrip("# ").strip()


def _section(nb, heading: str):
    """Index of the markdown cell that opens ``## heading`` and of the next ``##`` cell."""
    start = next((k for k, c in enumerate(nb.cells) if c.cell_type == "markdown"
                  and re.search(rf"^## {heading}", c.source, re.M)), None)
    if start is None:
        return None, None
    end = next((k for k in range(start + 1, len(nb.cells)) if nb.cells[k].cell_type == "markdown"
                and nb.cells[k].source.lstrip().startswith("## ")), len(nb.cells))
    return start, end


def _from_heading(text: str, heading: str) -> str:
    """A cell's text after its ``## heading`` line (a cell may hold a section before it)."""
    return re.split(rf"^## {heading}[^\n]*\n", text, maxsplit=1, flags=re.M)[-1].strip()


def _html(cells, title: str, path: Path) -> None:
    nb = nbformat.v4.new_notebook()
    nb.cells = cells
    nb.metadata["title"] = title
    body, _ = HTMLExporter(template_name="classic").from_notebook_node(nb)
    path.write_text(body, encoding="utf-8")


def _md(text: str):
    return nbformat.v4.new_markdown_cell(text)


def exercise_sheet(out: Path, *, answers: bool) -> Path:
    cells = [_md("# labkit — " + ("answer key" if answers else "exercise sheet"))]
    for path in _chapters():
        nb = nbformat.read(path, as_version=4)
        shown = nb if answers else student_edition(nb)
        start, end = _section(shown, "Exercises")
        if start is None:
            continue
        cells.append(_md(f"## {_title(nb)}"))
        body = _from_heading(shown.cells[start].source, "Exercises")
        cells.append(_md(body))
        if answers:
            for cell in shown.cells[start + 1:end]:
                if SOLUTION_TAG in cell.metadata.get("tags", []):
                    shown_cell = nbformat.from_dict(dict(cell))
                    shown_cell.metadata = {}
                    cells.append(shown_cell)
    target = out / ("answer-key.html" if answers else "exercise-sheet.html")
    _html(cells, "answer key" if answers else "exercise sheet", target)
    return target


def lessons() -> list[dict]:
    """TEACHING.md's eight lessons: number, name, before, in class, homework (Markdown)."""
    rows = re.findall(r"^\| (\d+)\. ([^|]+) \| ([^|]*) \| ([^|]*) \| ([^|]*) \|$",
                      TEACHING.read_text(encoding="utf-8"), re.M)
    return [dict(number=int(n), name=name.strip(), before=b.strip(), in_class=c.strip(), homework=h.strip())
            for n, name, b, c, h in rows]


def handouts(out: Path) -> list[Path]:
    written = []
    for lesson in lessons():
        cells = [_md(f"# Lesson {lesson['number']}: {lesson['name']}\n\n"
                     f"**Before class:** {lesson['before'] or '—'}\n\n"
                     f"**In class:** {lesson['in_class']}\n\n"
                     f"**Homework:** {lesson['homework']}")]
        files = dict.fromkeys(re.findall(r"\((\d\d-[^)]+\.ipynb)\)", lesson["in_class"]))
        for name in files:
            nb = nbformat.read(NOTEBOOKS / name, as_version=4)
            start, _ = _section(nb, "What to take away")
            if start is not None:
                cells.append(_md(f"## {_title(nb)}: what to take away\n\n"
                                 + _from_heading(nb.cells[start].source, "What to take away")))
        target = out / f"handout-lesson-{lesson['number']}.html"
        _html(cells, f"lesson {lesson['number']}", target)
        written.append(target)
    return written


_MARKED_PARTS = {
    "Predict": "prediction written before running, with its reason (2) · the run compared with it (1) · "
               "the difference explained (2)",
    "Fix": "the fault named with the message that shows it (2) · the fix, smallest that works (2) · "
           "checked by running it (1)",
    "Change": "the change made and run (2) · the numbers asked for (1) · the why, in a sentence or two (2)",
}


def marking_scheme(out: Path) -> Path:
    rows = ["| exercise | marks (5 in all) |", "|---|---|"]
    for path in _chapters():
        nb = nbformat.read(path, as_version=4)
        start, _ = _section(nb, "Exercises")
        if start is None:
            continue
        for number, kind in re.findall(r"^(\d+)\.\s+(?:\*\*)?(\w+)",
                                       _from_heading(nb.cells[start].source, "Exercises"), re.M):
            key = f"{path.name[:2]}-{number}"
            if key in EXERCISES:
                marks = (f"checked by the virtual machine (`labkit course grade`): one mark a check passed, "
                         f"scaled to 5 — {', '.join(_checks_of(key))}")
            else:
                part = next((v for k, v in _MARKED_PARTS.items() if kind.lower().startswith(k.lower())),
                            "the answer (3) · how it was found, shown by running it (2)")
                marks = part
            rows.append(f"| {key} | {marks} |")
    _html([_md("# Marking scheme per exercise\n\n" + "\n".join(rows))], "marking scheme",
          out / "marking-scheme.html")
    return out / "marking-scheme.html"


def _checks_of(key: str) -> list[str]:
    """The checks the grader runs for an exercise (those its specification asks for)."""
    ex = EXERCISES[key]
    names = ["check", "machine", "work area"]
    if ex.drawing:
        names += ["drawing", "nothing else"]
    if ex.max_time_s is not None:
        names.append("time")
    if ex.feed_mm_min is not None:
        names.append("speed")
    if ex.width_mm is not None:
        names.append("width")
    if ex.beam_off:
        names.append("beam off")
    return names


_RUBRIC = [
    ("The job (30 %)", "runs on the virtual machine and the machine without a fault; every safety rule of "
     "chapter 23 kept; the fault and resume of step 3 done and the resumed job complete",
     "runs; safe; resume done with one slip that the report explains",
     "runs after help; one safety rule missed but caught before burning",
     "does not run, or burns where it should not, or no resume"),
    ("The plan and its justification (30 %)", "feed, power and passes chosen from the student's own test "
     "grid (chapter 16) with the fit and its interval; kerf measured and used",
     "settings from the grid, kerf from the table; reasons given",
     "settings from the starting table only, with a reason",
     "settings without a reason"),
    ("Measurement and explanation (30 %)", "outside size, holes and engraving measured; every difference "
     "over 0.1 mm explained by a named cause with a number (kerf, steps/mm, focus, corners)",
     "measured; most differences explained",
     "measured; differences listed, not explained",
     "not measured"),
    ("Presentation (10 %)", "a notebook that runs top to bottom: figures from labkit, one clear plot, "
     "what they would change", "runs, one figure missing", "runs after fixes", "does not run"),
]


def capstone_rubric(out: Path) -> Path:
    rows = ["| criterion | excellent | good | adequate | insufficient |", "|---|---|---|---|---|"]
    rows += [f"| {c} | {a} | {b} | {d} | {e} |" for c, a, b, d, e in _RUBRIC]
    _html([_md("# Capstone project: rubric\n\nFrom a picture to a burned, measured part (TEACHING.md). "
               "Score each criterion at one level: excellent 100 %, good 75 %, adequate 50 %, "
               "insufficient 0 % of its weight.\n\n" + "\n".join(rows))], "capstone rubric",
          out / "capstone-rubric.html")
    return out / "capstone-rubric.html"


def build(out) -> list[Path]:
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    return [exercise_sheet(out, answers=False), exercise_sheet(out, answers=True), *handouts(out),
            marking_scheme(out), capstone_rubric(out)]


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    written = build(argv[0] if argv else ROOT / "build" / "sheets")
    print(f"{len(written)} sheets written to {written[0].parent}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
