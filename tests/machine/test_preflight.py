"""The job checked against the controller before the first line is sent (issue 25 §6).

``run_job`` reads the status, ``$G`` and ``$#`` (``$$`` came with the connection) and refuses,
with the fix named, a job that would alarm or burn where it should not: power above ``$30``,
units or distance mode left to what the controller holds, a job outside the travel where
soft limits (or the machine description) say where the travel is, a controller in alarm.
Nothing may reach the machine then (the virtual machine executes nothing).
"""

import numpy as np
import pytest

from labkit.cli import main
from labkit.machine.stream import Job, preflight_check, run_job

from ._pty_controller import PtyController
from .test_stream import MACHINE, machine


def burn(text):
    return Job.from_text(text, machine=MACHINE)


def assert_refused(rep, vm, *words):
    assert rep.refused and not rep.ok and rep.lines_sent == 0, rep.summary()
    assert rep.fault.startswith("refused before anything was sent (pre-flight check")
    for w in words:
        assert w in rep.fault, (w, rep.fault)
    assert rep.summary().startswith("STOPPED before anything was sent: 0/")
    assert vm.executed == []


def test_power_above_s30_is_refused_with_the_setting_to_send():
    vm, g = machine()
    g.set_setting(30, 255)
    rep = run_job(g, burn("G21 G90\nM4 S100 F600\nG1 X10\nG1 X20 S1000\nM5\n"))
    assert_refused(rep, vm, "S1000 (line 4)", "$30 is 255", "GRBL clamps every higher S to full "
                   "power", "'$30=1000'", "scale the job's S to 0…255")
    g.close()


def test_a_job_far_below_s30_runs_with_a_note():
    vm, g = machine()
    rep = run_job(g, burn("G21 G90\nM4 S100 F600\nG1 X10\nM5\n"))
    assert rep.ok, rep.summary()
    assert any("highest power is S100, 10 % of $30=1000" in w for w in rep.warnings)
    g.close()


@pytest.mark.parametrize("mode, fix", [("G20", "add G21 at the top"), ("G91", "add G90 at the top")])
def test_units_and_distance_mode_left_to_the_controller_are_refused(mode, fix):
    vm, g = machine()
    g.command(mode)
    job = burn("M4 S500 F600\nG1 X10 Y5\nM5\n")        # says neither units nor distance mode
    rep = run_job(g, job)
    assert_refused(rep, vm, f"({mode})", "before its first move (line 2)", fix)
    # the same job saying both runs
    rep = run_job(g, burn("G21 G90\nM4 S500 F600\nG1 X10 Y5\nM5\n"))
    assert rep.ok, rep.summary()
    g.close()


def soft_limits_on(g):
    g.set_setting(22, 1)                # GRBL takes soft limits only with homing enabled
    g.set_setting(20, 1)


def negative_y_job():
    """A job below the origin in Y, as the README's sample (cncjs' jsdc-laser) lies; in GRBL's
    machine space (−$13x…0, the power-up position 0) its X10 is outside from the origin at 0."""
    return burn("G21 G90\nM4 S300 F1200\nG0 X10 Y-5\nG1 X40 Y-40\nG1 X10\nM5\nG0 X0 Y0\n")


def test_a_job_outside_the_soft_limits_is_refused_then_runs_from_a_moved_origin():
    vm, g = machine()
    soft_limits_on(g)
    job = negative_y_job()
    rep = run_job(g, job)
    assert_refused(rep, vm, "line 3 (G0X10Y-5) would take X to 10.000 mm", "outside the travel "
                   "-400…0 mm (GRBL's", "ALARM:2", "G10 L20 P0 X0 Y0")
    # the fix it names: the origin where the job fits (the head at -300, -300 in GRBL's space)
    g.command("G0 X-300 Y-300")
    g.wait_status(lambda s: s.state == "Idle", 10)
    g.command("G10 L20 P0 X0 Y0")
    rep = run_job(g, job)
    assert rep.ok, rep.summary()
    burned = [p for p in vm.executed if p.power > 0]
    assert burned and min(min(p.start[1], p.end[1]) for p in burned) == pytest.approx(-340.0)
    g.close()


def test_the_controllers_own_alarm_is_what_the_check_foresees():
    """Independent of the check: the virtual GRBL, given the same job with soft limits on and
    the check off, raises ALARM:2 — on the line the check names."""
    vm, g = machine()
    soft_limits_on(g)
    problems, _ = preflight_check(g, negative_y_job())
    assert problems and problems[0].startswith("line 3 ")
    start = len(g.transcript)
    rep = run_job(g, negative_y_job(), preflight=False)
    assert rep.fault.startswith("ALARM:2")
    replies = [text for _, d, text in g.transcript[start:] if d == "<"]
    assert replies.index("ALARM:2") == 2            # two lines answered: the third alarmed
    g.close()


@pytest.mark.parametrize("own", ["G92 X0 Y0", "G10 L2 P1 X5", "G53 G0 X1", "G43.1 Z1", "G28"])
def test_a_job_setting_its_own_offsets_before_it_ends_is_not_travel_checked(own):
    # the offsets read from $# no longer hold once the job sets or escapes them: a note,
    # never a refusal computed with the wrong offset
    vm, g = machine()
    soft_limits_on(g)
    problems, notes = preflight_check(g, burn(f"G21 G90\n{own}\nM4 S300 F1200\nG1 X10 Y-5\nM5\n"))
    assert problems == [] and any("sets its own offsets" in n for n in notes), notes
    g.close()


