"""``labkit burncheck predict|compare``: a program's burn predicted by the dose model, and a scan of the
real burn checked against it (see :mod:`labkit.burncheck` for the method).

``predict PROGRAM --fit FIT.json -o PREDICTED.png`` draws the scan the burn should give (grey, at
``--dpi``, the resolution stored in the PNG); ``compare PROGRAM SCAN.png --fit FIT.json`` finds the
prediction in the scan and prints, per layer and over the part, where and by how much the burn
differs, writing the numbers (``-o REPORT.json``) and an overlay picture (``--overlay``).
"""

from __future__ import annotations

__all__ = ["add_burncheck_arguments", "run_burncheck"]


def _model_options(p) -> None:
    from labkit.commands._args import number

    p.add_argument("program", metavar="PROGRAM.gcode", help="the G-code program that was (or will be) burned")
    p.add_argument("--fit", metavar="FIT.json", help="a cut-width fit (labkit cutwidth fit -o): its dose model")
    p.add_argument("--w0", type=number(0, lo_open=True), metavar="MM",
                   help="1/e² beam radius, mm (typed: beats the fit's)")
    p.add_argument("--fth", type=number(0, lo_open=True), metavar="MJ_MM2",
                   help="threshold fluence, mJ/mm² (typed: beats the fit's)")
    p.add_argument("--machine", default=None, metavar="NAME|TOML",
                   help="the machine whose planner moves the head (default: cbr40-laser)")
    p.add_argument("--pixel", type=number(0, lo_open=True), default=None, metavar="MM",
                   help="the simulation's pixel, mm (default w0/8, at most the scan's pixel)")


def add_burncheck_arguments(parser) -> None:
    """Options of ``labkit burncheck``."""
    from labkit.commands._args import number

    sub = parser.add_subparsers(dest="action", required=True, metavar="ACTION")
    p = sub.add_parser("predict", help="the scan the burn should give, as a grey PNG")
    _model_options(p)
    p.add_argument("-o", "--output", required=True, metavar="PREDICTED.png", help="the picture to write")
    p.add_argument("--dpi", type=number(10, 10_000), default=600.0, help="its resolution (default 600)")
    p.add_argument("--margin", type=number(0, 100), default=3.0, metavar="MM",
                   help="paper round the burn, mm (default 3)")
    p = sub.add_parser("compare", help="a scan of the real burn against the prediction: numbers and an overlay")
    _model_options(p)
    p.add_argument("scan", metavar="SCAN.png", help="the scan of the burned piece, square on the scanner")
    p.add_argument("--dpi", type=number(10, 10_000), default=None,
                   help="the scan's resolution (default: the one stored in the file)")
    p.add_argument("-o", "--output", default=None, metavar="REPORT.json", help="write the numbers as JSON")
    p.add_argument("--overlay", default=None, metavar="OVERLAY.png",
                   help="write the picture: scan in grey, missing red, extra blue, lighter orange, darker purple")
    p.add_argument("--solid-darkness", type=number(0, 1, lo_open=True), default=None, metavar="D",
                   help="the darkness (1 − grey/paper) of a solid burn in this material (default: the scan's "
                        "own, where the prediction is solid; give it to find a burn that is pale all over)")
    p.add_argument("--paper", type=number(0, 1, lo_open=True), default=None, metavar="GREY",
                   help="the paper's grey level, 0…1 (default: estimated from the scan)")
    p.add_argument("--tolerance", type=number(0, 1, lo_open=True, hi_open=True), default=0.15,
                   help="a darkness difference, as a share of a solid burn, that is reported (default 0.15)")


