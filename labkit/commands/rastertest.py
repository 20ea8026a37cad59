"""``labkit raster-test``: raster calibration patterns and their scans measured.

``scan-offset`` and ``measure-offset``: bidirectional lines at several speeds, the backward
lines' offset fitted to a beam delay (``img2gcode --scan-offset``). ``wedge`` and ``measure-tone``:
a gray step wedge, its darkness per step fitted to a monotone tone curve (``img2gcode --tone``).
The library decides (:mod:`labkit.laser.scanoffset`, :mod:`labkit.laser.tone`); this module parses
and prints.
"""

from __future__ import annotations

__all__ = ["add_raster_test_arguments", "run_raster_test"]


def add_raster_test_arguments(parser) -> None:
    """Options of ``labkit raster-test``."""
    from labkit.commands._args import add_dialect_option, add_line_grid_options, integer, number

    sub = parser.add_subparsers(dest="action", required=True, metavar="ACTION")

    p = sub.add_parser("scan-offset", help="bidirectional lines at several speeds, with their layout JSON")
    p.add_argument("--speeds", required=True, metavar="LO:HI:N", help="feeds, mm/min: LO:HI:N or a comma list")
    p.add_argument("--power", type=number(0, 1e6, lo_open=True), required=True, metavar="MW",
                   help="optical power of every line, mW")
    p.add_argument("--pairs", type=integer(2, 50), default=3, metavar="N",
                   help="forward/backward row pairs per speed (default 3)")
    add_line_grid_options(p, line_mm=8.0, pitch_mm=1.0, overscan_mm=None, shortest_line_mm=1.0)

    w = sub.add_parser("wedge", help="a gray step wedge: patches of lines at rising S, with their layout JSON")
    w.add_argument("--steps", type=integer(2, 64), default=16, metavar="N", help="patches (default 16)")
    w.add_argument("--feed", type=number(1, 1e6), default=None, metavar="MM_MIN",
                   help="scanning feed, mm/min: the engraving's (default 3000 or the machine's X rate if lower)")
    w.add_argument("--interval", type=number(0.01, 10), default=0.1, metavar="MM",
                   help="line interval = the engraving's pixel, mm (default 0.1)")
    w.add_argument("--patch", type=number(1, 100), default=8.0, metavar="MM", help="patch width, mm (default 8)")
    w.add_argument("--lines", type=integer(3, 1000), default=30, metavar="N", help="lines per patch (default 30)")
    w.add_argument("--overscan", type=number(0.5, 100), default=3.0, metavar="MM",
                   help="beam-off run each side, mm (default 3)")
    w.add_argument("--s-max", type=number(0, 1e6, lo_open=True), default=1000.0, help="S of full power (default 1000)")
    for q in (p, w):
        q.add_argument("-o", "--output", required=True, metavar="PATTERN.gcode",
                       help="G-code to write; the layout goes to the same name with .json")
        q.add_argument("--machine", default=None, metavar="NAME|TOML",
                       help="machine (rates, acceleration, power at full S; default cbr40-laser)")
        add_dialect_option(q)

    m = sub.add_parser("measure-offset", help="fit the backward lines' offset against speed in a scan")
    t = sub.add_parser("measure-tone", help="fit a monotone tone curve to a scanned wedge")
    for q, what in ((m, "scan-offset model JSON"), (t, "tone curve JSON")):
        q.add_argument("scan", metavar="SCAN.png", help="scan or photograph (burn dark on light)")
        q.add_argument("--layout", required=True, metavar="PATTERN.json", help="layout written with the pattern")
        q.add_argument("-o", "--output", required=True, metavar="OUT.json", help=f"{what} to write")


def run_raster_test(args) -> int:
    return {"scan-offset": _scan_offset, "wedge": _wedge, "measure-offset": _measure_offset,
            "measure-tone": _measure_tone}[args.action](args)


def _machine(args):
    from labkit.motion.spec import CBR40, load_machine

    return CBR40 if args.machine is None else load_machine(args.machine)


