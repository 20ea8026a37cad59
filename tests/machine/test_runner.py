"""The job runner's steps, one at a time, with its state read between them (issue 28 §3).

The reference for what character counting may keep in flight is GRBL's documented rule
(its doc/script/stream.py and the wiki's streaming notes): the bytes of the unanswered lines,
each with its newline, stay within the 128-byte RX buffer less one; every ``ok`` or
``error`` retires the oldest line. The expected numbers below are worked out from the job's
own lines, not from the runner.
"""

from __future__ import annotations

import pytest

from labkit.machine import Grbl, Job
from labkit.machine.faults import FaultyPort
from labkit.machine.link import Link
from labkit.machine.stream import Controls, JobReport, JobRunner, StopSignals
from labkit.machine.virtual import VirtualMachine

MACHINE = "grbl-diode"
RX_LIMIT = 128 - 1            # GRBL 1.1's RX buffer, less one byte


def _job(rows=6):
    lines = ["G21 G90", "M4 S600", "G0 X0 Y0"]
    for r in range(rows):
        y = 0.25 * r
        lines += [f"G1 X{10 if r % 2 == 0 else 0} Y{y:.2f} F1200", f"G0 Y{y + 0.25:.2f}"]
    lines += ["M5", "G0 X0 Y0"]
    return Job.from_text("\n".join(lines) + "\n", machine=MACHINE)


def _connect(port_wrapper=None):
    vm = VirtualMachine(MACHINE, time_scale=0, tick_s=0.05)
    g = Grbl(Link(port_wrapper(vm) if port_wrapper else vm, "test"))
    g.connect()
    return vm, g


def _runner(g, job, signals, **kw):
    report = JobReport(ok=False, lines_total=len(job.source_lines), planned_s=job.job_time_s)
    return JobRunner(g, job, report, Controls(), signals, **kw)


def _next_answer(g):
    while True:
        ev = g.next_event(5.0)
        assert ev is not None, "no answer from the virtual machine within 5 s"
        if ev.kind in ("ok", "error"):
            return ev


def test_counting_fills_the_buffer_by_grbl_s_rule_and_each_ok_retires_the_oldest_line():
    job = _job()
    sizes = [len(text) + 1 for _, text in job.send]
    fits = 0                                   # the longest prefix within the RX limit, by hand
    while fits < len(sizes) and sum(sizes[:fits + 1]) <= RX_LIMIT:
        fits += 1
    assert 1 < fits < len(sizes)               # the job is longer than one buffer
    vm, g = _connect()
    try:
        with StopSignals() as signals:
            r = _runner(g, job, signals)
            assert r.phase == "ready" and r.rx_limit == RX_LIMIT and not r.inflight
            assert r.send() is True
            assert r.sent_lines == [ln for ln, _ in job.send[:fits]]
            assert [n for _, n in r.inflight] == sizes[:fits]
            assert r.rx_used == sum(sizes[:fits]) <= RX_LIMIT < r.rx_used + sizes[fits]
            assert r.line_ends == [sum(sizes[:k + 1]) for k in range(fits)]
            assert r.send() is False           # nothing more fits until an answer comes

            ev = _next_answer(g)
            assert ev.kind == "ok"
            r.acknowledge(ev)
            first = job.send[0][0]
            assert r.report.last_acknowledged_line == first and r.report.lines_acknowledged == 1
            assert len(r.inflight) == fits - 1 and r.rx_used == sum(sizes[1:fits])
            assert r.events_taken == 1

            r.send_all()
            r.finish()
        assert r.phase == "done", r.report.summary()
        assert r.report.ok and not r.inflight and r.rx_used == 0
        assert r.sent_lines == [ln for ln, _ in job.send]
        assert r.report.lines_acknowledged == len(job.send)
        assert [a[0] for a in r.acked] == sorted(job.blocks_per_line)   # every motion line planned
        assert r.report.last_executed_line == job.send[-1][0]
        assert vm.laser_output() == 0.0
    finally:
        g.close()


def test_send_response_keeps_one_line_in_flight():
    job = _job(rows=2)
    vm, g = _connect()
    try:
        with StopSignals() as signals:
            r = _runner(g, job, signals, mode="send-response")
            assert r.send() is True and len(r.inflight) == 1
            assert r.send() is False and len(r.inflight) == 1
            r.acknowledge(_next_answer(g))
            assert not r.inflight and r.rx_used == 0
            assert r.send() is True and r.sent_lines == [ln for ln, _ in job.send[:2]]
            r.send_all()
            r.finish()
        assert r.phase == "done" and r.report.ok
    finally:
        g.close()


@pytest.mark.parametrize("mode", ["counting", "send-response"])
def test_a_rejected_line_faults_the_run_names_its_line_and_leaves_the_beam_off(mode):
    job = _job()
    k = 6                                         # the 6th line sent arrives garbled: error:20
    bad_line = job.send[k - 1][0]
    vm, g = _connect(lambda v: FaultyPort(v, garble_line=k))
    try:
        with StopSignals() as signals:
            r = _runner(g, job, signals, mode=mode)
            r.run(preflight=False)
        assert r.phase == "faulted"
        assert r.report.fault.startswith(f"line {bad_line} rejected: error:20")
        assert r.report.errors[0][:2] == (bad_line, 20)
        assert bad_line in r.sent_lines and r.report.last_acknowledged_line >= bad_line
        assert "soft reset (buffers flushed, laser off)" in r.report.safe_actions
        assert vm.laser_output() == 0.0
    finally:
        g.close()


def test_executed_line_counts_the_lines_answered_after_the_report_as_a_full_scan_does():
    """_executed_line stops its search at the first entry before which no line was answered
    after the status report (the entries carry the highest answer number so far, _ack). Against
    the plain definition, every acknowledged line with an answer number at or after the report
    counted, on random histories in which a buffer report's lines carry an earlier number."""
    import random
    from types import SimpleNamespace

    from labkit.machine.stream import _ack, _executed_line

    rng = random.Random(7)
    for _ in range(400):
        acked, seq = [], 0
        for line in range(1, rng.randint(1, 60)):
            seq += rng.randint(0, 2)
            late = rng.random() < 0.1               # counted from a buffer report: earlier number
            _ack(acked, line, rng.randint(1, 4), max(0, seq - rng.randint(1, 5)) if late else seq)
        depth = rng.choice((4, 15, 36))
        st = SimpleNamespace(line=None, planner_free=rng.randint(0, depth),
                             answers_before=rng.randint(0, seq + 2))
        grbl = SimpleNamespace(status=st, info=SimpleNamespace(planner_blocks=depth))
        later = sum(a[1] for a in acked if a[2] >= st.answers_before)
        remaining = min(depth, max(0, depth - st.planner_free) + later)
        want = 0
        for idx in range(len(acked) - 1, -1, -1):
            if remaining <= 0:
                want = acked[idx][0]
                break
            remaining -= acked[idx][1]
        assert _executed_line(grbl, acked, 0) == want
