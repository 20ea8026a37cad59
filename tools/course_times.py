"""How long each chapter takes to work through, estimated from what it holds.

Counted in the student edition of each chapter (solutions and appendices removed, as a student
sees it): the words of its prose, its code cells, its widgets and its exercises. Each count is
turned into minutes at a stated rate — these are assumptions, written here so that a teacher
can change them, not measurements of students:

* prose at 120 words a minute (technical text with formulas; fluent adult reading of plain text
  is about 200–250 words a minute, and study reading of technical text is commonly taken at
  about half of that);
* 1 minute a code cell (read the code, run it, read what it prints or draws);
* 3 minutes more a widget (a cell whose stored output is a widget view, or that builds a
  slider or an interactive figure);
* 8 minutes an exercise (predict/fix/change: write the answer, run it, compare).

Usage::

    python tools/course_times.py [--markdown]
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

import nbformat

from labkit.course import STUB_TAG, student_edition

NOTEBOOKS = Path(__file__).resolve().parents[1] / "notebooks"
WORDS_PER_MIN = 120
CODE_CELL_MIN = 1.0
WIDGET_MIN = 3.0
EXERCISE_MIN = 8.0
_WIDGET = re.compile(r"\binteract(ive|_figure)?\s*\(|widgets\.\w+\(|ControlPanel\(|\.observe\(")


def chapter_counts(path: Path) -> dict:
    """Words, code cells, widgets and exercises of a chapter's student edition."""
    nb = student_edition(nbformat.read(path, as_version=4))
    words = code = widgets = 0
    exercises = set()
    for cell in nb.cells:
        if cell.cell_type == "markdown":
            text = re.sub(r"```.*?```", " ", cell.source, flags=re.S)      # code shown, not read as prose
            text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", text)          # a link counts its words only
            words += len(re.findall(r"[^\W_][\w'’\-]*", text))
        elif cell.cell_type == "code":
            if STUB_TAG in cell.metadata.get("tags", []):
                match = re.match(r"# Exercise (\d+)", cell.source)
                exercises.add(match.group(1) if match else cell.source)
                continue
            code += 1
            # a widget: its stored output is a widget view, or the cell builds one
            views = any("application/vnd.jupyter.widget-view+json" in out.get("data", {})
                        for out in cell.get("outputs", []))
            widgets += bool(views or _WIDGET.search(cell.source))
    return dict(words=words, code_cells=code, widgets=widgets, exercises=len(exercises))


def minutes(counts: dict) -> tuple[float, float]:
    """(reading and running, exercises) in minutes at the module's rates."""
    study = counts["words"] / WORDS_PER_MIN + counts["code_cells"] * CODE_CELL_MIN \
        + counts["widgets"] * WIDGET_MIN
    return study, counts["exercises"] * EXERCISE_MIN


def table(paths) -> list[dict]:
    rows = []
    for path in paths:
        counts = chapter_counts(path)
        study, work = minutes(counts)
        rows.append(dict(chapter=path.name, **counts, study_min=round(study), exercises_min=round(work),
                         total_min=round(study + work)))
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--markdown", action="store_true", help="a Markdown table (for TEACHING.md)")
    args = parser.parse_args(argv)
    rows = table(sorted(NOTEBOOKS.glob("[0-9][0-9]-*.ipynb"))[1:])
    if args.markdown:
        print("| chapter | words | code cells | widgets | exercises | read and run (min) | exercises (min) | total (min) |")
        print("|---|---:|---:|---:|---:|---:|---:|---:|")
        for r in rows:
            print(f"| {r['chapter'][:2]} | {r['words']} | {r['code_cells']} | {r['widgets']} | {r['exercises']} "
                  f"| {r['study_min']} | {r['exercises_min']} | {r['total_min']} |")
    else:
        for r in rows:
            print(" ".join(f"{k}={v}" for k, v in r.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
