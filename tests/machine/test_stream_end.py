"""Every way a stream ends stops the machine before the port closes (issue 25 §2).

A GRBL behaviour model behind a real pty (``_pty_controller``) records every byte labkit
sends. For SIGINT and SIGTERM to a real ``labkit stream`` process, an exception in a
progress callback, a process that exits under a job running in a thread (a closed
notebook kernel) and ``labkit console``, the bytes that reach the controller after the
event must be feed hold ``!``, then the soft reset 0x18, then ``M5 S0`` — and no line of
the job after them. Where the link itself goes, the report must say that the controller
was not told to stop, and name the lines and the command to resume with.
"""

import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest

from labkit.cli import main
from labkit.machine.grbl import NOT_TOLD, Grbl
from labkit.machine.link import open_link
from labkit.machine.stream import Job, run_job

from ._pty_controller import PtyController

MAIN = "import sys; from labkit.cli import main; sys.exit(main(sys.argv[1:]))"


def long_job_text(rows=40):
    """A slow engraving (about 5 s of machine time a row at F600): time to interrupt it."""
    lines = ["G21 G90", "M4 S500 F600"]
    for r in range(rows):
        lines.append(f"G1 X{10 + (r % 2) * 50} Y{5 + 0.5 * r:.1f}")
    return "\n".join(lines + ["M5", "G0 X0 Y0"]) + "\n"


@pytest.fixture
def job_file(tmp_path):
    p = tmp_path / "long.gcode"
    p.write_text(long_job_text())
    return p


@pytest.fixture
def fake():
    controllers = []

    def make(**kw):
        controllers.append(PtyController(**kw))
        return controllers[-1]

    yield make
    for c in controllers:
        c.close()


def assert_stopped_after(controller, t):
    """After time ``t`` the controller received ``!``, then 0x18, then ``M5 S0`` — and no
    job line after that; its beam is off."""
    data = controller.data(since=t)
    assert b"!" in data, data
    hold = data.index(b"!")
    reset = data.index(b"\x18", hold)
    m5 = data.index(b"M5 S0\n", reset)
    assert b"G1" not in data[m5:], "a job line was sent after the safe stop"
    assert controller.vm.laser_output() == 0
    return hold, reset, m5


def wait_burning(controller, lines=8):
    """Until ``lines`` job lines have arrived and the beam is on (the job is cutting)."""
    # generous: a fresh process compiles (or loads) the planner's kernels on the first line
    controller.wait_lines(lines, timeout_s=120)
    deadline = time.monotonic() + 120
    while controller.vm.laser_output() == 0:
        assert time.monotonic() < deadline, "the job never started burning"
        time.sleep(0.01)


def connect(controller):
    g = Grbl(open_link(controller.port))
    g.connect(0.3)
    return g


