"""``labkit svg2gcode`` and ``labkit dxf2gcode``: vector artwork to laser G-code with a summary."""

from __future__ import annotations

import argparse
import math
import sys
import warnings
from pathlib import Path as FilePath

import numpy as np

__all__ = ["add_svg2gcode_arguments", "run_svg2gcode", "add_dxf2gcode_arguments", "run_dxf2gcode",
           "parse_layer_option"]


def parse_layer_option(text: str):
    """``NAME:FEED:POWER[:PASSES[:ZSTEP]]`` → (name, LayerSettings).

    >>> name, s = parse_layer_option("#ff0000:600:900:2")
    >>> name, s.feed_mm_min, s.s_word, s.passes
    ('#ff0000', 600.0, 900.0, 2)
    """
    from labkit.errors import GeometryError
    from labkit.toolpath.build import LayerSettings

    fields = text.split(":")             # numbers from the right; the name may hold colons
    numbers = []
    while fields and len(numbers) < 4:
        try:
            numbers.insert(0, float(fields[-1]))
            fields.pop()
        except ValueError:
            break
    name = ":".join(fields)
    if not name or len(numbers) < 2:
        raise GeometryError(f"--layer {text!r}: expected NAME:FEED:POWER[:PASSES[:ZSTEP]], "
                            "e.g. '#ff0000:600:1000:2'")
    feed, power = numbers[0], numbers[1]
    passes = numbers[2] if len(numbers) > 2 else 1.0
    z_step = numbers[3] if len(numbers) > 3 else 0.0
    problems = []
    if not (math.isfinite(feed) and feed > 0):
        problems.append(f"FEED {feed:g} must be a finite number > 0 (mm/min)")
    if not (math.isfinite(power) and power >= 0):
        problems.append(f"POWER {power:g} must be a finite number >= 0 (S)")
    if not (math.isfinite(passes) and passes >= 1 and passes == int(passes)):
        problems.append(f"PASSES {passes:g} must be a whole number >= 1")
    if not math.isfinite(z_step):
        problems.append(f"ZSTEP {z_step:g} must be finite (mm)")
    if problems:
        raise GeometryError(f"--layer {text!r}: " + "; ".join(problems))
    passes = int(passes)
    return name, LayerSettings(feed_mm_min=feed, s_word=power, passes=passes, z_step_mm=z_step)


def _common_arguments(parser: argparse.ArgumentParser, kind: str) -> None:
    from labkit.commands._args import FEED, add_machine_options, integer, number, tolerance_option

    positive = number(0, lo_open=True)
    non_negative = number(0)
    parser.add_argument("input", help=f"{kind} file")
    parser.add_argument("-o", "--output", required=True, help="G-code file to write")
    parser.add_argument("--tol", **tolerance_option("largest deviation of the toolpath from the "
                                                    "drawing", 0.01))
    parser.add_argument("--feed", type=FEED, default=1000.0, metavar="MM_MIN",
                        help="cutting feed, mm/min (default 1000)")
    parser.add_argument("--power", type=non_negative, default=1000.0, metavar="S",
                        help="laser power S, 0…--s-max (default 1000)")
    parser.add_argument("--passes", type=integer(1), default=1, help="passes over every layer (default 1)")
    parser.add_argument("--z-step", type=number(-100, 100), default=0.0, metavar="MM",
                        help="Z down after each pass, -100…100 mm")
    parser.add_argument("--dynamic", action="store_true", help="M4 (power follows speed) instead of M3")
    parser.add_argument("--layer", action="append", default=[], metavar="NAME:FEED:POWER[:PASSES[:ZSTEP]]",
                        help="settings for one layer (SVG colour such as #ff0000, or DXF layer); repeatable")
    parser.add_argument("--arcs", action="store_true", help="keep arcs and fit arcs to curves (G2/G3)")
    parser.add_argument("--fill", action="store_true", help="hatch closed shapes before their contours")
    parser.add_argument("--fill-spacing", type=positive, default=0.1, metavar="MM",
                        help="hatch line spacing = beam width, mm (default 0.1)")
    parser.add_argument("--fill-angle", type=number(-360, 360), default=0.0, metavar="DEG",
                        help="hatch angle, degrees")
    parser.add_argument("--kerf", type=number(0, 10), default=0.0, metavar="MM",
                        help="kerf width: closed shapes are offset by half of it (parts to size)")
    parser.add_argument("--no-order", action="store_true", help="cut in drawing order")
    parser.add_argument("--no-improve", action="store_true", help="greedy ordering only (no 2-opt)")
    parser.add_argument("--rapid", type=FEED, default=None, metavar="MM_MIN",
                        help="travel speed for the time estimate (default: the simulator's)")
    parser.add_argument("--s-max", type=positive, default=1000.0, help="S of full power (GRBL $30)")
    parser.add_argument("--dialect", default="grbl", help="G-code dialect (grbl, labkit-fw, marlin)")
    parser.add_argument("--travel-beam-off", action="store_true",
                        help="switch the beam off (M5) for every rapid, for controllers that "
                             "burn on G0 (GRBL with $32=0)")
    parser.add_argument("--preview", default=None, metavar="PNG", help="also draw the job to this PNG")
    add_machine_options(parser)
    from labkit.materials import add_material_options

    add_material_options(parser, "vector")
    from labkit.record import add_record_option

    add_record_option(parser)


