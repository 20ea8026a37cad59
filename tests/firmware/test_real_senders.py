"""Senders nobody here wrote stream real laser jobs through the firmware's host simulator (issue 26 §4).

The simulator runs on a pty in the grbl dialect (``--dialect grbl`` passed explicitly) with a
beam log. Two senders drive it:

* GRBL's own ``doc/script/stream.py`` (gnea/grbl), re-implemented here from its documented
  behaviour in its two modes — character counting against GRBL's 128-byte receive buffer
  (a line goes out only while the characters sent and not yet answered stay below 127; the
  script removes whitespace and parenthesised comments and upper-cases the line, but keeps
  ``;`` comments), and send-response (its settings mode: each line sent whole, the next only
  after ``ok`` or ``error``). A ``?`` goes out every second as the script does.
* grbl-streamer (PyPI, a test dependency), unchanged, in its two modes: counting characters
  (``incremental_streaming = False``, its default) and incremental (send-response).

The jobs: cncjs's jsdc-laser.gcode (written by a real CAM tool) and labkit's own img2gcode
output (a drawn image; its header comments once made stream.py deadlock). Each gets a last
rapid to ``G0 X12.3456 Y7.891`` appended so that the final position says something. Checked
for every run: every line answered ``ok``, ``?`` at the end reports the appended point (to
one step), and the beam log's last duty is 0 with the beam on during the job. Lines per
second are printed, not asserted (speed is measured in benchmarks/).
"""
from __future__ import annotations

import csv
import re
import subprocess
import threading
import time
from pathlib import Path

import numpy as np
import pytest
import serial
from PIL import Image

from labkit.cli import main
from labkit.machine.safety import end_process

ROOT = Path(__file__).resolve().parents[2]
FW = ROOT / "firmware"
SIM = FW / "build/host/labkit-fw-sim"
STEPS_PER_MM = 6400.0 / 3.0             # firmware defaults.h (CBR-40)
END_XY = (12.3456, 7.891)
END_LINE = f"G0 X{END_XY[0]} Y{END_XY[1]}"
RX_BUFFER = 128                          # GRBL 1.1's serial receive buffer ($I: [OPT:V,15,128])
TIMEOUT_S = 60.0


@pytest.fixture(scope="module")
def sim():
    run = subprocess.run(["make", "-C", str(FW), "sim"], capture_output=True, text=True)
    assert run.returncode == 0, f"make -C firmware sim failed:\n{run.stdout}\n{run.stderr}"
    return str(SIM)


@pytest.fixture(scope="module")
def jobs(tmp_path_factory):
    """name -> path of a job ending with the known rapid."""
    tmp = tmp_path_factory.mktemp("jobs")
    yy, xx = np.mgrid[0:60, 0:80]
    picture = np.full((60, 80), 255, np.uint8)
    picture[(xx - 40) ** 2 + (yy - 30) ** 2 < 500] = 0                 # a disc, drawn here
    png = tmp / "disc.png"
    Image.fromarray(picture).save(png, dpi=(254, 254))
    labkit_job = tmp / "disc.gcode"
    assert main(["img2gcode", str(png), "-o", str(labkit_job), "--mode", "zigzag", "--beam", "0.2",
                 "--width", "24", "--preview", "none", "--dialect", "grbl"]) == 0
    out = {}
    for name, src in (("cncjs-jsdc", ROOT / "data/gcode/cncjs/jsdc-laser.gcode"),
                      ("labkit-img2gcode", labkit_job)):
        path = tmp / f"{name}.gcode"
        path.write_text(src.read_text("ascii").rstrip("\n") + f"\n{END_LINE}\n", "ascii")
        out[name] = path
    return out


class Simulator:
    """labkit-fw-sim on a pty in the grbl dialect, logging the beam."""

    def __init__(self, sim, beam_log: Path):
        self.beam_log = beam_log
        self.proc = subprocess.Popen([sim, "--pty", "--dialect", "grbl", "--beam-log", str(beam_log)],
                                     stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                     stderr=subprocess.PIPE, text=True)
        line = self.proc.stderr.readline()
        if "pty " not in line:
            self.proc.kill()
            raise AssertionError(f"simulator did not announce its pty: {line!r}")
        self.pty = line.split("pty ", 1)[1].strip()

    def beam_rows(self):
        with open(self.beam_log, newline="", encoding="ascii") as fh:
            rows = list(csv.reader(fh))
        assert rows and rows[0] == ["time_s", "duty", "state", "line"], rows[:1]
        return [(float(t), int(d), s, int(n)) for t, d, s, n in rows[1:]]

    def close(self):
        end_process(self.proc)


@pytest.fixture
def machine(sim, tmp_path):
    s = Simulator(sim, tmp_path / "beam.csv")
    yield s
    s.close()


# ---------------------------------------------------------------- GRBL's stream.py, from its behaviour

