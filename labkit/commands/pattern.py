"""``labkit pattern``: the parametric CAM toolpaths of :mod:`labkit.toolpath.patterns`.

``labkit pattern helix|spiral|square-spiral|zigzag|cone [options] -o OUT.gcode`` builds
one generator's Moves, checks the number of moves against the ``moves`` budget
before building, and writes G-code. Every numeric option has a stated range.
"""

from __future__ import annotations

import math


#: coordinates and sizes, mm: a laser machine's table is far below a 10 m square
_COORD = (-10_000.0, 10_000.0)
_SIZE = (0.001, 10_000.0)


def _common(p):
    from labkit.commands._args import add_cut_options

    p.add_argument("-o", "--output", required=True, metavar="OUT.gcode", help="G-code file to write")
    add_cut_options(p)


def _centre(p, z_name="--z"):
    from labkit.commands._args import number

    for name in ("--x", "--y", z_name):
        p.add_argument(name, type=number(*_COORD), default=0.0, metavar="MM",
                       help=f"{name[2:]} of the centre/start, -10000…10000 mm (default 0)")


def _sub(sub, name, help_text):
    p = sub.add_parser(name, help=help_text)
    _common(p)
    _centre(p)
    return p


def _size(help_text, default, lo=_SIZE[0]):
    from labkit.commands._args import number

    return dict(type=number(lo, _SIZE[1]), default=default, metavar="MM",
                help=f"{help_text}, {lo:g}…{_SIZE[1]:g} mm (default {default:g})")


def add_pattern_arguments(parser):
    from labkit.commands._args import integer, number, tolerance_option

    tol = tolerance_option("largest distance between the arcs and the curve", 0.005)
    sub = parser.add_subparsers(dest="pattern", required=True, metavar="PATTERN")
    h = _sub(sub, "helix", "helical G2/G3 descent for a hole, then a full circle")
    h.add_argument("--radius", **_size("helix radius (beam centre)", 1.0))
    h.add_argument("--pitch", **_size("Z per turn", 0.5))
    h.add_argument("--turns", type=number(0, 100_000, lo_open=True), default=2.0, metavar="N",
                   help="number of turns, > 0 and <= 100000 (default 2)")
    h.add_argument("--cw", action="store_true", help="clockwise (G2) instead of G3")

    s = _sub(sub, "spiral", "Archimedean spiral r = a + b·θ closed by a full circle")
    s.add_argument("--radius", **_size("outer radius (closing circle)", 5.0))
    s.add_argument("--inner", **_size("inner radius a, below --radius", 0.0, lo=0))
    s.add_argument("--step", **_size("radial step per turn", 0.2))
    s.add_argument("--tol", **tol)

    q = _sub(sub, "square-spiral", "square spiral at a constant step with corner loops")
    q.add_argument("--size", **_size("side of the square", 10.0))
    q.add_argument("--step", **_size("step between passes", 0.5))
    q.add_argument("--accel", type=number(1, 1_000_000), default=500.0, metavar="MM_S2",
                   help="machine acceleration for the loops, 1…1e6 mm/s² (default 500)")
    q.add_argument("--no-loops", action="store_true", help="no corner loops or leads")

    z = _sub(sub, "zigzag", "zig-zag face machining in XY or XZ")
    z.add_argument("--width", **_size("extent along the plane's first axis (X)", 10.0))
    z.add_argument("--height", **_size("extent along the plane's second axis (Y or Z)", 5.0))
    z.add_argument("--step", **_size("step-over", 0.5))
    z.add_argument("--along", choices=("x", "y", "z"), default="x", help="pass direction (default x)")
    z.add_argument("--plane", choices=("xy", "xz"), default="xy", help="face plane (default xy)")
    z.add_argument("--lead", **_size("laser-off lead-in/out per pass", 0.0, lo=0))
    z.add_argument("--reverse", action="store_true", help="step-over towards the origin")

    c = _sub(sub, "cone", "cone as stacked spirals ([MicroCAM] eqs. 6.4-6.6)")
    c.add_argument("--d1", **_size("diameter at the start Z", 10.0))
    c.add_argument("--d2", **_size("diameter at depth H", 4.0))
    c.add_argument("--height", **_size("cone height H", 2.0))
    c.add_argument("--levels", type=integer(1, 100_000), default=4, metavar="N",
                   help="number of passes Zlevel, 1…100000 (default 4)")
    c.add_argument("--beam", **_size("beam diameter (spiral step)", 0.2))
    c.add_argument("--tol", **tol)


