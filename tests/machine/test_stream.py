"""The job runner against the virtual machine and the faulty-link double.

The central property (issue 13 §7): after any fault and a resume from the
reported line and stop point, every burn of the job was executed exactly once
(no gap, no double burn, nothing burned off the job's paths), and the beam was
off whenever motion stopped.
"""

import threading
import time

import numpy as np
import pytest

from labkit.errors import GcodeError, InputError, MachineError
from labkit.machine import Grbl, Job, run_job
from labkit.machine.link import Link
from labkit.machine.stream import Controls, frame_text, resume_text
from labkit.machine.virtual import VirtualMachine

from labkit.machine.faults import FaultyPort
from labkit.machine.virtual import burn_coverage

MACHINE = "grbl-diode"


def raster_text(rows=12, seed=0):
    """A small raster engraving: per row a rapid, then 3 burns at varying power (M4)."""
    rng = np.random.default_rng(seed)
    lines = ["G21 G90", "M4 S0 F2400"]
    for r in range(rows):
        y = 5 + 0.5 * r
        xs = np.sort(rng.uniform(5, 60, 4)).round(3)
        lines.append(f"G0 X{xs[0]} Y{y}")
        for a, b in zip(xs[:-1], xs[1:]):
            lines.append(f"G1 X{b} S{int(rng.integers(100, 1000))}")
    lines += ["M5 S0", "G0 X0 Y0"]
    return "\n".join(lines) + "\n"


def job_segments(job):
    m = job.moves
    on = np.flatnonzero(m.laser_on)
    return [(m.start[i, :2], m.end[i, :2]) for i in on]


def machine(port_wrapper=None, **vm_opts):
    vm_opts.setdefault("time_scale", 0)
    vm_opts.setdefault("tick_s", 0.05)
    vm = VirtualMachine(MACHINE, **vm_opts)
    port = port_wrapper(vm) if port_wrapper else vm
    g = Grbl(Link(port, "test"))
    g.connect()
    return vm, g


# GRBL reports positions to 0.001 mm, so a resume from a reported stop point may leave a gap
# or overlap of up to half of that per axis (a GRBL machine steps 0.0125 mm at 80 steps/mm).
POSITION_TOL_MM = 1e-3


def assert_exactly_once(job, vm, origin_mm=(0.0, 0.0)):
    covered, doubled, stray, lengths = burn_coverage(job.moves, vm, tol_mm=POSITION_TOL_MM, origin_mm=origin_mm)
    assert len(lengths) == len(job_segments(job)) > 0
    np.testing.assert_allclose(covered, lengths, atol=POSITION_TOL_MM)
    assert doubled.max() < POSITION_TOL_MM, "a stretch was burned twice"
    assert stray < POSITION_TOL_MM, "the beam was on off the job's paths"
    assert vm.unsafe_stops == [], "the beam was on while the machine stood still"


def test_counting_completes_and_fills_the_buffer():
    job = Job.from_text(raster_text(), machine=MACHINE)
    vm, g = machine()
    rep = run_job(g, job)
    assert rep.ok, rep.summary()
    assert rep.lines_acknowledged == len(job.send) and rep.last_executed_line == \
        job.send[-1][0]
    assert 100 <= rep.max_rx_used <= 127 and vm.overflows == 0
    assert_exactly_once(job, vm)
    g.close()


def test_send_response_keeps_one_line_in_flight():
    job = Job.from_text(raster_text(rows=3), machine=MACHINE)
    vm, g = machine()
    rep = run_job(g, job, mode="send-response")
    assert rep.ok and rep.max_rx_used == max(len(s) + 1 for _, s in job.send)
    assert_exactly_once(job, vm)
    g.close()


