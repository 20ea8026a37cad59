"""The virtual machine's beam in laser mode follows GRBL 1.1's documented laser mode
(doc/markdown/laser_mode.md of gnea/grbl): M3 keeps the programmed power "regardless if the
machine is moving, accelerating, or stopped" (it can focus), M4 turns the laser off when not in
motion, "G0 M3 S1000 will not turn on the laser", and the status report shows A:S / A:C with its
Ov: field while the output is on."""

import pytest

from labkit.machine.virtual import VirtualMachine


def machine():
    return VirtualMachine("grbl-diode", time_scale=0, tick_s=0.05, banner=False)


def run(vm, data, polls=40):
    vm.write(data)
    return b"".join(vm.read(4096) for _ in range(polls)).decode()


def test_m3_keeps_its_power_at_rest_m4_does_not():
    vm = machine()
    run(vm, b"G21 G91 G1 X5 F600 S500 M4\n")
    assert (vm.state, vm.laser_output()) == ("Idle", 0.0)          # M4: off when not in motion
    run(vm, b"G1 X5 S500 M3\n")
    assert (vm.state, vm.laser_output()) == ("Idle", 0.5)          # M3: constant power at rest
    assert vm.unsafe_stops[-1][1:] == ("buffer empty", 0.5)        # and it is recorded
    run(vm, b"M5\n")
    assert vm.laser_output() == 0.0
    run(vm, b"G1 M3 S200\n")                                       # focusing: M3 S, no motion, G1
    assert vm.laser_output() == 0.2
    run(vm, b"S0\n")
    assert vm.laser_output() == 0.0
    run(vm, b"S300\n")
    assert vm.laser_output() == 0.3
    run(vm, b"G0\n")                                               # G0 switches the laser off
    assert vm.laser_output() == 0.0
    run(vm, b"M5\nG0 M3 S1000\n")                                  # ... and never turns it on
    assert vm.laser_output() == 0.0
    run(vm, b"G0 X5\n")
    assert vm.laser_output() == 0.0 and not any(p.power for p in vm.executed if p.rapid)


def test_program_end_reset_and_alarm_switch_it_off():
    vm = machine()
    for ending in (b"M2\n", b"M30\n"):
        run(vm, b"G21 G91 G1 X2 F600 S400 M3\n")
        assert vm.laser_output() == 0.4
        run(vm, ending)
        assert vm.laser_output() == 0.0
    vm.write(b"G1 X2 S400 M3\n")
    vm.write(b"\x18")                                              # mid-move: ALARM:3
    assert vm.laser_output() == 0.0 and vm.state == "Alarm"
    run(vm, b"$X\n")
    vm.settings[22], vm.settings[20] = "1", "1"                     # soft limits: an ALARM:2
    run(vm, b"G90 G1 X-1 F600 S400 M3\n")           # the reset forgot F; inside GRBL's −$130…0
    assert vm.laser_output() == 0.4
    assert "ALARM:2" in run(vm, b"G1 X9999\n") and vm.laser_output() == 0.0


def test_a_stopped_hold_switches_the_beam_off_m3_and_m4_alike_and_cycle_start_restores_it():
    """GRBL 1.1h protocol.c: in laser mode a feed hold sets the spindle-stop override
    (DISABLE_LASER_DURING_HOLD, on in its default config.h), and once the hold is complete the
    laser is de-energized whatever M3/M4 is in effect; cycle start restores it with the motion."""
    for mode in (b"M4", b"M3"):
        vm = machine()
        vm.write(b"G21 G91 G1 X50 F600 S500 " + mode + b"\n")
        vm.read(4096)
        vm.write(b"!")
        run(vm, b"")
        assert (vm.state, vm.substate) == ("Hold", 0)
        assert vm.laser_output() == 0.0, mode
        vm.write(b"?")
        report = vm.read(4096).decode()
        assert "FS:0,0" in report and "|A:" not in report, report
        vm.write(b"~")
        vm.read(4096)
        assert vm.state == "Run" and vm.laser_output() > 0.0, mode


def test_a_dwell_keeps_the_level_it_starts_with():
    vm = machine()
    vm.write(b"G21 G1 M3 S250\nG4 P1\n")
    vm.read(4096)
    assert vm.state == "Run" and vm._blocks[0].is_dwell and vm.laser_output() == 0.25
    run(vm, b"M5\nM4 S250\nG4 P1\n", polls=3)
    assert vm.laser_output() == 0.0                                # M4: a dwell is dark


def test_beam_log_and_accessory_field():
    vm = machine()
    vm.write(b"G21 G91 G1 X20 F600 S500 M4\n")
    reports = [run(vm, b"?", polls=1) for _ in range(12)]
    lit = [r for r in reports if "Ov:" in r and "<Run" in r]
    assert lit and all("|A:C" in r for r in lit)                   # M4 is GRBL's CCW: C
    run(vm, b"")
    assert [round(lv, 3) for _, lv, _, _ in vm.beam_log] == [0.5, 0.0]
    assert vm.beam_log[0][2] == "Run" and vm.beam_log[1][2] == "Idle"
    run(vm, b"G1 X1 M3\n")
    idle = [run(vm, b"?", polls=1) for _ in range(12)]
    assert any("<Idle" in r and "|A:S" in r for r in idle)         # M3 on at rest: A:S


@pytest.mark.parametrize("mode", ["M3", "M4"])
def test_spindle_mode_keeps_the_beam_on_whatever_the_motion(mode):
    vm = machine()
    run(vm, b"$32=0\n")
    run(vm, f"G21 G0 {mode} S300\n".encode())
    assert vm.laser_output() == 0.3                                # $32=0: a spindle, on at once
    vm.write(b"G0 X10\n")
    vm.read(4096)
    assert vm.state == "Run" and vm._blocks[0].rapid and vm.laser_output() == 0.3
