"""``labkit plough``: chip and ploughing area of a micro-milling program on a dual-dexel stock.

``labkit plough FILE --tool-d MM --teeth N --rpm RPM --resolution MM [--min-chip MM |
--edge-radius MM] [--scale S] [--stock XMIN YMIN XMAX YMAX] [--csv OUT.csv]`` prints the
removed and ploughing areas ([MicroCAM] ch. 5, :func:`labkit.micromachining.dexel.plough`)
and writes the per-step figures as CSV.
"""

from __future__ import annotations


def add_plough_arguments(parser):
    from labkit.commands._args import integer, number

    parser.add_argument("file", metavar="FILE", help="micro-milling G-code program (XY)")
    parser.add_argument("--tool-d", type=number(0.001, 100), required=True, metavar="MM",
                        help="flat-end mill diameter, 0.001…100 mm")
    parser.add_argument("--teeth", type=integer(1, 64), required=True, metavar="N", help="flutes, 1…64")
    parser.add_argument("--rpm", type=number(1, 1_000_000), required=True, metavar="RPM",
                        help="spindle speed, 1…1e6 rev/min")
    parser.add_argument("--resolution", type=number(0.0001, 10), default=0.01, metavar="MM",
                        help="dexel spacing R, 0.0001…10 mm (default 0.01)")
    parser.add_argument("--min-chip", type=number(0, 1), default=None, metavar="MM",
                        help="minimum chip thickness per tooth, mm (default 0.3 × --edge-radius)")
    parser.add_argument("--edge-radius", type=number(0, 1), default=0.002, metavar="MM",
                        help="cutting-edge radius, mm (default 0.002)")
    parser.add_argument("--scale", type=number(1, 10_000), default=10.0, metavar="S",
                        help="steps of S × feed per tooth, 1…10000 (default 10)")
    parser.add_argument("--stock", type=number(-10_000, 10_000), nargs=4, default=None,
                        metavar=("XMIN", "YMIN", "XMAX", "YMAX"),
                        help="stock, mm (default: the cutting moves' extent plus the tool radius)")
    parser.add_argument("--csv", default=None, metavar="OUT.csv", help="per-step x, y, chip and ploughing area")


def run_plough(args) -> int:
    """Simulate and print the totals (and write the CSV)."""
    import numpy as np

    from labkit._files import atomic_output, check_output_file
    from labkit.gcode import parse_file
    from labkit.micromachining.chipvolume import stock_extent
    from labkit.micromachining.dexel import plough

    if args.csv:
        check_output_file(args.csv, args.file)
    moves = parse_file(args.file)
    lower, upper = stock_extent(moves, args.tool_d, args.stock)
    res = plough(moves, lower, upper, resolution_mm=args.resolution, tool_diameter_mm=args.tool_d,
                 rpm=args.rpm, teeth=args.teeth, min_chip_mm=args.min_chip,
                 edge_radius_mm=args.edge_radius, scale=args.scale)
    chip, pl = float(res.chip_mm2.sum()), float(res.plough_mm2.sum())
    print(f"{args.file}: {len(res.xyz)} steps, removed {res.removed_dual_mm2:.6f} mm² "
          f"(X dexels {res.removed_mm2[0]:.6f}, Y dexels {res.removed_mm2[1]:.6f})")
    print(f"chip {chip:.6f} mm², ploughing {pl:.6f} mm² ({100 * pl / chip if chip else 0:.1f} % of the chip)")
    if args.csv:
        data = np.c_[res.xyz[:, :2], res.chip_mm2, res.plough_mm2]
        with atomic_output(args.csv) as fh:
            np.savetxt(fh, data, delimiter=",", header="x_mm,y_mm,chip_mm2,plough_mm2", comments="",
                       fmt="%.9g")
        print(f"{args.csv}: {len(data)} rows")
    return 0
