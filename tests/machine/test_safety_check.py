"""labkit safety-check (issue 25 §7): it passes on the virtual machine and on the firmware's host
simulator, and every scenario fails on a controller that gets that case wrong."""

import json
import subprocess
from pathlib import Path

import pytest

from labkit.cli import main
from labkit.errors import InputError
from labkit.machine.safety import SCENARIOS, run_safety_check
from labkit.machine.virtual import VirtualMachine

FW = Path(__file__).resolve().parents[2] / "firmware"


@pytest.fixture(scope="module")
def sim():
    # the firmware tests' own way to get the simulator (tests/firmware/test_firmware.py)
    run = subprocess.run(["make", "-C", str(FW), "sim"], capture_output=True, text=True)
    assert run.returncode == 0, f"make -C firmware sim failed:\n{run.stdout}\n{run.stderr}"
    return FW / "build/host/labkit-fw-sim"


def _verdicts(report):
    return {r.key: r.verdict for r in report.results}


def test_every_scenario_passes_on_the_virtual_machine():
    report = run_safety_check()
    assert _verdicts(report) == {k: "PASS" for k in SCENARIOS}, report.format()
    assert report.ok and report.beam_observed and report.s_word == 10   # 1 % of $30 = 1000
    # the evidence names what was sent, what came back and what the beam did
    hold = report.results[0]
    assert "!" in hold.sent and any(r.startswith("<Hold:0") for r in hold.reported)
    assert any("FS:300,10" in r for r in hold.reported)      # the control: it burned first
    assert hold.beam.startswith("now 0.000 of full")
    g0 = next(r for r in report.results if r.key == "g0_laser_mode")
    assert "with $32=0 the same rapid burned" in g0.reason    # GRBL's spindle mode, for contrast
    record = json.loads(report.to_json())
    assert record["ok"] is True and len(record["results"]) == len(SCENARIOS)


def test_every_scenario_passes_on_the_firmware_simulator(sim):
    report = run_safety_check(sim=sim)
    verdicts = _verdicts(report)
    assert report.beam_observed and report.ok, report.format()
    # the firmware takes 0x84 as a feed hold (no door state): judged all the same
    assert all(v == "PASS" for v in verdicts.values()), report.format()
    door = next(r for r in report.results if r.key == "door")
    assert "takes 0x84 as a feed hold" in door.reason
    assert "duty now 0" in report.results[0].beam


def test_command_line_on_the_simulator(sim, capsys):
    assert main(["safety-check", "--sim", str(sim), "--only", "m5", "--json"]) == 0
    record = json.loads(capsys.readouterr().out)
    assert record["target"] == f"sim:{sim}" and record["beam_observed"] is True
    (m5,) = record["results"]
    assert m5["verdict"] == "PASS" and m5["sent"][-1] == "M5" and "duty now 0" in m5["beam"]


class _Unsafe(VirtualMachine):
    """A virtual machine that gets one case wrong (each fault keeps the beam on where it must
    be off, as a faulty controller or a misconfigured one would)."""

    def __init__(self, fault, **kw):
        self.fault = fault
        self.stuck = False
        super().__init__(time_scale=5.0, **kw)

    def _realtime(self, kind):
        super()._realtime(kind)
        if (self.fault, kind) in (("soft_reset", "reset"), ("resume", "start")):
            self.stuck = True

    def _emit(self, text):
        super()._emit(text)
        if self.fault == "error_line" and text.startswith("error:"):
            self.stuck = True

    def _laser_output(self):
        level = super()._laser_output()
        fault, state = self.fault, self.state
        if level > 0 and self.laser_mode_word == 3:
            self.m3_burned = True
        on = {
            "feed_hold": state == "Hold" and bool(self._blocks),
            "resume": self.stuck and state == "Idle",
            "soft_reset": self.stuck,
            "door": state == "Door",
            "alarm": state == "Alarm",
            "error_line": self.stuck,
            "program_end_m2": getattr(self, "m3_burned", False),   # M2 leaves the beam on
            "program_end_m30": getattr(self, "m3_burned", False),
            "m5": getattr(self, "m3_burned", False),
            "g0_laser_mode": bool(self._blocks) and self._blocks[0].rapid and self.laser_mode_word == 3,
            "disconnect": state == "Idle" and self.laser_mode_word == 4,
        }[fault]
        return max(level, 0.01) if on else level


@pytest.mark.parametrize("fault", list(SCENARIOS))
def test_each_scenario_fails_on_a_controller_that_gets_it_wrong(fault):
    report = run_safety_check(virtual=_Unsafe(fault), scenarios=[fault])
    (result,) = report.results
    assert result.verdict == "FAIL", result.line()
    assert not report.ok
    assert "on" in result.reason or "burn" in result.reason