def test_counting_is_faster_than_send_response_in_real_time():
    # a slow link answer (10 ms per reply, 0.2 s of machine time at time_scale 20) makes
    # send-response starve the planner; counting keeps the buffer full (a clear margin even
    # on a loaded machine: at 3 ms the two came within 0.5 % under a parallel test run)
    text = raster_text(rows=6)
    times = {}
    for mode in ("counting", "send-response"):
        job = Job.from_text(text, machine=MACHINE)
        vm, g = machine(lambda v: FaultyPort(v, delay_s=0.01), time_scale=20)
        rep = run_job(g, job, mode=mode)
        assert rep.ok
        times[mode] = vm.sim_time_s
        g.close()
    assert times["counting"] < 0.8 * times["send-response"]


@pytest.mark.parametrize("mode", ["counting", "send-response"])
def test_error_is_attributed_to_its_source_line_and_resume_runs_each_line_once(mode):
    job = Job.from_text(raster_text(), machine=MACHINE)
    k = 20                                                   # the 20th line sent is garbled
    bad_source_line = job.send[k - 1][0]
    vm, g = machine(lambda v: FaultyPort(v, garble_line=k))
    rep = run_job(g, job, mode=mode)
    assert not rep.ok and rep.errors[0][:2] == (bad_source_line, 20)
    assert "rejected: error:20" in rep.fault
    assert "soft reset (buffers flushed, laser off)" in rep.safe_actions
    assert rep.last_acknowledged_line >= bad_source_line
    # acknowledged is not executed: with counting, lines after it were still buffered
    assert rep.last_executed_line <= bad_source_line
    assert rep.resume_line is not None and rep.resume_line <= bad_source_line
    # the machine: fault found it mid-job; resume on the same (now healthy) link
    g.link.port.garble_line = None
    pos = rep.stop_position
    line = rep.resume_line
    rows = np.flatnonzero(job.moves.line == line)
    at_start = len(rows) == 0 or np.allclose(job.moves.start[rows[-1]], pos)
    rep2 = run_job(g, job, mode=mode, resume_from=line, resume_position=None if at_start else pos)
    assert rep2.ok, rep2.summary()
    assert_exactly_once(job, vm)
    g.close()


def test_skip_policy_reports_and_goes_on():
    job = Job.from_text(raster_text(rows=4), machine=MACHINE)
    vm, g = machine(lambda v: FaultyPort(v, garble_line=6))
    rep = run_job(g, job, on_error="skip")
    assert rep.fault is None and not rep.ok
    assert [e[0] for e in rep.errors] == [job.send[5][0]]
    assert rep.lines_acknowledged == len(job.send)
    g.close()


def _resume_after(job, g, vm, rep):
    assert rep.resume_line is not None, rep.summary()
    rows = np.flatnonzero(job.moves.line == rep.resume_line)
    pos = rep.stop_position
    at_start = len(rows) == 0 or pos is None or np.allclose(job.moves.start[rows[-1]], pos)
    rep2 = run_job(g, job, resume_from=rep.resume_line, resume_position=None if at_start else pos)
    assert rep2.ok, rep2.summary()
    assert_exactly_once(job, vm)


def test_dropped_newline_stops_and_resumes_exactly_once():
    job = Job.from_text(raster_text(), machine=MACHINE)
    vm, g = machine(lambda v: FaultyPort(v, drop_newline_of=15))
    rep = run_job(g, job)
    assert not rep.ok and rep.errors and rep.errors[0][0] == job.send[14][0]
    g.link.port.drop_newline_of = None
    _resume_after(job, g, vm, rep)
    g.close()


def test_pause_resume_and_cancel_keep_the_beam_off_when_stopped():
    job = Job.from_text(raster_text(rows=20), machine=MACHINE)
    vm, g = machine(time_scale=5)
    controls = Controls()
    states = []

    def operator():
        time.sleep(0.4)
        controls.pause()
        time.sleep(0.4)
        states.append(g.status.state)
        controls.resume()
        time.sleep(0.3)
        controls.cancel()

    t = threading.Thread(target=operator)
    t.start()
    rep = run_job(g, job, controls=controls)
    t.join()
    assert states == ["Hold"]
    assert rep.fault == "cancelled by the user" and "M5 S0" in rep.safe_actions
    assert vm.laser_output() == 0 and vm.unsafe_stops == []
    _resume_after(job, g, vm, rep)
    g.close()


