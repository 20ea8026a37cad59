"""A provenance record per burn: what made a program, and what happened when it was streamed.

A record is one JSON file written beside the program (``OUT.gcode.record.json``) or, for a
stream, beside the job with the start time in its name. Its format (version 1)::

    {
      "format": "labkit-record",          # required, exactly this
      "version": 1,                       # required; a later version is refused
      "kind": "program" | "stream",
      "created": "2026-11-25T13:00:00+00:00",   # UTC
      "labkit": "0.1.0",                  # labkit's version
      "command": "svg2gcode",             # the labkit command
      "argv": ["svg2gcode", "card.svg", "-o", "card.gcode", "--record"],  # as typed (may be absent;
                                          # `labkit record rerun` needs it)
      "options": {"feed": 600.0, …},      # every option as parsed (after the library filled in)
      "inputs":  [{"role": "input", "path": "card.svg", "sha256": "…", "bytes": 123}, …],
      "outputs": [{"role": "program", "path": "card.gcode", "sha256": "…", "bytes": 456}],
      "machine": {…},                     # the machine description's fields (MachineSpec.to_dict)
      "material": null | {"spec": "card:cut", "library": {path, sha256, bytes},
                          "entry": {…the library's setting…}, "fit": {…its fit provenance…}},
      "planned": {"estimated_time_s": …, "laser_on_time_s": …, "cut_length_mm": …,
                  "travel_length_mm": …, "moves": …, "bounds_mm": [[x, y, z], [x, y, z]]},
      "layers": […],                      # labkit job only: each layer's settings and where they came from
      "placement": {"start_from": "current", "offset_mm": [0, 0], "how": "…G92 X0 Y0…"},  # labkit job only
      "stream": null | {"started": …, "ended": …, "ok": true, "lines_total": …,   # GRBL, firmware or Dobot
                        "lines_acknowledged": …, "elapsed_s": …, "planned_s": …, "fault": null,
                        "errors": [[line, code, message], …], "resume_line": null,
                        "resumed_from": null, "safe_stop": […], "warnings": […], "summary": "…"}
    }

A Dobot stream's record is the same; its ``machine`` is the arm's (name ``dobot-magician``: canvas
origin, drawing plane, reach, laser PWM), ``planned_s`` and ``estimated_time_s`` are null (the arm
moves at the speeds set on it), lines count the source lines that make commands, and ``safe_stop``
lists each stop command with what became of it.

Paths are stored as given on the command line; hashes let :func:`diff_records` tell a changed
input from a renamed one, and :func:`rerun_record` make a program again from its record and tell
whether it came out byte for byte the same (run it from the folder the command was run in). Records are written through :func:`labkit._files.atomic_output`.
"""

from __future__ import annotations

import datetime
import json
import os
from pathlib import Path

from labkit.errors import InputError

__all__ = ["FORMAT", "VERSION", "file_entry", "program_record", "stream_record", "stream_document", "write_record",
           "read_record", "diff_records", "format_record", "default_record_path", "add_record_option",
           "record_program", "stream_record_target", "utc_now", "rerun_record"]

FORMAT = "labkit-record"
VERSION = 1


def utc_now() -> str:
    return datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")


def file_entry(path, role: str) -> dict:
    """``{"role", "path", "sha256", "bytes"}`` of a file (hash read in blocks)."""
    import hashlib          # here: it loads OpenSSL, ~4 ms of every command that writes no record

    h = hashlib.sha256()
    size = 0
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
            size += len(block)
    return dict(role=role, path=os.fspath(path), sha256=h.hexdigest(), bytes=size)


def _plain(value):
    """A JSON-ready copy of an option's value."""
    if value is None or isinstance(value, (bool, int, float, str)):
        return value if not isinstance(value, float) else float(value)
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    return str(value)


