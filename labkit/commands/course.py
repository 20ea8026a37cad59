"""``labkit course``: the chapters as course material.

``labkit course student DIR [--source NOTEBOOKS]``
    write the student edition of every chapter into DIR: the cells tagged ``solution`` replaced
    by a stub to fill in, the cells tagged ``appendix`` removed with their outputs, every other
    cell kept with its outputs (see :mod:`labkit.course`).
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


def run_course(args) -> int:
    from labkit.course import write_student_edition

    written = write_student_edition(args.source, args.out)
    print(f"student edition: {len(written)} notebooks written to {args.out} "
          f"(solutions replaced by stubs, appendices removed)")
    return 0
