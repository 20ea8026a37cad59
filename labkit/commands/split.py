"""``labkit split``: a long G-code program as sub-programs a controller's buffer holds.

``labkit split FILE --max-lines N | --max-bytes N [-o DIR]`` writes
``DIR/NAME.part001.gcode`` … (DIR defaults to the file's folder); every part after the
first restates the modal state and the position, and the parts are checked, each parsed
alone, against the whole program before anything is written
(:func:`labkit.gcode.split.split_program`, [MicroCAM] §6.2.1).
"""

from __future__ import annotations


def add_split_arguments(parser):
    from labkit.commands._args import add_dialect_option, integer

    parser.add_argument("file", metavar="FILE", help="G-code program to split")
    parser.add_argument("--max-lines", type=integer(2, 1_000_000_000), default=None, metavar="N",
                        help="most lines per part, added lines included, 2…1e9")
    parser.add_argument("--max-bytes", type=integer(16, 1_000_000_000_000), default=None, metavar="N",
                        help="most bytes per part, newlines included, 16…1e12")
    parser.add_argument("-o", "--output-dir", default=None, metavar="DIR",
                        help="folder for NAME.partNNN.gcode (default: the file's folder)")
    add_dialect_option(parser)


def run_split(args) -> int:
    """Split, verify, write the parts, print one line per part and a summary."""
    from pathlib import Path

    from labkit._files import atomic_output, check_input_file
    from labkit.errors import InputError
    from labkit.gcode.split import split_program

    if args.max_lines is None and args.max_bytes is None:
        raise InputError("give --max-lines N or --max-bytes N (the controller's program buffer)")
    src = check_input_file(args.file, what="G-code file")
    text = src.read_bytes().decode("utf-8", "surrogateescape")
    res = split_program(text, max_lines=args.max_lines, max_bytes=args.max_bytes,
                        dialect=args.dialect, filename=str(src))
    out_dir = Path(args.output_dir) if args.output_dir else src.parent
    if out_dir.exists() and not out_dir.is_dir():
        raise InputError(f"{out_dir}: not a folder; expected a folder for the parts (-o)")
    out_dir.mkdir(parents=True, exist_ok=True)
    width = max(3, len(str(len(res.parts))))
    for k, part in enumerate(res.parts, 1):
        path = out_dir / f"{src.stem}.part{k:0{width}d}.gcode"
        if path.resolve() == src.resolve():
            raise InputError(f"{path}: is the input file; expected another folder (-o)")
        with atomic_output(path, encoding="utf-8", errors="surrogateescape") as fh:
            fh.write(part.text)
        note = "" if part.safe else "  (split inside a cut: no safe point within the limit)"
        print(f"{path}: lines {part.first_line}-{part.last_line}, {part.n_lines} lines, "
              f"{part.n_bytes} bytes{note}")
    print(f"{src}: {res.source_lines} lines -> {len(res.parts)} parts, {res.added_lines} lines added "
          f"(state restated), {res.inside_cuts} split inside a cut; verified: each part alone "
          "gives the program's moves")
    return 0