def start_cli(*args, **kw):
    return subprocess.Popen([sys.executable, "-c", MAIN, *map(str, args)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, **kw)


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_to_labkit_stream_stops_the_machine_first(fake, job_file, tmp_path, sig):
    controller = fake()
    log = tmp_path / "t.log"
    proc = start_cli("stream", job_file, "--port", controller.port, "--log", log)
    wait_burning(controller)
    t = time.monotonic()
    proc.send_signal(sig)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 1, err
    assert_stopped_after(controller, t)
    name = signal.Signals(sig).name
    assert f"fault: interrupted by {name}" in out
    assert "safe stop: feed hold; stopped (Hold:0); soft reset (buffers flushed, laser off); M5 S0" in out
    assert "resume with: labkit stream" in out and "--resume-from" in out
    # the transcript was written as the job ran, and ends with the stop and the report
    text = log.read_text()
    assert "> G1X60Y5.5" in text and "> <feed_hold>" in text and "> M5 S0" in text
    assert f"#   fault: interrupted by {name}" in text


def test_a_second_ctrl_c_does_not_skip_the_stop(fake, job_file):
    # the controller takes 1.5 s to come back from its reset: the second Ctrl-C falls inside
    # the safe stop, which goes on, and says so
    controller = fake(reset_delay_s=1.5)
    proc = start_cli("stream", job_file, "--port", controller.port)
    wait_burning(controller)
    t = time.monotonic()
    proc.send_signal(signal.SIGINT)
    deadline = time.monotonic() + 30
    while b"\x18" not in controller.data(since=t) and time.monotonic() < deadline:
        time.sleep(0.01)
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 1
    assert_stopped_after(controller, t)
    assert "SIGINT again — still stopping the machine safely" in err
    assert "soft reset (buffers flushed, laser off); M5 S0" in out


def test_an_exception_in_the_progress_callback_stops_the_machine(fake):
    controller = fake()
    g = connect(controller)
    job = Job.from_text(long_job_text(), machine="grbl-diode")
    calls = []

    def progress(executed, acked, total, eta_s):
        calls.append(time.monotonic())
        if len(calls) == 6:
            raise RuntimeError("the progress display broke")

    rep = run_job(g, job, progress=progress)
    g.close()
    assert not rep.ok and isinstance(rep.exception, RuntimeError)
    assert rep.fault == "stopped by an exception during the run: RuntimeError: the progress display broke"
    assert rep.safe_actions[-1] == "M5 S0"
    assert_stopped_after(controller, calls[-1])


def test_a_process_ending_under_a_job_in_a_thread_stops_it(fake, job_file):
    """A notebook kernel that closes while the panel streams: the job runs in a daemon thread
    and the interpreter exits; the exit hook cancels the job and waits for its safe stop."""
    controller = fake()
    script = textwrap.dedent("""
        import sys, threading, time
        from labkit.machine.grbl import Grbl
        from labkit.machine.link import open_link
        from labkit.machine.stream import Job, run_job

        g = Grbl(open_link(sys.argv[1]))
        g.connect(0.3)
        job = Job.from_file(sys.argv[2], machine="grbl-diode")
        threading.Thread(target=run_job, args=(g, job), daemon=True).start()
        while g.status is None or g.status.state != "Run":
            time.sleep(0.05)
        print("leaving", flush=True)
        time.sleep(0.5)
    """)
    proc = subprocess.Popen([sys.executable, "-c", script, controller.port, str(job_file)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "leaving"
    t = time.monotonic()
    proc.wait(timeout=60)
    assert proc.returncode == 0, proc.stderr.read()
    assert_stopped_after(controller, t)


def test_labkit_console_stops_the_machine_on_sigterm(fake):
    controller = fake()
    proc = subprocess.Popen([sys.executable, "-c", MAIN, "console", "--port", controller.port],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    proc.stdin.write("G1 X100 F300 M3 S300\n")
    proc.stdin.flush()
    wait_burning(controller, lines=1)                     # burning, as the line asked
    t = time.monotonic()
    proc.send_signal(signal.SIGTERM)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 1
    assert_stopped_after(controller, t)
    assert "interrupted by SIGTERM" in err and "safe stop: feed hold" in err


def test_labkit_console_quit_stops_the_machine(fake, monkeypatch, capsys):
    import io

    controller = fake()
    monkeypatch.setattr("sys.stdin", io.StringIO("G1 X100 F300 M3 S300\nquit\n"))
    t = time.monotonic()
    assert main(["console", "--port", controller.port]) == 0
    assert_stopped_after(controller, t)
    assert "M5 S0" in capsys.readouterr().err


def test_a_lost_link_names_the_lines_and_the_resume_command(fake, tmp_path, capsys):
    # ten quick lines, then slow ones; the cable goes once 20 answers have come back
    job_file = tmp_path / "job.gcode"
    quick = [f"G1 X{1 + k % 2} Y{0.1 * k:.1f}" for k in range(10)]
    job_file.write_text("G21 G90\nM4 S500 F3000\n" + "\n".join(quick) + "\n"
                        + long_job_text().split("\n", 2)[2])
    controller = fake(disconnect_after_oks=20)
    log = tmp_path / "t.log"
    assert main(["stream", str(job_file), "--port", controller.port, "--log", str(log)]) == 1
    out = capsys.readouterr().out
    assert "fault: link lost: disconnected from" in out
    assert NOT_TOLD in out
    # the report names both lines, and a resume command that runs every line not known to
    # have run (the controller may have gone further on its own buffer: said so)
    head = out.split("last acknowledged line ")[1]
    acked = int(head.split(",")[0])
    executed = int(head.split("last executed line ")[1].split()[0].rstrip(","))
    job = Job.from_file(job_file)
    assert acked == job.send[19][0]                       # 20 answers: 20 lines
    assert 3 <= executed < acked                          # some quick lines had run
    resume = next(ln for ln, _ in job.send if ln > executed)
    assert (f"resume with: labkit stream {job_file} --port {controller.port} --log {log}.resume "
            f"--resume-from {resume}") in out
    assert f"may have run after the last status report" in out
    # nothing could be sent after the link went: no hold claimed
    assert "feed hold" not in out
    # the transcript survived the disconnect, with every line sent before it
    text = log.read_text()
    for _, line in job.send[:20]:
        assert f"> {line}\n" in text
    assert "link lost" in text


@pytest.mark.parametrize("where", ["missing folder", "full disk"])
def test_an_unwritable_log_is_refused_before_anything_is_sent(fake, job_file, tmp_path, capsys,
                                                              where):
    controller = fake()
    log = tmp_path / "missing" / "t.log" if where == "missing folder" else "/dev/full"
    assert main(["stream", str(job_file), "--port", controller.port, "--log", str(log)]) == 1
    assert "nothing was sent" in capsys.readouterr().err
    time.sleep(0.2)
    assert controller.data() == b""


def test_labkit_console_says_when_the_link_is_gone(fake, monkeypatch, capsys):
    controller = fake(disconnect_after_lines=1)

    def typed():
        yield "G1 X100 F300 M3 S300\n"
        deadline = time.monotonic() + 120
        while controller.closed_at is None:              # the cable goes after that line
            assert time.monotonic() < deadline
            time.sleep(0.01)
        yield "?\n"
        yield "G0 X0\n"
        yield "quit\n"

    monkeypatch.setattr("sys.stdin", typed())
    assert main(["console", "--port", controller.port]) == 1
    err = capsys.readouterr().err
    assert "labkit console: disconnected from" in err
    assert f"safe stop: link lost (disconnected from {controller.port}" in err and NOT_TOLD in err
    assert b"G0 X0" not in controller.data()


def test_the_signal_handlers_are_the_callers_again_after_a_stream(fake):
    controller = fake()
    g = connect(controller)
    before = signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)
    seen = []

    def progress(*args):
        seen.append((signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)))

    rep = run_job(g, Job.from_text("G21 G90\nM4 S300 F3000\nG1 X2\nM5\n", machine="grbl-diode"),
                  progress=progress)
    g.close()
    assert rep.ok, rep.summary()
    # labkit's own, for both signals, during the stream
    assert seen and all(a != before[0] and b != before[1] for a, b in seen)
    assert (signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)) == before