def test_alarm_stops_and_names_the_line():
    text = raster_text(rows=3).replace("G0 X0 Y0", "G0 X9999 Y0")
    job = Job.from_text(text, machine=MACHINE)
    vm, g = machine()
    g.set_setting(22, 1)            # GRBL ships soft limits off; they need homing enabled
    g.set_setting(20, 1)
    g.command("G10 L2 P1 X-300 Y-300")   # GRBL's travel is −$13x…0: the raster's origin inside it
    # the pre-flight check would refuse this job (test_preflight.py): here the controller's own
    # alarm mid-job is what is tested
    rep = run_job(g, job, preflight=False)
    assert not rep.ok and rep.fault.startswith("ALARM:2: soft limit")
    assert rep.last_acknowledged_line == len(job.source_lines) - 1
    g.close()


def test_disconnect_mid_job():
    job = Job.from_text(raster_text(), machine=MACHINE)
    vm, g = machine(lambda v: FaultyPort(v, disconnect_after_lines=25))
    rep = run_job(g, job)
    assert not rep.ok and rep.fault.startswith("link lost")
    assert any("link lost" in a for a in rep.safe_actions)
    g.close()


def test_reset_mid_job_stops_and_leaves_the_resume_line_to_the_user():
    job = Job.from_text(raster_text(), machine=MACHINE)
    vm, g = machine(lambda v: FaultyPort(v, reset_after_lines=10))
    rep = run_job(g, job)
    # GRBL: a reset while moving loses the position (ALARM:3) and flushes every buffer
    assert not rep.ok and rep.fault.startswith("ALARM:3: reset while in motion")
    assert rep.resume_line is None and any("by hand" in w for w in rep.warnings)
    assert vm.laser_output() == 0 and vm.unsafe_stops == []
    g.close()


def test_lost_ok_is_resynchronised_from_the_buffer_report():
    """A lost 'ok' no longer leaves character counting one line behind: the controller's RX
    fill in the next status report shows a consumed line without an answer, and the job goes on."""
    job = Job.from_text(raster_text(), machine=MACHINE)
    vm, g = machine(lambda v: FaultyPort(v, drop_ok=30))
    t = time.monotonic()
    rep = run_job(g, job, stall_s=0.5)
    assert rep.fault is None and rep.errors == []
    assert rep.lines_acknowledged == rep.lines_sent == len(job.send)
    assert rep.answers_lost == 1 and sum("was lost on the link" in w for w in rep.warnings) == 1
    assert not rep.ok and rep.summary().startswith("completed over a faulty link")   # not a clean run
    assert time.monotonic() - t < 10
    assert vm.unsafe_stops == [] and vm.laser_output() == 0
    g.close()


@pytest.mark.parametrize("drop_ok, garble", [(5, 20), (12, 13)])
def test_error_right_after_a_lost_answer_names_the_earliest_candidate(drop_ok, garble):
    """No report between the lost answer and the error (the machine took every line at once):
    the error belongs to one of two lines; the earliest is named (a resume from it skips
    nothing) and the warning names both."""
    job = Job.from_text(raster_text(), machine=MACHINE)
    gcode_lines = [ln for ln, text in job.send if not text.startswith("$")]
    vm, g = machine(lambda v: FaultyPort(v, drop_ok=drop_ok, garble_line=garble))
    rep = run_job(g, job, stall_s=0.5)
    first, real = gcode_lines[garble - 2], gcode_lines[garble - 1]
    assert not rep.ok and [e[0] for e in rep.errors] == [first]
    assert any(f"one of lines {first}…{real}" in w for w in rep.warnings), rep.warnings
    assert rep.resume_line is None or rep.resume_line <= first
    assert vm.unsafe_stops == [] and vm.laser_output() == 0
    g.close()


