"""The virtual machine's limit switches and homing cycle, as GRBL 1.1h's (issue 26).

Every expected figure here is worked by hand from GRBL's documented rules (the v1.1 wiki's
"Configuration" page for $22-$27, limits.c's cycle as the firmware's homing.c follows it) on
GRBL's DEFAULTS_GENERIC mechanics (500 mm/min, 10 mm/s² on every axis) with the settings the
recorded homing transcripts use ($13x=20, $25=200, $24=100, $27=3, $26=250 ms): the
transcripts themselves are replayed by tests/firmware/test_grbl_transcripts.py.
"""

import pytest

from labkit.errors import MachineError
from labkit.machine.virtual import VirtualMachine
from labkit.motion import load_machine

TICK_S = 0.005
HOMING = (b"$130=20\n", b"$131=20\n", b"$132=20\n", b"$25=200\n", b"$24=100\n", b"$27=3\n",
          b"$22=1\n")
LOCK = "[MSG:'$H'|'$X' to unlock]"
CHECK = "[MSG:Check Limits]"     # after a reset with $21=1 and a limit input pressed
BANNER = "Grbl 1.1h ['$' for help]"


def generic(**changes):
    """GRBL's DEFAULTS_GENERIC mechanics, no settings of grbl-diode's own."""
    return load_machine("grbl-diode").replace(
        steps_per_mm=(250.0,) * 3, max_rate_mm_min=(500.0,) * 3, accel_mm_s2=(10.0,) * 3,
        travel_mm=(200.0,) * 3, grbl_settings=(), **changes)


def machine(switches="X:+5,Y:+5,Z:+5", **kw):
    vm = VirtualMachine(generic(), time_scale=0, tick_s=TICK_S, banner=False, switches=switches, **kw)
    vm.timeout = 0                      # one tick of simulated time per read
    for line in HOMING:
        assert talk(vm, line) == ["ok"]
    return vm


def talk(vm, data=b"", seconds=0.05):
    """Write ``data``, let ``seconds`` of simulated time pass, return the lines that came."""
    vm.write(data)
    out = b""
    for _ in range(max(1, round(seconds / TICK_S))):
        out += vm.read(1 << 16)
    return [ln for ln in out.decode().split("\r\n") if ln]


def until(vm, text, limit_s=60.0):
    """Lines up to and including the first ``text``, and the simulated time it came."""
    lines = []
    for _ in range(round(limit_s / TICK_S)):
        got = vm.read(1 << 16).decode()
        lines += [ln for ln in got.split("\r\n") if ln]
        if text in lines:
            return lines, vm.sim_time_s
    raise AssertionError(f"{text!r} never came: {lines}")


def mpos(report):
    field = next(f for f in report.strip("<>").split("|") if f.startswith("MPos:"))
    return tuple(float(v) for v in field[5:].split(","))


def trapezoid_time(distance, rate_mm_min, accel=10.0):
    """Time from rest to ``distance`` mm (reached at full speed, not at the end) for a move
    from rest at ``accel`` to ``rate``; worked by hand: ramp v/a, then the rest at v."""
    v = rate_mm_min / 60.0
    return v / accel + (distance - v * v / (2 * accel)) / v


def test_a_cycle_homes_z_then_xy_to_minus_pulloff_in_the_time_worked_by_hand():
    vm = machine()
    t0 = vm.sim_time_s
    vm.write(b"$H\n")
    lines, t_ok = until(vm, "ok")
    assert lines == ["ok"]
    # GRBL sets -$27 on an axis homed towards + ($23=0)
    assert mpos(talk(vm, b"?")[0]) == (-3.0, -3.0, -3.0)
    # per group: search from 0 to the switch at 5 mm at $25 (3.33 mm/s, 10 mm/s²), pull-off 3 mm
    # (ramp up, cruise, ramp down: 2 x 1/3 s + (3 - 2 x 5/9) / (10/3) s), locate 3 mm at $24,
    # pull-off again, 250 ms after each; X and Y move together, each at $25
    pull = 2 * (10 / 3) / 10 + (3 - 2 * (10 / 3) ** 2 / 20) / (10 / 3)
    group = trapezoid_time(5, 200) + pull + trapezoid_time(3, 100) + pull + 4 * 0.250
    assert pull == pytest.approx(1.23333, abs=1e-4) and group == pytest.approx(7.01667, abs=1e-4)
    assert t_ok - t0 == pytest.approx(2 * group, abs=3 * TICK_S)
    # no beam anywhere in the cycle
    assert all(p.power == 0 for p in vm.executed) and vm.laser_output() == 0.0


