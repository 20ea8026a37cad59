"""``labkit course``: the chapters as course material.

``labkit course student DIR [--source NOTEBOOKS]``
    write the student edition of every chapter into DIR: the cells tagged ``solution`` replaced
    by a stub to fill in, the cells tagged ``appendix`` removed with their outputs, every other
    cell kept with its outputs (see :mod:`labkit.course`).
``labkit course grade DIR [-o OUT]``
    grade a folder of submissions on the virtual machine (see :mod:`labkit.grade`): one report
    per student and ``grades.csv`` in OUT (default ``DIR/grades``).
``labkit course exercises``
    list the exercises the virtual machine grades.
"""

from __future__ import annotations

from pathlib import Path

#: the repository's chapters, when labkit runs from its checkout
_CHAPTERS = Path(__file__).resolve().parents[2] / "notebooks"


def add_course_arguments(parser):
    sub = parser.add_subparsers(dest="action", required=True, metavar="ACTION")
    p = sub.add_parser("student", help="write the student edition of every chapter (no answers, no appendices)")
    p.add_argument("out", metavar="DIR", help="folder for the edition (created if missing)")
    p.add_argument("--source", default=str(_CHAPTERS), metavar="NOTEBOOKS",
                   help="folder of the chapters (default: the repository's notebooks/)")
    g = sub.add_parser("grade", help="grade a folder of submissions on the virtual machine")
    g.add_argument("folder", metavar="DIR",
                   help="one entry per student: a folder of KEY.gcode files and/or chapters "
                        "(.ipynb, read, never run), or a notebook STUDENT.ipynb")
    g.add_argument("-o", "--out", metavar="OUT", default=None,
                   help="folder for STUDENT.txt reports and grades.csv (default: DIR/grades)")
    sub.add_parser("exercises", help="list the exercises the virtual machine grades")


def run_course(args) -> int:
    if args.action == "grade":
        from labkit.grade import EXERCISES, grade_folder

        out = Path(args.out) if args.out else Path(args.folder) / "grades"
        rows = grade_folder(args.folder, out)
        students = sorted({r["student"] for r in rows})
        width = max(len("student"), *(len(s) for s in students))
        print(f"{'student':<{width}}  " + "  ".join(sorted(EXERCISES)) + "  passed")
        for s in students:
            mine = {r["exercise"]: r for r in rows if r["student"] == s}
            cells = [("pass" if mine[k]["passed"] else ("-" if not mine[k]["checks_run"] else
                      f"{mine[k]['checks_passed']}/{mine[k]['checks_run']}")).center(len(k))
                     for k in sorted(EXERCISES)]
            print(f"{s:<{width}}  " + "  ".join(cells) + f"  {sum(r['passed'] for r in mine.values())}")
        print(f"reports and grades.csv written to {out}")
        return 0
    if args.action == "exercises":
        from labkit.grade import EXERCISES

        for key, ex in sorted(EXERCISES.items()):
            print(f"{key}  {ex.title}")
        return 0
    from labkit.course import write_student_edition

    written = write_student_edition(args.source, args.out)
    print(f"student edition: {len(written)} notebooks written to {args.out} "
          f"(solutions replaced by stubs, appendices removed)")
    return 0