def test_a_lost_line_end_is_never_a_clean_run():
    """Two lines merged by a lost line end get one answer: the run goes on, but is reported
    as not clean, naming where to check the work."""
    job = Job.from_text(raster_text(), machine=MACHINE)
    vm, g = machine(lambda v: FaultyPort(v, drop_newline_of=len(job.send) - 1))
    rep = run_job(g, job, stall_s=0.5)
    assert not rep.ok and (rep.fault or rep.answers_lost)
    assert vm.unsafe_stops == [] and vm.laser_output() == 0
    g.close()


def test_stalled_device_trips_the_watchdog():
    job = Job.from_text(raster_text(), machine=MACHINE)
    vm, g = machine(lambda v: FaultyPort(v, silent_after_lines=12))
    t = time.monotonic()
    rep = run_job(g, job, watchdog_s=0.5)
    assert rep.fault.startswith("watchdog: no status report for 0.5 s")
    assert time.monotonic() - t < 10
    g.close()


def test_check_first_rejects_before_anything_moves():
    job = Job.from_text(raster_text(rows=3), machine=MACHINE)
    vm, g = machine(lambda v: FaultyPort(v, garble_line=8))
    rep = run_job(g, job, check_first=True)
    assert not rep.ok and "check mode" in rep.fault
    assert [e[1] for e in rep.errors] == [20]
    assert vm.executed == [] or all(p.start == p.end for p in vm.executed)
    g.close()


def test_spindle_mode_machine_refuses_a_laser_job():
    job = Job.from_text(raster_text(rows=2), machine=MACHINE)
    vm, g = machine()
    g.set_setting(32, 0)
    with pytest.raises(MachineError, match="laser mode is off"):
        run_job(g, job)
    assert vm.executed == []
    g.close()


def test_bad_file_and_options_are_refused_up_front():
    with pytest.raises(GcodeError, match="<string>:2:"):
        Job.from_text("G21\nG1 X1 X2 F100\n")
    with pytest.raises(InputError, match=r"<string>:1:1: line 1 \(G1X1\.0000.*has 99 characters.*at most 79"):
        Job.from_text("G1 X1." + "0" * 90 + " F100\n")
    job = Job.from_text("G1 X1 F100\n")
    with pytest.raises(InputError, match="mode must be"):
        run_job(None, job, mode="fast")


def test_resume_text_restores_inch_relative_state():
    job = Job.from_text("G20 G91\nM3 S200 F10\nG1 X1\nG1 Y1\n")
    pre = resume_text(job, 4)
    assert pre[:3] == ["M5 S0", "G21 G90 G91.1 G17 G54", "G0 X25.4 Y0 Z0"]
    assert pre[3] == "G1 F254 S200" and pre[-1] == "G20 G91"
    with pytest.raises(InputError, match="outside the file"):
        resume_text(job, 99)


def test_resume_from_line_runs_the_rest_once():
    job = Job.from_text(raster_text(rows=5), machine=MACHINE)
    vm, g = machine()
    row_start = job.send[10][0]
    rep = run_job(g, job, resume_from=row_start)
    assert rep.ok
    segs = job_segments(job)
    covered, doubled, stray, _ = burn_coverage(job.moves, vm)
    later = [i for i, r in enumerate(np.flatnonzero(job.moves.laser_on))
             if job.moves.line[r] >= row_start]
    earlier = sorted(set(range(len(segs))) - set(later))
    lengths = np.array([np.linalg.norm(b - a) for a, b in segs])
    np.testing.assert_allclose(covered[later], lengths[later], atol=1e-6)
    assert covered[earlier].max() < 1e-9 and stray < 1e-6
    g.close()


def test_frame_traces_the_box_with_the_beam_off():
    job = Job.from_text(raster_text(rows=3), machine=MACHINE)
    vm, g = machine()
    for line in frame_text(job):
        g.command(line)
    g.wait_status(lambda s: s.state == "Idle", 10)
    (x0, y0, _), (x1, y1, _) = job.moves.bounds(job.moves.laser_on).round(3)
    visited = {tuple(np.round(p.end[:2], 3)) for p in vm.executed}
    assert {(x0, y0), (x1, y0), (x1, y1), (x0, y1)} <= visited
    assert all(p.power == 0 for p in vm.executed)
    g.close()


