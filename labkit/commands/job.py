"""``labkit job JOB.toml -o OUT.gcode``: layers from several sources composed into one program
(see :mod:`labkit.jobfile` for the job file's format)."""

from __future__ import annotations

__all__ = ["add_job_arguments", "run_job"]


def add_job_arguments(parser) -> None:
    """Options of ``labkit job``."""
    from labkit.record import add_record_option

    parser.add_argument("job", metavar="JOB.toml", help="the job file")
    parser.add_argument("-o", "--output", required=True, metavar="OUT.gcode", help="G-code file to write")
    parser.add_argument("--travel-beam-off", action="store_true",
                        help="switch the beam off (M5) for every rapid (GRBL with $32=0)")
    parser.add_argument("--force", action="store_true", help="write a job larger than the machine's travel anyway")
    add_record_option(parser, default_on=True)


def run_job(args) -> int:
    """Read the job file, compose its layers, write the program (and its record), print the layers."""
    from pathlib import Path

    from labkit._files import atomic_output, check_output_file
    from labkit.gcode import emit
    from labkit.gcode.simulate import summarize
    from labkit.jobfile import compose_job, read_job
    from labkit.motion.spec import check_job_fits
    from labkit.record import default_record_path, program_record, write_record

    job = read_job(args.job)
    inputs = [job.path] + [L.source for L in job.layers]
    output = check_output_file(args.output, *inputs)
    record = None
    if args.record:
        record = default_record_path(output) if args.record == "auto" else Path(args.record)
        check_output_file(record, *inputs, option="--record")
    composed = compose_job(job)
    moves = composed.moves
    import sys

    for warned in composed.warnings:
        print(f"warning: {warned}", file=sys.stderr)

    import numpy as np

    box = moves.bounds(moves.laser_on)
    msg = check_job_fits(np.ptp(box, axis=0)[:2], job.machine, force=args.force, what="the job")
    if msg:
        print(f"warning: {msg} (written anyway: --force)", file=sys.stderr)
    from labkit.jobfile import PLACEMENTS

    placement = dict(start_from=job.start_from, offset_mm=list(job.offset_mm), how=PLACEMENTS[job.start_from])
    lines = [f"{Path(args.job).name}: {len(composed.layers)} layer(s) on {job.machine}"]
    if job.start_from != "absolute" or any(job.offset_mm):
        lines.append(f"placed {job.start_from}: {placement['how']}"
                     + (f", offset {job.offset_mm[0]:g}, {job.offset_mm[1]:g} mm" if any(job.offset_mm) else ""))
    if job.start_from == "current":
        lines.append("a reset clears G92: after one, burn the job again from its start (--resume-from "
                     "cannot restore where the head stood)")
    for d in composed.layers:
        lib = f", library: {' '.join(d['from_library'])}" if d["from_library"] else ""
        lines.append(f"layer {d['index']} {d['operation']} {Path(d['source']).name}: {d['power_mw']:g} mW = "
                     f"S{d['s_word']:g}, {d['speed_mm_min']:g} mm/min, {d['passes']} pass(es)"
                     + (f", kerf {d['kerf_mm']:g} mm" if d["kerf_mm"] else "")
                     + (f", material {d['material']}{lib}" if d["material"] else ""))
    text = emit(moves, dialect=job.dialect, travel_beam_off=args.travel_beam_off or None,
                comment="; ".join(lines))
    with atomic_output(output, encoding="ascii") as fh:
        fh.write(text)
    for line in lines:
        print(line)
    print(summarize(moves, source_lines=text.count("\n")).format())
    print(f"G-code          {args.output}")
    if record is not None:
        args.machine = job.machine              # the record describes the job's machine
        rec = program_record("job", args, inputs=[(p, "job" if i == 0 else f"layer {i}")
                                                   for i, p in enumerate(inputs)], program=output)
        rec["layers"] = composed.layers
        rec["placement"] = placement
        write_record(rec, record)
        print(f"record          {record}")
    return 0