def test_homing_again_from_elsewhere_and_towards_minus():
    vm = machine(switches="X:-5,Y:+5,Z:+5")
    assert talk(vm, b"$23=1\n") == ["ok"]            # X homes towards -, onto its switch at -5
    vm.write(b"$H\n")
    until(vm, "ok")
    # towards -: GRBL sets -$130 + $27 (its machine space is -$130..0)
    assert mpos(talk(vm, b"?")[0]) == (-17.0, -3.0, -3.0)
    talk(vm, b"G0 X-10 Y-5\nG4 P0.01\n", 10.0)
    assert mpos(talk(vm, b"?")[0]) == (-10.0, -5.0, -3.0)
    vm.write(b"$H\n")
    until(vm, "ok")
    assert mpos(talk(vm, b"?")[0]) == (-17.0, -3.0, -3.0)     # the switches did not move


def test_no_switch_within_the_search_is_alarm_9_and_a_reset():
    vm = machine(switches=None)                     # nothing wired: Z is first and never finds one
    vm.write(b"$H\n")
    lines, _ = until(vm, LOCK)
    assert lines == ["ALARM:9", "ok", BANNER, LOCK]
    report = talk(vm, b"?")[0]
    # Z searched 1.5 x $132 = 30 mm towards +, counted from 0; X and Y never moved
    assert report.startswith("<Alarm|") and mpos(report) == (0.0, 0.0, 30.0)
    assert talk(vm, b"G0 X1\n") == ["error:9"]       # locked until $X or $H
    assert talk(vm, b"$X\n") == ["[MSG:Caution: Unlocked]", "ok"]


def test_a_switch_still_pressed_after_the_pull_off_is_alarm_8_and_pn_shows_it():
    vm = machine(switches="X:stuck,Y:+5,Z:+5")
    assert "|Pn:X|" in talk(vm, b"?")[0]
    vm.write(b"$H\n")
    lines, _ = until(vm, LOCK)
    assert lines == ["ALARM:8", "ok", BANNER, LOCK]
    # Z homed (-3); X (stopped at once) and Y (stopped at 5) pulled off 3 mm from their new 0
    report = talk(vm, b"?")[0]
    assert report.startswith("<Alarm|MPos:-3.000,-3.000,-3.000|FS:0,0|Pn:X|")
    assert vm.limit_pins == "X"


def test_a_reset_during_the_cycle_is_alarm_6_where_it_stopped():
    vm = machine()
    talk(vm, b"$H\n", 1.0)                           # 1 s into Z's search: 0.56 + 2/3 x 10/3 mm
    assert vm.state == "Home" and vm.pos[2] == pytest.approx(0.5556 + (1 - 1 / 3) * 10 / 3, abs=0.03)
    assert talk(vm, b"\x18") == ["ALARM:6", "ok", BANNER, LOCK]
    report = talk(vm, b"?")[0]
    assert report.startswith("<Alarm|") and mpos(report)[2] == pytest.approx(2.778, abs=0.02)
    assert talk(vm, b"$X\n") == ["[MSG:Caution: Unlocked]", "ok"]


def test_the_door_during_the_cycle_is_alarm_7():
    vm = machine()
    talk(vm, b"$H\n", 0.5)
    assert talk(vm, b"\x84") == ["ALARM:7", "ok", BANNER, LOCK]
    assert vm.state == "Alarm"


def test_status_during_the_cycle_is_answered_at_its_end_in_home_and_lines_wait():
    vm = machine()
    vm.write(b"$H\n")
    assert talk(vm, b"", 1.0) == [] and vm.state == "Home"
    vm.write(b"?")
    vm.write(b"G0 X-1\n")                           # read only once the cycle has ended
    assert talk(vm, b"", 1.0) == []
    lines, _ = until(vm, "ok")
    # the report, $H's ok, then the G0's (read from the RX buffer once the cycle has ended)
    assert lines[0].startswith("<Home|MPos:-3.000,-3.000,-3.000|") and lines[1:] == ["ok", "ok"]
    talk(vm, b"", 2.0)
    assert mpos(talk(vm, b"?")[0]) == (-1.0, -3.0, -3.0)


def test_start_up_lines_run_after_the_cycle_before_its_ok():
    vm = machine()
    assert talk(vm, b"$N0=G91\n") == ["ok"]
    vm.write(b"$H\n")
    lines, _ = until(vm, "ok")
    assert lines == [">G91:ok", "ok"]


def test_homing_on_at_power_up_locks_until_h_and_the_beam_stays_off(tmp_path):
    p = tmp_path / "homed.toml"
    p.write_text("max_rate_mm_min = 500\naccel_mm_s2 = 10\ntravel_mm = 20\n"
                 "grbl_settings = { 22 = 1, 27 = 3, 25 = 200, 24 = 100, 32 = 1 }\n")
    vm = VirtualMachine(str(p), time_scale=0, tick_s=TICK_S, switches="X:+5,Y:+5,Z:+5")
    vm.timeout = 0
    assert talk(vm) == [BANNER, LOCK] and vm.state == "Alarm"      # GRBL's HOMING_INIT_LOCK
    assert talk(vm, b"M3 S1000\n") == ["error:9"]
    vm.write(b"$H\n")
    until(vm, "ok")
    assert vm.state == "Idle" and mpos(talk(vm, b"?")[0]) == (-3.0, -3.0, -3.0)
    assert all(level == 0 for _, level, state, _ in vm.beam_log if state == "Home")
    # a soft reset is no power-up: no lock
    assert talk(vm, b"\x18") == [BANNER] and vm.state == "Idle"


