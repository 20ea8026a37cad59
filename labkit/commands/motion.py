"""``labkit plan`` and ``labkit steps``: the motion reference from the shell.

``labkit plan FILE.gcode --planner junction|fast|normal|hq`` prints the job
time, blocks, super blocks, peak and mean speed and laser-on time; ``--trace
OUT.csv`` writes one row per block. It also predicts the stream over the
machine's serial link (labkit.motion.stall): where the planner runs dry, the
highest feed at which it does not (per image row for a raster job), and with
``--fill OUT.csv`` each line's planner fill level. ``labkit steps FILE.gcode -o OUT.csv``
writes the step pulse train (time, steps per axis, direction bits, timer
period) that the firmware must reproduce.
"""

from __future__ import annotations

import json
import sys



def _add_common(parser):
    from labkit.commands._args import add_dialect_option, integer, number, tolerance_option
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
    add_dialect_option(parser, reads=True)
    parser.add_argument("--lenient", action="store_true",
                        help="skip rejected lines (as a controller would) instead of failing")


def _read_program(args):
    """The program's moves and the lines its controller syncs at. Where the machine syncs on
    a grbl program, from one strict reading that records every line's state (a plain parse and
    then a traced one read the file twice; the traced one alone costs six plain ones as
    Python); other dialects sync on no line, so their trace would be read for nothing."""
    from labkit._files import check_input_file
    from labkit.gcode import parse, parse_with_states
    from labkit.motion.spec import load_machine
    from labkit.motion.stall import controller_sync_lines, controller_syncs

    check_input_file(args.file, what="G-code file")
    with open(args.file, "rb") as fh:
        data = fh.read()
    machine = load_machine(args.machine)
    if args.lenient or not controller_syncs(machine, args.dialect):
        moves, trace = parse(data, dialect=args.dialect, filename=args.file, lenient=args.lenient), None
    else:
        moves, trace = parse_with_states(data, dialect=args.dialect, filename=args.file)
    return moves, controller_sync_lines(data, machine, args.dialect, trace=trace)


def _plan(args, moves, sync_lines):
    from labkit.motion import plan

    return plan(moves, args.machine, planner=args.planner, buffer_blocks=args.buffer, law=args.law,
                arc_tol_mm=args.arc_tol, sync_lines=sync_lines)


# -- plan ------------------------------------------------------------------------------------

def add_plan_arguments(parser):
    _add_common(parser)
    parser.add_argument("--json", action="store_true", help="print the summary as JSON")
    parser.add_argument("--trace", metavar="OUT.csv",
                        help="write one row per block: source line, length, entry/peak/exit "
                             "speed, power, start and duration")
    from labkit.commands._args import integer

    parser.add_argument("--baud", type=integer(300, 10_000_000), default=None, metavar="N",
                        help="serial link speed for the stall prediction, 300…10000000 baud "
                             "(default: the machine's link_baud)")
    parser.add_argument("--fill", metavar="OUT.csv",
                        help="write one row per line sent: source line, bytes, when sent, "
                             "arrived and parsed (s), the planner's fill level (blocks)")
    parser.add_argument("--no-link", action="store_true",
                        help="leave out the stall prediction (the serial link)")


def _hms(seconds: float) -> str:
    m, s = divmod(seconds, 60.0)
    h, m = divmod(int(m), 60)
    return f"{h}:{m:02d}:{s:06.3f}"


def _link_prediction(args, machine, plan=None, moves=None):
    """The stream over the machine's link: (prediction at the programmed feed, stall-free feed).

    ``moves`` and ``plan`` are the command's own, used when they are the ones the predictor
    makes (every line read; GRBL's junction planner with its constant-acceleration ramps,
    arcs whole)."""
    from pathlib import Path

    from labkit.motion.stall import predict_stalls, program_feeds, stall_free_feed

    m = machine
    if args.baud is not None:
        m = m.replace(link_baud=args.baud)
    if args.buffer is not None:
        m = m.replace(buffer_blocks=args.buffer)
    text = Path(args.file).read_text("utf-8", errors="replace")     # parsed already: readable
    same = (args.planner == "junction" and args.law in (None, "accel") and args.arc_tol is None
            and not args.lenient)
    if not same:
        moves = plan = None
    pred = predict_stalls(text, m, dialect=args.dialect, plan=plan)
    free = (stall_free_feed(text, m, dialect=args.dialect, moves=moves, plan=plan)
            if program_feeds(text) else None)
    return m, pred, free


