"""The virtual machine's serial link and parser time (issue 30 §1): bytes arrive at baud/10 per
second of simulated time (8N1), a line is parsed for ``parse_s`` before it is planned, and every
time the planner stands empty while a line is on its way it reports a
:class:`labkit.motion.stall.Starvation`."""

import math

import pytest

from labkit.machine.virtual import VirtualMachine
from labkit.motion import load_machine

#: grbl-diode with the rest speed (250 Hz / 80 steps/mm, planned from: not GRBL's 0) the
#: hand-worked numbers use
DIODE = load_machine("grbl-diode").replace(start_rate_hz=250, rest_at_zero=False, planner_blocks=15,
                                           block_parse_s=0.0)


def _until_idle(vm, step_s=0.001, limit_s=30.0):
    vm.tick_s = step_s
    while (vm.state != "Idle" or vm._wire or vm.rx_used or vm._parsed) and vm.sim_time_s < limit_s:
        vm.in_waiting


def _one_mm_s():
    """1 mm at F600 on grbl-diode from rest to rest: 3.125 → 10 mm/s at 1000 mm/s² (6.875 ms
    over 0.0451172 mm), the rest at 10 mm/s, the same down."""
    ramp_mm = (10.0 ** 2 - 3.125 ** 2) / 2000.0
    return 2 * (10.0 - 3.125) / 1000.0 + (1.0 - 2 * ramp_mm) / 10.0


@pytest.mark.parametrize("parse_s", [0.0, 0.01])
def test_a_starvation_worked_by_hand(parse_s):
    """At 1200 baud (120 bytes/s) the 11 bytes of 'G1 X1 F600' arrive at 91.67 ms; its 1 mm
    runs alone (the next line is not there: it stops at its end) and ends 104.73 ms later;
    the 30 bytes of the next line arrive 250 ms after the first. The planner stood empty from
    the end of the first block to the end of the second line's parse."""
    vm = VirtualMachine(DIODE, time_scale=0, tick_s=0.0, banner=False, baud=1200, parse_s=parse_s)
    first, second = b"G1 X1 F600\n", b"G1 X2 (padding to 30 bytes..)\n"
    assert len(first) == 11 and len(second) == 30
    vm.write(first + second)
    _until_idle(vm)
    dry_s = 11 / 120 + parse_s + _one_mm_s()
    arrives_s = 41 / 120 + parse_s
    assert len(vm.starvations) == 1
    s = vm.starvations[0]
    assert s.line == 2
    assert s.time_s == pytest.approx(dry_s, abs=1e-9)
    assert s.duration_s == pytest.approx(arrives_s - dry_s, abs=1e-9)
    assert vm.executed[-1].t_end == pytest.approx(arrives_s + _one_mm_s(), abs=1e-9)


def test_a_fast_link_does_not_starve_long_moves():
    vm = VirtualMachine(DIODE, time_scale=0, tick_s=0.0, banner=False, baud=115200)
    vm.write(b"".join(b"G1 X%d F3000\n" % (10 * k) for k in range(1, 8)))
    _until_idle(vm)
    assert vm.starvations == [] and tuple(vm.pos) == (70.0, 0.0, 0.0)


def test_real_time_bytes_wait_their_turn_on_the_link():
    """A '?' written behind a line arrives after it: 12 bytes at 1200 baud = 100 ms."""
    vm = VirtualMachine(DIODE, time_scale=0, tick_s=0.0, banner=False, baud=1200)
    vm.write(b"G1 X1 F600\n?")
    vm.tick_s = 0.099
    early = vm.read(vm.in_waiting or 1)
    assert b"<" not in early
    vm.tick_s = 0.002
    reply = early
    for _ in range(3):
        reply += vm.read(vm.in_waiting or 1)
    assert b"ok" in reply and b"<Run|" in reply


def test_short_raster_blocks_are_paced_by_115200_baud():
    """0.1 mm pixels at 6000 mm/min need a line every millisecond; 115200 baud carries one of
    these 19-21 byte lines in 1.7-1.8 ms, so the link sets the pace: the job takes at least its
    bytes' time on the wire (a machine of 5000 mm/s²: 15 queued blocks, 1.5 mm, would let it
    reach 6000 mm/min)."""
    lines = [b"G21 G90 M4", b"G0 X10 Y10"] + [b"G1 X%.1f S%d F6000" % (10 + 0.1 * (k + 1), (k * 37) % 1000)
                                              for k in range(200)]
    vm = VirtualMachine(DIODE.replace(accel_mm_s2=(5000.0, 5000.0, 100.0)), time_scale=0, tick_s=0.0,
                        banner=False, baud=115200)
    sent, unanswered, replies = 0, [], b""
    while sent < len(lines) or unanswered:      # character counting: 127 bytes unanswered at most
        while sent < len(lines) and sum(unanswered) + len(lines[sent]) + 1 <= 127:
            vm.write(lines[sent] + b"\n")
            unanswered.append(len(lines[sent]) + 1)
            sent += 1
        vm.tick_s = 0.0005
        replies += vm.read(vm.in_waiting) if vm.in_waiting else b""
        vm.tick_s = 0.0
        *done, replies = replies.split(b"\n")
        for reply in done:
            if reply.strip() == b"ok":
                unanswered.pop(0)
    _until_idle(vm)
    wire_s = sum(len(ln) + 1 for ln in lines) / 11520
    assert vm.executed[-1].t_end >= wire_s
    # GRBL plans every queue to stop at its end, so a short queue slows the head down and the
    # next line often arrives before it stops: the wire sets the pace with few or no dry spells
    assert all(3 <= s.line <= len(lines) and s.duration_s > 0 for s in vm.starvations)
    times = [s.time_s for s in vm.starvations]
    assert times == sorted(times) and math.isfinite(sum(s.duration_s for s in vm.starvations))


def test_a_stream_reports_the_starvations_by_source_line():
    """labkit's job runner on the virtual machine at 1200 baud: the case worked by hand above,
    lines 3 and 4 of the file (after a comment line and a blank one), in the stream's report."""
    from labkit.machine import Grbl, Job, run_job
    from labkit.machine.link import Link

    vm = VirtualMachine(DIODE, time_scale=0, tick_s=0.01, baud=1200)
    g = Grbl(Link(vm, "test"))
    g.connect()
    # the runner strips spaces and comments before sending: the second line stays 30 bytes
    job = Job.from_text("(two moves)\n\nG1 X1 F600\nG1X2.000000000000Y0.000000000\n", machine=DIODE)
    report = run_job(g, job)
    g.close()
    assert report.ok, report.summary()
    assert [s.line for s in report.starvations] == [4]
    s = report.starvations[0]
    assert 0.1 < s.duration_s < 0.3 and s.time_s > 0
    assert "planner ran dry 1 time(s)" in report.summary() and "line 4 at" in report.summary()
