"""``labkit slice``: planar sections of a 3-D model, each pocketed, as one laser job.

``labkit slice MODEL.stl --step MM --beam MM [--bottom-up] [--max-deg DEG] -o OUT.gcode``
sections a closed mesh at the middle of every slab of ``--step``, pockets each section
by inward offsets of the beam ([MicroCAM] §6.1.3.6,
:func:`labkit.toolpath.sections.section_toolpath`) and writes G-code.
"""

from __future__ import annotations


def add_slice_arguments(parser):
    from labkit.commands._args import add_cut_options, number, tolerance_option

    parser.add_argument("model", metavar="MODEL.stl", help="closed triangle mesh (STL, OBJ, PLY, OFF), mm")
    parser.add_argument("-o", "--output", required=True, metavar="OUT.gcode", help="G-code file to write")
    parser.add_argument("--step", type=number(0.001, 10_000), required=True, metavar="MM",
                        help="step down between sections, 0.001…10000 mm")
    parser.add_argument("--beam", type=number(0.001, 1_000), required=True, metavar="MM",
                        help="beam diameter (offset step), 0.001…1000 mm")
    parser.add_argument("--bottom-up", action="store_true", help="levels from the bottom up (default top-down)")
    parser.add_argument("--max-deg", type=number(0, 180), default=5.0, metavar="DEG",
                        help="drop contour vertices turning less than this, 0…180° (default 5)")
    parser.add_argument("--tol", **tolerance_option("tolerance of simplification and offsets", 0.005))
    parser.add_argument("--z-top", type=number(-10_000, 10_000), default=None, metavar="MM",
                        help="machine Z of the model's top (default: the model's own Z)")
    add_cut_options(parser)


def run_slice(args) -> int:
    """Read, check the work budget, section, pocket, write; one summary line."""
    import math

    from labkit._files import check_output_file
    from labkit.budget import check_budget
    from labkit.gcode import write_gcode
    from labkit.toolpath.sections import read_mesh, section_toolpath

    check_output_file(args.output, args.model)
    mesh = read_mesh(args.model)
    lo, hi = mesh.bounds
    levels = math.ceil((hi[2] - lo[2]) / args.step)
    rings = levels * math.ceil(0.5 * max(hi[:2] - lo[:2]) / args.beam + 1)
    check_budget("moves", rings * 64, cause=f"{levels} levels of --step {args.step:g} with --beam {args.beam:g}",
                 option="--step (or raise --beam)")
    moves, info = section_toolpath(mesh, args.step, args.beam, top_down=not args.bottom_up,
                                   max_deg=args.max_deg, tol_mm=args.tol, z_top_mm=args.z_top,
                                   feed_mm_min=args.feed, s_word=args.power)
    lines = write_gcode(args.output, moves, dialect=args.dialect, comment=f"labkit slice {args.model}")
    cut = moves.laser_on
    print(f"{args.output}: {len(info)} levels, {sum(lv['rings'] for lv in info)} rings, {len(moves)} moves, "
          f"{float(moves.lengths_mm()[cut].sum()):.3f} mm cut, {lines} lines")
    return 0