def _write_fill(path, pred) -> None:
    from labkit._files import atomic_output

    with atomic_output(path, newline="") as fh:
        fh.write("line,bytes,sent_s,arrived_s,parsed_s,fill_blocks\n")
        for row in zip(pred.line, pred.bytes, pred.sent_s, pred.arrived_s, pred.parsed_s, pred.fill):
            fh.write(f"{row[0]},{row[1]},{row[2]:.9g},{row[3]:.9g},{row[4]:.9g},{row[5]}\n")


def link_rows(m, pred, free, *, rows_shown: int = 12) -> list[tuple[str, str]]:
    """The stall prediction as (label, text) rows for a summary table."""
    out = [("link", f"{m.link_baud} baud ({m.link_bytes_per_s:.0f} bytes/s), RX buffer "
                    f"{m.rx_buffer_bytes} bytes, planner {m.planner_blocks} blocks, "
                    f"parse {m.block_parse_s * 1e6:.0f} µs a line")]
    if not m.waits_for_lookahead:
        out.append(("  caution", "GRBL-style controller: it slows down as its buffer thins, "
                                 "which the prediction leaves out (it may stall less, run longer)"))
    if pred.stalls:
        lines = ", ".join(str(s.line) for s in pred.stalls[:8]) + (" …" if len(pred.stalls) > 8 else "")
        out.append(("stalls", f"{len(pred.stalls)}, standing {pred.stall_time_s:.3f} s "
                              f"(job {pred.job_time_s:.3f} s over the link); at lines {lines}"))
    else:
        out.append(("stalls", f"none (job {pred.job_time_s:.3f} s over the link)"))
    if free is not None:
        how = {"link": "the link limits it", "machine": "the machine's top speed; the link never starves it",
               "travel": "none: rapids outrun the link at any feed"}[free.limited_by]
        out.append(("stall-free feed", f"{free.feed_mm_min:.0f} mm/min ({how}; programmed "
                                       f"{free.programmed_mm_min:g})"))
        for r in free.rows[:rows_shown]:
            out.append((f"  row y={r['y_mm']:.3f}", f"lines {r['first_line']}–{r['last_line']}: "
                                                   f"{r['feed_mm_min']:.0f} mm/min, {r['stalls']} stalls"))
        if len(free.rows) > rows_shown:
            out.append(("  rows", f"{len(free.rows) - rows_shown} more in --json"))
    return out


def run_plan(args) -> int:
    from labkit._files import atomic_output, check_output_file

    if args.trace:
        check_output_file(args.trace, args.file)
    if args.fill:
        check_output_file(args.fill, args.file)
    moves, sync_lines = _read_program(args)
    p = _plan(args, moves, sync_lines=sync_lines)
    s = p.summary()
    link, link_note = None, None
    if not args.no_link:
        from labkit.errors import GcodeError

        try:
            link = _link_prediction(args, p.machine, p, moves)
        except GcodeError as exc:       # --lenient: a line the controller refuses stops a sender
            link_note = (f"not predicted: a sender would stop at line {exc.line} (error {exc.code}: "
                         f"{exc.message})")
    if args.trace:
        with atomic_output(args.trace, newline="") as fh:
            p.trace().to_csv(fh, index=False, float_format="%.9g")
    if args.fill and link:
        _write_fill(args.fill, link[1])
    if args.json:
        out = s.as_dict()
        out["file"] = args.file
        out["machine"] = p.machine.name
        if link:
            m, pred, free = link
            out["link_baud"] = m.link_baud
            out["stalls"] = [{"time_s": x.time_s, "line": x.line, "duration_s": x.duration_s}
                             for x in pred.stalls]
            out["stall_time_s"] = pred.stall_time_s
            out["job_time_over_link_s"] = pred.job_time_s
            out["stall_free_feed_mm_min"] = free.feed_mm_min if free else None
            out["stall_free_limited_by"] = free.limited_by if free else None
            out["stall_free_rows"] = free.rows if free else []
        elif link_note:
            out["stalls"] = None
            out["stall_prediction"] = link_note
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
    if link:
        rows += link_rows(*link)
    elif link_note:
        rows.append(("stalls", link_note))
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
    # the steps of the firmware's twin: the machine stops where the controller syncs (GRBL's
    # laser, coolant and offset lines; firmware/README.md), decided where plan decides it
    moves, sync_lines = _read_program(args)                     # checks the file
    p = _plan(args, moves, sync_lines=sync_lines)
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
