"""The command line: every command reachable, messages on stderr, exit statuses."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

from labkit.cli import COMMANDS, main

DATA = Path(__file__).resolve().parents[1] / "data" / "gcode" / "cncjs"


def test_help_lists_every_command(capsys):
    assert main([]) == 2
    out = capsys.readouterr().out
    for name in COMMANDS:
        assert name in out


def test_check_ok_and_errors(capsys, tmp_path):
    assert main(["check", str(DATA / "jsdc-laser.gcode")]) == 0
    assert "ok, 2418 lines, 2371 moves" in capsys.readouterr().err
    bad = tmp_path / "bad.gcode"
    bad.write_text("G1 X1 F100\nG1 X2 X3\nG2 X1 Y1 R0.1\n")
    assert main(["check", str(bad)]) == 1
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith(f"{bad}:2:7: error 25: ")
    assert out[1].startswith(f"{bad}:3:1") or out[1].startswith(f"{bad}:3:")
    assert len(out) == 2


def test_check_with_envelope(capsys):
    path = str(DATA / "jsdc-laser.gcode")
    assert main(["check", path, "--envelope", "50x50"]) == 1
    assert "error 102: move leaves the machine envelope" in capsys.readouterr().out


def test_info_text_and_json(capsys):
    path = str(DATA / "tball-engrave-laser.gcode")
    assert main(["info", path]) == 0
    text = capsys.readouterr().out
    assert "lines           3455" in text and "cut length" in text
    assert main(["info", path, "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["source_lines"] == 3455 and data["counts"]["line"] == 3422
    # This jscut file switches the laser on with "M3 S0": in laser mode the beam never burns.
    assert data["cut_length_mm"] == 0 and data["travel_length_mm"] > 0
    assert main(["info", str(DATA / "jsdc-laser.gcode"), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["cut_length_mm"] > 0 and data["estimated_time_s"] > data["laser_on_time_s"]


def test_info_fails_cleanly_on_bad_file(capsys):
    assert main(["info", str(DATA / "Circle_Diamond_Square_Calibration.gcode")]) == 1
    err = capsys.readouterr().err
    assert err.startswith("labkit info: ") and ":624:6: error 33" in err
    assert "Traceback" not in err
    assert main(["info", "/no/such/file.gcode"]) == 1
    assert "no such file; expected an existing G-code file" in capsys.readouterr().err


def test_preview_writes_a_png(tmp_path, capsys):
    out = tmp_path / "p.png"
    assert main(["preview", str(DATA / "jsdc-laser.gcode"), "-o", str(out)]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and out.stat().st_size > 10_000


def test_python_dash_m_and_console_script_entry():
    done = subprocess.run([sys.executable, "-m", "labkit", "--version"], capture_output=True, text=True)
    assert done.returncode == 0 and done.stdout.startswith("labkit ")


def test_unknown_command_is_a_usage_error():
    with pytest.raises(SystemExit) as info:
        main(["frobnicate"])
    assert info.value.code == 2


@pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="counts threads in /proc")
def test_a_command_runs_one_blas_thread_unless_the_user_asks(tmp_path):
    # OpenBLAS starts its thread pool at numpy's import and its idle threads spin (~0.1 s of CPU
    # a command for nothing): a command starts none. Counted by the kernel's own thread list;
    # a user's OPENBLAS_NUM_THREADS still wins.
    import os

    script = ("import os, sys\nfrom labkit.cli import main\n"
              f"assert main(['check', {str(DATA / 'jsdc-laser.gcode')!r}]) == 0\n"
              "assert 'numpy' in sys.modules\nprint(len(os.listdir('/proc/self/task')))\n")
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    env["LABKIT_JIT"] = "python"            # numba's own threads are not the question here
    ours = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True,
                          check=True)
    assert ours.stdout.split()[-1] == "1"
    if (os.cpu_count() or 1) > 1:
        theirs = subprocess.run([sys.executable, "-c", script], env={**env, "OPENBLAS_NUM_THREADS": "2"},
                                capture_output=True, text=True, check=True)
        assert int(theirs.stdout.split()[-1]) > 1
