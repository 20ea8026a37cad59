"""GRBL 1.1h's own job time for three jobs on the grbl-diode machine, from grbl-sim's step file.

    python tests/vectors/grbl/job_times.py GRBL_SIM_EXE [JOB ...]

Never run in CI (it needs the grbl-sim binary built as README.md in this folder says). For each
job of ``jobs/`` it starts grbl-sim in an empty folder, gives GRBL the grbl-diode description's
settings (``$100``–``$132``, ``$11``, ``$12``, ``$32=1``), streams the program with character
counting (GRBL's 128-byte receive buffer kept full, so its planner never waits on the link),
closes grbl-sim's input (it exits once GRBL is idle) and reads the step file grbl-sim wrote (``-s``, one line per
``-r`` interval of simulated time and at every block's end: ``time x, y, z, pwm``). The job
time is the simulated time from the start of motion (the last line still at the start
position) to the last step (the first line at the final position after which it never
changes). grbl-sim is the README's build with two more patches for timing (patch 8: the step
file also prints every step of the last block's tail, which the planner has already
discarded; patch 9: simulated time stands still while GRBL's main loop, starved of CPU by the
host, owes the step interrupt its next segment; patch 10: it also stands still while GRBL's
thread has its interrupts off during a cycle (step interrupt armed; outside one GRBL also
waits with interrupts off for the simulated EEPROM), since a host that deschedules that thread inside a ``cli()``
section held the step interrupt back while simulated time ran on: rows of the zig-zag took
0.85–0.96 s while lines streamed in and 0.8505 s once they had all arrived; with the patch,
0.8505 s throughout). It is written to ``job_times.json`` with how it was
made; ``tests/motion/test_grbl_job_time.py`` holds ``labkit plan`` to it.

The jobs (``make_jobs``; written here, by hand-chosen rules, not by a CAM tool):

- ``zigzag.gcode``: 200 rows of 40 mm, 0.2 mm apart, at 3000 mm/min;
- ``polyline905.gcode``: a random walk of 905 segments (numpy ``default_rng(2)``, steps of
  1.5 mm standard deviation) at 2400 mm/min;
- ``arcs1631.gcode``: 1,631 arcs alternating G2/G3 with radii 0.5–2.3 mm at 1800 mm/min.
"""

from __future__ import annotations

import datetime as _dt
import json
import os
import select
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
JOBS = HERE / "jobs"
OUT = HERE / "job_times.json"
STEP_REPORT_S = 0.0005          # grbl-sim's -r: a step-file line at most this often (simulated s)
#: grbl-sim's -t per job (simulated seconds per wall second at most): the sender keeps GRBL's
#: planner full at this pace (checked with status reports: Bf:0 free blocks throughout)
SPEEDUP = {"zigzag": 1.0, "polyline905": 1.0, "arcs1631": 1.0}


def make_jobs() -> dict[str, str]:
    """The three programs (see the module docstring)."""
    import numpy as np

    zz = ["G21 G90", "M3 S500"] + [f"G1 X{40 if k % 2 else 0} Y{k * 0.2:.1f} F3000"
                                   for k in range(200)] + ["M5"]
    walk = np.cumsum(np.random.default_rng(2).normal(0, 1.5, (905, 2)), axis=0)
    pl = ["G21 G90", "M3 S500"] + [f"G1 X{x:.3f} Y{y:.3f} F2400" for x, y in walk] + ["M5"]
    arcs = ["G21 G90", "M3 S500", "G0 X10 Y0"] + [
        f"G{2 + k % 2} X{10 + 2 * (k + 1) * 0.1:.3f} Y0 R{0.5 + (k % 7) * 0.3:.2f} F1800"
        for k in range(1631)] + ["M5"]
    return {"zigzag": "\n".join(zz) + "\n", "polyline905": "\n".join(pl) + "\n",
            "arcs1631": "\n".join(arcs) + "\n"}


def grbl_settings() -> list[str]:
    """The grbl-diode description as GRBL settings lines."""
    sys.path.insert(0, str(HERE.parents[2]))
    from labkit.motion import load_machine

    m = load_machine("grbl-diode")
    lines = [f"${100 + i}={m.steps_per_mm[i]:g}" for i in range(3)]
    lines += [f"${110 + i}={m.max_rate_mm_min[i]:g}" for i in range(3)]
    lines += [f"${120 + i}={m.accel_mm_s2[i]:g}" for i in range(3)]
    lines += [f"${130 + i}={m.travel_mm[i]:g}" for i in range(3)]
    lines += [f"$11={m.junction_deviation_mm:g}", f"$12={m.arc_tolerance_mm:g}"]
    lines += [f"${k}={v:g}" for k, v in m.grbl_settings]
    return lines