def _material(args) -> dict | None:
    spec = getattr(args, "material", None)
    if not spec:
        return None
    from labkit.materials import default_library_path, parse_material_spec, read_library
    from labkit.motion.spec import load_machine

    path = getattr(args, "library", None) or default_library_path(load_machine(args.machine).name)
    lib = read_library(path)
    name, op = parse_material_spec(spec)
    m, op, s = lib.get(name, op)
    import dataclasses

    entry = {k: _plain(v) for k, v in dataclasses.asdict(s).items() if k != "fit"}
    return dict(spec=f"{name}:{op}", library=file_entry(path, "library"), thickness_mm=m.thickness_mm,
                entry=entry, fit=_plain(s.fit))


def _planned(text: str) -> dict:
    from labkit.gcode import parse
    from labkit.gcode.simulate import summarize

    s = summarize(parse(text))
    return dict(estimated_time_s=float(s.estimated_time_s), laser_on_time_s=float(s.laser_on_time_s),
                cut_length_mm=float(s.cut_length_mm), travel_length_mm=float(s.travel_length_mm),
                moves=int(s.moves), bounds_mm=_plain([list(map(float, b)) for b in s.bounds]))


def program_record(command: str, args, *, inputs: list, program, extra_outputs: list = ()) -> dict:
    """The record of a program a command wrote.

    Parameters
    ----------
    command : str
        The labkit command (``svg2gcode``, ``job``, …).
    args : argparse.Namespace
        Its options (recorded as parsed; ``--material`` is looked up again for the entry).
    inputs : list of (path, role)
        The files read.
    program : str or os.PathLike
        The G-code written; its planned time comes from labkit's job summary of that text.
    extra_outputs : list of (path, role)

    Returns
    -------
    dict
        In the format of the module docstring, ``kind = "program"``.
    """
    from labkit import __version__
    from labkit.motion.spec import load_machine

    text = Path(program).read_text("ascii")
    options = {k: _plain(v) for k, v in sorted(vars(args).items())
               if k != "traceback" and not k.startswith("_")}
    return dict(format=FORMAT, version=VERSION, kind="program", created=utc_now(), labkit=__version__,
                command=command, argv=list(getattr(args, "_argv", None) or []) or None, options=options,
                inputs=[file_entry(p, role) for p, role in inputs],
                outputs=[file_entry(program, "program")] + [file_entry(p, r) for p, r in extra_outputs],
                machine=_plain(load_machine(getattr(args, "machine", None)).to_dict()),
                material=_material(args), planned=_planned(text), stream=None)


def stream_record(args, report, *, started: str, ended: str, machine_name: str, command: list) -> dict:
    """The record of a stream: the job's file, the machine, the options and the run's outcome.

    Parameters
    ----------
    args : argparse.Namespace
        ``labkit stream``'s options.
    report : labkit.machine.stream.JobReport
    started, ended : str
        UTC times (ISO 8601).
    machine_name : str
        The machine description the stream planned with.
    command : list of str
        The command line that runs the job again.
    """
    from labkit.motion.spec import load_machine

    stream = dict(started=started, ended=ended, ok=bool(report.ok), lines_total=report.lines_total,
                  lines_acknowledged=report.lines_acknowledged, elapsed_s=float(report.elapsed_s),
                  planned_s=float(report.planned_s), fault=report.fault,
                  errors=_plain(report.errors), resume_line=report.resume_line,
                  resumed_from=getattr(args, "resume_from", None), safe_stop=_plain(report.safe_actions),
                  warnings=_plain(report.warnings), summary=report.summary(command=command))
    return stream_document(args, stream, load_machine(machine_name).to_dict())


def stream_document(args, stream: dict, machine: dict) -> dict:
    """A stream's record from its outcome (the ``stream`` table) and the machine's description.

    :func:`stream_record` makes ``stream`` from a GRBL job's report, :meth:`labkit.machine.dobot.
    DobotJob.outcome` from the arm's run; the rest of the record is the same for both.
    """
    from labkit import __version__

    options = {k: _plain(v) for k, v in sorted(vars(args).items())
               if k != "traceback" and not k.startswith("_")}
    # the program's own record, when it was written with one, ties the burn to its making
    made_by = Path(os.fspath(args.file) + ".record.json")
    inputs = [file_entry(args.file, "program")]
    if made_by.is_file():
        inputs.append(file_entry(made_by, "program record"))
    planned = stream.get("planned_s")
    return dict(format=FORMAT, version=VERSION, kind="stream", created=stream["ended"], labkit=__version__,
                command="stream", options=options, inputs=inputs, outputs=[], machine=_plain(machine),
                material=None, planned=dict(estimated_time_s=None if planned is None else float(planned)),
                stream=_plain(stream))


