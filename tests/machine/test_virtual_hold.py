"""Feed hold on the virtual machine as GRBL 1.1 does it: the head decelerates along the
programmed path (Hold:1) at the machine's acceleration, stops (Hold:0) a braking distance
v²/(2a) further on, with the beam off once stopped; cycle start finishes the job with
every millimetre burned exactly once."""

import re

import numpy as np
import pytest

from labkit.machine.virtual import VirtualMachine
from labkit.motion import load_machine

FEED = 1800.0                                   # mm/min: 30 mm/s


def _poll(vm, n=1):
    out = ""
    for _ in range(n):
        out += vm.read(vm.in_waiting or 1).decode()
    return out


def _status(vm):
    vm.write(b"?")
    return re.search(r"<([A-Za-z]+(?::\d)?)\|MPos:([-\d.]+),([-\d.]+)", _poll(vm)).groups()


def test_feed_hold_brakes_along_the_path_and_resumes_burning_each_mm_once():
    vm = VirtualMachine("grbl-diode", time_scale=0, tick_s=0.005, banner=False)
    accel = load_machine("grbl-diode").accel_mm_s2[0]
    vm.write(f"G21 G90 M4 S800\nG1 X150 F{FEED:g}\nM5\n".encode())
    while vm.pos[0] < 60.0:                       # well into the cruise of the 150 mm line
        _poll(vm)
    v = vm._current_speed()
    assert v == pytest.approx(FEED / 60.0, rel=0.05)
    x_hold = float(vm.pos[0])
    vm.write(b"!")
    state, x, _ = _status(vm)
    assert state == "Hold:1"                      # braking, not stopped
    assert vm.laser_output() > 0                  # still cutting while it moves
    for _ in range(2000):
        state, x, _ = _status(vm)
        if state == "Hold:0":
            break
    assert state == "Hold:0" and vm.laser_output() == 0
    braking = float(vm.pos[0]) - x_hold
    assert braking == pytest.approx(v * v / (2 * accel), rel=0.05, abs=v * 0.005 * 2)
    stopped = vm.pos.copy()
    _poll(vm, 50)                                 # standing still while held
    assert np.array_equal(vm.pos, stopped)
    vm.write(b"~")
    for _ in range(20000):
        _poll(vm)
        if vm.state == "Idle" and not vm._rx:
            break
    assert vm.pos[0] == pytest.approx(150.0)
    burned = [p for p in vm.executed if p.power > 0]
    spans = sorted((min(p.start[0], p.end[0]), max(p.start[0], p.end[0])) for p in burned)
    total = sum(b - a for a, b in spans)
    assert total == pytest.approx(150.0, abs=1e-9)           # no gap, nothing twice
    assert all(a2 >= b1 - 1e-9 for (_, b1), (a2, _) in zip(spans, spans[1:]))
    assert vm.unsafe_stops == []


def test_a_reset_while_braking_is_an_alarm():
    vm = VirtualMachine("grbl-diode", time_scale=0, tick_s=0.005, banner=False)
    vm.write(f"G21 G90 G1 X150 F{FEED:g}\n".encode())
    while vm.pos[0] < 30.0:
        _poll(vm)
    vm.write(b"!")
    _ = vm.in_waiting                             # one tick (5 ms) of the ~30 ms of braking
    assert vm.state == "Hold" and vm.substate == 1
    vm.write(b"\x18")
    assert "ALARM:3" in _poll(vm, 3)
