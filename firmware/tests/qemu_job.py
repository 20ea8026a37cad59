"""Boot the netduinoplus2 image in QEMU and stream a job to it.

    PYTHONPATH=<repo> /work/main/.venv/bin/python firmware/tests/qemu_job.py \
        firmware/build/arm/netduinoplus2.elf [REPO_ROOT]

QEMU (-M netduinoplus2, an STM32F405) runs the firmware with USART1 on a TCP
socket (QEMU waits for this script to connect before the CPU starts, so the
banner is not lost) and USART2, the trace port, in a file (one byte per
step tick: bits 0-2 steps, 3-5 directions, 6 laser on). The script

* waits for the banner, switches to the GRBL dialect ($208=1),
* streams a short laser job with labkit's character-counting runner,
* checks every line got ok, reads the final position with '?',
* checks the laser ended off (FS power 0, $G M5, the last trace byte),
* counts the steps on the trace port and compares them with '?'.

QEMU runs with ``-icount shift=3,sleep=off`` (override with $QEMU_EXTRA).
"""
from __future__ import annotations

import os
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1]))

from labkit.machine.grbl import Grbl  # noqa: E402
from labkit.machine.link import open_link  # noqa: E402
from labkit.machine.stream import Job, run_job  # noqa: E402
from sim_stream import STEPS_PER_MM, end_state_failures, verdict  # noqa: E402  (this folder, beside it)

JOB = """G21 G90
G0 X5 Y5
M3 S300
G1 X15 F1200
G1 Y15
G2 X5 Y15 I-5 J0
G1 Y5
M5
G4 P0.1
M4 S500
G1 X10 Y8 F900
M5
G0 X12.5 Y7.25
M2
"""


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def main(argv):
    elf = argv[1] if len(argv) > 1 else str(HERE.parent / "build/arm/netduinoplus2.elf")
    port = free_port()
    tmp = tempfile.mkdtemp(prefix="labkit-qemu-")
    trace_path = os.path.join(tmp, "trace.bin")
    cmd = ["qemu-system-arm", "-M", "netduinoplus2", "-display", "none", "-monitor", "none",
           "-kernel", elf,
           "-serial", f"tcp:127.0.0.1:{port},server=on,wait=on",
           "-serial", f"file:{trace_path}"]
    # Virtual time counted in instructions (8 ns each): QEMU's wall-clock
    # timers cannot deliver step interrupts at tens of kHz, icount can.
    cmd += os.environ.get("QEMU_EXTRA", "-icount shift=3,sleep=off").split()
    qemu = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    failures = []
    try:
        link = None
        for _ in range(100):
            try:
                link = open_link(f"socket://127.0.0.1:{port}")
                break
            except Exception:
                time.sleep(0.05)
        if link is None:
            raise SystemExit("cannot connect to QEMU's USART1 socket")
        g = Grbl(link)
        t0 = time.monotonic()
        info = g.connect(timeout_s=10.0)
        print(f"banner after {time.monotonic() - t0:.2f} s: {info.banner!r}")
        g.set_setting(208, 1)                 # GRBL dialect for labkit's runner
        info = g.read_info()
        print(f"$I: {info.version} [{info.options}]")
        job = Job.from_text(JOB, dialect="grbl")
        t0 = time.monotonic()
        report = run_job(g, job, mode="counting", status_interval_s=0.1, watchdog_s=5.0)
        dt = time.monotonic() - t0
        print(f"job: {report.summary()}")
        print(f"{report.lines_sent} lines sent, {report.lines_acknowledged} ok, max RX used "
              f"{report.max_rx_used} bytes, {dt:.2f} s (planned {job.job_time_s:.2f} s)")
        if not report.ok or report.fault or report.lines_acknowledged != len(job.send):
            failures.append(f"job: {report.fault} {report.errors}")
        failures += end_state_failures(g, job)      # to one step, as on the simulator
        g.close()
    finally:
        qemu.terminate()
        try:
            qemu.wait(5)
        except subprocess.TimeoutExpired:
            qemu.kill()
    data = Path(trace_path).read_bytes() if os.path.exists(trace_path) else b""
    pos = [0, 0, 0]
    burning = 0
    for b in data:
        for i in range(3):
            if b & (1 << i):
                pos[i] += -1 if b & (8 << i) else 1
        burning += (b >> 6) & 1
    print(f"trace port: {len(data)} ticks, {burning} with the laser on, steps {pos}")
    want = [round(v * STEPS_PER_MM) for v in (12.5, 7.25, 0.0)]
    if pos != want:
        failures.append(f"trace port counted {pos} steps, expected {want}")
    if not data or data[-1] & 0x40:
        failures.append("trace: laser on at the last tick (or no trace)")
    if burning == 0:
        failures.append("trace: the laser never burned")
    return verdict(failures, "qemu_job: PASS")


if __name__ == "__main__":
    sys.exit(main(sys.argv))