def _prediction(args, scan_pixel_mm: float):
    """The program, its predicted burn and a line naming the dose model used."""
    from labkit.burncheck import predict_burn
    from labkit.errors import InputError
    from labkit.gcode import parse_file

    w0, fth, source = args.w0, args.fth, []
    if args.fit:
        from labkit.laser.models import load_fit

        _, fit = load_fit(args.fit, "dose")
        w0 = fit.params["w0_mm"] if w0 is None else w0
        fth = fit.params["fth_mj_mm2"] if fth is None else fth
        source.append(f"fit {args.fit}")
    if w0 is None or fth is None:
        raise InputError("no dose model: expected --fit FIT.json (a cut-width fit) or both --w0 and --fth")
    typed = [name for name, v in (("--w0", args.w0), ("--fth", args.fth)) if v is not None]
    if typed:
        source.append("typed " + " ".join(typed))
    pixel = min(w0 / 8, scan_pixel_mm) if args.pixel is None else args.pixel
    if pixel > scan_pixel_mm * 1.000001:
        raise InputError(f"--pixel {pixel:g} mm is coarser than the scan's pixel ({scan_pixel_mm:.4f} mm); "
                         "expected at most that")
    moves = parse_file(args.program)
    burn = predict_burn(moves, w0_mm=w0, fth_mj_mm2=fth, pixel_mm=pixel, machine=args.machine)
    return moves, burn, f"dose model w0 {w0:.4g} mm, F_th {fth:.4g} mJ/mm² ({', '.join(source)})"


def _write_png(path, rgb_or_grey, dpi: float) -> None:
    from PIL import Image

    from labkit._files import atomic_output

    with atomic_output(path, "wb") as fh:
        Image.fromarray(rgb_or_grey).save(fh, format="PNG", dpi=(dpi, dpi))


def run_burncheck(args) -> int:
    """Predict a burn, or compare a scan with the prediction; ``compare`` exits 1 when a defect is found."""
    import numpy as np

    from labkit._files import check_output_file
    from labkit.errors import InputError

    if args.action == "predict":
        from labkit.burncheck import predicted_scan

        check_output_file(args.output, args.program)
        _, burn, model = _prediction(args, 25.4 / args.dpi)
        img = predicted_scan(burn, dpi=args.dpi, margin_mm=args.margin)
        _write_png(args.output, np.round(img * 255).astype(np.uint8), args.dpi)
        print(f"{args.output}: {img.shape[1]} × {img.shape[0]} px at {args.dpi:g} dpi, the burn predicted by the "
              f"{model}; paper 0.9, solid burn 0.1; {args.margin:g} mm of paper round it")
        return 0

    import json

    from labkit.burncheck import check_scan
    from labkit.raster.color import to_gray
    from labkit.raster.io import read_image

    for out, option in ((args.output, "-o"), (args.overlay, "--overlay")):
        if out is not None:
            check_output_file(out, args.program, args.scan, option=option)
    if args.output and args.overlay and args.output == args.overlay:
        raise InputError(f"{args.output}: is both the report (-o) and the overlay; expected two names")
    im = read_image(args.scan)
    dpi = args.dpi or im.dpi
    if not dpi:
        raise InputError(f"{args.scan}: stores no resolution; expected --dpi (the scanner's setting)")
    moves, burn, model = _prediction(args, 25.4 / dpi)
    res = check_scan(burn, to_gray(im.pixels) / 255.0, dpi=dpi, moves=moves, paper=args.paper,
                     solid_darkness=args.solid_darkness, tolerance=args.tolerance)
    print(f"{args.scan} at {dpi:g} dpi against {args.program}: {model}")
    print(res.summary())
    if args.output:
        from labkit._files import atomic_output

        from labkit.burncheck import FORMAT, VERSION

        doc = {"format": FORMAT, "version": VERSION, "program": args.program, "scan": args.scan,
               "dpi": dpi, "model": model, "tolerance": args.tolerance} | res.to_dict()
        with atomic_output(args.output, encoding="utf-8") as fh:
            json.dump(doc, fh, indent=1)
        print(f"report          {args.output}")
    if args.overlay:
        _write_png(args.overlay, res.overlay(), dpi)
        print(f"overlay         {args.overlay}")
    return 1 if res.defects else 0
