"""Streaming throughput: character counting against send-response over a real pseudo-terminal.

Run:  .venv/bin/python benchmarks/bench_stream.py [--lines 10000] [--baud 115200] [--latency-ms 1]

A seeded 10,000-line zig-zag raster engraving (0.1 mm G1 pixels with changing
S) is streamed to a simulated GRBL device on the other end of a pty. The device is :class:`labkit.machine.virtual.VirtualMachine` running in
real time (128-byte RX buffer, 16-block planner, the grbl-diode machine's
rates and accelerations), behind a wire model: every byte takes 10 bit times
at the baud rate in each direction, and each transfer adds a USB-serial
latency (FTDI and CH340 bridges deliver after about 1 ms). The host side is
labkit's own stack over the pty's device path (pyserial ``Serial``, the GRBL
reader, :func:`labkit.machine.stream.run_job`).

Printed for each mode: wall time, lines/s, the link's theoretical limit
(bytes/s ÷ mean line length, newline included), and the mean RX-buffer fill
(time-weighted, from the device); then the counting / send-response time ratio
(issue 13 §7 asks for at most 0.60) and whether every burn ran exactly once.
"""

from __future__ import annotations

import argparse
import os
import pty
import select
import sys
import threading
import time
import tty
from collections import deque

import numpy as np

from labkit.machine.grbl import Grbl
from labkit.machine.link import open_link
from labkit.machine.stream import Job, run_job
from labkit.machine.virtual import VirtualMachine


def raster_job(n_lines: int, seed: int = 0) -> str:
    """A zig-zag raster engraving of ``n_lines`` lines: rows of 200 pixels of 0.1 mm at
    6000 mm/min, grey level as S (0-1000), a 0.1 mm step between rows."""
    rng = np.random.default_rng(seed)
    lines = ["G21 G90", "M4 S0 F6000", "G0 X10 Y10"]
    row = 0
    x = 10.0
    while len(lines) < n_lines - 2:
        y = 10 + 0.1 * row
        if row:
            lines.append(f"G1 Y{y:.1f} S0")
        step = 0.1 if row % 2 == 0 else -0.1
        for _ in range(min(200, n_lines - 2 - len(lines))):
            x += step
            lines.append(f"G1 X{x:.1f} S{int(rng.integers(0, 1000))}")
        row += 1
    lines += ["M5 S0", "G0 X0 Y0"]
    return "\n".join(lines[:n_lines]) + "\n"


class PtyDevice(threading.Thread):
    """A virtual GRBL on the master side of a pty, with a wire of finite speed and latency."""

    def __init__(self, vm: VirtualMachine, baud: int, latency_s: float):
        super().__init__(daemon=True)
        self.vm = vm
        self.byte_s = 10.0 / baud
        self.latency_s = latency_s
        self.master, self.slave = pty.openpty()
        tty.setraw(self.slave)
        self.path = os.ttyname(self.slave)
        self.stop = threading.Event()

    def run(self):
        inbound: deque = deque()      # (due time, byte)
        outbound: deque = deque()
        in_free = out_free = 0.0
        while not self.stop.is_set():
            ready, _, _ = select.select([self.master], [], [], 0.0002)
            now = time.monotonic()
            if ready:
                try:
                    data = os.read(self.master, 4096)
                except OSError:
                    return
                t = max(now + self.latency_s, in_free)
                for b in data:
                    t += self.byte_s
                    inbound.append((t, b))
                in_free = t
            due = bytearray()
            while inbound and inbound[0][0] <= now:
                due.append(inbound.popleft()[1])
            if due:
                self.vm.write(bytes(due))
            n = self.vm.in_waiting
            if n:
                data = self.vm.read(n)
                t = max(now + self.latency_s, out_free)
                for b in data:
                    t += self.byte_s
                    outbound.append((t, b))
                out_free = t
            out = bytearray()
            while outbound and outbound[0][0] <= now:
                out.append(outbound.popleft()[1])
            if out:
                os.write(self.master, bytes(out))

    def close(self):
        self.stop.set()
        self.join(1.0)
        os.close(self.master)
        os.close(self.slave)


def mean_fill(samples, t_from: float) -> float:
    arr = np.array([s for s in samples if s[0] >= t_from])
    if len(arr) < 2:
        return float("nan")
    dt = np.diff(arr[:, 0])
    return float((arr[:-1, 1] * dt).sum() / dt.sum()) if dt.sum() > 0 else float("nan")


def run(mode: str, text: str, baud: int, latency_s: float):
    vm = VirtualMachine("grbl-diode", time_scale=1.0)
    vm.timeout = 0
    dev = PtyDevice(vm, baud, latency_s)
    dev.start()
    g = Grbl(open_link(dev.path, baud))
    try:
        g.connect()
        job = Job.from_text(text, machine="grbl-diode")
        t_start = vm.sim_time_s
        t0 = time.perf_counter()
        rep = run_job(g, job, mode=mode, watchdog_s=10.0)
        wall = time.perf_counter() - t0
        fill = mean_fill(vm.rx_fill, t_start)
    finally:
        g.close()
        dev.close()
    return rep, wall, fill, job, vm


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lines", type=int, default=10_000)
    ap.add_argument("--baud", type=int, default=115_200)
    ap.add_argument("--latency-ms", type=float, default=1.0)
    args = ap.parse_args(argv)
    text = raster_job(args.lines)
    sent = [len(line) + 1 for line in
            (ln.replace(" ", "") for ln in text.splitlines()) if line]
    mean_len = sum(sent) / len(sent)
    limit = args.baud / 10 / mean_len
    print(f"job: {args.lines} lines, mean {mean_len:.1f} bytes sent per line; link "
          f"{args.baud} baud = {args.baud / 10:.0f} bytes/s -> theoretical limit "
          f"{limit:.0f} lines/s; USB latency {args.latency_ms:g} ms per transfer")
    times = {}
    for mode in ("counting", "send-response"):
        rep, wall, fill, job, vm = run(mode, text, args.baud, args.latency_ms / 1000)
        times[mode] = wall
        print(f"{mode:>13}: {wall:7.2f} s  {args.lines / wall:6.0f} lines/s "
              f"({args.lines / wall / limit:5.1%} of the link limit)  mean RX fill "
              f"{fill:5.1f} of 127 bytes  planned job {job.job_time_s:.1f} s  "
              f"{'ok' if rep.ok else 'FAILED: ' + str(rep.fault)}  overflows {vm.overflows}")
    ratio = times["counting"] / times["send-response"]
    print(f"counting / send-response time: {ratio:.2f} (issue 13 asks <= 0.60: "
          f"{'met' if ratio <= 0.60 else 'NOT met'})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
