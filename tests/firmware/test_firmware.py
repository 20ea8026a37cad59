"""The firmware from the top-level suite: its C tests, and the host simulator
driven by labkit.machine over a pty and compared with labkit.motion.

The simulator is built with ``make -C firmware sim`` (a failed build fails
every test here). Jobs are small so that the whole module runs in well under
a minute.
"""
from __future__ import annotations

import csv
import importlib.util
import re
import subprocess
import threading
import time
from pathlib import Path

import pytest

from labkit.errors import GcodeError
from labkit.gcode import parse
from labkit.machine.grbl import Grbl
from labkit.machine.safety import end_process
from labkit.machine.link import open_link
from labkit.machine.stream import Controls, Job, run_job

ROOT = Path(__file__).resolve().parents[2]
FW = ROOT / "firmware"
SIM = FW / "build/host/labkit-fw-sim"
JOB = ROOT / "data/gcode/cncjs/jsdc-laser.gcode"
STEPS_PER_MM = 6400.0 / 3.0      # firmware defaults.h (CBR-40): one step, 0.47 µm


def _load(name):
    spec = importlib.util.spec_from_file_location(name, FW / "tests" / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def sim():
    run = subprocess.run(["make", "-C", str(FW), "sim"], capture_output=True, text=True)
    assert run.returncode == 0, f"make -C firmware sim failed:\n{run.stdout}\n{run.stderr}"
    assert SIM.exists()
    return str(SIM)


@pytest.fixture
def short_job(tmp_path):
    """The first 300 lines of jsdc-laser.gcode and an M5 (the beam off at the end)."""
    lines = JOB.read_text("utf-8").splitlines()[:300] + ["M5"]
    path = tmp_path / "jsdc-300.gcode"
    path.write_text("\n".join(lines) + "\n", "utf-8")
    return path


def _status_name(number):
    with open(ROOT / "labkit/status_codes.csv", newline="", encoding="utf-8") as f:
        return {int(row["code"]): row["name"] for row in csv.DictReader(f) if row["kind"] == "error"}[number]


class _Sim:
    """The simulator on a pty in GRBL mode, with labkit's GRBL client connected."""

    def __init__(self, sim):
        self.proc, pty = _load("sim_stream").start_sim(sim, "grbl")
        self.grbl = Grbl(open_link(pty))
        self.grbl.realtime("soft_reset")          # the banner went out before the pty opened
        self.info = self.grbl.connect(timeout_s=5.0)
        # GRBL's default $10=1 sends no Bf:, which the stream needs to place a resume line
        self.grbl.set_setting(10, 3)

    def close(self):
        self.grbl.close()
        end_process(self.proc)


def _assert_ends_at(status, job):
    end = [float(v) for v in job.moves.end[-1]]
    for got, want in zip(status.mpos, end):
        assert abs(got * STEPS_PER_MM - round(want * STEPS_PER_MM)) <= 1.01, (status.raw, end)


def test_c_host_tests():
    run = subprocess.run(["make", "--no-print-directory", "-C", str(FW), "test"], capture_output=True, text=True)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    last = [ln for ln in run.stdout.splitlines() if ln.strip()][-1]
    m = re.search(r"\ball (\d+) test programs passed$", last)
    assert m and int(m.group(1)) >= 6, last


@pytest.mark.parametrize("native", [False, True], ids=["grbl", "labkit-fw"])
def test_stream_job(sim, short_job, native, capsys):
    """(a) GRBL mode with the character-counting streamer, (b) the labkit-fw dialect:
    every line ok, RX budget 128 kept, '?' at the job's end point, beam off, M5."""
    argv = ["sim_stream", sim, str(short_job)] + (["--labkit-fw"] if native else [])
    rc = _load("sim_stream").main(argv)
    out = capsys.readouterr().out
    assert rc == 0, out
    assert "sim_stream (" + ("labkit-fw" if native else "grbl") + "): PASS" in out
    sent = re.search(r"(\d+) lines sent, (\d+) ok", out)
    assert native or (sent and sent.group(1) == sent.group(2) and int(sent.group(1)) > 250), out


@pytest.mark.parametrize("text", [
    "G21 G90\nM4 S600\nG1 X5 Y0 F1200\nG2 X10 Y5 I0 J5\nG1 X10 Y8 S300\n"
    "G3 X6 Y8 I-2 J0 F900\nG0 X0 Y0\nG1 X2 Y1 F3000\nM5\n",
    # a dwell between moves of other directions (jsdc-laser's 'M3 S80, G4 P0.5' between
    # paths): the machine stands still, each side ramps from and to its own rest speed
    "G21 G90\nG1 X3 Y-2 F1500\nM3 S80\nG4 P0.5\nG1 X2.9 Y-2.01 F100\nG1 X2 Y-2.1\n"
    "G4 P0.2\nG1 X2 Y1 F600\nM5\n",
    # lines GRBL syncs on between collinear cuts (a new S alone, M8, G92, M9, M5, M4): the head
    # stops before each; an S on a motion line rides with its move and does not stop it
    "G21 G90\nM3 S100\nG1 X3 F1200\nS300\nG1 X6\nG1 X9 S500\nM8\nG1 X12\nG92 X0\n"
    "G1 X3\nM9\nG1 X6\nM4\nG1 X9\nM5\nG0 X0\n"], ids=["lines-arcs", "dwells", "syncs"])
def test_trace_equals_labkit_steps(sim, tmp_path, capsys, text):
    """(c) the simulator's --trace equals ``labkit steps`` tick for tick (lines, arcs, dwells)."""
    job = tmp_path / "job.gcode"
    job.write_text(text, "utf-8")
    rc = _load("sim_trace").main(["sim_trace", sim, str(job)])
    out = capsys.readouterr().out
    assert rc == 0, out
    assert "sim_trace: identical" in out
    ticks = int(out.split(" simulator ticks")[0].rsplit(" ", 1)[1])
    assert ticks > 10000, out


def test_feed_hold_and_resume(sim, short_job):
    """(d) '!' mid-job: Hold with the laser at 0 at once; '~' finishes it, every line ok."""
    job = Job.from_text(short_job.read_text("utf-8"), filename=str(short_job))
    s = _Sim(sim)
    controls = Controls()
    seen = {}

    def progress(executed, acknowledged, total, eta):
        if acknowledged >= 120 and "hold_at" not in seen:
            seen["hold_at"] = acknowledged
            controls.pause()

    def watcher():
        while "hold_at" not in seen:
            time.sleep(0.005)
        st = s.grbl.wait_status(lambda st: st.state.startswith("Hold"), timeout_s=5.0)
        seen["hold"] = st
        time.sleep(0.3)                       # held: nothing may move meanwhile
        seen["still"] = s.grbl.get_status()
        controls.resume()

    t = threading.Thread(target=watcher, daemon=True)
    try:
        t.start()
        report = run_job(s.grbl, job, mode="counting", status_interval_s=0.02,
                         progress=progress, controls=controls, watchdog_s=5.0)
        t.join(10)
        assert report.ok and report.fault is None, report.summary()
        assert report.lines_acknowledged == len(job.send)
        assert not report.errors
        hold, still = seen["hold"], seen["still"]
        assert hold.spindle in (0, 0.0), hold.raw          # the beam went off with the hold
        assert still.state.startswith("Hold") and still.mpos == hold.mpos, (hold.raw, still.raw)
        final = s.grbl.get_status()
        assert final.state == "Idle" and final.spindle in (0, 0.0), final.raw
        _assert_ends_at(final, job)
    finally:
        s.close()


def test_rejected_line_and_resume(sim, short_job):
    """(e) a line GRBL rejects: error:N with labkit's number; resuming finishes the job."""
    bad = "G90 G91 X3 Y3"                     # two distance modes (one modal group; G0 G1 is GRBL's 24)
    with pytest.raises(GcodeError) as exc:
        parse(bad + "\n", dialect="grbl")
    want_code = exc.value.code
    assert _status_name(want_code) == "modal_group_violation"
    job = Job.from_text(short_job.read_text("utf-8"), filename=str(short_job))
    k = 150
    bad_line, good_text = job.send[k]
    job.send[k] = (bad_line, bad)
    s = _Sim(sim)
    try:
        report = run_job(s.grbl, job, mode="counting", on_error="stop", watchdog_s=5.0)
        assert not report.ok
        assert report.errors[0][:2] == (bad_line, want_code), report.errors
        assert report.resume_line is not None and report.resume_line <= bad_line
        assert report.last_executed_line < bad_line
        # the line fixed, resume where the report says: every line ok, the job's end reached
        job.send[k] = (bad_line, good_text)
        if s.grbl.get_status().state == "Alarm":    # the reset stopped motion: GRBL's ALARM:3
            s.grbl.unlock()
        again = run_job(s.grbl, job, mode="counting", resume_from=report.resume_line,
                        resume_position=report.stop_position, watchdog_s=5.0)
        assert again.ok and not again.errors, again.summary()
        final = s.grbl.get_status()
        assert final.state == "Idle" and final.spindle in (0, 0.0), final.raw
        _assert_ends_at(final, job)
    finally:
        s.close()


# ------------------------------------------------------------------ the beam (issue 25 §1)

def _beam_rows(path):
    with open(path, newline="", encoding="ascii") as f:
        rows = list(csv.reader(f))
    assert rows and rows[0] == ["time_s", "duty", "state", "line"], rows[:1]
    return [(float(t), int(d), s, int(n)) for t, d, s, n in rows[1:]]


class _Stdin:
    """The simulator on stdin/stdout (GRBL dialect) with a beam log and optionally a panel file."""

    def __init__(self, sim, tmp_path, panel=None):
        self.log = tmp_path / "beam.csv"
        argv = [sim, "--dialect", "grbl", "--beam-log", str(self.log)]
        if panel is not None:
            argv += ["--panel", str(panel)]
        self.proc = subprocess.Popen(argv, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=subprocess.PIPE)

    def send(self, data: bytes):
        self.proc.stdin.write(data)
        self.proc.stdin.flush()

    def wait_rows(self, pred, timeout_s=10.0):
        end = time.monotonic() + timeout_s
        while time.monotonic() < end:
            rows = _beam_rows(self.log) if self.log.exists() and self.log.stat().st_size else []
            if pred(rows):
                return rows
            time.sleep(0.01)
        raise AssertionError(f"beam log never matched: {_beam_rows(self.log)}")

    def finish(self):
        out, err = self.proc.communicate(timeout=30)
        assert self.proc.returncode == 0, err
        return out.decode("ascii", "replace"), _beam_rows(self.log)


def test_serial_bytes_never_reach_the_panel(sim, tmp_path):
    """Two UTF-8 '²' in a comment once pressed OK twice on the menu and fired the beam at duty 10,
    idle. Now bytes above 0x7F that are not GRBL real-time commands are dropped: the line is
    answered ok, the beam log stays empty, and a cut then logs exactly its own beam: on at
    S500 of $30=1000 (duty 500 of 1000) on line 2, off when its 2 mm at 600 mm/min end."""
    s = _Stdin(sim, tmp_path)
    s.send("G21 (mm² ²)\n".encode("utf-8") + b"\xb2\xb2\xb0\xb2\xb2\n$LCD\n")
    s.send(b"G1 X2 F600 S500 M3\nG0 X0\nM5\n")
    out, rows = s.finish()
    assert out.count("ok") == 6 and "error" not in out, out
    assert "[LCD:> Laser" in out                       # the menu was not entered
    assert [(d, st, n) for _, d, st, n in rows] == [(500, "Run", 3), (0, "Run", 4)], rows
    assert rows[0][0] == 0.0
    # 2 mm at 10 mm/s is 0.2 s; the ramps (accel 200 mm/s² ... ) add less than 0.1 s
    assert 0.2 < rows[1][0] < 0.3, rows


def test_panel_channel_fires_focus_only_deliberately(sim, tmp_path):
    """The panel's own channel (a FIFO): two OKs do nothing; a turn to On, OK, OK fires the
    focus beam at duty 10 on the idle machine; any host line switches it off."""
    import os

    fifo = tmp_path / "panel"
    os.mkfifo(fifo)
    s = _Stdin(sim, tmp_path, panel=fifo)
    try:
        with open(fifo, "wb", buffering=0) as panel:
            panel.write(b"\xb2\xb2")                       # Laser, then "Off" applied
            s.send(b"?")
            time.sleep(0.2)
            assert not _beam_rows(s.log)
            panel.write(b"\xb2\xb0\xb2\xb2")               # Laser, turn to On, OK, OK
            rows = s.wait_rows(lambda r: len(r) >= 1)
            assert [(d, st, n) for _, d, st, n in rows] == [(10, "Idle", 0)]
            s.send(b"G4 P0\n")
            s.wait_rows(lambda r: len(r) >= 2)
        out, rows = s.finish()
    finally:
        if s.proc.poll() is None:
            s.proc.kill()
    assert [(d, st) for _, d, st, _ in rows] == [(10, "Idle"), (0, "Idle")], rows


def test_hold_switches_the_beam_off_at_once(sim, tmp_path):
    """'!' in the middle of a long cut: the next row of the beam log is duty 0 in Hold."""
    s = _Stdin(sim, tmp_path)
    try:
        s.send(b"G1 X4000 F100 S300 M3\n")
        s.wait_rows(lambda r: len(r) >= 1)
        s.send(b"!")
        rows = s.wait_rows(lambda r: len(r) >= 2)
        s.send(b"\x18")
        out, rows = s.finish()
    finally:
        if s.proc.poll() is None:
            s.proc.kill()
    assert [(d, st, n) for _, d, st, n in rows[:2]] == [(300, "Run", 1), (0, "Hold", 1)], rows
    assert len(rows) == 2, rows                          # nothing burned after the hold
