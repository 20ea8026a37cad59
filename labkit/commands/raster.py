"""``labkit img2gcode``: a raster image to laser G-code, with the report and a preview PNG."""

from __future__ import annotations

import argparse
from pathlib import Path

__all__ = ["add_img2gcode_arguments", "run_img2gcode"]


def add_img2gcode_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``labkit img2gcode``."""
    from labkit.commands._args import FEED, add_machine_options, number
    from labkit.raster.diffusion import DIFFUSION
    from labkit.raster.engrave import MODES

    positive = number(0, lo_open=True)
    non_negative = number(0)
    fraction = number(0, 1)

    parser.add_argument("input", help="image file (PNG, BMP, JPEG, …)")
    parser.add_argument("-o", "--output", required=True, help="G-code file to write")
    parser.add_argument("--mode", choices=MODES, default="zigzag", help="how to engrave (default zigzag)")
    parser.add_argument("--beam", type=positive, default=0.1, metavar="MM",
                        help="beam diameter = pixel size of the job, mm (default 0.1)")
    size = parser.add_mutually_exclusive_group()
    size.add_argument("--width", type=positive, metavar="MM", help="engraved width, mm")
    size.add_argument("--height", type=positive, metavar="MM", help="engraved height, mm")
    size.add_argument("--dpi", type=positive,
                      help="image resolution across (default: the file's, else 96; non-square pixels keep "
                           "the file's aspect)")
    parser.add_argument("--resample", choices=("bicubic", "nearest"), default="bicubic",
                        help="resampling to the beam (nearest for pixel art)")
    parser.add_argument("--feed", type=FEED, default=1000.0, metavar="MM_MIN", help="feed, 1…1000000 mm/min")
    parser.add_argument("--rapid", type=FEED, default=None, metavar="MM_MIN",
                        help="travel speed for the time estimate (default: the feed, as the seed)")
    parser.add_argument("--power", type=non_negative, default=1000.0, metavar="S",
                        help="S for binary modes (default 1000)")
    parser.add_argument("--s-max", type=positive, default=1000.0, help="S of full power (GRBL $30)")
    parser.add_argument("--threshold", type=number(0, 256), default=128, metavar="LEVEL",
                        help="gray level 0…256 below which a pixel burns (binary modes)")
    parser.add_argument("--invert", action="store_true", help="negative image first")
    parser.add_argument("--blur", action="store_true", help="3×3 blur first")
    parser.add_argument("--sharpen", action="store_true", help="3×3 sharpen first")
    parser.add_argument("--order", choices=("indexed", "reference", "scan"), default="indexed",
                        help="segment connection: greedy nearest (indexed or the seed's O(n²)) or scan order")
    parser.add_argument("--axis", choices=("auto", "rows", "columns"), default="auto", help="zig-zag lines")
    parser.add_argument("--unidirectional", action="store_true", help="zig-zag in one direction only")
    parser.add_argument("--edge-operator", choices=("sobel", "prewitt", "roberts", "sxor", "canny"),
                        default="sobel", help="edges mode: the detector")
    parser.add_argument("--edge-threshold", type=non_negative, default=None,
                        help="edges mode: magnitude threshold (default a quarter of the maximum)")
    parser.add_argument("--edge-path", choices=("spiral", "zigzag"), default="spiral",
                        help="edges mode: how edge pixels are pathed")
    parser.add_argument("--min-power", type=fraction, default=0.0, help="gray: power of the lightest pixel, 0…1")
    parser.add_argument("--max-power", type=fraction, default=1.0, help="gray/dither: power of the darkest, 0…1")
    parser.add_argument("--gamma", type=positive, default=1.0, help="gray/dither: gamma")
    parser.add_argument("--tone", default=None, metavar="CURVE.json",
                        help="gray: the material's tone curve ('labkit raster-test measure-tone'); "
                             "grays burn as the material shows them")
    parser.add_argument("--scan-offset", default=None, metavar="MODEL.json",
                        help="shift each backward row by the measured offset at its feed "
                             "('labkit raster-test measure-offset')")
    parser.add_argument("--dither", choices=sorted(DIFFUSION), default="floyd-steinberg",
                        help="dither mode: error diffusion method")
    parser.add_argument("--overscan", type=non_negative, default=2.0, metavar="MM", help="gray/dither: overscan, mm")
    parser.add_argument("--skip-white", type=non_negative, default=5.0, metavar="MM",
                        help="gray/dither: rapid over white gaps longer than this, mm")
    parser.add_argument("--dialect", default="grbl", help="G-code dialect (grbl, labkit-fw, marlin)")
    add_machine_options(parser)
    parser.add_argument("--readable", action="store_true",
                        help="spaced, absolute G-code (about a third larger); the default is compact: no spaces, "
                             "relative moves along a row where shorter (stock Marlin always gets the readable form)")
    parser.add_argument("--travel-beam-off", action="store_true",
                        help="switch the beam off (M5) for every rapid, for controllers that "
                             "burn on G0 (GRBL with $32=0)")
    parser.add_argument("--preview", default=None, metavar="PNG",
                        help="preview image (default: OUTPUT with .png); 'none' for no preview")
    from labkit.materials import add_material_options

    add_material_options(parser, "raster")
    from labkit.record import add_record_option

    add_record_option(parser)


def run_img2gcode(args) -> int:
    """Convert, write the G-code and the preview, print the report."""
    from labkit.gcode import emit
    from labkit.raster.engrave import RasterSettings, image_to_job, placed_size
    from labkit.raster.io import read_image

    from labkit._files import atomic_output, check_output_file
    from labkit.budget import check_budget
    from labkit.commands._args import check_fits
    from labkit.errors import InputError
    from labkit.units import s_within
    from labkit.viz.preview import preview_format, write_job_preview

    from labkit.materials import apply_material

    material = apply_material(args, "raster", raster_mode=args.mode)    # typed options beat the library's
    if material:
        print(f"material {material}")
    output = check_output_file(args.output, args.input)
    preview = None
    if (args.preview or "").lower() != "none":      # checked before any work, like the output
        preview = args.preview or str(Path(args.output).with_suffix(".png"))
        if not args.preview and Path(preview).resolve() == Path(args.input).resolve():
            preview = str(Path(args.output).with_suffix(".preview.png"))   # never the image itself
        check_output_file(preview, args.input)
        preview_format(preview)
    if not s_within(args.power, args.s_max):
        raise InputError(f"--power {args.power:g} is above --s-max {args.s_max:g}; "
                         f"expected a power within 0…{args.s_max:g}")
    if args.min_power > args.max_power:
        raise InputError(f"--min-power {args.min_power:g} is above --max-power {args.max_power:g}")
    tone = scan_offset = None
    if args.tone is not None:
        from labkit.laser.tone import load_tone

        if args.mode != "gray":
            raise InputError(f"--tone applies to --mode gray (a tone curve sets each gray's power), not {args.mode}")
        tone = load_tone(args.tone)
        import sys

        if abs(tone.feed_mm_min - args.feed) > 0.01 * args.feed:      # NaN (not known) says nothing
            print(f"warning: {args.tone} was measured at {tone.feed_mm_min:g} mm/min, the job runs at "
                  f"{args.feed:g}: the material darkens differently at another feed", file=sys.stderr)
    if args.scan_offset is not None:
        from labkit.laser.scanoffset import load_scan_offset

        scan_offset = load_scan_offset(args.scan_offset)
    img = read_image(args.input)
    rows, cols = img.pixels.shape[:2]
    width_mm, height_mm, size, source = placed_size(img.pixels.shape, width_mm=args.width, height_mm=args.height,
                                                    dpi=args.dpi, file_dpi=img.dpi,
                                                    pixel_aspect=img.pixel_aspect)
    print(f"job size {width_mm:.1f} × {height_mm:.1f} mm from {source}")
    check_fits(args, (width_mm, height_mm), what="the engraving")
    # Estimate the resampled size before resampling: one pixel per beam diameter.
    check_budget("pixels", (width_mm / args.beam) * (height_mm / args.beam),
                 cause=f"a {width_mm:.0f} × {height_mm:.0f} mm job at a {args.beam:g} mm beam",
                 option="--width/--height/--dpi or raise --beam")
    settings = RasterSettings(
        mode=args.mode, beam_mm=args.beam, **size, resample=args.resample, level=args.threshold,
        invert=args.invert, blur=args.blur, sharpen=args.sharpen, gamma=args.gamma, tone=tone,
        edge_operator=args.edge_operator, edge_threshold=args.edge_threshold, edge_path=args.edge_path,
        feed_mm_min=args.feed, rapid_mm_min=args.rapid, s_max=args.s_max, s_word=args.power,
        order=args.order, axis=args.axis, direction="unidirectional" if args.unidirectional else "bidirectional",
        min_power=args.min_power, max_power=args.max_power, overscan_mm=args.overscan,
        skip_white_mm=args.skip_white, dither=args.dither if args.mode == "dither" else None)
    try:
        job = image_to_job(img, settings)     # the file's pixel aspect and transparency with it
    except MemoryError:
        # image_to_job estimates its memory first (budget raster_bytes); a machine with
        # less free memory than the budget still gets a sentence, not a traceback.
        from labkit.errors import BudgetError

        raise BudgetError(f"out of memory converting the {cols:,} × {rows:,} px image "
                          f"({width_mm:.0f} × {height_mm:.0f} mm at a {args.beam:g} mm beam); "
                          f"reduce --width/--height/--dpi or raise --beam") from None
    if scan_offset is not None:
        from dataclasses import replace

        from labkit.laser.scanoffset import apply_scan_offset

        job = replace(job, moves=apply_scan_offset(job.moves, scan_offset))
        print(f"scan offset: backward rows moved {float(scan_offset.offset_mm(args.feed)) * 1e3:.1f} µm "
              f"at {args.feed:g} mm/min")
    if not len(job.moves):
        from labkit.errors import RasterError

        hint = ("--edge-threshold lower, or another --edge-operator" if args.mode == "edges" else
                "--threshold higher, or --invert" if args.mode in ("zigzag", "spiral") else
                "--max-power higher, or a darker image")
        raise RasterError(f"{args.input}: nothing to burn in mode {args.mode} (no marked pixel); "
                          f"expected an image with dark content — try {hint}")
    from labkit.gcode.dialects import get_dialect

    compact = not args.readable and get_dialect(args.dialect).modal_motion     # Marlin reads spaced words
    text = emit(job.moves, dialect=args.dialect, travel_beam_off=args.travel_beam_off or None, compact=compact,
                comment=f"img2gcode {Path(args.input).name}: mode {args.mode}, beam {args.beam:g} mm"
                        + (f"; material {material}" if material else ""))
    with atomic_output(output, encoding="ascii") as fh:
        fh.write(text)
    report = job.report.with_gcode(text)
    print(report.format())
    print(f"{'G-code':<{_label_width(report)}}  {args.output}")
    if preview is not None:
        write_job_preview(job, preview)
        print(f"{'preview':<{_label_width(report)}}  {preview}")
    _warn_if_link_starves(text, job.moves, args)
    from labkit.record import record_program

    made = record_program("img2gcode", args, inputs=[(args.input, "input")], program=output,
                          extra_outputs=[(preview, "preview")])
    if made:
        print(f"{'record':<{_label_width(report)}}  {made}")
    return 0


def _warn_if_link_starves(text: str, moves, args) -> None:
    """Warn on stderr when the machine's link cannot deliver the job at its feed, and say what
    feed or pixel pitch it can (issue 30 §3). A cheap necessary condition first
    (:func:`labkit.motion.stall.may_starve`); the predictor only when it holds."""
    import math
    import sys

    from labkit.errors import LabkitError
    from labkit.motion.spec import load_machine
    from labkit.motion.stall import block_time_bounds, may_starve, motion_line_numbers

    m = load_machine(args.machine)
    line, nbytes = motion_line_numbers(text, len(moves))
    bounds = block_time_bounds(moves, m) if line is not None else None
    if bounds is not None:
        rows, least_s = bounds
        del bounds
        block_line = line if len(rows) == len(line) else line[rows]    # every move a block: as is
        del rows, line
        if not may_starve(nbytes, block_line, least_s, m):
            return
        del block_line, least_s, nbytes
    from labkit.gcode import parse
    from labkit.motion.pipeline import plan
    from labkit.motion.stall import predict_stalls, stall_free_feed

    try:
        read = parse(text, dialect=args.dialect)
        planned = plan(read, m, planner="junction")
        stalls = predict_stalls(text, m, dialect=args.dialect, plan=planned).stalls
        if not stalls:
            return
        free = stall_free_feed(text, m, dialect=args.dialect, rows=False, moves=read, plan=planned)
    except LabkitError as exc:         # the program is written; only the check could not be made
        print(f"note: the link to {m.name} was not checked: {exc}", file=sys.stderr)
        return
    head = (f"warning: at {m.link_baud} baud ({m.name}) the link cannot keep up with this job: "
            f"{len(stalls)} starvations predicted at the programmed feed {free.programmed_mm_min:g} mm/min "
            f"(first at line {stalls[0].line})")
    if free.limited_by == "travel":
        print(f"{head}; its rapids outrun the link at any feed: a faster link (baud) is needed",
              file=sys.stderr)
        return
    feed = math.floor(free.feed_mm_min)
    # lines per mm fall as the pitch grows, so the feed the link allows grows with it
    pitch = math.ceil(args.beam * free.programmed_mm_min / free.feed_mm_min * 1000) / 1000
    print(f"{head}. The link limits it to {feed} mm/min: write it with --feed {feed}, or at a pixel "
          f"pitch of about {pitch:g} mm (--beam; an estimate: the feed the link allows grows about "
          f"in proportion with the pitch). Written anyway: a faster link may run it",
          file=sys.stderr)


def _label_width(report) -> int:
    return max(len(k) for k, _ in report.rows())
