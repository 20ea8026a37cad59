"""The virtual machine's soft limits in GRBL's machine space and GRBL's critical-alarm wait
(issue 26).

Expected replies are worked by hand from GRBL 1.1h's rules (limits.c's
system_check_travel_limits without HOMING_FORCE_SET_ORIGIN: a target is outside when any axis
is above 0 or below −$13x; protocol.c's critical event: after ALARM:1 or ALARM:2 nothing is
read or answered, '?' included, until a reset, which answers the alarmed line first). The
recorded conversations are replayed by tests/firmware/test_grbl_transcripts.py.
"""

import pytest

from labkit.machine.virtual import VirtualMachine

from .test_virtual_homing import BANNER, CHECK, LOCK, TICK_S, generic, talk

ALARM_2 = ["ALARM:2", "[MSG:Reset to continue]"]


def soft_limited(switches=None):
    """GRBL's generic mechanics, travel 200 mm, homing enabled and soft limits on."""
    vm = VirtualMachine(generic(), time_scale=0, tick_s=TICK_S, banner=False, switches=switches)
    vm.timeout = 0
    assert talk(vm, b"$22=1\n$20=1\n") == ["ok", "ok"]
    return vm


def test_soft_limits_need_homing_enabled():
    vm = VirtualMachine(generic(), time_scale=0, tick_s=TICK_S, banner=False)
    vm.timeout = 0
    assert talk(vm, b"$20=1\n") == ["error:10"]


def test_the_travel_is_minus_130_to_0_and_a_jog_outside_is_error_15():
    vm = soft_limited()
    assert talk(vm, b"G0 X-5 Y-200\n", 60.0) == ["ok"]        # both ends of the travel: inside
    assert tuple(vm.pos) == (-5.0, -200.0, 0.0)
    assert talk(vm, b"$J=G91 X6 F300\n") == ["error:15"]     # target X+1: above 0
    assert talk(vm, b"$J=G91 Y-0.01 F300\n") == ["error:15"]  # target Y-200.01: below −$131
    assert talk(vm, b"$J=G91 X-6 F300\n", 3.0) == ["ok"]     # target X-11: inside
    assert vm.pos[0] == pytest.approx(-11.0) and vm.state == "Idle"


def test_a_line_outside_is_alarm_2_and_nothing_is_answered_until_a_reset():
    vm = soft_limited()
    assert talk(vm, b"G0 X-2\n", 2.0) == ["ok"]
    assert talk(vm, b"G0 X5\n", 1.0) == ALARM_2              # not run: the head stays at X-2
    assert vm.state == "Alarm" and vm.alarm_code == 2 and vm.pos[0] == -2.0
    # GRBL's critical-event loop: no status report, no line read, no unlock
    assert talk(vm, b"?G0 X-1\n$X\n?", 1.0) == []
    assert vm.pos[0] == -2.0 and vm.laser_output() == 0.0
    # the reset answers the alarmed line, then the banner; still locked
    assert talk(vm, b"\x18") == ["ok", BANNER, LOCK]
    assert vm.state == "Alarm"
    assert talk(vm, b"$X\n") == ["[MSG:Caution: Unlocked]", "ok"]
    assert talk(vm, b"G0 X-1\n", 2.0) == ["ok"] and vm.pos[0] == -1.0


def test_an_arc_is_checked_on_its_chords_not_only_its_end():
    """Half circles of radius 5 about (-1, -15), counter-clockwise (G3): from the top (-1, -10)
    down to (-1, -20) through X = -6, inside; from there back up through X = +4, above 0,
    though both ends are inside."""
    vm = soft_limited()
    assert talk(vm, b"G0 X-1 Y-10\n", 5.0) == ["ok"]
    assert talk(vm, b"G3 X-1 Y-20 I0 J-5 F3000\n", 10.0) == ["ok"]
    assert vm.pos.tolist() == pytest.approx([-1.0, -20.0, 0.0])
    assert talk(vm, b"G3 X-1 Y-10 I0 J5\n", 1.0) == ALARM_2
    assert vm.pos.tolist() == pytest.approx([-1.0, -20.0, 0.0])


def test_a_hard_limit_waits_for_the_reset_too_and_owes_no_ok_when_no_line_was_in_progress():
    """X's switch 3 mm towards −: G0 X-10 is answered at once (queued), then meets the
    switch: ALARM:1. Nothing is answered until the reset, which owes no line an ok."""
    vm = VirtualMachine(generic(), time_scale=0, tick_s=TICK_S, banner=False, switches="X:-3")
    vm.timeout = 0
    assert talk(vm, b"$21=1\n") == ["ok"]
    assert talk(vm, b"G0 X-10\n", 3.0) == ["ok", "ALARM:1", "[MSG:Reset to continue]"]
    assert vm.pos[0] == pytest.approx(-3.0)
    assert talk(vm, b"?$X\n", 0.5) == []
    assert talk(vm, b"\x18") == [BANNER, CHECK, LOCK]      # the switch still pressed


