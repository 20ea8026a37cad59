"""``labkit materials``: the machine's material library (see :mod:`labkit.materials` for the format).

``labkit materials list`` · ``show NAME`` · ``add NAME --operation OP --power-mw MW --speed MM_MIN …`` ·
``from-fit FIT.json --name NAME [--operation OP] [--power-mw MW] [--width MM]`` · ``remove NAME[:OP]``,
each with ``--library FILE`` (default: the machine's library) and ``--machine NAME``.
"""

from __future__ import annotations

__all__ = ["add_materials_arguments", "run_materials"]


def add_materials_arguments(parser) -> None:
    """Options of ``labkit materials``."""
    from labkit.commands._args import integer, number
    from labkit.materials import OPERATIONS

    positive = number(0, lo_open=True)
    sub = parser.add_subparsers(dest="action", required=True, metavar="ACTION")

    def common(p):
        p.add_argument("--library", default=None, metavar="FILE",
                       help="library file (default: the machine's, in labkit's configuration folder)")
        p.add_argument("--machine", default=None, metavar="NAME|TOML",
                       help="the machine whose library is meant (default: cbr40-laser)")

    common(sub.add_parser("list", help="the materials and operations in the library"))
    p = sub.add_parser("show", help="one material's settings with their origin")
    p.add_argument("name", metavar="NAME")
    common(p)

    def entry(p):
        p.add_argument("--operation", choices=OPERATIONS, default="cut", help="which operation (default cut)")
        p.add_argument("--passes", type=integer(1, 1000), default=1, help="passes (default 1)")
        p.add_argument("--thickness", type=positive, default=None, metavar="MM", help="material thickness, mm")
        p.add_argument("--air", action="store_true", default=None, help="air assist on (recorded)")
        p.add_argument("--dynamic", action="store_true", default=None, help="M4: power follows speed")
        p.add_argument("--note", default="", help="free text kept with the entry")
        p.add_argument("--replace", action="store_true", help="replace an existing entry for this operation")
        common(p)

    p = sub.add_parser("add", help="add settings typed by hand (marked origin = typed)")
    p.add_argument("name", metavar="NAME")
    p.add_argument("--power-mw", type=number(0), required=True, metavar="MW", help="optical power, mW")
    p.add_argument("--speed", type=positive, required=True, metavar="MM_MIN", help="feed, mm/min")
    p.add_argument("--kerf", type=positive, default=None, metavar="MM", help="burned width, mm")
    p.add_argument("--line-interval", type=positive, default=None, metavar="MM",
                   help="fill hatch spacing or image line pitch, mm")
    entry(p)

    p = sub.add_parser("from-fit", help="derive settings from a 'labkit cutwidth fit -o FIT.json'")
    p.add_argument("fit", metavar="FIT.json")
    p.add_argument("--name", required=True, help="material name")
    p.add_argument("--power-mw", type=positive, default=None, metavar="MW",
                   help="optical power to derive the speed at (default 90 %% of the machine's laser)")
    p.add_argument("--width", type=positive, default=None, metavar="MM",
                   help="wanted line width (score, fill, image; fill and image lines are this far apart)")
    p.add_argument("--probability", type=number(0, 1, lo_open=True, hi_open=True), default=0.95,
                   help="cut: the predicted chance of cutting through to hold (default 0.95)")
    p.add_argument("--model", default=None, help="the fit's model to use (default: the one it chose)")
    entry(p)

    p = sub.add_parser("remove", help="remove a material, or one operation of it (NAME:OPERATION)")
    p.add_argument("name", metavar="NAME[:OPERATION]")
    common(p)


def _open(args, *, create: bool = False):
    from pathlib import Path

    from labkit.materials import Library, default_library_path, read_library
    from labkit.motion.spec import load_machine

    machine = load_machine(args.machine).name
    path = Path(args.library) if args.library else default_library_path(machine)
    if not path.exists():
        if create:
            return Library(machine=machine, path=path)
        from labkit.errors import InputError

        raise InputError(f"{path}: no such material library; expected one made with 'labkit materials add' "
                         "or 'from-fit' (or --library FILE; examples in data/materials/)")
    return read_library(path)


