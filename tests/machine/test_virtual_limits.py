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

from .test_virtual_homing import BANNER, LOCK, TICK_S, generic, talk

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
    assert talk(vm, b"\x18") == [BANNER, LOCK]


def test_a_hard_limit_answers_the_line_waiting_on_a_dwell_at_the_reset():
    """G4 is answered when the moves before it have run: the switch is met first, so its ok
    comes with the reset (GRBL was inside that line, waiting for the planner to empty)."""
    vm = VirtualMachine(generic(), time_scale=0, tick_s=TICK_S, banner=False, switches="X:-3")
    vm.timeout = 0
    assert talk(vm, b"$21=1\n") == ["ok"]
    assert talk(vm, b"G0 X-10\nG4 P0.01\n", 3.0) == ["ok", "ALARM:1", "[MSG:Reset to continue]"]
    assert talk(vm, b"\x18") == ["ok", BANNER, LOCK]
