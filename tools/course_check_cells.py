"""Add the virtual machine's check cells to the chapters' graded exercises (idempotent).

For each graded exercise (:data:`labkit.grade.EXERCISES`) this inserts, right after the
chapter's ``# Solution N`` cell, two cells:

* a solution cell (tagged ``solution``, collapsed) assigning the model program to
  ``answer_N`` — the student edition turns it into a stub assigning an empty program;
* a check cell (tagged ``autograde``) that runs ``check_exercise(KEY, answer_N)``, with the
  output of that run stored so that nbval compares it.

Each notebook is read, changed and written at once (other people edit the chapters' content):
a chapter that already has its check cell is left as it is; one whose file changes while this
runs is skipped with a message. ``--refresh`` stores the current report under existing check
cells (after a change to the grader). Usage::

    python tools/course_check_cells.py [--dry-run] [--refresh] [KEY ...]
"""

from __future__ import annotations

import argparse
import contextlib
import io
import sys
from pathlib import Path

import nbformat

from labkit.course import CHECK_TAG, SOLUTION_TAG, solution_number
from labkit.grade import CH01_PROGRAM, EXERCISES, check_exercise

NOTEBOOKS = Path(__file__).resolve().parents[1] / "notebooks"

#: the model answer of each graded exercise (a program a teacher would accept)
MODEL_ANSWERS = {
    "01-3": CH01_PROGRAM.replace("M3 S600", "M3 S300           ; half the power")
                        .replace("G1 X30 F1200", "G1 X30 F600       ; half the feed"),
    "02-2": """G1 X0 Y0 F100
G2 X10 Y0 R5      ; or: G2 X10 Y0 I5 J0
""",
    "05-2": """G21 G90
G0 X9.9 Y9.9      ; half the 0.2 mm kerf outside the part
M4 S800 F600
G1 X30.1
Y30.1
X9.9
Y9.9
M5
""",
    "16-1": """G21 G90
G0 X10 Y10
M4 S718.6 F900    ; 3952 mW of the machine's 5500 mW at S1000
G1 X30
M5
""",
    "21-2": """G21 G90 G0 X0 Y0
M3 S300
G3 X0 Y0 I5 J0 F300
M5
""",
    "22-2": """G21 G90
G0 X50 Y40
G10 L20 P2 X0 Y0
G55               ; run in the system whose origin was just set
M3 S300 F600
G1 X10
G1 Y10
G1 X0
G1 Y0
M5
""",
}

#: what each check cell tells the student, one comment line or two
PROMPTS = {
    "01-3": "section 1's program at half the power and half the feed: the same square, the same\n"
            "# width (dose model), 600 mm/min, the beam off at the end",
    "02-2": "one of your fixes: the head must trace the half circle over the top, nothing else",
    "05-2": "a 20 mm square part with its corner at (10, 10), cut with a 0.2 mm kerf: the beam's\n"
            "# path must run where the kerf leaves the part its drawn size",
    "16-1": "a 20 mm line from (10, 10) to (30, 10) at 900 mm/min, 0.25 mm wide (w0 = 0.12 mm,\n"
            "# F_th = 200 mJ/mm²; the virtual machine's laser gives 5500 mW at S1000)",
    "21-2": "your fixed program (keep G3): a 10 mm circle through (0, 0) with its centre at (5, 0)",
    "22-2": "your fixed program: the square at the jogged corner (machine X50 Y40), the beam off at the end",
}


def _chapter(key: str) -> Path:
    (path,) = NOTEBOOKS.glob(f"{key.split('-')[0]}-*.ipynb")
    return path


def check_cells(key: str):
    """The solution cell and the check cell of one graded exercise, the check's output stored."""
    number = int(key.split("-")[1])
    name = EXERCISES[key].answer_name
    program = MODEL_ANSWERS[key]
    solution = nbformat.v4.new_code_cell(
        f"# Solution {number}\n# the program the check below runs\n{name} = '''{program}'''")
    solution.metadata["tags"] = [SOLUTION_TAG]
    solution.metadata["jupyter"] = {"source_hidden": True, "outputs_hidden": True}
    text = io.StringIO()
    with contextlib.redirect_stdout(text):
        check_exercise(key, program)
    check = nbformat.v4.new_code_cell(
        f"# Check exercise {number} on the virtual machine — {PROMPTS[key]}\n"
        f"from labkit.grade import check_exercise\n"
        f"check_exercise(\"{key}\", {name})",
        outputs=[nbformat.v4.new_output("stream", name="stdout", text=text.getvalue())])
    check.metadata["tags"] = [CHECK_TAG]
    return solution, check


def add(key: str, *, dry_run: bool = False, refresh: bool = False) -> str:
    path = _chapter(key)
    raw = path.read_text(encoding="utf-8")
    nb = nbformat.reads(raw, as_version=4)
    for cell in nb.cells:
        if f'check_exercise("{key}"' in cell.source:
            if not refresh:
                return f"{path.name}: exercise {key} has its check cell already"
            fresh = check_cells(key)[1].outputs
            if cell.outputs == fresh:
                return f"{path.name}: exercise {key}'s stored check output is current"
            cell.outputs = fresh
            if path.read_text(encoding="utf-8") != raw:
                return f"{path.name}: changed while this ran; exercise {key} skipped, run again"
            path.write_text(nbformat.writes(nb) + "\n", encoding="utf-8")
            return f"{path.name}: exercise {key}'s stored check output refreshed"
    number = int(key.split("-")[1])
    at = [k for k, c in enumerate(nb.cells) if SOLUTION_TAG in c.metadata.get("tags", [])
          and solution_number(c) == number]
    if not at:
        return f"{path.name}: no '# Solution {number}' cell; exercise {key} left out"
    cells = check_cells(key)
    if dry_run:
        return f"{path.name}: would add exercise {key}'s check after cell {at[-1]}"
    # nbval runs a stored output only under an execution count: the one after the solution's
    cells[1].execution_count = (nb.cells[at[-1]].get("execution_count") or 0) + 1
    nb.cells[at[-1] + 1:at[-1] + 1] = list(cells)
    nbformat.validate(nb)
    if path.read_text(encoding="utf-8") != raw:        # someone saved it meanwhile
        return f"{path.name}: changed while this ran; exercise {key} skipped, run again"
    path.write_text(nbformat.writes(nb) + "\n", encoding="utf-8")
    return f"{path.name}: exercise {key}'s check added after cell {at[-1]}"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--dry-run", action="store_true", help="say what would change")
    parser.add_argument("--refresh", action="store_true",
                        help="store the current output of existing check cells (after a grader change)")
    parser.add_argument("keys", nargs="*", default=sorted(MODEL_ANSWERS), help="exercises (default all)")
    args = parser.parse_args(argv)
    for key in args.keys:
        print(add(key, dry_run=args.dry_run, refresh=args.refresh))
    return 0


if __name__ == "__main__":
    sys.exit(main())