def run_materials(args) -> int:
    """Dispatch to the action."""
    return {"list": _list, "show": _show, "add": _add, "from-fit": _from_fit, "remove": _remove}[args.action](args)


def _list(args) -> int:
    lib = _open(args)
    print(f"{lib.path}: {len(lib.materials)} material(s) for {lib.machine or 'any machine'}")
    for name, m in lib.materials.items():
        thick = f"{m.thickness_mm:g} mm" if m.thickness_mm else "-"
        ops = ", ".join(f"{op} [{s.origin}]" for op, s in m.operations.items()) or "no settings"
        print(f"  {name:<24} {thick:>8}  {ops}")
    return 0


def _show(args) -> int:
    from labkit.materials import parse_material_spec

    lib = _open(args)
    name, op = parse_material_spec(args.name)
    if name not in lib.materials or op:
        lib.get(name, op or "cut")          # names what the library holds
    m = lib.materials[name]
    print(f"{m.name}" + (f", {m.thickness_mm:g} mm" if m.thickness_mm else "") + (f": {m.note}" if m.note else ""))
    for o, s in m.operations.items():
        if op and o != op:
            continue
        print(f"  {o:<6} {s.describe()}")
        if s.note:
            print(f"         note: {s.note}")
        if s.fit:
            f = s.fit
            print(f"         fit {f.get('file')} ({f.get('model', '?')} model, scan {f.get('scan', '?')}, "
                  f"{f.get('date', '?')})")
            if f.get("rule"):
                print(f"         rule: {f['rule']}")
    return 0


def _store(args, lib, setting) -> int:
    from labkit.errors import InputError
    from labkit.materials import Material, write_library

    m = lib.materials.setdefault(args.name, Material(name=args.name))
    if args.operation in m.operations and not args.replace:
        raise InputError(f"{lib.path}: {args.name}:{args.operation} exists "
                         f"({m.operations[args.operation].describe()}); expected --replace to overwrite it")
    if args.thickness is not None:
        m.thickness_mm = args.thickness
    m.operations[args.operation] = setting
    path = write_library(lib)
    print(f"{path}: {args.name}:{args.operation} = {setting.describe()}")
    return 0


def _add(args) -> int:
    from labkit.materials import Setting

    lib = _open(args, create=True)
    s = Setting(origin="typed", power_mw=args.power_mw, speed_mm_min=args.speed, passes=args.passes,
                line_interval_mm=args.line_interval, kerf_mm=args.kerf, air=args.air, dynamic=args.dynamic,
                note=args.note)
    return _store(args, lib, s)


def _from_fit(args) -> int:
    from labkit.materials import setting_from_fit
    from labkit.motion.spec import load_machine

    lib = _open(args, create=True)
    machine = load_machine(args.machine)
    power = args.power_mw if args.power_mw is not None else 0.9 * machine.laser_max_power_mw
    s = setting_from_fit(args.fit, args.operation, power_mw=power, width_mm=args.width,
                         cut_probability=args.probability, model=args.model, passes=args.passes,
                         dynamic=args.dynamic, air=args.air, max_speed_mm_min=float(min(machine.max_rate_mm_min[:2])))
    s.note = args.note
    _store(args, lib, s)
    print(f"  rule: {s.fit['rule']}")
    return 0


def _remove(args) -> int:
    from labkit.errors import InputError
    from labkit.materials import parse_material_spec, write_library

    lib = _open(args)
    name, op = parse_material_spec(args.name)
    if name not in lib.materials:
        raise InputError(f"{lib.path}: no material {name!r}; expected one of: {', '.join(lib.materials) or 'none'}")
    if op is None:
        del lib.materials[name]
    else:
        lib.get(name, op)
        del lib.materials[name].operations[op]
    write_library(lib)
    print(f"{lib.path}: removed {args.name}")
    return 0