def test_cutting_with_m3_fails_where_grbl_keeps_the_beam_on():
    """GRBL 1.1's M3 (constant power) leaves the PWM on when its queue runs out — at the end of
    the resumed cut and when the link is lost (stepper.c switches it off at the end of motion
    only for M4) — while a feed hold de-energizes it once stopped, M3 too (protocol.c's
    DISABLE_LASER_DURING_HOLD, on in GRBL's default config.h); the virtual machine models both."""
    report = run_safety_check(cut_mode="M3", scenarios=["feed_hold", "resume", "soft_reset",
                                                        "disconnect"])
    assert _verdicts(report) == {"feed_hold": "PASS", "resume": "FAIL", "soft_reset": "PASS",
                                 "disconnect": "FAIL"}, report.format()
    resume = report.results[1]
    assert "on" in resume.reason, resume.line()
    assert "S10 M3" in report.results[0].sent[0] and not report.ok


def test_a_real_port_is_judged_from_the_reports_alone():
    """Over a serial port (here a pty with GRBL's model behind it, as tests/machine/_pty_controller
    builds it) the beam cannot be watched: the status reports decide, and they suffice to fail a
    controller whose report says the laser is on in a hold."""
    from tests.machine._pty_controller import PtyController

    class KeepsBeamInHold(VirtualMachine):
        def _laser_output(self):
            if self.state == "Hold" and self._blocks:
                return self._blocks[0].power
            return super()._laser_output()

    for vm, want in ((VirtualMachine("grbl-diode", time_scale=5.0), "PASS"),
                     (KeepsBeamInHold("grbl-diode", time_scale=5.0), "FAIL")):
        ctl = PtyController(vm)
        try:
            report = run_safety_check(ctl.port, scenarios=["feed_hold", "disconnect"])
        finally:
            ctl.close()
        assert not report.beam_observed and report.target == ctl.port
        assert report.results[0].verdict == want, report.format()
        assert report.results[0].beam.startswith("not observed (a real machine")
        if want == "FAIL":
            assert "FS laser value 10" in report.results[0].reason
        # the port is opened again without a reset: the controller's own state after its buffer
        disconnect = report.results[1]
        assert disconnect.verdict == "PASS", disconnect.line()
        assert "ran out its buffer and reports Idle" in disconnect.reason


def test_no_beam_means_nothing_was_checked():
    """A controller whose beam never comes on cannot pass: the check needs its control."""

    class Dark(VirtualMachine):
        def _laser_output(self):
            return 0.0

    report = run_safety_check(virtual=Dark(time_scale=5.0), scenarios=["feed_hold"])
    assert report.results[0].verdict == "FAIL"
    assert "never came on" in report.results[0].reason


def test_a_controller_that_stops_answering_is_stopped_safely(monkeypatch):
    """A scenario that cannot go on (here: the judging step raises as a lost answer would)
    stops the machine — hold, reset, M5 S0 — before the error is reported."""
    from labkit.errors import MachineError
    from labkit.machine import safety

    def no_answer(self, st, what, **kw):
        raise MachineError("no answer to '?' within 5 s")

    monkeypatch.setattr(safety._Run, "judge", no_answer)
    vm = VirtualMachine(time_scale=5.0)
    with pytest.raises(MachineError, match=r"stopped in 'feed_hold': no answer .*soft reset"):
        run_safety_check(virtual=vm, scenarios=["feed_hold"])
    assert vm.laser_output() == 0 and not vm._blocks and vm.laser_mode_word == 0     # M5 S0
    assert vm.beam_log[-1][1] == 0.0


def test_bad_arguments_are_named():
    with pytest.raises(InputError, match="scenarios: unknown"):
        run_safety_check(scenarios=["hold"])
    with pytest.raises(InputError, match=r"s_word: expected 0 < S ≤ \$30 = 1000"):
        run_safety_check(s_word=5000, scenarios=["m5"])
    with pytest.raises(InputError, match="cut_mode"):
        run_safety_check(cut_mode="M7", scenarios=["m5"])


def test_command_line(capsys):
    assert main(["safety-check", "--only", "feed_hold", "--only", "m5", "--power", "20"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("PASS           feed hold during a cut:") and "S20 M4" in out[0]
    assert out[-1] == "all applicable scenarios passed: 2 passed, 0 failed, 0 not applicable"
    assert main(["safety-check", "--only", "door", "--json"]) == 0
    record = json.loads(capsys.readouterr().out)
    assert record["results"][0]["verdict"] == "PASS" and record["target"] == "virtual://"


def test_a_real_port_needs_confirmation(capsys, monkeypatch):
    import io

    monkeypatch.setattr("sys.stdin", io.StringIO("yes\n"))        # not a terminal: never asked
    assert main(["safety-check", "--port", "/dev/ttyLABKIT_NONE"]) == 1
    err = capsys.readouterr().err
    assert "laser goggles" in err and "nothing was sent" in err
    # with --yes it goes on and says why the port cannot be used
    assert main(["safety-check", "--port", "/dev/ttyLABKIT_NONE", "--yes"]) == 1
    assert "does not exist" in capsys.readouterr().err
