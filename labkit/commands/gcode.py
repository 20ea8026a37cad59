"""``labkit check``, ``labkit info`` and ``labkit preview``: G-code files from the shell."""

from __future__ import annotations

import sys

from labkit.gcode.dialects import DIALECTS


def _add_common(parser):
    parser.add_argument("file", help="G-code file")
    parser.add_argument("--dialect", choices=list(DIALECTS), default="grbl",
                        help="how F, G4 P and S are read (default: grbl)")


def _read(path):
    with open(path, "rb") as fh:
        return fh.read()


def _envelope(text):
    from labkit.gcode.simulate import Envelope

    try:
        parts = [float(v) for v in text.lower().split("x")]
    except ValueError:
        parts = []
    if len(parts) not in (2, 3):
        raise SystemExit(f"labkit: --envelope wants WIDTHxDEPTH[xHEIGHT] in mm, got {text!r}")
    return Envelope.from_size(*parts)


# -- check ---------------------------------------------------------------------------------

def add_check_arguments(parser):
    _add_common(parser)
    parser.add_argument("--envelope", metavar="WxD[xH]",
                        help="also check every move stays within 0..W x 0..D (x 0..H) mm")


def run_check(args) -> int:
    from labkit.errors import BoundsError
    from labkit.gcode import parse
    from labkit.gcode.simulate import check_bounds

    data = _read(args.file)
    moves = parse(data, dialect=args.dialect, filename=args.file, lenient=True)
    problems = list(moves.diagnostics)
    if args.envelope:
        try:
            check_bounds(moves, _envelope(args.envelope))
        except BoundsError as exc:
            problems.append(exc)
    for err in problems:
        print(err.format())
    lines = data.count(b"\n") + (0 if data.endswith(b"\n") or not data else 1)
    if problems:
        print(f"{args.file}: {len(problems)} error(s) in {lines} lines", file=sys.stderr)
        return 1
    print(f"{args.file}: ok, {lines} lines, {len(moves)} moves", file=sys.stderr)
    return 0


# -- info ----------------------------------------------------------------------------------

def add_info_arguments(parser):
    _add_common(parser)
    parser.add_argument("--json", action="store_true", help="print the summary as JSON")
    parser.add_argument("--rapid", type=float, default=None, metavar="MM_MIN",
                        help="rapid rate for the time estimate, mm/min (default 6000)")
    parser.add_argument("--lenient", action="store_true",
                        help="skip rejected lines (as a controller would) instead of failing")


def run_info(args) -> int:
    from labkit.gcode import parse
    from labkit.gcode.simulate import DEFAULT_RAPID_MM_MIN, summarize

    data = _read(args.file)
    moves = parse(data, dialect=args.dialect, filename=args.file, lenient=args.lenient)
    lines = data.count(b"\n") + (0 if data.endswith(b"\n") or not data else 1)
    summary = summarize(moves, rapid_mm_min=args.rapid or DEFAULT_RAPID_MM_MIN, source_lines=lines)
    if args.json:
        print(summary.to_json())
    else:
        print(f"file            {args.file} (dialect {args.dialect})")
        print(summary.format())
        for err in moves.diagnostics:
            print(err.format(), file=sys.stderr)
    return 0


# -- preview -------------------------------------------------------------------------------

def add_preview_arguments(parser):
    _add_common(parser)
    parser.add_argument("-o", "--output", required=True, help="PNG file to write")
    parser.add_argument("--view", choices=["xy", "xz", "yz"], default="xy", help="projection")
    parser.add_argument("--no-travel", action="store_true", help="hide moves with the laser off")
    parser.add_argument("--dpi", type=int, default=120, help="resolution of the PNG")
    parser.add_argument("--lenient", action="store_true",
                        help="skip rejected lines instead of failing")


def run_preview(args) -> int:
    from labkit.gcode import parse
    from labkit.viz.gcode import save_preview

    moves = parse(_read(args.file), dialect=args.dialect, filename=args.file, lenient=args.lenient)
    save_preview(moves, args.output, dpi=args.dpi, view=args.view, show_travel=not args.no_travel)
    print(f"wrote {args.output}", file=sys.stderr)
    return 0
