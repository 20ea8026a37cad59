"""The simulator's step trace against labkit's, tick for tick.

    PYTHONPATH=<repo> /work/main/.venv/bin/python firmware/tests/sim_trace.py \
        [SIM] [JOB.gcode]

Runs the job through ``labkit-fw-sim --dialect grbl --trace`` (over stdin:
the whole stream, look-ahead flushed at its end) and through
``labkit steps`` (labkit.motion: junction planner, constant acceleration,
the CBR-40 machine — the firmware's defaults) and compares every column of
every tick: time_s, cycle, block, line, x, y, z, dir, period, power_mw.
Exit status 0 when they are identical.
"""
from __future__ import annotations

import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
sys.path.insert(0, str(HERE))
from sim_stream import verdict  # noqa: E402  (beside this file)


def main(argv):
    sim = argv[1] if len(argv) > 1 else str(ROOT / "firmware/build/host/labkit-fw-sim")
    job = Path(argv[2]) if len(argv) > 2 else ROOT / "data/gcode/cncjs/jsdc-laser.gcode"
    tmp = Path(tempfile.mkdtemp(prefix="labkit-sim-trace-"))
    with open(job, "rb") as fin:
        run = subprocess.run([sim, "--dialect", "grbl", "--stats", "--trace", str(tmp / "sim.csv")],
                             stdin=fin, capture_output=True, check=True)
    replies = run.stdout.decode().split()
    print(run.stderr.decode().strip())
    subprocess.run([sys.executable, "-m", "labkit.cli", "steps", str(job), "-o", str(tmp / "ref.csv")],
                   check=True, cwd=ROOT, env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"})
    a, b = pd.read_csv(tmp / "ref.csv"), pd.read_csv(tmp / "sim.csv")
    bad = []
    if replies.count("ok") == 0 or any(r.startswith("error") for r in replies):
        bad.append(f"replies: {replies.count('ok')} ok, errors {[r for r in replies if r.startswith('error')]}")
    if len(a) != len(b):
        bad.append(f"{len(b)} ticks, labkit steps has {len(a)}")
    n = min(len(a), len(b))
    for col in a.columns:
        va, vb = a[col].to_numpy()[:n], b[col].to_numpy()[:n]
        diff = np.abs(va - vb) > 1e-6 if va.dtype.kind == "f" else va != vb
        if diff.any():
            bad.append(f"column {col}: {int(diff.sum())} ticks differ, first at tick {int(np.argmax(diff))}")
    print(f"{job.name}: {len(b)} simulator ticks, {len(a)} labkit ticks, columns {', '.join(a.columns)}")
    return verdict(bad, "sim_trace: identical")


if __name__ == "__main__":
    sys.exit(main(sys.argv))
