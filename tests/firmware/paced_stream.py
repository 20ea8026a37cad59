"""A job through the firmware's paced host simulator, as a machine description sets it up.

Used by ``test_paced_raster.py`` and ``benchmarks/bench_raster_gcode.py`` (issue 30): the
simulator runs on a pty in the grbl dialect with ``--baud`` (the description's link),
``--parse-us`` (its ``block_parse_s``), a starvation log and a beam log; the machine's
mechanics go in as settings lines ahead of the job (GRBL's ``$0``, ``$11``, ``$12``,
``$100``–``$132`` and the firmware's own ``$200``–``$209``); GRBL's ``stream.py`` in its
character-counting mode (``test_real_senders.py``) streams them and the job.
"""
from __future__ import annotations

import csv
import importlib.util
import re
import subprocess
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from labkit.machine.safety import end_process
from labkit.motion.stall import Starvation, read_starvation_log

HERE = Path(__file__).resolve().parent
#: stream.py wakes GRBL up with "\r\n\r\n": four empty lines the grbl dialect counts.
WAKE_UP_LINES = 4


def _real_senders():
    spec = importlib.util.spec_from_file_location("real_senders", HERE / "test_real_senders.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


REAL_SENDERS = _real_senders()


def stream_py_bytes(text: str) -> np.ndarray:
    """Bytes stream.py puts on the link per line: whitespace and (...) removed, newline added
    (it keeps ``;`` comments)."""
    return np.array([len(REAL_SENDERS.stream_py_line(raw)) for raw in text.splitlines()])


def paced_sim(sim: str, machine, text: str, tmp: Path, *, parse_us: float | None = None,
              extra_args=()) -> tuple[list[str], Path]:
    """The simulator's command line for stream.py streaming ``text`` over ``machine``'s link.

    The simulator gets what stream.py will write (``--expect``: it then holds its clock for
    the sender's next line however late a loaded machine makes it, so that only the link
    can starve the planner) and a starvation log, returned with the command.
    """
    expect, log = tmp / "expect.txt", tmp / "starvations.csv"
    expect.write_bytes(REAL_SENDERS.stream_py_sent(text))
    parse_us = machine.block_parse_s * 1e6 if parse_us is None else parse_us
    return ([sim, "--pty", "--dialect", "grbl", "--baud", str(machine.link_baud), "--parse-us", f"{parse_us:.6f}",
             "--starvation-log", str(log), "--expect", str(expect), *extra_args], log)


def sim_complaints(err: str) -> tuple[int, str]:
    """What the paced simulator said at exit about its host: (times late, the --expect
    mismatch or '')."""
    late = re.search(r"the host was late (\d+) times", err)
    off = re.search(r"--expect: .*", err)
    return (int(late.group(1)) if late else 0), (off.group(0) if off else "")


def poll_shadows(simulated, predicted, baud: int, seconds: float):
    """Split the simulated starvations the prediction lacks into those a ``?`` can explain and the rest.

    stream.py's once-a-second ``?`` is one byte on the wire at a wall-clock moment no
    prediction can know; the line bytes behind it arrive one byte time (10 / baud s) later.
    A starvation it causes is at most that long, and there are at most as many as ``?``s.
    """
    lines = {s.line for s in predicted}
    missed = [s for s in simulated if s.line not in lines]
    byte_s = 10.0 / baud
    shadows = [s for s in missed if s.duration_s <= byte_s * 1.001]
    rest = [s for s in missed if s.duration_s > byte_s * 1.001]
    if len(shadows) > seconds + 2:
        rest += shadows
        shadows = []
    return shadows, rest


def _number(value: float) -> str:
    return f"{value:.6f}".rstrip("0").rstrip(".")


def firmware_settings(machine) -> list[str]:
    """The settings lines that make the firmware (grbl dialect) the machine ``machine`` describes.

    The prescaler goes first and the step pulse after the rates, so that every labkit setting
    ($200–$209) is accepted on the machine as it stands when it arrives (the firmware refuses
    one its core could not run with); the timer clock is the board's (48 MHz) and must be the
    description's. ``grbl_settings`` come last.

    Raises
    ------
    ValueError
        The description's timer clock is not the firmware's.
    """
    if machine.timer_clock_hz != 48_000_000:
        raise ValueError(f"machine {machine.name!r}: timer_clock_hz {machine.timer_clock_hz} is not the "
                         f"firmware's 48 MHz step timer")
    out = [f"$209={machine.prescaler}"]
    for first, values in ((100, machine.steps_per_mm), (110, machine.max_rate_mm_min),
                          (120, machine.accel_mm_s2), (130, machine.travel_mm)):
        out += [f"${first + a}={_number(v)}" for a, v in enumerate(values)]
    out += [f"$11={_number(machine.junction_deviation_mm)}", f"$12={_number(machine.arc_tolerance_mm)}",
            f"$0={round(machine.step_pulse_us)}",
            f"$200={machine.accel_hz_per_step}", f"$201={machine.decel_hz_per_step}",
            f"$202={machine.start_rate_hz}", f"$203={_number(machine.laser_max_power_mw)}",
            f"$207={machine.buffer_blocks}"]
    out += [f"${n}={_number(v)}" for n, v in machine.grbl_settings]
    return out


@dataclass
class PacedRun:
    """What the paced simulator did with a job.

    Attributes
    ----------
    stalls : list of Starvation
        Its starvations, numbered by the job's source lines.
    beam : list of (time_s, duty)
        The beam log's rows (simulated time, duty 0–1000).
    seconds : float
        Wall time of the stream.
    host_late : int
        How often the sender had room for a line and took longer than the simulator waits
        for it (10 s of wall time, ``--expect``) while blocks were queued: the simulated
        clock ran on without it, so a stop after that may be the sender's, not the link's.
    """

    stalls: list
    beam: list
    seconds: float
    host_late: int = 0

    @property
    def burn_span_s(self) -> float:
        """Simulated time from the beam's first switch-on to its last switch-off, s."""
        on = [t for t, d in self.beam if d > 0]
        off = [t for t, d in self.beam if d == 0]
        return off[-1] - on[0] if on and off else 0.0

    @property
    def stall_time_s(self) -> float:
        """Time the motors stood in starvations, s."""
        return float(sum(s.duration_s for s in self.stalls))


def stream_paced(sim: str, text: str, machine, tmp: Path, *, parse_us: float | None = None,
                 extra_args=()) -> PacedRun:
    """Stream ``text`` with stream.py (counting) through the simulator set up as ``machine``.

    Parameters
    ----------
    sim : str
        The simulator (``make -C firmware sim``).
    text : str
        The job, in the grbl dialect.
    machine : MachineSpec
        Its link (``link_baud``, ``block_parse_s``) paces the simulator; its mechanics are
        sent as settings first.
    tmp : Path
        Folder for the logs.
    parse_us : float, optional
        The simulator's ``--parse-us`` (default: ``block_parse_s``).
    extra_args : sequence of str
        More simulator options (``--trace FILE``).

    Raises
    ------
    AssertionError
        A line not answered ``ok``, or stream.py wrote other bytes than the simulator was
        told to expect.
    """
    settings = firmware_settings(machine)
    job = "\n".join(settings) + "\n" + text
    beam = tmp / "beam.csv"
    cmd, log = paced_sim(sim, machine, job, tmp, parse_us=parse_us, extra_args=("--beam-log", str(beam), *extra_args))
    proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            text=True)
    try:
        line = proc.stderr.readline()
        if "pty " not in line:
            raise AssertionError(f"simulator did not announce its pty: {line!r}")
        tally = REAL_SENDERS.stream_py(line.split("pty ", 1)[1].strip(), job, counting=True)
        proc.terminate()
        err = proc.communicate(timeout=30)[1]
    finally:
        end_process(proc)
    late, off = sim_complaints(err)
    if off:
        raise AssertionError(f"the simulator was told the wrong bytes: {off}")
    bad = [(k + 1, a) for k, a in enumerate(tally["answers"]) if a != "ok"]
    if len(tally["answers"]) != len(job.splitlines()) or bad:
        raise AssertionError(f"not every line answered ok: {bad[:3]} ({len(tally['answers'])} answers)")
    # the firmware numbers the lines its G-code parser reads: the wake-up's empty lines, not
    # the settings ($ system commands)
    stalls = [Starvation(s.time_s, s.line - WAKE_UP_LINES, s.duration_s) for s in read_starvation_log(log)]
    with open(beam, newline="", encoding="ascii") as fh:
        rows = list(csv.reader(fh))[1:]
    return PacedRun(stalls=stalls, beam=[(float(r[0]), int(r[1])) for r in rows], seconds=tally["seconds"],
                    host_late=late)
