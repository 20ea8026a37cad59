"""``labkit check``, ``labkit info`` and ``labkit preview``: G-code files from the shell."""

from __future__ import annotations

import sys

from labkit.commands._args import add_dialect_option, integer, number


def _add_common(parser):
    parser.add_argument("file", help="G-code file")
    add_dialect_option(parser, reads=True)


def _read(path):
    from labkit._files import check_input_file

    with open(check_input_file(path, what="G-code file"), "rb") as fh:
        return fh.read()


def _envelope(text):
    """``WIDTHxDEPTH[xHEIGHT]`` in mm, each finite and > 0."""
    from labkit.errors import InputError
    from labkit.gcode.simulate import Envelope

    size = number(0, 1e6, lo_open=True)
    parts = text.lower().split("x")
    if len(parts) not in (2, 3):
        raise InputError(f"--envelope: expected WIDTHxDEPTH[xHEIGHT] in mm, got {text!r}")
    try:
        values = [size(v) for v in parts]
    except Exception as exc:   # argparse's ArgumentTypeError: say which option
        raise InputError(f"--envelope {text!r}: {exc}") from None
    return Envelope.from_size(*values)


def _line_count(data: bytes) -> int:
    return data.count(b"\n") + (0 if data.endswith(b"\n") or not data else 1)


# -- check ---------------------------------------------------------------------------------

def add_check_arguments(parser):
    _add_common(parser)
    parser.add_argument("--envelope", metavar="WxD[xH]",
                        help="also check every move stays within 0..W x 0..D (x 0..H) mm")


def run_check(args) -> int:
    from labkit.errors import BoundsError
    from labkit.gcode import parse
    from labkit.gcode.simulate import check_bounds

    envelope = _envelope(args.envelope) if args.envelope else None
    data = _read(args.file)
    # As it would be streamed: the controller's line buffer counts too (GRBL error 11).
    moves = parse(data, dialect=args.dialect, filename=args.file, lenient=True, streaming=True)
    problems = list(moves.diagnostics)
    if envelope is not None:
        try:
            check_bounds(moves, envelope)
        except BoundsError as exc:
            problems.append(exc)
    for err in problems:
        print(err.format())
    lines = _line_count(data)
    total = len(problems) + moves.dropped_diagnostics
    if total:
        more = (f" ({moves.dropped_diagnostics} more not shown: the diagnostics budget keeps "
                f"{len(moves.diagnostics)})" if moves.dropped_diagnostics else "")
        print(f"{args.file}: {total} error(s) in {lines} lines{more}", file=sys.stderr)
        return 1
    print(f"{args.file}: ok, {lines} lines, {len(moves)} moves", file=sys.stderr)
    return 0


# -- info ----------------------------------------------------------------------------------

def add_info_arguments(parser):
    _add_common(parser)
    parser.add_argument("--json", action="store_true", help="print the summary as JSON")
    parser.add_argument("--rapid", type=number(0, 1e7, lo_open=True), default=None,
                        metavar="MM_MIN",
                        help="rapid rate for the time estimate, mm/min (default 6000)")
    parser.add_argument("--lenient", action="store_true",
                        help="skip rejected lines (as a controller would) instead of failing")


def run_info(args) -> int:
    from labkit.gcode import parse
    from labkit.gcode.simulate import DEFAULT_RAPID_MM_MIN, summarize

    data = _read(args.file)
    moves = parse(data, dialect=args.dialect, filename=args.file, lenient=args.lenient)
    lines = _line_count(data)
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
    parser.add_argument("--dpi", type=integer(10, 1200), default=120, help="resolution of the PNG")
    parser.add_argument("--lenient", action="store_true",
                        help="skip rejected lines instead of failing")


def run_preview(args) -> int:
    from labkit.budget import check_budget
    from labkit.gcode import parse
    from labkit.viz.preview import preview_format, write_moves_preview

    from labkit._files import check_output_file

    check_output_file(args.output, args.file)
    preview_format(args.output)
    text = _read(args.file)
    # The whole job is held while it is drawn: count its lines before parsing.
    check_budget("preview_lines", text.count(b"\n") + 1, cause=f"drawing all of {args.file}",
                 option="the job (preview a part of it)")
    moves = parse(text, dialect=args.dialect, filename=args.file, lenient=args.lenient)
    write_moves_preview(moves, args.output, dpi=args.dpi, view=args.view, show_travel=not args.no_travel)
    print(f"wrote {args.output}", file=sys.stderr)
    return 0