def _image_mode(text: str) -> str:
    """``--images MODE``, checked against img2gcode's modes only when given: the raster package
    costs every svg2gcode command ~30 ms to import."""
    from labkit.raster.engrave import MODES

    if text not in MODES:
        raise argparse.ArgumentTypeError(f"invalid choice: {text!r} (choose from {', '.join(MODES)})")
    return text


def add_svg2gcode_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``labkit svg2gcode``."""
    _common_arguments(parser, "SVG")
    parser.add_argument("--fit", choices=("greedy", "biarc"), default="greedy",
                        help="with --arcs, how curves become arcs: fewest blocks (greedy, default) "
                             "or tangent-continuous biarcs")
    parser.add_argument("--no-flip", action="store_true", help="keep SVG's downward y axis")
    parser.add_argument("--clip-to-page", action="store_true",
                        help="cut only what lies on the page, as a renderer shows it (default: "
                             "shapes reaching beyond the page are cut whole, with a warning)")
    from labkit.commands._args import FEED, number

    parser.add_argument("--images", type=_image_mode, default=None, metavar="MODE",
                        help="engrave the bitmaps the SVG embeds, where it places them, before the cuts "
                             "(a mode of img2gcode --mode; as labkit job's image layers, line interval "
                             "--fill-spacing); default: they are named in a warning and not burned")
    parser.add_argument("--image-power", type=number(0), default=None, metavar="S",
                        help="with --images: S of full black (default --power)")
    parser.add_argument("--image-feed", type=FEED, default=None, metavar="MM_MIN",
                        help="with --images: engraving speed, mm/min (default --feed)")


def add_dxf2gcode_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``labkit dxf2gcode``."""
    from labkit.vector.dxf import UNIT_NAMES

    _common_arguments(parser, "DXF")
    parser.add_argument("--units", choices=sorted(UNIT_NAMES), default=None,
                        help="the drawing's unit, overriding $INSUNITS (a drawing without units "
                             "is taken as mm, with a warning)")


def _run(args, drawing, images=None) -> int:
    from labkit._files import atomic_output, check_output_file
    from labkit.commands._args import check_fits
    from labkit.errors import GeometryError, InputError
    from labkit.gcode.simulate import summarize
    from labkit.units import s_within
    from labkit.geometry.path import count_segments, max_deviation
    from labkit.toolpath.build import LayerSettings
    from labkit.toolpath.job import vector_job
    from labkit.toolpath.moves import LaserMode
    from labkit.viz.preview import preview_format, write_moves_preview

    from labkit.materials import apply_material

    material = apply_material(args, "vector")    # typed options beat the library's
    output = check_output_file(args.output, args.input)
    if args.preview:                 # checked before any work, like the output
        check_output_file(args.preview, args.input)
        preview_format(args.preview)
    laser = LaserMode.DYNAMIC if args.dynamic else LaserMode.CONSTANT
    default = LayerSettings(feed_mm_min=args.feed, s_word=args.power, passes=args.passes,
                            z_step_mm=args.z_step, laser=laser)
    per_layer = {}
    for text in args.layer:
        name, s = parse_layer_option(text)
        per_layer[name] = LayerSettings(s.feed_mm_min, s.s_word, s.passes, s.z_step_mm, laser)
    for name, layer in [("--power", default)] + [(f"--layer {n}", v) for n, v in per_layer.items()]:
        if not s_within(layer.s_word, args.s_max):
            raise InputError(f"{name}: power S{layer.s_word:g} is above --s-max {args.s_max:g}; "
                             f"expected a power within 0…{args.s_max:g}")
    try:
        with warnings.catch_warnings(record=True) as caught:     # e.g. a hole the kerf closes
            warnings.simplefilter("always")
            job = vector_job(drawing.paths, default=default, layers=per_layer, tol_mm=args.tol,
                             arcs=args.arcs, kerf_mm=args.kerf, fill=args.fill,
                             fill_spacing_mm=args.fill_spacing, fill_angle_rad=math.radians(args.fill_angle),
                             order=not args.no_order, improve=not args.no_improve, s_max=args.s_max)
    except GeometryError as exc:
        raise InputError(str(exc)) from None
    for w in caught:
        print(f"warning: {w.message}", file=sys.stderr)
    if images is not None:                     # the bitmaps first, then the cuts (engrave before cut)
        from labkit.toolpath.job import VectorJob
        from labkit.toolpath.moves import Moves

        cuts = job.moves.copy()
        if len(cuts):
            cuts.start[0] = images.end[-1]    # the cut's first rapid leaves from the last bitmap
        job = VectorJob(job.paths, Moves.concat([images, cuts]), job.tol_mm)
    paths, moves = job.paths, job.moves
    if len(moves):
        ends = np.vstack([moves.start, moves.end])
        extent = np.ptp(ends, axis=0)
        check_fits(args, extent if extent[2] > 0 else extent[:2])
    text = job.gcode(args.dialect, travel_beam_off=args.travel_beam_off or None,
                     comment=f"{FilePath(args.input).name}: tol {args.tol:g} mm, "
                             f"{'arcs' if args.arcs else 'lines'}" + (f"; material {material}" if material else ""))
    with atomic_output(output, encoding="ascii") as fh:
        fh.write(text)
    opts = {} if args.rapid is None else {"rapid_mm_min": args.rapid}
    summary = summarize(moves, source_lines=text.count("\n"), **opts)
    lines, arcs = count_segments(paths)
    motion = moves.motion_lines
    print(f"input           {args.input} ({len(drawing.paths)} paths, layers {', '.join(drawing.layers) or '-'})")
    if drawing.skipped:
        print(f"skipped         {', '.join(drawing.skipped)}")
    if material:
        print(f"material        {material}")
    print(f"segments        {lines + arcs} ({lines} lines, {arcs} arcs) in {len(paths)} paths")
    print(f"G-code lines    {text.count(chr(10))} ({motion} motion)")
    print(f"max deviation   {max_deviation(paths):.4f} mm (tolerance {args.tol:g} mm)")
    print(summary.format())
    print(f"G-code          {args.output}")
    if args.preview:
        write_moves_preview(moves, args.preview)
        print(f"preview         {args.preview}")
    from labkit.record import record_program

    made = record_program("svg2gcode" if hasattr(args, "fit") else "dxf2gcode", args,
                          inputs=[(args.input, "input")], program=output, extra_outputs=[(args.preview, "preview")])
    if made:
        print(f"record          {made}")
    return 0