def write_record(record: dict, path) -> Path:
    """Write a record whole (atomic_output); returns its path."""
    from labkit._files import atomic_output

    with atomic_output(path, encoding="utf-8") as fh:
        json.dump(record, fh, indent=1, ensure_ascii=False)
        fh.write("\n")
    return Path(path)


def read_record(path) -> dict:
    """A record, checked for its format and version.

    Raises
    ------
    InputError
        Not a file, not JSON, not a labkit record, or a later version.
    """
    from labkit._files import read_json

    rec = read_json(path, what="record file")
    if not isinstance(rec, dict) or rec.get("format") != FORMAT:
        raise InputError(f"{path}: not a labkit record (expected \"format\": \"{FORMAT}\")")
    if rec.get("version") != VERSION:
        raise InputError(f"{path}: record version {rec.get('version')!r}; this labkit reads version {VERSION}")
    return rec


def default_record_path(output, *, stream_started: str | None = None) -> Path:
    """``OUT.record.json`` beside a program; for a stream ``JOB.stream-<UTC time>.record.json``.

    >>> default_record_path("part.gcode").name
    'part.gcode.record.json'
    >>> default_record_path("part.gcode", stream_started="2026-11-25T13:00:05+00:00").name
    'part.gcode.stream-20261125T130005Z.record.json'
    """
    p = Path(os.fspath(output))
    if stream_started is None:
        return p.with_name(p.name + ".record.json")
    stamp = stream_started.replace("+00:00", "Z").replace("-", "").replace(":", "")
    return p.with_name(f"{p.name}.stream-{stamp}.record.json")


def _flatten(value, prefix="") -> dict:
    if isinstance(value, dict):
        out = {}
        for k, v in value.items():
            out.update(_flatten(v, f"{prefix}.{k}" if prefix else str(k)))
        return out
    if isinstance(value, list) and value and all(isinstance(v, dict) and "role" in v for v in value):
        # inputs/outputs: keyed by role (several of one role by position)
        out, seen = {}, {}
        for v in value:
            n = seen.get(v["role"], 0)
            seen[v["role"]] = n + 1
            key = v["role"] if n == 0 else f"{v['role']}#{n + 1}"
            out.update(_flatten({k: x for k, x in v.items() if k != "role"}, f"{prefix}.{key}"))
        return out
    return {prefix: value}


#: Keys that differ between any two runs and say nothing about the burn (where the record itself went).
# (the command line as typed repeats the options, which are compared one by one)
_ALWAYS_DIFFERENT = ("created", "stream.started", "stream.ended", "stream.summary", "options.record", "argv")


def diff_records(a: dict, b: dict, *, everything: bool = False) -> list[tuple[str, object, object]]:
    """What differs between two records: ``(key, value in a, value in b)``, keys dotted.

    Missing keys show as ``None`` on their side. The creation and stream times, the stream's
    text summary (its numbers are compared one by one), the record's own path and the command
    line as typed (its options are compared one by one) are left out unless ``everything``.

    Examples
    --------
    >>> diff_records({"options": {"feed": 600, "power": 500}}, {"options": {"feed": 900, "power": 500}})
    [('options.feed', 600, 900)]
    """
    fa, fb = _flatten(a), _flatten(b)
    out = []
    for key in sorted(set(fa) | set(fb)):
        if not everything and key in _ALWAYS_DIFFERENT:
            continue
        if fa.get(key) != fb.get(key):
            out.append((key, fa.get(key), fb.get(key)))
    return out