def test_transcript_has_timestamps_and_both_directions():
    job = Job.from_text(raster_text(rows=1), machine=MACHINE)
    vm, g = machine()
    run_job(g, job)
    sent = [t for t in g.transcript if t[1] == ">"]
    got = [t for t in g.transcript if t[1] == "<"]
    assert [s[2] for s in sent if s[2] in dict(job.send).values()]
    assert any(x[2] == "ok" for x in got)
    ts = [t[0] for t in g.transcript]
    assert ts == sorted(ts)
    g.close()


@pytest.mark.parametrize("own_g92", [False, True])
def test_resume_lands_in_the_job_coordinates_under_work_offsets(own_g92):
    """The user set the origin at (30, 20) before the job (G10 L20, kept by the controller);
    the job may also shift itself with G92 (cleared by the fault's soft reset). After a
    garbled line and a resume from the reported stop point, every burn happened exactly
    once, at the job's coordinates from that origin."""
    text = raster_text()
    if own_g92:
        text = "G0 X5 Y5\nG92 X0 Y0\n" + text      # the job's (0, 0) is (35, 25) on the machine
    job = Job.from_text(text, machine=MACHINE)
    vm, g = machine(lambda v: FaultyPort(v, garble_line=24))
    g.command("G0 X30 Y20")
    g.wait_status(lambda s: s.state == "Idle", 5)
    g.command("G10 L20 P0 X0 Y0")
    rep = run_job(g, job)
    assert not rep.ok and "soft reset (buffers flushed, laser off)" in rep.safe_actions
    assert vm.g92.tolist() == [0, 0, 0] and vm.work_offset[:2].tolist() == [30, 20]
    g.link.port.garble_line = None
    rep2 = run_job(g, job, resume_from=rep.resume_line, resume_position=rep.stop_position)
    assert rep2.ok, rep2.summary()
    assert_exactly_once(job, vm, origin_mm=(30, 20))
    g.close()


def test_a_line_finished_after_a_stop_burns_with_its_own_feed_and_power():
    """The rest of an interrupted line must carry the S and F the line itself sets (found when
    the virtual machine learned to brake through a feed hold: the stop fell inside a line whose
    S differs from the line before, and the rest was 'finished' at S0)."""
    job = Job.from_text("G21 G90\nM4 S0 F600\nG1 X5\nG1 X10 S500 F1200\nM5\n")
    pre = resume_text(job, 4, position=(7, 0, 0))
    assert pre[-1] == "G1 X10 Y0 Z0 F1200 S500"
    job = Job.from_text("G21 G90\nM5 F600\nG0 X5\nM3 G1 X10 S500\nM5\n")
    pre = resume_text(job, 4, position=(7, 0, 0))
    assert pre[-2:] == ["M3", "G1 X10 Y0 Z0 F600 S500"]


def test_feed_hold_inside_a_line_then_resume_burns_each_stretch_once():
    """A raster whose lines each set their power; the garbled line's fault brakes the head to a
    stop, and the resume from there covers the rest exactly once. Where the head stops depends
    on when the sender's reader thread sees the error, so several faults are tried: each resume
    must be exact, and most stop inside a line — the case that matters (lines 10, 19 and 32 stop
    inside the first line after an S0 line; without the line's own S the rest of it burned at S0)."""
    rng = np.random.default_rng(1)
    lines, x = ["G21 G90", "M4 S0 F3000", "G0 X10 Y10"], 10.0
    for r in range(6):
        if r:
            lines.append(f"G1 Y{10 + 0.5 * r:.1f} S0")
        for _ in range(12):
            x += 0.5 if r % 2 == 0 else -0.5
            lines.append(f"G1 X{x:.1f} S{int(rng.integers(50, 1000))}")
    job = Job.from_text("\n".join(lines + ["M5 S0"]) + "\n", machine=MACHINE)
    inside = 0
    for garbled in (10, 19, 32, 45, 58):
        vm, g = machine(lambda v: FaultyPort(v, garble_line=garbled), tick_s=0.002)
        rep = run_job(g, job)
        assert not rep.ok
        g.link.port.garble_line = None
        rows = np.flatnonzero(job.moves.line == rep.resume_line)
        assert len(rows)
        inside += not np.allclose(job.moves.start[rows[-1]][:2], rep.stop_position[:2])
        rep2 = run_job(g, job, resume_from=rep.resume_line, resume_position=rep.stop_position)
        assert rep2.ok, rep2.summary()
        assert_exactly_once(job, vm)
        g.close()
    assert inside >= 2, f"only {inside} of 5 faults stopped inside a line"