def test_a_hard_limit_answers_the_line_waiting_on_a_dwell_at_the_reset():
    """G4 is answered when the moves before it have run: the switch is met first, so its ok
    comes with the reset (GRBL was inside that line, waiting for the planner to empty)."""
    vm = VirtualMachine(generic(), time_scale=0, tick_s=TICK_S, banner=False, switches="X:-3")
    vm.timeout = 0
    assert talk(vm, b"$21=1\n") == ["ok"]
    assert talk(vm, b"G0 X-10\nG4 P0.01\n", 3.0) == ["ok", "ALARM:1", "[MSG:Reset to continue]"]
    assert talk(vm, b"\x18") == ["ok", BANNER, CHECK, LOCK]


# -- probing (G38.2-G38.5) ---------------------------------------------------------------------

def probing(probe="Z:-2", **kw):
    """GRBL's generic mechanics with a probe plate 2 mm below the power-up position."""
    vm = VirtualMachine(generic(), time_scale=0, tick_s=TICK_S, banner=False, probe=probe, **kw)
    vm.timeout = 0
    return vm


def prb(line):
    """The position and success flag of a ``[PRB:x,y,z:f]`` line."""
    xyz, flag = line[5:-1].rsplit(":", 1)
    return tuple(float(v) for v in xyz.split(",")), int(flag)


def test_g38_2_stops_where_the_probe_touches_and_dollar_hash_shows_it():
    """Z from 0 towards -5 at 60 mm/min (1 mm/s): the plate at Z-2 is met after 2 mm,
    [PRB:0,0,-2:1] then ok; the beam stays off. The head runs on for the segments already
    prepared (0.046 s) and brakes at 10 mm/s² (v²/2a), v the block's mean speed in the
    virtual machine (5 mm in 0.1 + 4.9 + 0.1 s): about 0.093 mm past the plate, and the
    parser continues from there."""
    v = 5.0 / 5.1
    past = 0.046 * v + v * v / 20.0
    vm = probing()
    assert talk(vm, b"M3 S1000\n") == ["ok"]
    lines = talk(vm, b"G38.2 Z-5 F60\n", 6.0)
    assert len(lines) == 2 and lines[1] == "ok"
    (x, y, z), flag = prb(lines[0])
    assert (x, y, flag) == (0.0, 0.0, 1) and z == pytest.approx(-2.0, abs=1e-3)
    assert vm.pos[2] == pytest.approx(-2.0 - past, abs=1e-3) and vm.state == "Idle"
    assert all(p.power == 0 for p in vm.executed)
    assert talk(vm, b"$#\n")[-2:] == [lines[0], "ok"]
    # the parser continues from where it stopped: G91 Z1 ends 1 mm above it
    stopped = vm.pos[2]
    assert talk(vm, b"G91 G0 Z1\n", 3.0) == ["ok"]
    assert vm.pos[2] == pytest.approx(stopped + 1.0, abs=1e-3)


def test_g38_4_moves_until_the_probe_lets_go():
    vm = probing()
    assert talk(vm, b"G0 Z-3\n", 5.0) == ["ok"]                # on the plate
    lines = talk(vm, b"G38.4 Z0 F60\n", 4.0)                   # away: leaves it at Z-2
    (_, _, z), flag = prb(lines[0])
    # GRBL reads the input step by step: the first step that reads open is one step
    # (1/250 mm, $102) above the plate
    assert lines[1:] == ["ok"] and flag == 1 and z == pytest.approx(-1.996, abs=1e-6)


def test_a_probe_already_where_the_move_should_end_is_alarm_4_and_nothing_moves():
    vm = probing(probe="Z:stuck")
    assert talk(vm, b"G38.2 Z-5 F60\n", 1.0) == ["ALARM:4", "ok"]
    assert vm.state == "Alarm" and vm.alarm_code == 4 and vm.pos[2] == 0.0
    assert talk(vm, b"G0 X-1\n") == ["error:9"]


def test_no_touch_is_alarm_5_for_g38_2_and_a_result_for_g38_3():
    """No plate: G38.2 runs its whole move, ALARM:5 and the last probe position (none yet:
    0,0,0) with flag 0; G38.3 reports where it stopped, flag 0, without an alarm."""
    vm = probing(probe=None)
    assert talk(vm, b"G38.2 Z-1 F60\n", 2.0) == ["ALARM:5", "[PRB:0.000,0.000,0.000:0]", "ok"]
    assert vm.state == "Alarm" and vm.pos[2] == pytest.approx(-1.0)
    assert talk(vm, b"$X\n") == ["[MSG:Caution: Unlocked]", "ok"]
    assert talk(vm, b"G38.3 Z-1.5 F60\n", 2.0) == ["[PRB:0.000,0.000,-1.500:0]", "ok"]
    assert vm.state == "Idle"
    assert talk(vm, b"\x18")[0] == "Grbl 1.1h ['$' for help]"   # a reset clears the result
    assert "[PRB:0.000,0.000,0.000:0]" in talk(vm, b"$#\n")


def test_a_bad_probe_spec_is_a_clear_error():
    from labkit.errors import MachineError

    with pytest.raises(MachineError, match="probe 'Q:1'"):
        probing(probe="Q:1")
