"""The virtual machine starts with GRBL 1.1's default settings unless its machine file says
otherwise (issue 25 §6), and obeys the ones that change behaviour ($10, $20, $22, $32)."""

import pytest

from labkit.cli import main
from labkit.errors import MachineError, MotionError
from labkit.machine.virtual import VirtualMachine
from labkit.motion import load_machine

# GRBL 1.1's defaults as its documentation lists them (the v1.1 wiki "Configuration" page;
# gnea/grbl grbl/defaults.h, DEFAULTS_GENERIC), written out by hand: the settings a machine
# description does not give through its mechanics.
GRBL_11_DEFAULTS = {
    0: "10", 1: "25", 2: "0", 3: "0", 4: "0", 5: "0", 6: "0", 10: "1", 13: "0",
    20: "0", 21: "0", 22: "0", 23: "0", 24: "25.000", 25: "500.000", 26: "250", 27: "1.000",
    30: "1000", 31: "0", 32: "0",
}


def settings_of(vm):
    vm.write(b"$$\n")
    text = b"".join(vm.read(4096) for _ in range(5)).decode()
    return dict((int(k[1:]), v) for k, v in (line.split("=", 1) for line in text.split()
                                             if line.startswith("$")))


def test_grbl_defaults_unless_the_machine_file_says_otherwise(tmp_path):
    bare = tmp_path / "bare.toml"        # a machine with mechanics only
    bare.write_text("steps_per_mm = 100\nmax_rate_mm_min = 3000\naccel_mm_s2 = 200\n"
                    "travel_mm = [300, 200, 40]\n")
    got = settings_of(VirtualMachine(str(bare), time_scale=0, banner=False))
    assert {k: got[k] for k in GRBL_11_DEFAULTS} == GRBL_11_DEFAULTS
    # the mechanics come from the file, printed as GRBL prints them
    assert (got[100], got[110], got[120], got[130], got[132]) == \
        ("100.000", "3000.000", "200.000", "300.000", "40.000")
    assert (got[11], got[12]) == ("0.010", "0.002")
    # grbl-diode says laser mode and status reports with the buffer state; the rest is GRBL's
    diode = settings_of(VirtualMachine("grbl-diode", time_scale=0, banner=False))
    differ = {k for k in GRBL_11_DEFAULTS if diode[k] != GRBL_11_DEFAULTS[k]}
    assert differ == {10, 32} and (diode[10], diode[32]) == ("3", "1")
    assert dict(load_machine("grbl-diode").grbl_settings) == {10: 3, 32: 1}


def test_machine_file_grbl_settings_are_checked(tmp_path):
    def machine(line):
        p = tmp_path / "m.toml"
        p.write_text("travel_mm = 100\n" + line + "\n")
        return str(p)

    with pytest.raises(MotionError, match=r"\$130, which the description's travel_mm already says"):
        load_machine(machine("grbl_settings = { 130 = 5 }"))
    with pytest.raises(MotionError, match="must be a finite number"):
        load_machine(machine('grbl_settings = { 32 = "on" }'))
    with pytest.raises(MachineError, match=r"\$99 is not a GRBL 1.1 setting"):
        VirtualMachine(machine("grbl_settings = { 99 = 1 }"), time_scale=0)
    with pytest.raises(MachineError, match=r"\$20=1 \(soft limits\) needs \$22=1"):
        VirtualMachine(machine("grbl_settings = { 20 = 1 }"), time_scale=0)


def reply(vm, data, polls=5):
    vm.write(data)
    return b"".join(vm.read(4096) for _ in range(polls)).decode()


def test_homing_enabled_starts_locked_and_soft_limits_follow_20(tmp_path):
    p = tmp_path / "homed.toml"
    p.write_text("travel_mm = 100\ngrbl_settings = { 22 = 1, 20 = 1, 10 = 3 }\n")
    vm = VirtualMachine(str(p), time_scale=0, tick_s=0.05)
    banner = vm.read(4096).decode()
    assert "[MSG:'$H'|'$X' to unlock]" in banner and vm.state == "Alarm"   # HOMING_INIT_LOCK
    assert "error:9" in reply(vm, b"G0 X1\n")
    reply(vm, b"$X\n")
    assert "ALARM:2" in reply(vm, b"G0 X150\n")                          # beyond the travel
    # GRBL's defaults: no soft limits, so the same move runs; $20=1 needs homing ($22=1)
    vm = VirtualMachine("grbl-diode", time_scale=0, tick_s=0.05, banner=False)
    assert "ok" in reply(vm, b"G0 X-5 Y-5\n") and "ALARM" not in reply(vm, b"?")
    assert "error:10" in reply(vm, b"$20=1\n")
    assert reply(vm, b"$22=1\n").split() == ["ok"] and reply(vm, b"$20=1\n").split() == ["ok"]
    assert reply(vm, b"$22=0\n").split() == ["ok"] and settings_of(vm)[20] == "0"
    assert "error:4" in reply(vm, b"$30=-1\n")
    reply(vm, b"$32=0.0\n")
    assert settings_of(vm)[32] == "0"


@pytest.mark.parametrize("mask, fields", [("0", ["WPos:"]), ("1", ["MPos:"]), ("2", ["WPos:", "Bf:"]),
                                          ("3", ["MPos:", "Bf:"])])
def test_status_report_follows_10(mask, fields):
    vm = VirtualMachine("grbl-diode", time_scale=0, banner=False)
    reply(vm, b"G10 L2 P1 X5\n$10=" + mask.encode() + b"\n")
    status = reply(vm, b"?").strip()
    names = [f.split(":")[0] + ":" for f in status.strip("<>").split("|")[1:]]
    assert [n for n in names if n in ("MPos:", "WPos:", "Bf:")] == fields
    if "WPos:" in fields:
        assert "WPos:-5.000,0.000,0.000" in status          # MPos 0 minus the G54 origin X5


def test_door_stops_and_the_beam_goes_off():
    vm = VirtualMachine("grbl-diode", time_scale=0, tick_s=0.02, banner=False)
    vm.timeout = 0          # one tick per read: an empty read would tick for 50 ms of wall time
    reply(vm, b"G21 G91 G1 X20 F600 S500 M4\n")
    assert vm.laser_output() == 0.5
    vm.write(b"\x84")
    assert vm.state == "Door" and vm.substate == 2             # decelerating
    for _ in range(50):
        vm.read(4096)
    assert (vm.state, vm.substate, vm.laser_output()) == ("Door", 0, 0.0)
    assert reply(vm, b"?").startswith("<Door:0|")
    vm.write(b"~")
    assert vm.state == "Run"
    assert [round(lv, 3) for _, lv, _, _ in vm.beam_log] == [0.5, 0.0, 0.5]


def test_the_readme_sample_streams_to_completion_on_the_default_machine(capsys, tmp_path):
    """`labkit stream data/gcode/cncjs/jsdc-laser.gcode` (the job lies at negative Y: with GRBL's
    $20=0 it runs, as on a stock GRBL; it stopped at line 17 with ALARM:2 before). Its provenance
    record goes to tmp_path, not beside the repository's data file."""
    assert main(["stream", "data/gcode/cncjs/jsdc-laser.gcode", "--record", str(tmp_path / "r.json")]) == 0
    out = capsys.readouterr().out
    assert out.startswith("completed: 2384/2418 lines acknowledged"), out
    assert "ALARM" not in out and "STOPPED" not in out
