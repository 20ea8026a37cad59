"""``labkit plan`` and ``labkit steps``: the motion reference from the shell.

``labkit plan FILE.gcode --planner junction|fast|normal|hq`` prints the job
time, blocks, super blocks, peak and mean speed and laser-on time; ``--trace
OUT.csv`` writes one row per block. ``labkit steps FILE.gcode -o OUT.csv``
writes the step pulse train (time, steps per axis, direction bits, timer
period) that the firmware must reproduce.
"""

from __future__ import annotations

import json
import sys

from labkit.gcode.dialects import DIALECTS


def _add_common(parser):
    from labkit.commands._args import integer, number, tolerance_option
    from labkit.motion.planner import PLANNERS

    parser.add_argument("file", help="G-code file")
    parser.add_argument("--planner", choices=PLANNERS, default="junction",
                        help="look-ahead: GRBL junction deviation, or [CBR40]'s MBLA modes "
                             "fast/normal/hq (default: junction)")
    parser.add_argument("--machine", default=None, metavar="TOML",
                        help="machine description file or name shipped with labkit (labkit/motion/machines/) (default: cbr40-laser)")
    parser.add_argument("--buffer", type=integer(1, 100_000), default=None, metavar="N",
                        help="look-ahead depth in blocks, 1…100000 (default: the machine's)")
    parser.add_argument("--law", choices=("linear", "accel"), default=None,
                        help="ramp law: [CBR40] Hz/step (linear) or constant acceleration "
                             "(default: linear for MBLA, accel for junction)")
    parser.add_argument("--arc-tol", **tolerance_option(
        "cut arcs into chords at this tolerance (GRBL $12) instead of walking them as octant "
        "Bresenham arcs", None))
    parser.add_argument("--dialect", choices=list(DIALECTS), default="grbl",
                        help="how F, G4 P and S are read (default: grbl)")
    parser.add_argument("--lenient", action="store_true",
                        help="skip rejected lines (as a controller would) instead of failing")


def _plan(args):
    from labkit.gcode import parse_file
    from labkit.motion import plan

    moves = parse_file(args.file, dialect=args.dialect, lenient=args.lenient)
    return plan(moves, args.machine, planner=args.planner, buffer_blocks=args.buffer, law=args.law,
                arc_tol_mm=args.arc_tol)


# -- plan ------------------------------------------------------------------------------------

def add_plan_arguments(parser):
    _add_common(parser)
    parser.add_argument("--json", action="store_true", help="print the summary as JSON")
    parser.add_argument("--trace", metavar="OUT.csv",
                        help="write one row per block: source line, length, entry/peak/exit "
                             "speed, power, start and duration")


def _hms(seconds: float) -> str:
    m, s = divmod(seconds, 60.0)
    h, m = divmod(int(m), 60)
    return f"{h}:{m:02d}:{s:06.3f}"


def run_plan(args) -> int:
    from labkit._files import atomic_output, check_output_file

    if args.trace:
        check_output_file(args.trace, args.file)
    p = _plan(args)
    s = p.summary()
    if args.trace:
        with atomic_output(args.trace, newline="") as fh:
            p.trace().to_csv(fh, index=False, float_format="%.9g")
    if args.json:
        out = s.as_dict()
        out["file"] = args.file
        out["machine"] = p.machine.name
        print(json.dumps(out, indent=2))
        return 0
    rows = [
        ("file", args.file),
        ("machine", p.machine.name),
        ("planner", f"{s.planner} (ramps: {s.law}, buffer {s.buffer_blocks} blocks)"),
        ("job time", f"{s.job_time_s:.3f} s ({_hms(s.job_time_s)})"),
        ("blocks", f"{s.blocks} ({s.motion_blocks} motion)"),
        ("super blocks", f"{s.super_blocks}" + ("  (runs between full stops)" if s.planner == "junction" else "")),
        ("peak speed", f"{s.peak_speed_mm_s:.3f} mm/s ({s.peak_speed_mm_s * 60:.1f} mm/min)"),
        ("mean speed", f"{s.mean_speed_mm_s:.3f} mm/s"),
        ("laser on", f"{s.laser_on_time_s:.3f} s over {s.cut_length_mm:.3f} mm"),
        ("travel", f"{s.travel_length_mm:.3f} mm"),
        ("dwell", f"{s.dwell_time_s:.3f} s"),
        ("corners above GRBL's limit", f"{s.junctions_over_limit}"),
    ]
    width = max(len(k) for k, _ in rows)
    for k, v in rows:
        print(f"{k:<{width}}  {v}")
    if args.trace:
        print(f"{'trace':<{width}}  {args.trace}", file=sys.stderr)
    return 0


# -- steps -----------------------------------------------------------------------------------

def add_steps_arguments(parser):
    _add_common(parser)
    parser.add_argument("-o", "--output", required=True, metavar="OUT.csv",
                        help="CSV: time_s, cycle, block, line, x, y, z (-1/0/+1 steps), "
                             "dir (bit i: axis i negative), period (timer register), power_mw")


def run_steps(args) -> int:
    from labkit._files import atomic_output, check_output_file
    from labkit.motion.timer import iter_step_chunks

    check_output_file(args.output, args.file)
    p = _plan(args)
    ticks = 0
    last_t = 0.0
    with atomic_output(args.output, newline="") as fh:
        header = True
        for chunk in iter_step_chunks(p, max_ticks=500_000):
            chunk.to_dataframe().to_csv(fh, index=False, header=header, float_format="%.9f")
            header = False
            ticks += len(chunk)
            if len(chunk):
                last_t = float(chunk.time_s[-1])
    print(f"{args.output}: {ticks} ticks, last step at {last_t:.6f} s "
          f"(profiles: {p.job_time_s:.6f} s)", file=sys.stderr)
    return 0