class _Sim:
    def __init__(self, exe: str, folder: Path, speedup: float):
        self.proc = subprocess.Popen([exe, "-n", "-t", str(speedup), "-r", str(STEP_REPORT_S), "-s", "steps.out",
                                      "-b", "/dev/null"], cwd=folder, stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, bufsize=0)
        self.text = b""

    def read(self, timeout_s: float) -> None:
        ready, _, _ = select.select([self.proc.stdout], [], [], timeout_s)
        if ready:
            self.text += os.read(self.proc.stdout.fileno(), 65536)

    def lines(self) -> list[str]:
        *done, self.text = self.text.split(b"\n")
        return [d.decode(errors="replace").strip() for d in done]

    def send(self, data: bytes) -> None:
        self.proc.stdin.write(data)


def run_job(exe: str, program: str, speedup: float = 1.0) -> dict:
    """Stream one program to a fresh grbl-sim; GRBL's job time from the step file.

    ``speedup`` is grbl-sim's ``-t`` (simulated seconds per wall second, at most): slow enough
    that this sender, on a loaded host, refills GRBL's planner long before it runs dry (a
    planner run dry stops the machine in simulated time, and the job takes longer)."""
    with tempfile.TemporaryDirectory() as tmp:
        sim = _Sim(exe, Path(tmp), speedup)
        deadline = time.time() + 30
        while b"help]" not in sim.text and time.time() < deadline:
            sim.read(0.1)
        sim.lines()
        for setting in grbl_settings():                         # send-response for the settings
            sim.send(setting.encode() + b"\n")
            reply = []
            while not reply:
                sim.read(5)
                reply = [r for r in sim.lines() if r in ("ok",) or r.startswith("error")]
            if reply[0] != "ok":
                raise RuntimeError(f"{setting}: {reply[0]}")
        pending: list[int] = []                                 # character counting
        queue = [ln + "\n" for ln in program.splitlines()]
        errors = []
        while queue or pending:
            while queue and sum(pending) + len(queue[0]) <= 127:
                sim.send(queue[0].encode())
                pending.append(len(queue.pop(0)))
            sim.read(0.005)
            for reply in sim.lines():
                if reply == "ok" or reply.startswith("error"):
                    pending.pop(0)
                    if reply != "ok":
                        errors.append(reply)
        if errors:
            raise RuntimeError(f"GRBL refused lines: {errors[:5]}")
        # End of input: grbl-sim exits once GRBL is idle, closing (flushing) the step file.
        sim.proc.stdin.close()
        while sim.proc.poll() is None:
            sim.read(0.5)
        rows = []
        for text in (Path(tmp) / "steps.out").read_text().splitlines():
            if text.startswith("#") or not text.strip():
                continue
            t, rest = text.split(None, 1)
            rows.append((float(t), tuple(int(v) for v in rest.split(",")[:3])))
    # GRBL counts a step in its position when the interrupt computes it, and the first
    # interrupt of a move steps its driver axis (the Bresenham counters start at half), so
    # motion starts after the last line still at the start position, within one -r interval.
    # The last step: the first line at the final position after which it never changes.
    first = next(k for k, (_, p) in enumerate(rows) if p != rows[0][1])
    start_s = rows[first - 1][0]
    end_pos = rows[-1][1]
    k = len(rows) - 1
    while k > 0 and rows[k - 1][1] == end_pos:
        k -= 1
    last = rows[k][0]
    return {"motion_start_s": start_s, "last_step_s": last, "job_time_s": round(last - start_s, 6),
            "resolution_s": STEP_REPORT_S, "final_steps": list(end_pos)}


def main(argv: list[str]) -> int:
    exe, names = argv[0], argv[1:]
    JOBS.mkdir(exist_ok=True)
    programs = make_jobs()
    for name, text in programs.items():
        (JOBS / f"{name}.gcode").write_text(text)
    table = json.loads(OUT.read_text()) if OUT.exists() else {}
    table["how"] = ("tests/vectors/grbl/job_times.py: grbl-sim (README.md of this folder: GRBL 1.1h "
                    "bfb67f0, grbl-sim 9bdd165, the local patches) given the grbl-diode settings, "
                    "the program streamed with character counting; job time = simulated time from "
                    "the last step-file line at the start position to the last step (lines every "
                    f"{STEP_REPORT_S} s of simulated time, at block ends and, patch 8, at every step "
                    "of the last block's tail); patches 9 and 10 stop simulated time while the host "
                    "starves GRBL's thread (see the script's docstring)")
    table["recorded"] = _dt.date.today().isoformat()
    table["settings"] = grbl_settings()
    table.setdefault("jobs", {})
    for name in names or programs:
        print(f"{name} ...", flush=True)
        table["jobs"][name] = run_job(exe, programs[name], SPEEDUP[name])
        table["jobs"][name]["grbl_sim_speedup"] = SPEEDUP[name]
        print(table["jobs"][name], flush=True)
        OUT.write_text(json.dumps(table, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