class StreamPyDeadlock(Exception):
    """stream.py would wait for an answer to a line it has not sent (it blocks for ever)."""


#: what stream.py writes first to wake GRBL up (four empty lines in the grbl dialect)
STREAM_PY_WAKE_UP = b"\r\n\r\n"


def stream_py_line(raw: str) -> bytes:
    """The bytes stream.py's counting mode writes for one line of a program: whitespace and
    ``(...)`` removed, upper case (``;`` comments kept), a newline added."""
    return re.sub(r"\s|\(.*?\)", "", raw).upper().encode("ascii") + b"\n"


def stream_py_sent(text: str) -> bytes:
    """Every line byte stream.py's counting mode writes for ``text``, the wake-up first (its
    ``?`` status polls, real-time bytes, left out): the simulator's ``--expect`` file."""
    return STREAM_PY_WAKE_UP + b"".join(stream_py_line(raw) for raw in text.splitlines())


def _is_answer(reply: str) -> bool:
    # stream.py takes any line containing 'ok' or 'error' as the answer to the oldest line
    return "ok" in reply or "error" in reply


def stream_py(port: str, text: str, *, counting: bool) -> dict:
    """Stream ``text`` as GRBL's doc/script/stream.py does; returns its tally.

    Counting mode: each line is cleaned (whitespace and ``(...)`` removed, upper case; ``;``
    comments stay), its length plus the newline is added to the characters in flight, and
    before sending, answers are read while that total would reach 127 (RX_BUFFER - 1). With no
    line in flight and still too long, the script would block on its read for ever: raised
    here as :class:`StreamPyDeadlock`. Send-response mode (its ``-s``): each line stripped of
    its line end only, sent, and its answer awaited.
    """
    link = serial.Serial(port, 115200, timeout=TIMEOUT_S)
    stop_polling = threading.Event()
    write_lock = threading.Lock()

    def write(data: bytes):
        with write_lock:
            link.write(data)

    def poll():                         # '?' once a second, as the script's timer thread does
        while not stop_polling.wait(1.0):
            write(b"?")

    def read_reply() -> str:
        raw = link.readline()
        if not raw.endswith(b"\n"):
            raise AssertionError(f"no answer within {TIMEOUT_S} s (got {raw!r})")
        return raw.decode("ascii", "replace").strip()

    tally = {"sent": 0, "answers": [], "messages": []}
    try:
        write(STREAM_PY_WAKE_UP)          # the script then waits and drops what came back
        time.sleep(0.5)
        link.reset_input_buffer()
        threading.Thread(target=poll, daemon=True).start()
        t0 = time.monotonic()
        in_flight: list[int] = []

        def take_answer():
            reply = read_reply()
            if _is_answer(reply):
                tally["answers"].append(reply)
                if in_flight:
                    in_flight.pop(0)
            else:
                tally["messages"].append(reply)

        for raw in text.splitlines():
            if counting:
                data = stream_py_line(raw)
                in_flight.append(len(data))
                while sum(in_flight) >= RX_BUFFER - 1:
                    if len(in_flight) == 1:
                        raise StreamPyDeadlock(f"line {tally['sent'] + 1} is {len(data)} characters "
                                               f"with its newline: stream.py waits for ever")
                    take_answer()
                write(data)
                tally["sent"] += 1
            else:
                write(raw.strip().encode("ascii") + b"\n")
                tally["sent"] += 1
                while len(tally["answers"]) < tally["sent"]:
                    take_answer()
        while len(tally["answers"]) < tally["sent"]:
            take_answer()
        tally["seconds"] = time.monotonic() - t0
        stop_polling.set()
        tally["status"] = _idle_status(link.write, read_reply)
    finally:
        stop_polling.set()
        link.close()
    return tally


def _idle_status(write, read_reply) -> str:
    """'?' until the machine reports Idle (the planner has run out); the last report."""
    end = time.monotonic() + TIMEOUT_S
    while time.monotonic() < end:
        write(b"?")
        reply = read_reply()
        while not reply.startswith("<"):
            reply = read_reply()
        if reply.startswith("<Idle"):
            return reply
        time.sleep(0.05)
    raise AssertionError(f"not Idle after {TIMEOUT_S} s: {reply}")


# ---------------------------------------------------------------- grbl-streamer

