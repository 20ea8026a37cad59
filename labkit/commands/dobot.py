"""``labkit stream --protocol dobot``: draw a G-code file with the Dobot arm (or its emulator).

The library (:class:`labkit.machine.dobot.DobotJob`) checks the job and runs it; this module
refuses the options that belong to GRBL streaming, prints what happened and writes the stream's
record (``--record``, on by default, as for GRBL: :mod:`labkit.record`).
"""

from __future__ import annotations

import shlex

#: ``labkit stream``'s options for GRBL and the labkit firmware, with their defaults: given to
#: the Dobot path they are refused rather than ignored.
_STREAM_ONLY = {"mode": "counting", "check_first": False, "on_error": "stop", "log": None,
                "allow_spindle_mode": False, "virtual_speed": 0.0, "machine": None}


def run_dobot_stream(args, port, baud) -> int:
    """Draw ``args.file`` with the arm on ``port``.

    Everything the arm cannot draw as written is refused before the first frame.
    Any end but completion prints what the safe stop sent and what the Dobot
    confirmed, and the command that goes on from there; the exit status is 1,
    130 after Ctrl-C and 143 after SIGTERM.
    """
    from labkit.errors import InputError, MachineError
    from labkit.gcode import parse_file
    from labkit.machine.dobot import DobotJob

    unused = [f"--{name.replace('_', '-')}" for name, default in _STREAM_ONLY.items()
              if getattr(args, name, default) != default]
    if unused:
        raise InputError(f"{', '.join(unused)}: not available with --protocol dobot (it sends "
                         f"the job as it is, and keeps no transcript)")
    from labkit.record import stream_record_target, utc_now

    moves = parse_file(args.file, dialect=args.dialect or "grbl")
    job = DobotJob(moves, s_max=getattr(args, "s_max", None), from_line=getattr(args, "resume_from", None))
    warnings = []
    feeds = job.feed_range_mm_min()
    if feeds is not None:
        lo, hi = feeds
        span = f"F{lo:g}" if lo == hi else f"F{lo:g} to F{hi:g}"
        warnings.append(f"F is not sent to the Dobot: the arm draws at the speed set on it (its PTP "
                        f"and ARC parameters), not at the job's {span} mm/min")
        print(f"note: {warnings[-1]}")
    started = utc_now()
    record_path = stream_record_target(args, started)      # checked before the first frame
    try:
        last = job.run(port, baud)
    except (MachineError, KeyboardInterrupt, SystemExit) as exc:
        if isinstance(exc, KeyboardInterrupt):
            why, status = "interrupted (Ctrl-C)", 130
        elif isinstance(exc, SystemExit):
            why, status = "terminated (SIGTERM)", exc.code if isinstance(exc.code, int) else 1
        else:
            why, status = str(exc), 1
        text = [f"STOPPED: {why}"]
        stop = job.last_stop
        if stop is not None:
            text.append(stop.summary())
            if stop.resume_line is not None:
                text.append(f"to go on from there (the laser off, a joint move to where that line "
                            f"starts): {shlex.join(_again(args))} --resume-from {stop.resume_line}")
        print("\n".join(text))
        _record(args, job, record_path, started, why, warnings, "\n".join(text))
        return status
    text = (f"completed: {len(job.commands)} commands queued and executed (last queue index {last}) "
            f"in {job.elapsed_s:.1f} s")
    print(text)
    _record(args, job, record_path, started, None, warnings, text)
    return 0


def _record(args, job, path, started, fault, warnings, summary) -> None:
    """The stream's record, as ``labkit stream`` writes one for GRBL (nothing with --no-record)."""
    if path is None:
        return
    from labkit.record import stream_document, utc_now, write_record

    outcome = job.outcome(started=started, ended=utc_now(), fault=fault, warnings=warnings, summary=summary)
    write_record(stream_document(args, outcome, job.machine_description()), path)
    print(f"record: {path}")


def _again(args) -> list:
    """The command line that draws the same file again (``--resume-from`` is added after)."""
    again = ["labkit", "stream", str(args.file), "--protocol", "dobot"]
    for option in ("port", "baud", "dialect", "s_max"):
        value = getattr(args, option, None)
        if value is not None:
            again += [f"--{option.replace('_', '-')}", f"{value:g}" if option == "s_max" else str(value)]
    return again