def test_homing_off_or_a_bad_command_is_refused():
    vm = machine()
    assert talk(vm, b"$HX\n") == ["error:3"]         # GRBL's default build: no single-axis $H
    assert talk(vm, b"$22=0\n") == ["ok"]
    assert talk(vm, b"$H\n") == ["error:5"]


@pytest.mark.parametrize("spec, why", [("X5", "AXIS:MM"), ("W:+5", "AXIS:MM"), ("X:far", "not a distance"),
                                       ("X:0", "needs a side")])
def test_a_bad_switch_spec_is_a_clear_error(spec, why):
    with pytest.raises(MachineError, match=why):
        VirtualMachine(generic(), time_scale=0, switches=spec)


def test_pn_names_every_pressed_input_and_5_inverts_them():
    vm = machine(switches="X:+5,Z:-2")
    assert vm.limit_pins == ""
    talk(vm, b"G0 X6 Z-2\n", 6.0)                    # past X's switch, onto Z's
    fields = talk(vm, b"?")[0].strip("<>").split("|")
    assert vm.limit_pins == "XZ" and fields[fields.index("FS:0,0") + 1] == "Pn:XZ"
    assert talk(vm, b"$5=1\n") == ["ok"]
    assert vm.limit_pins == "Y"                      # inverted: the unwired input reads pressed


def test_hard_limits_stop_at_the_switch_with_alarm_1_and_the_beam_off():
    vm = machine(switches="X:+5")
    assert talk(vm, b"$21=1\n$32=1\n") == ["ok", "ok"]
    lines = talk(vm, b"G1 X10 F300 M3 S1000\n", 4.0)     # 5 mm at 5 mm/s: the switch after ~1 s
    assert lines == ["ok", "ALARM:1", "[MSG:Reset to continue]"]
    assert vm.state == "Alarm" and vm.pos[0] == pytest.approx(5.0, abs=1e-9)
    assert vm.laser_output() == 0.0 and max(p.end[0] for p in vm.executed) == pytest.approx(5.0)
    # a reset with the switch still pressed: GRBL checks the inputs (hard_limits.json #5)
    assert talk(vm, b"\x18") == [BANNER, CHECK, LOCK]
    # moving on along the pressed switch is no edge; leaving it is one, a step off the switch
    # (hard_limits.json #10 and #13: ALARM:1, 4.996, no Pn:X)
    assert talk(vm, b"$X\nG0 X6\n", 2.0) == ["[MSG:Caution: Unlocked]", "ok", "ok"]
    assert talk(vm, b"G0 X4\n", 2.0) == ["ok", "ALARM:1", "[MSG:Reset to continue]"]
    assert vm.pos[0] == pytest.approx(4.996) and vm.limit_pins == ""
    assert talk(vm, b"\x18$X\n") == [BANNER, LOCK, "[MSG:Caution: Unlocked]", "ok"]
    # $21=0: the same switch is only a Pn: input
    assert talk(vm, b"$21=0\nG0 X10\n", 3.0) == ["ok", "ok"]
    assert vm.pos[0] == 10.0 and vm.limit_pins == "X"


def test_a_hard_limit_is_any_input_changing_while_one_reads_pressed():
    """GRBL's pin-change interrupt fires on any change of an input, pressed or released: X
    leaving its switch is ALARM:1 one step (1/250 mm) off it, Z's stuck switch reads on."""
    vm = machine(switches="X:+5,Z:stuck")
    assert talk(vm, b"G0 X6\n", 3.0) == ["ok"] and vm.limit_pins == "XZ"
    assert talk(vm, b"$21=1\n") == ["ok"]
    assert talk(vm, b"G0 X4\n", 3.0) == ["ok", "ALARM:1", "[MSG:Reset to continue]"]
    assert vm.pos[0] == pytest.approx(4.996) and vm.limit_pins == "Z"


def test_a_hold_braking_onto_a_switch_is_a_hard_limit():
    """At 5 mm/s and 10 mm/s² a hold needs 5²/(2·10) = 1.25 mm to stop: held 0.5 mm before
    X's switch, the head reaches it while braking."""
    vm = machine(switches="X:+5")
    assert talk(vm, b"$21=1\n") == ["ok"]
    vm.write(b"G1 X10 F300\n")
    answered = []
    while vm.pos[0] < 4.5:                           # 0.5 mm before the switch, at full speed
        answered += talk(vm, b"", TICK_S)
    assert answered == ["ok"] and vm.pos[0] < 4.6 and vm.state == "Run"
    assert talk(vm, b"!", 2.0) == ["ALARM:1", "[MSG:Reset to continue]"]
    assert vm.state == "Alarm" and vm.alarm_code == 1 and vm.pos[0] == pytest.approx(5.0)
