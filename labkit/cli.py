"""``python -m labkit <command>`` (installed as ``labkit``).

Each command lives in a module under :mod:`labkit.commands` that is imported
only when the command runs, so ``labkit --help`` is instant and a command's
heavy dependencies (matplotlib, scikit-image) load only when needed. A
command module defines, for a command named ``name`` (dashes → underscores):

``add_<name>_arguments(parser)``
    configures an :class:`argparse.ArgumentParser`;
``run_<name>(args) -> int``
    does the work and returns the exit status.

Errors that labkit raises on purpose (:class:`labkit.errors.LabkitError`) and
file errors are printed as one line on stderr with exit status 1, never as a
traceback; ``--traceback`` shows the traceback for debugging.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys

from labkit import __version__

__all__ = ["COMMANDS", "main"]

#: command → (module under labkit.commands, one-line help). Order = order in --help.
COMMANDS: dict[str, tuple[str, str]] = {
    "check": ("gcode", "validate a G-code file; print every diagnostic as file:line:col"),
    "info": ("gcode", "summarise a G-code file: moves, bounds, lengths, times"),
    "preview": ("gcode", "draw a G-code file to a PNG"),
    "svg2gcode": ("vector", "convert SVG artwork to laser G-code"),
    "dxf2gcode": ("vector", "convert DXF drawings to laser G-code"),
    "img2gcode": ("raster", "engrave a raster image: zig-zag, spiral, edges, gray, dither"),
    "job": ("job", "compose a job file's layers (SVG, DXF, images; cut, score, fill, image) into one program"),
    "pattern": ("pattern", "write a parametric toolpath: helix, spiral, square-spiral, zigzag, cone"),
    "slice": ("slice", "planar sections of a 3-D model (STL), each pocketed, as one laser job"),
    "split": ("split", "split a long G-code program into sub-programs that each restate the state"),
    "millfeed": ("millfeed", "schedule a micro-milling program's feed from its chip volume"),
    "plough": ("plough", "chip and ploughing area of a micro-milling program on a dual-dexel stock"),
    "probe": ("probe", "the rotating-wire probe: effective diameter, calibration, a simulated part scanned"),
    "cutwidth": ("cutwidth", "cut width against power and speed: test grid, measure a scan, fit, settings, window"),
    "raster-test": ("rastertest", "raster calibration: scan-offset (ghosting) lines and a gray step wedge, their scans fitted"),
    "materials": ("materials", "the material library: list, show, add, from-fit (a cutwidth fit), remove"),
    "burncheck": ("burncheck", "predict a program's burn from the dose model; check a scan of the real burn against it"),
    "plan": ("motion", "plan a G-code job: blocks, speed profiles, look-ahead, job time"),
    "steps": ("motion", "write the Bresenham step sequence of a G-code job"),
    "ports": ("machine", "list serial ports and what each looks like (CH340, FTDI, CP210x, …)"),
    "stream": ("machine", "send a G-code job to a machine (the virtual one by default), safely"),
    "console": ("machine", "talk to a machine line by line"),
    "safety-check": ("safety", "check that the beam is off on every stop, reset, alarm and end"),
    "record": ("record", "provenance records of programs and streams: show one, diff two"),
    "course": ("course", "course material: the student edition (no answers), grading answers on the virtual machine"),
}


def command_entry(name: str):
    """A command's two functions, loaded on first use: (add_NAME_arguments, run_NAME)."""
    module = importlib.import_module(f"labkit.commands.{COMMANDS[name][0]}")
    attr = name.replace("-", "_")
    return getattr(module, f"add_{attr}_arguments"), getattr(module, f"run_{attr}")


def _top_parser() -> argparse.ArgumentParser:
    width = max(len(n) for n in COMMANDS)
    listing = "\n".join(f"  {n:<{width}}  {h}" for n, (_, h) in COMMANDS.items())
    parser = argparse.ArgumentParser(
        prog="labkit",
        description="labkit: laser CNC toolkit for teaching and research.",
        epilog=f"commands:\n{listing}\n\nrun 'labkit COMMAND --help' for a command's options",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"labkit {__version__}")
    parser.add_argument("command", choices=list(COMMANDS), metavar="COMMAND", help="what to do")
    parser.add_argument("args", nargs=argparse.REMAINDER, help=argparse.SUPPRESS)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit status (0 ok, 1 failure, 2 usage)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if "numpy" not in sys.modules:
        # One BLAS thread for a command: its matrix products are small, and OpenBLAS's pool,
        # started at numpy's import, spins ~0.1 s of CPU a process for nothing (a user's
        # own setting wins; a notebook, which does not come through here, keeps the pool).
        os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    top = _top_parser()
    if not argv:
        top.print_help()
        return 2
    ns = top.parse_args(argv[:1] if not argv[0].startswith("-") else argv)
    name = ns.command
    add_arguments, run = command_entry(name)
    parser = argparse.ArgumentParser(prog=f"labkit {name}", description=COMMANDS[name][1])
    parser.add_argument("--traceback", action="store_true", help="show a traceback on errors")
    add_arguments(parser)
    args = parser.parse_args(argv[1:])
    args._argv = [name] + argv[1:]          # the command line as typed, for provenance records
    from labkit.errors import LabkitError

    try:
        return int(run(args) or 0)
    except (LabkitError, OSError) as exc:
        if args.traceback:
            raise
        print(f"labkit {name}: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"labkit {name}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
