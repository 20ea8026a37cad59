"""``labkit stream``'s pre-flight warns before it sends when the link will starve the planner (issue 30 §2).

The job streams to the virtual machine (instant link: it runs); the warning comes from the
machine description named for the job (a 1200-baud CBR-40) and names what the predictor says.
"""
from __future__ import annotations

from labkit.machine.stream import Job, run_job
from labkit.motion import CBR40
from labkit.motion.stall import predict_stalls, stall_free_feed
from tests.machine.test_stream import machine

#: 60 relative 0.1 mm cuts at 600 mm/min: 4 bytes a line, 33 ms at 1200 baud, for 10 ms of motion
CUTS = "G21G91\nM4S100G1X.1F600\n" + "X.1\n" * 60 + "M5\n"


def _warnings(rep):
    return [w for w in rep.warnings if "planner will run dry" in w]


def test_the_preflight_warns_with_the_predicted_stalls_and_feed():
    slow = CBR40.replace(link_baud=1200, travel_mm=(400.0, 400.0, 50.0))
    vm, g = machine()
    try:
        rep = run_job(g, Job.from_text(CUTS, machine="grbl-diode"), machine=slow)
    finally:
        g.close()
    assert rep.ok, rep.summary()
    (warning,) = _warnings(rep)
    pred = predict_stalls(CUTS, slow)
    free = stall_free_feed(CUTS, slow, rel_tol=0.02, rows=False)
    assert f"run dry {len(pred.stalls)} time(s), first at line {pred.stalls[0].line}" in warning
    assert f"about {free.feed_mm_min:.0f} mm/min (programmed 600)" in warning
    assert "1200-baud link" in warning


def test_no_warning_when_the_link_keeps_up():
    vm, g = machine()
    try:
        rep = run_job(g, Job.from_text(CUTS, machine="grbl-diode"),
                      machine=CBR40.replace(travel_mm=(400.0, 400.0, 50.0)))
    finally:
        g.close()
    assert rep.ok and not _warnings(rep), rep.warnings