def format_record(rec: dict) -> str:
    """A record in words, for ``labkit record show``."""
    lines = [f"{rec['kind']} record, labkit {rec.get('labkit')}, {rec.get('created')}: labkit {rec.get('command')}"]
    for f in rec.get("inputs", []):
        lines.append(f"  input   {f['role']:<14} {f['path']}  sha256 {f['sha256'][:16]}…  {f['bytes']} B")
    for f in rec.get("outputs", []):
        lines.append(f"  output  {f['role']:<14} {f['path']}  sha256 {f['sha256'][:16]}…  {f['bytes']} B")
    m = rec.get("machine") or {}
    lines.append(f"  machine {m.get('name')}: {m.get('description', '')}")
    mat = rec.get("material")
    if mat:
        e = mat["entry"]
        lines.append(f"  material {mat['spec']} from {mat['library']['path']} [{e.get('origin')}]: "
                     f"{e.get('power_mw'):g} mW, {e.get('speed_mm_min'):g} mm/min, {e.get('passes')} pass(es)"
                     + (f", kerf {e['kerf_mm']:g} mm" if e.get("kerf_mm") is not None else ""))
        if mat.get("fit"):
            f = mat["fit"]
            lines.append(f"           fit {f.get('file')} (sha256 {str(f.get('sha256'))[:16]}…), scan "
                         f"{f.get('scan')}, {f.get('date')}")
    place = rec.get("placement")
    if place and (place["start_from"] != "absolute" or any(place["offset_mm"])):
        lines.append(f"  placed  {place['start_from']}: {place['how']}"
                     + (", offset {:g}, {:g} mm".format(*place["offset_mm"]) if any(place["offset_mm"]) else ""))
    p = rec.get("planned") or {}
    if p.get("estimated_time_s") is not None:
        lines.append(f"  planned {p['estimated_time_s']:.1f} s"
                     + (f", laser on {p['laser_on_time_s']:.1f} s, cut {p['cut_length_mm']:.1f} mm"
                        if "laser_on_time_s" in p else ""))
    s = rec.get("stream")
    if s:
        lines.append(f"  stream  {s['started']} → {s['ended']}: {'ok' if s['ok'] else 'STOPPED'}, "
                     f"{s['lines_acknowledged']}/{s['lines_total']} lines in {s['elapsed_s']:.1f} s"
                     + (f", resumed from line {s['resumed_from']}" if s.get("resumed_from") else ""))
        if s.get("fault"):
            lines.append(f"          fault: {s['fault']}; resume line {s.get('resume_line')}")
        for ln, code, msg in s.get("errors", []):
            lines.append(f"          line {ln}: error:{code}: {msg}")
        if m.get("name") == "dobot-magician":          # the arm's stop: each command and its fate
            for what, state in s.get("safe_stop") or []:
                lines.append(f"          stop: {what} {state}")
    opts = rec.get("options") or {}
    shown = ", ".join(f"{k}={v}" for k, v in opts.items() if v not in (None, False, [], ""))
    lines.append(f"  options {shown}")
    return "\n".join(lines)


def add_record_option(parser, *, default_on: bool = False) -> None:
    """``--record [FILE]`` (and ``--no-record`` when on by default)."""
    if default_on:
        parser.add_argument("--record", default="auto", metavar="FILE",
                            help="provenance record (JSON; default: beside the job, see labkit.record)")
        parser.add_argument("--no-record", dest="record", action="store_const", const=None,
                            help="write no record")
    else:
        parser.add_argument("--record", nargs="?", const="auto", default=None, metavar="FILE",
                            help="also write a provenance record (JSON; alone: OUTPUT.record.json)")


def record_program(command: str, args, *, inputs: list, program, extra_outputs: list = ()) -> Path | None:
    """Write ``--record``'s file for a program just written (nothing when ``args.record`` is unset).

    ``"auto"`` (``--record`` alone) is ``PROGRAM.record.json``. Returns the path written.
    """
    from labkit._files import check_output_file

    target = getattr(args, "record", None)
    if not target:
        return None
    path = default_record_path(program) if target == "auto" else Path(target)
    check_output_file(path, *[p for p, _ in inputs])
    rec = program_record(command, args, inputs=inputs, program=program,
                         extra_outputs=[(p, r) for p, r in extra_outputs if p and Path(p).is_file()])
    return write_record(rec, path)


