"""``labkit record show RECORD.json``, ``labkit record diff A.json B.json`` and ``labkit record rerun
RECORD.json -o PROGRAM``: provenance records
(see :mod:`labkit.record` for the format)."""

from __future__ import annotations

__all__ = ["add_record_arguments", "run_record"]


def add_record_arguments(parser) -> None:
    """Options of ``labkit record``."""
    sub = parser.add_subparsers(dest="action", required=True, metavar="ACTION")
    p = sub.add_parser("show", help="a record in words (or as JSON)")
    p.add_argument("file", metavar="RECORD.json")
    p.add_argument("--json", action="store_true", help="print the record's JSON")
    p = sub.add_parser("diff", help="what differs between two records (inputs by hash, options, machine, "
                                    "material, planned time, the stream's outcome)")
    p.add_argument("a", metavar="A.json")
    p.add_argument("b", metavar="B.json")
    p.add_argument("--all", action="store_true", help="also the creation and stream times")
    p = sub.add_parser("rerun", help="make a program again from its record (inputs checked by hash) and "
                                     "say whether it is byte for byte the recorded one")
    p.add_argument("file", metavar="RECORD.json")
    p.add_argument("-o", "--output", required=True, metavar="PROGRAM",
                   help="where the program made again goes")


def run_record(args) -> int:
    """Show a record, diff two, or make its program again; ``diff`` and ``rerun`` exit 1 when
    they differ (as diff(1))."""
    import json

    from labkit.record import diff_records, format_record, read_record

    if args.action == "show":
        rec = read_record(args.file)
        print(json.dumps(rec, indent=1, ensure_ascii=False) if args.json else format_record(rec))
        return 0
    if args.action == "rerun":
        from labkit.record import rerun_record

        same, out = rerun_record(args.file, args.output)
        print(f"{out}: " + ("the recorded program, byte for byte" if same else
                            "differs from the recorded program (the inputs are the same: labkit or "
                            "its libraries changed; `labkit record diff` on a new record says what)"))
        return 0 if same else 1
    a, b = read_record(args.a), read_record(args.b)
    rows = diff_records(a, b, everything=args.all)
    if not rows:
        print(f"{args.a} and {args.b}: the same" + ("" if args.all else " (times not compared)"))
        return 0
    width = max(len(k) for k, _, _ in rows)
    for key, va, vb in rows:
        print(f"{key:<{width}}  {_short(va)}  →  {_short(vb)}")
    return 1


def _short(value) -> str:
    text = "(none)" if value is None else str(value)
    return text if len(text) <= 60 else text[:57] + "…"
