"""labkit ports / stream / console on the virtual machine."""

import io

import pytest

from labkit.cli import main

JOB = "G21 G90\nM4 S500 F1200\nG0 X5 Y5\nG1 X20\nG1 Y10\nG1 X5\nM5\nG0 X0 Y0\n"


@pytest.fixture
def job(tmp_path):
    p = tmp_path / "job.gcode"
    p.write_text(JOB)
    return p


def test_stream_to_the_virtual_machine(job, tmp_path, capsys):
    log = tmp_path / "t.log"
    assert main(["stream", str(job), "--log", str(log)]) == 0
    out = capsys.readouterr().out
    assert out.startswith("completed: 8/8 lines acknowledged")
    text = log.read_text().splitlines()
    assert any(l.split()[1:] == [">", "G1X20"] for l in text)
    assert any(l.split()[1:] == ["<", "ok"] for l in text)


def test_stream_fault_exits_non_zero(tmp_path, capsys):
    p = tmp_path / "far.gcode"
    # GRBL ships soft limits off ($20=0), so the default machine takes a move beyond its
    # travel; a line the controller rejects is the fault here
    p.write_text("G21 G90\nM4 S100 F600\nG1 X10\n$Q\nG1 X20\n")
    assert main(["stream", str(p)]) == 1
    out = capsys.readouterr().out
    # GRBL answers a $ line while it moves with error:8 before reading it (transcript errors 154-167)
    assert "STOPPED" in out and "line 4: error:8" in out and "last executed line" in out


def test_stream_resume_and_check_first(job, capsys):
    assert main(["stream", str(job), "--resume-from", "5", "--check-first",
                 "--mode", "send-response"]) == 0
    assert "completed" in capsys.readouterr().out


def test_stream_refuses_bad_input(tmp_path, capsys, job):
    bad = tmp_path / "bad.gcode"
    bad.write_text("G1 X1 X2 F100\n")
    assert main(["stream", str(bad)]) == 1
    assert "bad.gcode:1:7: error 25" in capsys.readouterr().err
    assert main(["stream", str(tmp_path)]) == 1
    assert main(["stream", str(job), "--log", str(job)]) == 1
    err = capsys.readouterr().err
    assert "labkit stream:" in err
    with pytest.raises(SystemExit):
        main(["stream", str(job), "--baud", "inf"])


def test_stream_missing_port(job, capsys):
    assert main(["stream", str(job), "--port", "/dev/ttyLABKIT_NONE"]) == 1
    assert "does not exist" in capsys.readouterr().err


def test_ports_runs(capsys):
    assert main(["ports", "--all"]) == 0
    capsys.readouterr()


def test_console(monkeypatch, capsys):
    monkeypatch.setattr("sys.stdin", io.StringIO("$I\nG1 X1 F100\n?\nquit\n"))
    assert main(["console"]) == 0
    out = capsys.readouterr().out
    assert "connected: Grbl 1.1h" in out and "< [OPT:V,15,128]" in out and "< <" in out


def test_console_explains_a_line_the_interpreter_rejects(monkeypatch, capsys):
    # typed line 2 repeats X (GRBL's error 25 at the second X, column 7); it is still sent,
    # and the virtual GRBL answers error:25 itself; the state is kept from line to line
    # (line 3's G1 takes its feed from line 1)
    monkeypatch.setattr("sys.stdin", io.StringIO("G1 X1 F100\nG1 X1 X2\nX3\nquit\n"))
    assert main(["console"]) == 0
    out = capsys.readouterr().out
    assert "labkit reads it as <console>:2:7: error 25: a word is repeated" in out
    assert "< error:25" in out and out.count("labkit reads it") == 1


def test_stream_progress_is_a_tqdm_bar():
    from labkit.commands.machine import _Progress

    progress = _Progress(10)
    assert type(progress.bar).__module__.startswith("tqdm")
    progress(3, 5, 10, 12.0)
    assert progress.bar.n == 5 and "ETA 12 s" in progress.bar.postfix
    progress.close()
