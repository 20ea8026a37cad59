"""``labkit millfeed``: feed-rate scheduling of a micro-milling program from its chip volume.

``labkit millfeed FILE --tool-d MM --teeth N --rpm RPM --ft-min MM --ft-max MM -o OUT``
simulates the program on a z-map stock, sets each block's feed from its mean chip volume
([MicroCAM] eq. 3.2; ``--per-position``: a feed per step, smoothed) and writes the new
program, printing the chip volume range, the block counts and the machining time before
and after (:mod:`labkit.micromachining.feedschedule`).
"""

from __future__ import annotations


def add_millfeed_arguments(parser):
    from labkit.commands._args import add_dialect_option, integer, number

    parser.add_argument("file", metavar="FILE", help="micro-milling G-code program")
    parser.add_argument("-o", "--output", required=True, metavar="OUT.gcode", help="program to write")
    parser.add_argument("--tool-d", type=number(0.001, 100), required=True, metavar="MM",
                        help="flat-end mill diameter, 0.001…100 mm")
    parser.add_argument("--teeth", type=integer(1, 64), required=True, metavar="N", help="flutes, 1…64")
    parser.add_argument("--rpm", type=number(1, 1_000_000), required=True, metavar="RPM",
                        help="spindle speed, 1…1e6 rev/min")
    parser.add_argument("--ft-min", type=number(1e-6, 10), required=True, metavar="MM",
                        help="least feed per tooth, 1e-6…10 mm")
    parser.add_argument("--ft-max", type=number(1e-6, 10), required=True, metavar="MM",
                        help="largest feed per tooth, 1e-6…10 mm")
    parser.add_argument("--scale", type=number(1, 10_000), default=10.0, metavar="K",
                        help="steps of K × feed per tooth, 1…10000 (default 10)")
    parser.add_argument("--window", type=integer(1, 100_001), default=5, metavar="N",
                        help="moving-average window, odd, positions (default 5)")
    parser.add_argument("--per-position", action="store_true",
                        help="one feed per step (more blocks) instead of one per original block")
    parser.add_argument("--stock", type=number(-10_000, 10_000), nargs=4, default=None,
                        metavar=("XMIN", "YMIN", "XMAX", "YMAX"),
                        help="stock in XY, mm (default: the cutting moves' extent plus the tool radius)")
    parser.add_argument("--top", type=number(-10_000, 10_000), default=0.0, metavar="MM",
                        help="stock top Z, mm (default 0)")
    parser.add_argument("--thickness", type=number(0.001, 10_000), default=1.0, metavar="MM",
                        help="stock thickness T, mm (default 1)")
    parser.add_argument("--cell", type=number(0.0001, 10), default=0.005, metavar="MM",
                        help="z-map cell size, 0.0001…10 mm (default 0.005)")
    add_dialect_option(parser)


def run_millfeed(args) -> int:
    """Simulate, schedule, write; print the figures."""
    from labkit._files import check_output_file
    from labkit.errors import InputError
    from labkit.gcode import parse_file, write_gcode
    from labkit.micromachining.chipvolume import ZMap, stock_extent
    from labkit.micromachining.feedschedule import SEED_BLOCK_TIME_S, schedule_feeds

    check_output_file(args.output, args.file)
    if args.window % 2 == 0:
        raise InputError(f"--window must be odd, got {args.window}")
    moves = parse_file(args.file, dialect=args.dialect)
    lower, upper = stock_extent(moves, args.tool_d, args.stock)
    stock = ZMap.stock(lower, upper, top_z=args.top, bottom_z=args.top - args.thickness, cell_mm=args.cell)
    s = schedule_feeds(moves, stock, tool_diameter_mm=args.tool_d, rpm=args.rpm, teeth=args.teeth,
                       ft_min_mm=args.ft_min, ft_max_mm=args.ft_max, scale=args.scale, window=args.window)
    out = s.per_position if args.per_position else s.per_block
    write_gcode(args.output, out, dialect=args.dialect,
                comment=f"labkit millfeed {'per position' if args.per_position else 'per block'}")
    v = s.chips.per_tooth_mm3 * 1e9
    t = s.times_s()
    tb = s.times_s(block_time_s=SEED_BLOCK_TIME_S)
    print(f"{args.file}: {len(s.chips.xyz)} positions, chip volume per tooth {v.min():.1f}…{v.max():.1f} µm³")
    print(f"blocks: original {len(moves)}, per block {len(s.per_block)}, per position {len(s.per_position)}")
    print(f"time (planner): original {t['original']:.2f} s, per block {t['per_block']:.2f} s, "
          f"per position {t['per_position']:.2f} s")
    print(f"time with {SEED_BLOCK_TIME_S:.3f} s per block: original {tb['original']:.2f} s, per block "
          f"{tb['per_block']:.2f} s, per position {tb['per_position']:.2f} s")
    print(f"{args.output}: {'per position' if args.per_position else 'per block'}, {len(out)} moves")
    return 0