def grbl_streamer(port: str, path: Path, *, incremental: bool) -> dict:
    """Stream ``path`` with grbl-streamer as its README shows: connect, load, run, wait."""
    from grbl_streamer import GrblStreamer

    events: list = []
    changed = threading.Condition()

    def callback(event, *data):
        with changed:
            events.append((time.monotonic(), event, data))
            changed.notify_all()

    def wait_for(pred, what, timeout_s=TIMEOUT_S):
        with changed:
            if not changed.wait_for(lambda: pred(events), timeout_s):
                raise AssertionError(f"grbl-streamer: no {what} within {timeout_s} s; "
                                     f"last events {[e[1:] for e in events[-8:]]}")

    def count(name):
        return sum(1 for e in events if e[1] == name)

    gs = GrblStreamer(callback)
    try:
        gs.cnect(port)                   # opens the port and soft-resets
        wait_for(lambda ev: any(e[1] == "on_boot" for e in ev), "boot banner")
        # at boot it asks for $$ itself; let its answers pass before the job (their 'ok's
        # arrive while no job runs, so they are not counted against the stream)
        wait_for(lambda ev: any(e[1] == "on_read" and str(e[2][0]).startswith("$132=") for e in ev),
                 "$$ listing")
        time.sleep(0.3)
        gs.incremental_streaming = incremental
        gs.load_file(str(path))
        lines = gs.buffer_size
        completed_before = count("on_job_completed")
        t0 = time.monotonic()
        gs.job_run()
        wait_for(lambda ev: sum(1 for e in ev if e[1] == "on_job_completed") > completed_before
                 or any(e[1] in ("on_error", "on_alarm") for e in ev), "end of the job")
        seconds = time.monotonic() - t0
        errors = [e[2] for e in events if e[1] in ("on_error", "on_alarm")]
        # its own poll ('?' every 0.2 s) gives the final state: the first report after the
        # poll starts is always passed on (it forgets the last state), later ones on a change
        polled = time.monotonic()
        gs.poll_start()
        wait_for(lambda ev: any(e[1] == "on_stateupdate" and e[2][0] == "Idle" and e[0] >= polled
                                for e in ev), "Idle report after the job")
        return {"sent": count("on_line_sent"), "processed": count("on_processed_command"),
                "lines": lines, "errors": errors, "seconds": seconds,
                "mode": gs.cmode, "mpos": gs.cmpos}
    finally:
        gs.disconnect()


# ---------------------------------------------------------------- checks

def _assert_at_end(mpos):
    for axis, (got, want) in enumerate(zip(mpos, (*END_XY, 0.0))):
        assert abs(got * STEPS_PER_MM - round(want * STEPS_PER_MM)) <= 1.01, \
            f"{'XYZ'[axis]} ended at {got}, the job's last point is {want}"


def _assert_beam_off_at_end(machine):
    rows = machine.beam_rows()
    assert any(duty > 0 for _, duty, _, _ in rows), "the beam never came on: the job did not cut"
    assert rows[-1][1] == 0, f"the beam log ends at duty {rows[-1][1]}: {rows[-3:]}"


def _mpos(report: str):
    m = re.search(r"MPos:([-\d.]+),([-\d.]+),([-\d.]+)", report)
    assert m, report
    return [float(v) for v in m.groups()]


@pytest.mark.parametrize("job", ["cncjs-jsdc", "labkit-img2gcode"])
@pytest.mark.parametrize("mode", ["counting", "send-response"])
def test_grbl_stream_py(machine, jobs, job, mode):
    text = jobs[job].read_text("ascii")
    tally = stream_py(machine.pty, text, counting=mode == "counting")
    assert tally["sent"] == len(text.splitlines())
    assert tally["answers"] == ["ok"] * tally["sent"], \
        [a for a in tally["answers"] if a != "ok"][:5]
    _assert_at_end(_mpos(tally["status"]))
    machine.close()
    _assert_beam_off_at_end(machine)
    print(f"\nstream.py {mode}, {job}: {tally['sent']} lines in {tally['seconds']:.2f} s, "
          f"{tally['sent'] / tally['seconds']:.0f} lines/s")


def test_stream_py_deadlocks_on_a_long_comment_line(machine):
    """What labkit's header did before: one 231-character ';' line (stream.py keeps ';'
    comments and counts them) can never fit the 127 characters, so the script waits for ever."""
    text = "G21 G90\n; " + "x" * 229 + "\nG0 X1\n"
    with pytest.raises(StreamPyDeadlock, match="line 2 is 231 characters"):
        stream_py(machine.pty, text, counting=True)


@pytest.mark.parametrize("job", ["cncjs-jsdc", "labkit-img2gcode"])
@pytest.mark.parametrize("incremental", [False, True], ids=["counting", "incremental"])
def test_grbl_streamer(machine, jobs, job, incremental):
    run = grbl_streamer(machine.pty, jobs[job], incremental=incremental)
    assert run["errors"] == []
    assert run["sent"] == run["lines"] > 100
    assert run["processed"] == run["sent"], "a line without its ok"
    assert run["mode"] == "Idle"
    _assert_at_end(run["mpos"])
    machine.close()
    _assert_beam_off_at_end(machine)
    mode = "incremental" if incremental else "counting"
    print(f"\ngrbl-streamer {mode}, {job}: {run['sent']} lines in {run['seconds']:.2f} s, "
          f"{run['sent'] / run['seconds']:.0f} lines/s")
