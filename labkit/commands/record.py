"""``labkit record show RECORD.json`` and ``labkit record diff A.json B.json``: provenance records
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


def run_record(args) -> int:
    """Show a record, or diff two; ``diff`` exits 1 when they differ (as diff(1))."""
    import json

    from labkit.record import diff_records, format_record, read_record

    if args.action == "show":
        rec = read_record(args.file)
        print(json.dumps(rec, indent=1, ensure_ascii=False) if args.json else format_record(rec))
        return 0
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