def stream_record_target(args, started: str) -> Path | None:
    """Where ``labkit stream``'s record goes (None: ``--no-record``), checked before anything is sent."""
    from labkit._files import check_output_file

    target = getattr(args, "record", None)
    if not target:
        return None
    path = default_record_path(args.file, stream_started=started) if target == "auto" else Path(target)
    return check_output_file(path, args.file, option="--record")


def _records_by_default(command: str) -> bool:
    """Whether a labkit command writes its record unasked (it then takes ``--no-record``)."""
    import argparse

    from labkit.cli import COMMANDS, command_entry

    if command not in COMMANDS:
        raise InputError(f"the record's command {command!r} is not a labkit command")
    parser = argparse.ArgumentParser(add_help=False)
    command_entry(command)[0](parser)
    return "--no-record" in parser._option_string_actions


#: Options whose value is the program written, by command line convention.
_OUTPUT_OPTIONS = ("-o", "--output")


def rerun_record(path, output) -> tuple[bool, Path]:
    """Make a program again from its record: check the inputs, run the recorded command line
    with ``output`` as the program, and compare it with the recorded program.

    Paths in the record are as typed, so run it from the folder the command ran in. The
    inputs must be the files the record names (same SHA-256); nothing is written when one
    differs. The rerun writes no record of its own.

    Parameters
    ----------
    path : str or os.PathLike
        A program's record (``kind = "program"``) with its command line (``argv``).
    output : str or os.PathLike
        Where the program made again goes (not the recorded program's own path).

    Returns
    -------
    identical : bool
        The new program has the recorded program's SHA-256.
    output : Path

    Raises
    ------
    InputError
        Not a program's record, no command line in it, an input missing or changed, the
        output is the recorded program, or the command fails.
    """
    from labkit.cli import main

    rec = read_record(path)
    argv = rec.get("argv")
    if rec.get("kind") != "program" or not isinstance(argv, list) or not argv:
        raise InputError(f"{path}: a program's record with its command line (\"argv\") is needed "
                         f"to make the program again (records before this labkit lack it)")
    program = next((o for o in rec.get("outputs", []) if o.get("role") == "program"), None)
    if program is None:
        raise InputError(f"{path}: the record names no program")
    output = Path(output)
    if output.resolve() == Path(program["path"]).resolve():
        raise InputError(f"{output}: that is the recorded program itself; choose another file")
    for entry in rec.get("inputs", []):
        p = Path(entry["path"])
        if not p.is_file():
            raise InputError(f"{path}: input {entry['path']} ({entry['role']}) is missing here; run "
                             f"from the folder the command ran in")
        if file_entry(p, entry["role"])["sha256"] != entry["sha256"]:
            raise InputError(f"{path}: input {entry['path']} has changed since the record "
                             f"(SHA-256 differs): the program would not be the recorded one")
    args, i = [], 0
    while i < len(argv):
        a = str(argv[i])
        if a in _OUTPUT_OPTIONS and i + 1 < len(argv):
            args += [a, os.fspath(output)]
            i += 2
            continue
        if a.startswith("--output="):
            args.append(f"--output={os.fspath(output)}")
        elif a == "--record":                       # alone or with a file: no new record
            if i + 1 < len(argv) and not str(argv[i + 1]).startswith("-") and str(argv[i + 1]).endswith(".json"):
                i += 1
        elif not a.startswith("--record="):
            args.append(a)
        i += 1
    if _records_by_default(str(argv[0])):
        args.append("--no-record")
    if os.fspath(output) not in args and f"--output={os.fspath(output)}" not in args:
        raise InputError(f"{path}: the recorded command line names no -o OUTPUT to replace")
    import contextlib
    import io

    quiet = io.StringIO()
    with contextlib.redirect_stdout(quiet), contextlib.redirect_stderr(quiet):
        status = main(args)
    if status != 0 or not output.is_file():
        raise InputError(f"{path}: the recorded command failed when run again: "
                         + " ".join(quiet.getvalue().split())[-300:])
    return file_entry(output, "program")["sha256"] == program["sha256"], output
