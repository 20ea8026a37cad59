"""Which lines a controller may hold unanswered: the streamer reads it from the interpreter
trace's ``syncing`` flag once per job (issue 28), no longer from a regex per line sent.

The expected flags are worked by hand, line by line, from the rule the streamer used before
(its regex of the commands GRBL 1.1 waits on: G4, G10, G28, G30, G92, M0-M2, M30, M3-M9),
which the trace must keep: a motion line, a feed or S word alone and a mode change are
answered without waiting, and so is a ``$`` command. One case changes on purpose: a line
the interpreter rejects does not sync (GRBL checks a block before executing any of it and
answers the error at once; the regex went by the words alone).
"""
from labkit.machine.stream import Job, _resume_send

HAND_JOB = """\
G21 G90 (units and distance: no wait)
M4 S500
G1 X10 F600
S800
G4 P0.5
G92 X0
$H
; a comment line sends nothing
G10 L20 P1 Y0
M8
M9
G28
G1 X5 Y5
M5
M2
"""

#: (source line, text sent, syncs) for every line of HAND_JOB that sends something
HAND_FLAGS = [
    (1, "G21G90", False),
    (2, "M4S500", True),         # laser on: GRBL syncs the spindle state
    (3, "G1X10F600", False),
    (4, "S800", False),          # an S word alone: no sync, as before
    (5, "G4P0.5", True),
    (6, "G92X0", True),
    (7, "$H", False),            # a $ command runs idle, it holds no answer back
    (9, "G10L20P1Y0", True),
    (10, "M8", True),
    (11, "M9", True),
    (12, "G28", True),
    (13, "G1X5Y5", False),
    (14, "M5", True),
    (15, "M2", True),
]


def test_job_reads_each_lines_syncing_once():
    job = Job.from_text(HAND_JOB)
    assert [(ln, text, sync) for (ln, text), sync in zip(job.send, job.syncing)] == HAND_FLAGS
    assert len(job.syncing) == len(job.send)


def test_job_reads_which_lines_carry_coordinates_once():
    # the pre-flight's "first move": an accepted G-code line with X, Y or Z, offsets included
    job = Job.from_text(HAND_JOB)
    with_axes = [ln for (ln, _), axes in zip(job.send, job.axis_words) if axes]
    assert with_axes == [3, 6, 9, 13]


def test_a_rejected_line_is_answered_at_once():
    # G4 without P is refused (error 28): answered at once, though the regex the trace
    # replaced said it synced. A Job built without from_text reads its lines in order.
    job = Job(["G4", "G4 P1"], [(1, "G4"), (2, "G4P1")], None, {}, {}, 0.0)
    assert job.syncing == [False, True] and job.axis_words == [False, False]


def test_resume_lines_and_flags_stay_aligned():
    job = Job.from_text("G21 G90\nM4 S500\nG1 X10 F600\nG4 P0.5\nG1 Y10\nM5\nM2\n")
    lines, syncing = _resume_send(job, 5, None)
    assert len(lines) == len(syncing)
    flags = dict(zip(lines, syncing))
    # the preamble's beam-off and laser-mode lines sync, its modes and moves do not
    assert flags[(5, "M5S0")] is True and flags[(5, "M4")] is True
    assert flags[(5, "G21G90G91.1G17G54")] is False and flags[(5, "G1F600S500")] is False
    # the job's own lines keep the flags read from the whole job
    assert lines[-3:] == [(5, "G1Y10"), (6, "M5"), (7, "M2")]
    assert syncing[-3:] == [False, True, True]