def _refuse_empty(drawing, kind: str) -> None:
    """A drawing with nothing to cut is an error that says what was found, never an empty job."""
    from labkit.errors import InputError

    if drawing.paths:
        return
    if drawing.skipped:
        kinds = sorted({s.split("#")[0].split("[")[0] for s in drawing.skipped})
        raise InputError(f"{drawing.source}: nothing to cut: the {kind} holds only "
                         f"{', '.join(kinds)} ({len(drawing.skipped)} element(s)); engrave bitmaps with "
                         f"svg2gcode --images MODE or labkit job (a layer with operation \"image\"), and "
                         f"convert flowed text and text on a path to paths in the drawing program")
    hidden = getattr(drawing, "clipped", [])
    raise InputError(f"{drawing.source}: nothing to cut: the {kind} has no visible shapes"
                     + (f" ({len(hidden)} clipped away entirely: {', '.join(hidden[:5])})" if hidden else ""))


def run_svg2gcode(args) -> int:
    """Read the SVG, build the job, write G-code (and a preview), print the summary."""
    from labkit._files import check_input_file
    from labkit.vector.svg import read_svg

    check_input_file(args.input, what="SVG file")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        drawing = read_svg(args.input, tol_mm=args.tol, arcs=args.arcs, fit=args.fit, flip_y=not args.no_flip,
                           clip_to_page=args.clip_to_page)
    images = _svg_image_moves(args, drawing) if args.images else None     # engraved: no longer skipped
    for w in caught:
        if images is not None and not drawing.skipped and " not cut: " in str(w.message):
            continue                            # it named only the bitmaps now engraved
        print(f"warning: {w.message}", file=sys.stderr)
    if images is None:
        _refuse_empty(drawing, "SVG")
    return _run(args, drawing, images)


def _svg_image_moves(args, drawing):
    """``--images``: the SVG's bitmaps engraved as a job's image layer engraves them."""
    from labkit.errors import InputError
    from labkit.jobfile import engrave_images
    from labkit.units import s_within
    from labkit.vector.images import svg_images

    placed = svg_images(args.input, flip_y=not args.no_flip)
    if not placed:
        raise InputError(f"{args.input}: --images {args.images}: the SVG embeds no bitmap")
    power = args.power if args.image_power is None else args.image_power
    if not s_within(power, args.s_max):
        raise InputError(f"--image-power: power S{power:g} is above --s-max {args.s_max:g}; "
                         f"expected a power within 0…{args.s_max:g}")
    drawing.skipped[:] = [s for s in drawing.skipped if s not in {p.name for p in placed}]
    return engrave_images([p.engraving_item for p in placed], mode=args.images, line_interval_mm=args.fill_spacing,
                          feed_mm_min=args.feed if args.image_feed is None else args.image_feed, s_word=power,
                          s_max=args.s_max, dynamic=args.dynamic, where=args.input)


def run_dxf2gcode(args) -> int:
    """Read the DXF, build the job, write G-code (and a preview), print the summary."""
    from labkit._files import check_input_file
    from labkit.vector.dxf import read_dxf

    check_input_file(args.input, what="DXF file")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        drawing = read_dxf(args.input, tol_mm=args.tol, arcs=args.arcs, units=args.units)
    for w in caught:
        print(f"warning: {w.message}", file=sys.stderr)
    _refuse_empty(drawing, "DXF")
    return _run(args, drawing)
