"""The virtual machine's work offsets as GRBL 1.1 documents them: G10 L2/L20 set the G54–G59
origins (kept through a reset, as GRBL keeps them in EEPROM), G92 shifts the work position
(cleared by a reset), G43.1 offsets Z, and the status report's WCO is their sum, so that
WPos = MPos − WCO."""

import re

import numpy as np
import pytest

from labkit.machine.grbl import parse_status
from labkit.machine.virtual import VirtualMachine


def _vm():
    return VirtualMachine("grbl-diode", time_scale=0, tick_s=0.02, banner=False)


def _send(vm, line: str) -> str:
    vm.write(line.encode() + b"\n")
    out = ""
    for _ in range(2000):
        out += vm.read(vm.in_waiting or 1).decode()
        if re.search(r"^(ok|error:\d+)\r?$", out, re.M) and vm.state == "Idle":
            break
    assert vm.state == "Idle", out
    return out


def _status(vm):
    """A status report with WCO (GRBL sends it now and then; here every 10th report)."""
    for _ in range(12):
        vm.write(b"?")
        text = vm.read(vm.in_waiting or 1).decode()
        m = re.search(r"<[^>]+>", text)
        if m and "WCO:" in m.group(0):
            return parse_status(m.group(0))
    raise AssertionError("no WCO in 12 status reports")


def test_g10_l20_makes_the_current_position_the_work_origin():
    vm = _vm()
    assert "ok" in _send(vm, "G0 X30 Y40")
    assert "ok" in _send(vm, "G10 L20 P0 X0 Y0")
    st = _status(vm)
    assert st.mpos == pytest.approx((30, 40, 0)) and st.wpos == pytest.approx((0, 0, 0))
    _send(vm, "G0 X5 Y-2")                         # work coordinates from here on
    assert vm.pos == pytest.approx((35, 38, 0))
    st = _status(vm)
    assert st.wpos == pytest.approx((5, -2, 0)) and st.wco == pytest.approx((30, 40, 0))


def test_g92_adds_to_the_origin_and_a_reset_clears_it_but_not_g54():
    vm = _vm()
    _send(vm, "G10 L2 P1 X10 Y20")                  # G54 origin at machine (10, 20)
    _send(vm, "G0 X5 Y5")                           # work (5, 5) = machine (15, 25)
    assert vm.pos == pytest.approx((15, 25, 0))
    _send(vm, "G92 X0 Y0")                          # here reads (0, 0): G92 = (5, 5)
    assert _status(vm).wco == pytest.approx((15, 25, 0))
    _send(vm, "G0 X1 Y1")
    assert vm.pos == pytest.approx((16, 26, 0))
    text = _send(vm, "$#")
    assert "[G54:10.000,20.000,0.000]" in text and "[G92:5.000,5.000,0.000]" in text
    vm.write(b"\x18")
    vm.read(vm.in_waiting or 1)
    st = _status(vm)
    assert st.wco == pytest.approx((10, 20, 0))      # G92 gone, G54 kept
    assert st.wpos == pytest.approx((6, 6, 0))


def test_other_coordinate_systems_and_the_tool_length_offset():
    vm = _vm()
    _send(vm, "G10 L2 P2 X50 Y0 Z0")                # G55
    _send(vm, "G55 G0 X1 Y2")
    assert vm.pos == pytest.approx((51, 2, 0))
    assert "[GC:G0 G55 " in _send(vm, "$G")
    _send(vm, "G43.1 Z-1.5")
    st = _status(vm)
    assert st.wco == pytest.approx((50, 0, -1.5)) and st.wpos == pytest.approx((1, 2, 1.5))
    _send(vm, "G49 G54")
    assert _status(vm).wco == pytest.approx((0, 0, 0))


def test_work_offsets_move_the_planned_blocks_exactly():
    """A job run after set-origin burns the same shape, shifted by the origin."""
    job = "G21 G90 M4 S500\nG1 X10 Y0 F1200\nG2 X20 Y0 I5 J0\nM5\n"
    plain, shifted = _vm(), _vm()
    for line in job.splitlines():
        _send(plain, line)
    _send(shifted, "G0 X40 Y30")
    _send(shifted, "G10 L20 P0 X0 Y0")
    for line in job.splitlines():
        _send(shifted, line)
    a = np.array([p.end for p in plain.executed if p.power > 0])
    b = np.array([p.end for p in shifted.executed if p.power > 0])
    assert len(a) == len(b) > 10
    assert b - a == pytest.approx(np.tile([40, 30, 0], (len(a), 1)))