def _write(args, g, what) -> None:
    from labkit.laser.patterns import write_pattern

    layout = write_pattern(args.output, g, dialect=args.dialect)
    x0, y0, x1, y1 = g.layout["bounds_mm"]
    print(f"{args.output}: {what}, {x1 - x0:.1f} × {y1 - y0:.1f} mm")
    print(f"{layout}: layout")


def _scan_offset(args) -> int:
    from labkit.commands.cutwidth import parse_range
    from labkit.laser.scanoffset import scan_offset_pattern

    speeds = parse_range(args.speeds, "speeds")
    m = _machine(args)
    g = scan_offset_pattern(speeds, power_mw=args.power, pairs=args.pairs, line_mm=args.line,
                            pitch_mm=args.pitch, overscan_mm=args.overscan, machine=m)
    _write(args, g, f"{len(speeds)} speeds × {args.pairs} forward/backward pairs, "
                    f"overscan {g.layout['overscan_mm']:g} mm")
    return 0


def _wedge(args) -> int:
    from labkit.laser.tone import wedge_pattern

    m = _machine(args)
    g = wedge_pattern(args.steps, s_max=args.s_max, machine=m, speed_mm_min=args.feed,
                      line_interval_mm=args.interval, patch_mm=args.patch, patch_lines=args.lines,
                      overscan_mm=args.overscan)
    feed = g.layout["speeds_mm_min"][0]
    _write(args, g, f"{args.steps} steps of S up to {args.s_max:g} at {feed:g} mm/min")
    return 0


def _scan_image(args):
    from labkit._files import check_output_file, read_json
    from labkit.laser.measure import check_layout
    from labkit.raster.color import to_gray
    from labkit.raster.io import read_image

    check_output_file(args.output, args.scan, args.layout)
    layout = check_layout(read_json(args.layout, what="layout file"), source=args.layout)
    return to_gray(read_image(args.scan).pixels) / 255.0, layout


def _measure_offset(args) -> int:
    from labkit.laser.scanoffset import fit_scan_offset, measure_scan_offset

    img, layout = _scan_image(args)
    df = measure_scan_offset(img, layout)
    fit = fit_scan_offset(df.speed_mm_min, df.offset_mm, df.offset_sd_mm)
    fit.save(args.output)
    for r in df.itertuples():
        print(f"{r.speed_mm_min:8.0f} mm/min  offset {r.offset_mm * 1e3:7.1f} ± {r.offset_sd_mm * 1e3:.1f} µm"
              f"  ({r.pairs} pairs)")
    print(f"offset = {fit.slope_s * 1e3:.4f} ± {fit.slope_sd_s * 1e3:.4f} ms × v + "
          f"{fit.intercept_mm * 1e3:.1f} ± {fit.intercept_sd_mm * 1e3:.1f} µm; "
          f"beam delay {fit.beam_delay_s * 1e3:.3f} ms")
    print(f"{args.output}: scan-offset model (img2gcode --scan-offset)")
    return 0


def _measure_tone(args) -> int:
    from labkit.laser.tone import fit_tone, measure_wedge

    img, layout = _scan_image(args)
    df = measure_wedge(img, layout)
    curve = fit_tone(df.s_word, df.darkness, spread=df.darkness_sd, weights=df.pixels,
                     s_max=float(layout.get("s_max", 1000.0)), feed_mm_min=float(layout["speeds_mm_min"][0]),
                     line_interval_mm=float(layout["pitch_mm"]))
    curve.save(args.output)
    for r, fitted in zip(df.itertuples(), curve.darkness[1:]):
        print(f"step {r.step:2d}  S {r.s_word:7.1f}  darkness {r.darkness:.3f} ± {r.darkness_sd:.3f}"
              f"  fitted {fitted:.3f}")
    print(f"{args.output}: tone curve (img2gcode --mode gray --tone)")
    return 0