def test_a_program_end_after_the_last_move_keeps_the_travel_checked():
    # M2 and M30 reset the coordinate system (the trace's sets_offsets), but after the last
    # move: the job's extent is still where the controller's offsets put it
    vm, g = machine()
    soft_limits_on(g)
    for end in ("M2", "M30"):
        problems, _ = preflight_check(g, burn(f"G21 G90\nM4 S300 F1200\nG1 X10 Y-5\nM5\n{end}\n"))
        assert len(problems) == 1 and problems[0].startswith("line 3 "), problems
    g.close()


def test_the_coordinate_system_the_job_selects_is_the_one_checked():
    vm, g = machine()
    soft_limits_on(g)
    g.command("G10 L2 P2 X-50 Y-50")                  # G55's origin at -50, -50: X10 Y-5 inside
    job = "G21 G90 {}\nM4 S300 F1200\nG1 X10 Y-5\nM5\n"
    assert preflight_check(g, burn(job.format("G55")))[0] == []
    assert preflight_check(g, burn(job.format("G54")))[0][0].startswith("line 3 ")
    _, notes = preflight_check(g, burn(job.format("G55") + "G54\nG1 X1\n"))
    assert any("several coordinate systems (G54, G55)" in n for n in notes), notes
    g.close()


def test_a_job_larger_than_the_machine_is_refused():
    vm, g = machine()
    text = "G21 G90\nG0 X0 Y0\nM4 S300 F3000\nG1 X350\nG1 Y10\nM5\n"
    rep = run_job(g, burn(text), machine="cbr40-laser")
    assert_refused(rep, vm, "the job is 350.0 × 10.0 × 0.0 mm, larger than the travel of "
                   "cbr40-laser", "along X", "name the right machine (--machine)")
    rep = run_job(g, burn(text))                             # grbl-diode: 400 mm
    assert rep.ok, rep.summary()
    g.close()


def test_a_controller_in_alarm_is_refused():
    vm, g = machine()
    soft_limits_on(g)
    run_job(g, burn("G21 G90\nG0 X9999\n"), preflight=False)         # ALARM:2, then reset
    assert g.get_status().state == "Alarm"
    rep = run_job(g, burn("G21 G90\nM4 S300 F600\nG1 X5\nM5\n"))
    assert_refused(rep, vm, "in alarm", "unlock it with $X (or home it with $H)")
    g.close()


def test_check_first_still_runs_the_deeper_check():
    vm, g = machine()
    rep = run_job(g, burn("G21 G90\nM4 S300 F600\nG1 X5\nM5\n"), check_first=True)
    assert rep.ok, rep.summary()
    g.close()


def test_labkit_stream_prints_the_refusal(tmp_path, capsys):
    controller = PtyController()
    controller.vm.settings[30] = "255"
    p = tmp_path / "job.gcode"
    p.write_text("G21 G90\nM4 S800 F600\nG1 X10\nM5\n")
    try:
        assert main(["stream", str(p), "--port", controller.port]) == 1
    finally:
        controller.close()
    out = capsys.readouterr().out
    assert out.startswith("STOPPED before anything was sent: 0/4 lines acknowledged")
    assert "S800 (line 3)" in out and "'$30=800'" in out
    assert controller.lines == 0


def test_labkit_stream_no_preflight_sends_the_job(tmp_path, capsys):
    controller = PtyController()
    controller.vm.settings[30] = "255"
    p = tmp_path / "job.gcode"
    p.write_text("G21 G90\nM4 S800 F600\nG1 X10\nM5\n")
    try:
        assert main(["stream", str(p), "--port", controller.port, "--no-preflight"]) == 0
    finally:
        controller.close()
    assert capsys.readouterr().out.startswith("completed: 4/4 lines acknowledged")
    assert controller.lines == 5                  # the job's four, and the M5 S0 that ends a job


def test_travel_of_a_real_grbl_is_negative_unless_its_position_says_otherwise():
    """A controller that is not the virtual machine: GRBL's soft limits span −$130…0 per
    axis (machine zero at the homed corner), or 0…$130 where the position is positive."""
    controller = PtyController()
    controller.vm.settings.update({22: "1", 20: "1"})
    from .test_stream_end import connect

    g = connect(controller)
    try:
        job = burn("G21 G90\nM4 S300 F1200\nG1 X10 Y10\nM5\n")
        problems, _ = preflight_check(g, job)
        assert len(problems) == 1 and "outside the travel -400…0 mm (GRBL's" in problems[0]
        job = burn("G21 G90\nM4 S300 F1200\nG1 X-10 Y-10\nM5\n")
        assert preflight_check(g, job)[0] == []
        # a positive position, as a build homing to 0 (HOMING_FORCE_SET_ORIGIN) has: 0…$130.
        # The virtual GRBL's soft limits are GRBL's −$130…0, so they are off for the move there
        g.set_setting(20, 0)
        g.command("G0 X5 Y5")
        g.wait_status(lambda s: s.state == "Idle", 10)
        g.set_setting(20, 1)
        assert preflight_check(g, burn("G21 G90\nM4 S300 F1200\nG1 X10 Y10\nM5\n"))[0] == []
    finally:
        g.close()
        controller.close()
    assert np.all(controller.vm.pos >= 0)
