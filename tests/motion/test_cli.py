"""``labkit plan`` and ``labkit steps`` against the library they wrap."""

import json

import numpy as np
import pandas as pd
import pytest

from labkit.cli import main
from labkit.gcode import parse_file
from labkit.motion import plan, step_trace

GCODE = """G21 G90
M4 S500
G1 X1 Y0.5 F600
G1 X2 Y0.5
G2 X3 Y0.5 I0.5 J0
G4 P0.1
G0 X0 Y0
M5
"""


@pytest.fixture
def job(tmp_path):
    path = tmp_path / "job.gcode"
    path.write_text(GCODE)
    return path


@pytest.mark.parametrize("planner", ["junction", "fast", "normal", "hq"])
def test_plan_json_matches_the_library(job, planner, capsys, tmp_path):
    trace = tmp_path / "trace.csv"
    assert main(["plan", str(job), "--planner", planner, "--json", "--trace", str(trace)]) == 0
    out = json.loads(capsys.readouterr().out)
    ref = plan(parse_file(job), planner=planner).summary()
    assert out["job_time_s"] == pytest.approx(ref.job_time_s, rel=1e-12)
    assert (out["blocks"], out["super_blocks"], out["planner"]) == (ref.blocks, ref.super_blocks, planner)
    assert out["machine"] == "cbr40-laser"
    df = pd.read_csv(trace)
    assert df["line"].tolist() == [3, 4, 5, 6, 7]
    assert df["time_s"].sum() == pytest.approx(ref.job_time_s, rel=1e-6)
    assert df.columns.tolist()[:9] == ["block", "line", "kind", "super_block", "length_mm",
                                       "entry_mm_s", "peak_mm_s", "exit_mm_s", "cap_mm_s"]


def test_plan_text_report(job, capsys):
    assert main(["plan", str(job), "--machine", "grbl-diode", "--law", "linear", "--buffer", "4"]) == 0
    text = capsys.readouterr().out
    assert "grbl-diode" in text and "buffer 4 blocks" in text and "ramps: linear" in text
    assert "laser on" in text and "job time" in text


def test_steps_csv_is_the_step_trace(job, tmp_path, capsys):
    out = tmp_path / "steps.csv"
    assert main(["steps", str(job), "-o", str(out), "--planner", "normal"]) == 0
    df = pd.read_csv(out)
    ref = step_trace(plan(parse_file(job), planner="normal"))
    assert len(df) == len(ref)
    assert np.array_equal(df[["x", "y", "z"]].to_numpy(), ref.step)
    assert np.array_equal(df["cycle"].to_numpy(), ref.cycle)
    assert np.array_equal(df["dir"].to_numpy(), ref.dir_bits)
    assert "ticks" in capsys.readouterr().err


def test_errors_are_one_line(job, capsys):
    assert main(["plan", str(job), "--machine", "nope"]) == 1
    assert "unknown machine 'nope'" in capsys.readouterr().err
    assert main(["plan", str(job) + ".missing"]) == 1
    assert "no such file" in capsys.readouterr().err.lower()
    with pytest.raises(SystemExit):
        main(["plan", str(job), "--planner", "grbl"])


def test_plan_lenient_says_why_it_predicts_no_stalls(tmp_path, capsys):
    """--lenient plans around a line GRBL refuses (an arc whose end is off its circle: error 33),
    but a sender stops there, so the link prediction is left out with that reason, not a failure."""
    prog = tmp_path / "bad_arc.gcode"
    prog.write_text("G21 G90\nG1 X10 F600\nG3 X0 Y5 I-5 J0\nG1 X20\n")      # written by hand
    assert main(["plan", str(prog), "--lenient"]) == 0
    out = capsys.readouterr().out
    assert "not predicted: a sender would stop at line 3 (error 33" in out
    assert main(["plan", str(prog), "--lenient", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["stalls"] is None and "line 3" in doc["stall_prediction"] and doc["job_time_s"] > 0
    assert main(["plan", str(prog)]) == 1                  # without --lenient: the parse error itself


@pytest.mark.parametrize("machine,dialect,lenient,traced", [
    ("grbl-diode", "grbl", False, True),          # syncs on a grbl program: one traced reading
    ("grbl-diode", "grbl", True, False),          # lenient: the trace would not be the strict one
    ("grbl-diode", "labkit-fw", False, False),    # no sync lines in that dialect: no trace read
    ("no-sync", "grbl", False, False)])           # a machine that does not sync
def test_plan_reads_the_program_once_and_traced_only_where_sync_lines_come_from_it(
        job, monkeypatch, machine, dialect, lenient, traced):
    import argparse
    import dataclasses

    import labkit.gcode as gcode
    from labkit.commands import motion as cmd
    from labkit.motion.spec import load_machine
    from labkit.motion.stall import controller_sync_lines

    if machine == "no-sync":
        machine = dataclasses.replace(load_machine("grbl-diode"), laser_change_syncs=False)

    calls = []
    real = gcode.parse_with_states
    monkeypatch.setattr(gcode, "parse_with_states", lambda *a, **k: calls.append(1) or real(*a, **k))
    args = argparse.Namespace(file=str(job), machine=machine, dialect=dialect, lenient=lenient)
    moves, sync = cmd._read_program(args)
    assert bool(calls) == traced
    ref = parse_file(job, dialect=dialect, lenient=lenient)
    assert np.array_equal(moves.end, ref.end) and np.array_equal(moves.laser, ref.laser)
    assert sync.tolist() == controller_sync_lines(job.read_bytes(), machine, dialect).tolist()
