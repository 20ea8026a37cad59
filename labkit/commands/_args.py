"""Validated option types for the command line: finite numbers within a stated range.

argparse reports a type error as ``labkit CMD: error: argument --tol: …`` with exit
status 2, so an option's name always appears with the range it must lie in. Every
numeric option of every command uses :func:`number` (or :func:`integer`), never a
bare ``type=float``, which would accept ``inf``, ``nan`` and ``-1``.
"""

from __future__ import annotations

import argparse
import math

__all__ = ["number", "integer", "tolerance_option", "TOL_MIN_MM", "TOL_MAX_MM", "FEED", "add_dialect_option",
           "add_cut_options", "add_line_grid_options", "add_machine_options", "check_fits"]

#: The range of every tolerance option (``--tol``, ``--arc-tol``), mm. Below 0.1 µm no
#: laser machine can tell the difference and flattening explodes; above 10 mm a circle
#: is no longer a circle.
TOL_MIN_MM, TOL_MAX_MM = 1e-4, 10.0


def _range_text(lo, hi, lo_open, hi_open) -> str:
    parts = []
    if lo is not None:
        parts.append(f"{'>' if lo_open else '>='} {lo:g}")
    if hi is not None:
        parts.append(f"{'<' if hi_open else '<='} {hi:g}")
    return "a finite number" + (" " + " and ".join(parts) if parts else "")


def number(lo: float | None = None, hi: float | None = None, *,
           lo_open: bool = False, hi_open: bool = False):
    """An argparse ``type=`` accepting finite floats in ``[lo, hi]`` (open ends optional).

    >>> tol = number(0, 10, lo_open=True)
    >>> tol("0.1")
    0.1
    >>> tol("inf")
    Traceback (most recent call last):
    ...
    argparse.ArgumentTypeError: 'inf' is not a finite number > 0 and <= 10
    """
    expected = _range_text(lo, hi, lo_open, hi_open)

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not {expected}") from None
        ok = math.isfinite(value)
        if ok and lo is not None:
            ok = value > lo if lo_open else value >= lo
        if ok and hi is not None:
            ok = value < hi if hi_open else value <= hi
        if not ok:
            raise argparse.ArgumentTypeError(f"{text!r} is not {expected}")
        return value

    parse.__name__ = "number"          # argparse names the type in some messages
    return parse


def tolerance_option(what: str, default: float | None) -> dict:
    """The ``add_argument`` keywords of a tolerance option in mm: the one range
    (:data:`TOL_MIN_MM` … :data:`TOL_MAX_MM`), said in its help after ``what``.

    >>> tolerance_option("largest deviation from the drawing", 0.01)["help"]
    'largest deviation from the drawing, 0.0001…10 mm (default 0.01)'
    """
    shown = f" (default {default:g})" if default is not None else ""
    return dict(type=number(TOL_MIN_MM, TOL_MAX_MM), default=default, metavar="MM",
                help=f"{what}, {TOL_MIN_MM:g}…{TOL_MAX_MM:g} mm{shown}")


def integer(lo: int | None = None, hi: int | None = None):
    """An argparse ``type=`` accepting whole numbers in ``[lo, hi]`` (``2.5`` is refused).

    >>> integer(1, 100)("3")
    3
    >>> integer(1, 100)("2.5")
    Traceback (most recent call last):
    ...
    argparse.ArgumentTypeError: '2.5' is not a whole number >= 1 and <= 100
    """
    expected = _range_text(lo, hi, False, False).replace("a finite number", "a whole number")

    def parse(text: str) -> int:
        try:
            value = int(text.strip())
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not {expected}") from None
        if (lo is not None and value < lo) or (hi is not None and value > hi):
            raise argparse.ArgumentTypeError(f"{text!r} is not {expected}")
        return value

    parse.__name__ = "integer"
    return parse


#: Feeds and travel speeds, mm/min: below 1 mm/min a program's F rounds away and no laser
#: machine moves above a million (GRBL's own rates stay far below).
FEED = number(1, 1_000_000)


def add_dialect_option(parser, *, reads: bool = False) -> None:
    """``--dialect``, one of :data:`labkit.gcode.dialects.DIALECTS` (default grbl): the dialect a
    command writes its program in, or (``reads``) the one it reads the program in."""
    from labkit.gcode.dialects import DIALECTS

    parser.add_argument("--dialect", choices=list(DIALECTS), default="grbl",
                        help="how F, G4 P and S are read (default: grbl)" if reads
                        else "G-code dialect (default grbl)")


def add_cut_options(parser) -> None:
    """``--feed`` (mm/min, default 600), ``--power`` (the S word, default 1000) and ``--dialect``
    of a command that writes its program at one feed and power."""
    parser.add_argument("--feed", type=FEED, default=600.0, metavar="MM_MIN",
                        help="cutting feed, 1…1e6 mm/min (default 600)")
    parser.add_argument("--power", type=number(0, 1000), default=1000.0, metavar="S",
                        help="laser power word S, 0…1000 (default 1000)")
    add_dialect_option(parser)


def add_line_grid_options(parser, *, line_mm: float, pitch_mm: float, overscan_mm: float | None,
                          shortest_line_mm: float = 0.1) -> None:
    """``--line``, ``--pitch`` and ``--overscan`` of a test pattern of parallel burned lines
    (:func:`labkit.laser.patterns.grid_pattern`), mm, with these defaults: each line's burned
    length (at least ``shortest_line_mm``), the distance between rows and the beam-off run before
    and after each line (``overscan_mm`` None: the pattern's own, what the machine needs to reach
    the fastest feed)."""
    parser.add_argument("--line", type=number(shortest_line_mm, 1000), default=line_mm, metavar="MM",
                        help=f"burned length of each line, {shortest_line_mm:g}…1000 mm (default {line_mm:g})")
    parser.add_argument("--pitch", type=number(0.05, 100), default=pitch_mm, metavar="MM",
                        help=f"distance between rows, 0.05…100 mm (default {pitch_mm:g})")
    shown = "what the machine needs to reach the fastest feed" if overscan_mm is None else f"{overscan_mm:g}"
    parser.add_argument("--overscan", type=number(0, 100), default=overscan_mm, metavar="MM",
                        help=f"beam-off run before and after each line, 0…100 mm (default {shown})")


def add_machine_options(parser) -> None:
    """``--machine`` and ``--force``: the job is checked against the machine's travel."""
    parser.add_argument("--machine", default=None, metavar="NAME|TOML",
                        help="the machine the job is for; a job larger than its travel is "
                             "refused (default: cbr40-laser; names in labkit/motion/machines/)")
    parser.add_argument("--force", action="store_true",
                        help="write a job larger than the machine's travel anyway")


def check_fits(args, size_mm, what: str = "the job") -> None:
    """Refuse (or, with ``--force``, warn about) a job larger than ``--machine``'s travel."""
    import sys

    from labkit.motion.spec import check_job_fits

    msg = check_job_fits(size_mm, args.machine, force=args.force, what=what)
    if msg:
        print(f"warning: {msg} (written anyway: --force)", file=sys.stderr)
