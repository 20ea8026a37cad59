"""The virtual machine's overrides and settings behave as GRBL 1.1 documents them."""

import re

import pytest

from labkit.machine.grbl import parse_status
from labkit.machine.virtual import VirtualMachine
from labkit.motion import load_machine


def _drain(vm, rounds=5):
    out = b""
    for _ in range(rounds):
        out += vm.read(vm.in_waiting or 1)
    return out.decode()


def _sim_time_of(job: bytes, overrides: bytes = b"") -> float:
    vm = VirtualMachine("grbl-diode", time_scale=0, tick_s=0.01, banner=False)
    vm.write(overrides)
    vm.write(job)
    for _ in range(100_000):
        vm.read(vm.in_waiting)                      # each poll advances simulated time
        if vm.state == "Idle" and not vm._rx:
            break
    return vm.sim_time_s


def test_settings_report_steps_per_mm_of_the_machine():
    vm = VirtualMachine("grbl-diode", time_scale=0, banner=False)
    vm.write(b"$$\n")
    text = _drain(vm, 20)
    steps = float(re.search(r"\$100=([\d.]+)", text).group(1))
    assert steps == pytest.approx(load_machine("grbl-diode").steps_per_mm[0])


def test_feed_override_at_half_doubles_a_long_cut():
    job = b"G21 G90 M4 S500\nG1 X200 F600\nM5\n"         # 200 mm at 10 mm/s: 20 s of cruise
    full = _sim_time_of(job)
    half = _sim_time_of(job, bytes([0x92] * 5))            # 100 % - 5 x 10 % = 50 %
    assert full == pytest.approx(20.0, rel=0.02)
    assert half / full == pytest.approx(2.0, rel=0.02)


def test_override_limits_and_status_field():
    vm = VirtualMachine("grbl-diode", time_scale=0, banner=False)
    vm.write(bytes([0x91] * 15 + [0x96] + [0x9B] * 12))    # feed +150 % (max 200), rapid 50 %, power -120 % (min 10)
    vm.write(b"??")     # GRBL's first report after power-up carries WCO, and defers Ov to the next
    st = parse_status(re.findall(r"<[^>]+>", _drain(vm))[-1])
    assert vm.overrides == (200, 50, 10)
    assert tuple(st.overrides) == (200, 50, 10)


def test_laser_power_override_scales_the_beam_while_cutting():
    vm = VirtualMachine("grbl-diode", time_scale=0, tick_s=0.01, banner=False)
    vm.write(bytes([0x9B] * 5))                            # power 50 %
    vm.write(b"G21 G90 M3 S1000\nG1 X100 F600\n")
    for _ in range(50):                                    # each look advances 10 ms: 0.5 s in
        _ = vm.in_waiting
    assert vm.state == "Run" and vm.laser_output() == pytest.approx(0.5)