def test_resume_refuses_a_job_placed_at_the_current_position():
    """A G92 taken wherever the head stood is lost on reset and the program cannot say where
    that was: resuming would burn in the wrong place, so the resume says so instead."""
    placed_here = "G92 X0 Y0\nG21 G90\nM4 S300 F600\nG1 X10\nG1 Y10\nM5\nG92.1\n"
    job = Job.from_text(placed_here)
    with pytest.raises(InputError, match="G92 offset in effect at line 5 was taken wherever the head"):
        resume_text(job, 5)
    assert resume_text(job, 1)[0] == "M5 S0"   # from its first line it is a fresh run: allowed
    # a G92 taken at a position the program itself commanded is known, and restated
    known = Job.from_text("G0 X50 Y50\n" + placed_here)
    assert resume_text(known, 6)[2:5] == ["G92.1", "G0 X60 Y50 Z0", "G92 X10 Y0 Z0"]
    # after the program has cleared it again (G92.1), the rest resumes in work coordinates
    after = Job.from_text(placed_here + "G0 X5 Y5\nM4 S300\nG1 X6\n")
    assert resume_text(after, 10)[:3] == ["M5 S0", "G21 G90 G91.1 G17 G54", "G0 X5 Y5 Z0"]
    # the runner refuses before a byte is sent
    vm, g = machine()
    with pytest.raises(InputError, match="taken wherever the head stood"):
        run_job(g, job, resume_from=5)
    assert vm.laser_output() == 0 and vm.executed == []     # nothing was sent, nothing moved
    g.close()


def test_the_streamed_lines_are_one_job_for_the_kernels_rule():
    """labkit._jit's rule sees a stream's lines as one job (its units: the lines to send), a
    line done when it is answered: the virtual machine's per-line kernels are then projected
    over the lines left, whichever thread runs them."""
    from labkit import _jit

    vm, g = machine()
    job = Job.from_text(raster_text())
    seen = []

    def progress(executed, acked, total, eta_s):
        current = _jit._jobs[-1]
        seen.append((current.units, current.done))

    report = run_job(g, job, progress=progress)
    g.close()
    assert report.ok
    assert seen == [(len(job.send), k) for k in range(len(job.send))]
    assert _jit._jobs == []


def test_a_job_for_the_virtual_machine_declares_the_streams_work_while_its_file_is_read(monkeypatch):
    """Job.from_text(virtual_machine=True): the file's reading runs with the work the virtual
    machine will do per line declared (labkit.machine.virtual.stream_work), and only then."""
    import labkit.gcode
    from labkit import _jit
    from labkit.machine.virtual import stream_work

    real = labkit.gcode.parse_with_states
    declared = []
    monkeypatch.setattr(labkit.gcode, "parse_with_states",
                        lambda *a, **k: declared.append(list(_jit._after)) or real(*a, **k))
    text = raster_text()
    plain = Job.from_text(text)
    for_vm = Job.from_text(text, virtual_machine=True)
    lines = text.count("\n") + 1
    assert declared == [[], [stream_work(lines)]] and _jit._after == []
    assert for_vm.send == plain.send and for_vm.job_time_s == plain.job_time_s