def _spiral_samples(radius, inner, step, tol):
    """Samples the spiral's arc fit reads (an upper bound on its moves)."""
    dtheta = 2 * math.acos(max(-1.0, 1 - tol / (4 * radius)))
    return (radius - inner) / step * 2 * math.pi / dtheta + 10


def _estimate(a) -> tuple[float, str, str]:
    """(moves or samples, cause, option) before building."""
    if a.pattern == "helix":
        return 2 * a.turns + 4, f"--turns {a.turns:g}", "--turns"
    if a.pattern == "spiral":
        return (_spiral_samples(a.radius, min(a.inner, a.radius), a.step, a.tol),
                f"--radius {a.radius:g} / --step {a.step:g} at --tol {a.tol:g}",
                "--radius (or raise --step, --tol)")
    if a.pattern == "square-spiral":
        return (6 * (2 * a.size / a.step + 2), f"--size {a.size:g} / --step {a.step:g}",
                "--size (or raise --step)")
    if a.pattern == "zigzag":
        cross = a.width if a.along != "x" else a.height
        return 4 * (cross / a.step + 2), f"--step {a.step:g}", "the extent (or raise --step)"
    return (a.levels * _spiral_samples(a.d1 / 2, 0.0, a.beam, a.tol),
            f"--levels {a.levels} of --d1 {a.d1:g} / --beam {a.beam:g}",
            "--levels (or raise --beam, --tol)")


def _build(a):
    from labkit.toolpath import patterns

    kw = dict(feed_mm_min=a.feed, s_word=a.power)
    if a.pattern == "helix":
        return patterns.helix((a.x, a.y), a.radius, a.pitch, a.turns, z_start_mm=a.z, ccw=not a.cw, **kw)
    if a.pattern == "spiral":
        return patterns.archimedean_spiral((a.x, a.y), a.radius, a.step, inner_radius_mm=a.inner,
                                           tol_mm=a.tol, z_mm=a.z, **kw)
    if a.pattern == "square-spiral":
        return patterns.square_spiral((a.x, a.y), a.size, a.step, z_mm=a.z, accel_mm_s2=a.accel,
                                      loops=not a.no_loops, **kw)[0]
    if a.pattern == "zigzag":
        return patterns.zigzag((a.x, a.y, a.z), a.width, a.height, a.step, along=a.along, plane=a.plane,
                               lead_mm=a.lead, reverse=a.reverse, **kw)
    return patterns.cone((a.x, a.y), a.d1, a.d2, a.height, a.levels, a.beam, z_start_mm=a.z,
                         tol_mm=a.tol, **kw)


def run_pattern(args) -> int:
    """Check the budget, build the pattern, write the G-code, print one summary line."""
    from labkit.budget import check_budget
    from labkit.gcode import write_gcode

    estimate, cause, option = _estimate(args)
    check_budget("moves", estimate, cause=cause, option=option)
    moves = _build(args)
    lines = write_gcode(args.output, moves, dialect=args.dialect,
                        comment=f"labkit pattern {args.pattern}")
    cut = moves.laser_on
    print(f"{args.output}: {args.pattern}, {len(moves)} moves ({int(moves.is_arc.sum())} arcs), "
          f"{float(moves.lengths_mm()[cut].sum()):.3f} mm cut, {lines} lines")
    return 0
