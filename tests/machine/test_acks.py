"""Every acknowledgement accounted for (issue 25 §3).

A GRBL behaviour model behind a pty answers with faults: answers no line asked for,
a doubled ``ok``, no answers at all, absurd status reports. An ``ok`` that is not owed must
never acknowledge a line that was not sent or move the blame for an error; a controller that
does not answer is never "N/N acknowledged". Each case ends with a protocol error that names
the lines in doubt, and with the machine stopped (hold, reset, M5 S0).
"""

import pytest

from labkit.cli import main
from labkit.errors import MachineError
from labkit.machine.stream import Job, run_job

from ._pty_controller import PtyController, bad_buffer, nan_position
from .test_stream_end import assert_stopped_after, connect, fake  # noqa: F401  (fixture)


def numbered_job(n=20, bad=None, feed=3000):
    """``n`` short burning moves after a two-line preamble (source line k+2 is move k)."""
    lines = ["G21 G90", f"M4 S300 F{feed}"]
    lines += [f"G1 X{1 + k % 2} Y{0.2 * k:.1f}" for k in range(n)]
    return "\n".join(lines + ["M5"]) + "\n"


def test_thirty_oks_after_the_banner_are_refused_before_anything_is_sent(fake, tmp_path, capsys):
    controller = fake(oks_after_banner=30)
    p = tmp_path / "job.gcode"
    p.write_text(numbered_job())
    assert main(["stream", str(p), "--port", controller.port]) == 1
    captured = capsys.readouterr()
    assert "completed" not in captured.out
    assert "protocol error" in captured.err and "30 answer(s) ('ok')" in captured.err
    assert "nothing was sent" in captured.err
    assert controller.lines == 0                  # not one line of the job went out


def test_unsolicited_oks_mid_job_stop_it_and_name_the_lines_in_doubt(fake):
    controller = fake(oks_at_first_line=30)
    g = connect(controller)
    job = Job.from_text(numbered_job(), machine="grbl-diode")
    rep = run_job(g, job)
    g.close()
    assert not rep.ok and not rep.summary().startswith("completed")
    assert rep.fault.startswith("protocol error:")
    assert "answers no longer match lines" in rep.fault
    first = job.send[0][0]
    assert f"lines {first}…" in rep.fault          # every answer since the first line is in doubt
    assert rep.resume_line == first
    assert_stopped_after(controller, 0.0)


@pytest.mark.parametrize("mode", ["counting", "send-response"])
def test_a_doubled_ok_before_an_error_never_moves_the_blame(fake, mode):
    """The 5th 'ok' comes twice; the 9th move is garbled (error:20). Counting answers blindly
    blames the 10th. The error must be on the right line, or the range that holds it named.
    In counting mode a full planner (or a line that waits for it to empty) lets the controller
    hold the last line it read unanswered, which hides the doubled 'ok' exactly: then both
    candidates are named."""
    controller = fake(double_ok=5, garble_line=11)           # line 11 sent = the 9th move
    g = connect(controller)
    job = Job.from_text(numbered_job(), machine="grbl-diode")
    bad_line = job.send[10][0]
    rep = run_job(g, job, mode=mode)
    g.close()
    assert not rep.ok
    assert rep.errors, rep.summary()
    blamed, code, message = rep.errors[0]
    assert code == 20
    if "one of lines" in message:
        first, last = (int(v) for v in message.split("one of lines ")[1].split(" ")[0].split("…"))
        assert first <= bad_line <= last
        # either the surplus was seen (a protocol fault), or the controller may have been
        # holding a line unanswered and both candidates are named (issue 25 §3)
        assert rep.fault.startswith(("protocol error:", f"line {first} or {last} rejected"))
        assert rep.resume_line == first
    else:
        assert blamed == bad_line
    assert_stopped_after(controller, 0.0)


def test_a_controller_that_never_answers_is_not_acknowledged(fake):
    """Status reports keep coming (with the buffer state), answers never do: the lines the
    controller takes without answering are a protocol fault, not 'lost answers' to count as
    acknowledged."""
    controller = fake(mute_answers_after=1)
    g = connect(controller)
    job = Job.from_text(numbered_job(), machine="grbl-diode")
    rep = run_job(g, job, stall_s=1.0)
    g.close()
    summary = rep.summary()
    assert not rep.ok and not summary.startswith("completed")
    assert rep.lines_acknowledged < len(job.send)
    assert f"{len(job.send)}/{len(job.source_lines)} lines acknowledged" not in summary
    assert "without answering" in rep.fault, rep.fault
    assert_stopped_after(controller, 0.0)


def test_a_controller_that_goes_silent_trips_the_watchdog(fake):
    controller = fake(silent_after_lines=3)
    g = connect(controller)
    job = Job.from_text(numbered_job(), machine="grbl-diode")
    rep = run_job(g, job, watchdog_s=0.5)
    g.close()
    assert not rep.ok and rep.fault.startswith("watchdog: no status report")
    assert rep.lines_acknowledged <= 3
    # it was told to stop, and nothing confirmed it: the report says so step by step
    assert "feed hold" in rep.safe_actions
    assert any(a.startswith("soft reset sent, not confirmed") for a in rep.safe_actions)
    assert any(a.startswith("M5 S0 sent, not confirmed") for a in rep.safe_actions)
    assert_stopped_after(controller, 0.0)


@pytest.mark.parametrize("rewrite, field", [(bad_buffer, "Bf planner blocks -5"),
                                            (nan_position, "non-finite MPos")])
def test_absurd_status_reports_are_ignored_for_accounting(fake, rewrite, field):
    controller = fake(status_rewrite=rewrite)
    g = connect(controller)
    job = Job.from_text(numbered_job(6), machine="grbl-diode")
    rep = run_job(g, job)
    g.close()
    # the reports still show the controller alive (no watchdog), their numbers are not used
    assert rep.fault is None and rep.ok, rep.summary()
    assert rep.lines_acknowledged == len(job.send)
    warned = [w for w in rep.warnings if "ignored for accounting" in w]
    assert len(warned) == 1 and field in warned[0], rep.warnings
    assert controller.vm.laser_output() == 0


def test_absurd_fields_do_not_reach_the_status(fake):
    controller = fake(status_rewrite=bad_buffer)
    g = connect(controller)
    st = g.get_status()
    g.close()
    assert st.state == "Idle" and st.planner_free is None and st.rx_free is None
    assert st.mpos is None                       # nothing from an absurd report is used


def test_a_job_is_not_started_while_stray_answers_wait(fake):
    """Answers that arrive between connecting and the job (nothing asked for them)."""
    controller = fake()
    g = connect(controller)
    controller.faulty.inject(b"ok\r\nok\r\n")    # the controller says 'ok' twice, unasked
    job = Job.from_text(numbered_job(), machine="grbl-diode")
    rep = run_job(g, job)
    g.close()
    assert rep.refused and rep.fault.startswith("protocol error: 2 answer(s)")
    assert controller.lines == 0


def test_stray_answers_after_the_banner_fail_connect(fake):
    controller = fake(oks_after_banner=3)
    with pytest.raises(MachineError, match=r"protocol error: .* sent 3 answer\(s\) \('ok'\) after "
                                           r"its start-up banner"):
        connect(controller)
