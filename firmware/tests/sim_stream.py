"""Stream a real job to the host simulator over a pty in GRBL mode.

    PYTHONPATH=<repo> /work/main/.venv/bin/python firmware/tests/sim_stream.py \
        [SIM] [JOB.gcode] [--labkit-fw]

Starts ``labkit-fw-sim --pty --dialect grbl --stats`` (default
firmware/build/host/labkit-fw-sim), connects with labkit's GRBL client
(:class:`labkit.machine.grbl.Grbl` over :func:`labkit.machine.link.open_link`),
streams the job with GRBL character counting (128-byte RX budget, from
``$I``) through :func:`labkit.machine.stream.run_job`, and checks

* every line answered ``ok`` (none rejected, none lost), the RX budget kept;
* the final position from ``?`` equals the job's last end point (to one step);
* the laser ended off (``FS`` power 0, ``$G`` says M5).

Prints the simulator's statistics (blocks per second of host time).
With ``--labkit-fw`` the job is first written in the labkit-fw dialect by
``labkit.gcode.emit`` (F mm/s, S 0-255, G4 P ms) and streamed to the
simulator in that dialect with :class:`labkit.machine.labkitfw.LabkitFirmware`
(replies ``ok`` / ``er:N``).
Exit status 0 when everything holds. ``SIM_TRACE=FILE`` also writes the
simulator's step trace (compare it with ``labkit steps``, see sim_trace.py).
"""
from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
sys.path.insert(0, str(ROOT))

from labkit.gcode import emit, parse  # noqa: E402
from labkit.machine.grbl import Grbl  # noqa: E402
from labkit.machine.labkitfw import LabkitFirmware  # noqa: E402
from labkit.machine.link import open_link  # noqa: E402
from labkit.machine.stream import Job, run_job  # noqa: E402

STEPS_PER_MM = 6400.0 / 3.0   # defaults.h (CBR-40)


def start_sim(sim: str, dialect: str = "grbl", realtime: bool = False, extra_args=()):
    extra = ["--trace", os.environ["SIM_TRACE"]] if os.environ.get("SIM_TRACE") else []
    extra += list(extra_args)
    extra += ["--realtime"] if realtime else []      # moves take their machine time
    proc = subprocess.Popen([sim, "--pty", "--dialect", dialect, "--stats"] + extra,
                            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True)
    line = proc.stderr.readline()
    if "pty " not in line:
        proc.kill()
        raise SystemExit(f"simulator did not announce its pty: {line!r}")
    return proc, line.split("pty ", 1)[1].strip()


def verdict(failures: list[str], passed: str) -> int:
    """The end of a check (here, sim_trace.py, qemu_job.py): the failures and exit status 1, or
    ``passed`` and 0."""
    if failures:
        print("FAILED:\n  " + "\n  ".join(failures))
        return 1
    print(passed)
    return 0


def end_state_failures(g, job) -> list[str]:
    """After a job (here and tests/qemu_job.py): what is wrong with where and how the machine ended.

    The position from ``?`` must be the job's last end point to one step, the state ``Idle``,
    the laser off (``FS`` power 0 and ``$G`` in M5).
    """
    failures = []
    st = g.get_status()
    end = [float(v) for v in job.moves.end[-1]]
    print(f"final status {st.raw}; job ends at {end}")
    for axis, (got, want) in enumerate(zip(st.mpos, end)):
        want_steps = round(want * STEPS_PER_MM)
        if abs(got * STEPS_PER_MM - want_steps) > 1.01:
            failures.append(f"axis {'XYZ'[axis]} ended at {got}, expected {want}")
    if st.state != "Idle":
        failures.append(f"state {st.state} at the end")
    if st.spindle not in (0, 0.0):
        failures.append(f"laser power {st.spindle} at the end")
    modes = g.parser_state()
    print(f"$G: {modes}")
    if "M5" not in modes.split():
        failures.append("laser mode not M5 at the end")
    return failures


def main(argv):
    native = "--labkit-fw" in argv
    argv = [a for a in argv if a != "--labkit-fw"]
    dialect = "labkit-fw" if native else "grbl"
    sim = argv[1] if len(argv) > 1 else str(ROOT / "firmware/build/host/labkit-fw-sim")
    job_path = Path(argv[2]) if len(argv) > 2 else ROOT / "data/gcode/cncjs/jsdc-laser.gcode"
    # a last rapid away from the origin, so that '?' has a position worth checking
    text = job_path.read_text("utf-8").rstrip("\n") + "\nG90 G0 X12.3456 Y7.891\n"
    if native:
        text = emit(parse(text, dialect="grbl", filename=str(job_path)), dialect="labkit-fw")
    job = Job.from_text(text, filename=str(job_path), dialect=dialect)
    proc, pty = start_sim(sim, dialect)
    failures = []
    try:
        g = (LabkitFirmware if native else Grbl)(open_link(pty))
        g.realtime("soft_reset")            # the banner went out before we opened the pty
        info = g.connect(timeout_s=5.0)
        print(f"connected: {info.banner!r}; RX {info.rx_bytes} bytes, planner {info.planner_blocks} blocks")
        if info.rx_bytes != 128:
            failures.append(f"RX buffer {info.rx_bytes}, expected 128")
        if not g.laser_mode():
            failures.append("$32 is not 1")
        t0 = time.monotonic()
        report = run_job(g, job, mode="counting", status_interval_s=0.1, watchdog_s=5.0)
        dt = time.monotonic() - t0
        print(f"job: {report.summary()}")
        print(f"{report.lines_sent} lines sent, {report.lines_acknowledged} ok, "
              f"max RX used {report.max_rx_used} bytes, {dt:.2f} s host time "
              f"(planned job time {job.job_time_s:.1f} s)")
        if not report.ok or report.fault:
            failures.append(f"job failed: {report.fault} {report.errors}")
        if report.lines_acknowledged != len(job.send):
            failures.append(f"{report.lines_acknowledged} answers for {len(job.send)} lines")
        if report.max_rx_used > 127:
            failures.append(f"RX budget exceeded: {report.max_rx_used}")
        failures += end_state_failures(g, job)
        g.close()
    finally:
        proc.terminate()
        try:
            _, err = proc.communicate(timeout=5)
        except subprocess.TimeoutExpired:
            proc.kill()
            _, err = proc.communicate()
        print(err.strip())
    return verdict(failures, f"sim_stream ({dialect}): PASS")


if __name__ == "__main__":
    sys.exit(main(sys.argv))
