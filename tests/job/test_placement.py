"""A job placed at the current position (LightBurn's "Current Position"): the program zeroes XY where
the head stands with G92 X0 Y0 and clears it with G92.1; on the virtual machine, started with the head
at (30, 20), the cut lands at (30, 20) + the offset, and the controller's offset is gone afterwards.
The SVG and the job file are written by hand below."""

import json
from pathlib import Path

import numpy as np
import pytest

from labkit.cli import main
from labkit.errors import InputError
from labkit.jobfile import compose_job, read_job
from labkit.machine import Grbl, Job, run_job
from labkit.machine.link import Link
from labkit.machine.virtual import VirtualMachine, burn_coverage

SVG = ('<svg xmlns="http://www.w3.org/2000/svg" width="60mm" height="60mm" viewBox="0 0 60 60">'
       '<rect x="20" y="20" width="10" height="5" fill="none" stroke="#000"/></svg>')
JOB = """format = "labkit-job"
version = 1
machine = "grbl-diode"
[placement]
start_from = "{start}"
offset_mm = [1.0, 2.0]
[[layer]]
source = "r.svg"
operation = "cut"
power_mw = 1000
speed_mm_min = 600
"""


@pytest.fixture()
def folder(tmp_path):
    (tmp_path / "r.svg").write_text(SVG)
    (tmp_path / "j.toml").write_text(JOB.format(start="current"))
    return tmp_path


def test_the_program_zeroes_where_the_head_stands_and_clears_it_after(folder, capsys):
    assert main(["job", str(folder / "j.toml"), "-o", str(folder / "j.gcode")]) == 0
    lines = [ln for ln in (folder / "j.gcode").read_text().splitlines() if not ln.startswith(";")]
    motion = [i for i, ln in enumerate(lines) if ln.startswith(("G0", "G1"))]
    assert lines.index("G92 X0 Y0") < motion[0] and lines.index("G92.1") > motion[-1]
    assert lines[-3:] == ["G92.1", "M5", "M2"]
    # the rectangle's lower-left corner goes to the offset from the head: (1, 2), upper right (11, 7)
    assert "G0 X1 Y2" in lines and "X11" in lines and "G1 Y7 F600" in lines
    rec = json.loads((folder / "j.gcode.record.json").read_text())
    assert rec["placement"]["start_from"] == "current" and rec["placement"]["offset_mm"] == [1.0, 2.0]
    assert "G92 X0 Y0" in rec["placement"]["how"]
    assert "placed" in capsys.readouterr().out
    assert main(["record", "show", str(folder / "j.gcode.record.json")]) == 0
    assert "placed  current" in capsys.readouterr().out


def test_on_the_virtual_machine_from_a_non_zero_position(folder):
    assert main(["job", str(folder / "j.toml"), "-o", str(folder / "j.gcode"), "--no-record"]) == 0
    vm = VirtualMachine("grbl-diode", time_scale=0, tick_s=0.05)
    g = Grbl(Link(vm, "test"))
    g.connect()
    assert run_job(g, Job.from_text("G21 G90\nG0 X30 Y20\n", machine="grbl-diode")).ok
    assert vm.pos[:2] == pytest.approx((30, 20))
    job = Job.from_text((folder / "j.gcode").read_text(), machine="grbl-diode")
    rep = run_job(g, job)
    assert rep.ok, rep.summary()
    burned = [p for p in vm.executed if p.power > 0]
    xy = np.array([np.r_[p.start[:2], p.end[:2]] for p in burned]).reshape(-1, 2)
    # machine coordinates: the head's (30, 20) + the offset (1, 2), 10 x 5 mm
    assert xy.min(axis=0) == pytest.approx((31, 22), abs=1e-3)
    assert xy.max(axis=0) == pytest.approx((41, 27), abs=1e-3)
    covered, doubled, stray, lengths = burn_coverage(job.moves, vm, origin_mm=(30, 20))
    np.testing.assert_allclose(covered, lengths, atol=1e-3)
    assert stray < 1e-3
    assert vm.g92 == pytest.approx((0, 0, 0))          # G92.1: the next job runs in the coordinates it expects


def test_origin_and_absolute_write_no_g92(folder):
    for start in ("origin", "absolute"):
        (folder / "j.toml").write_text(JOB.format(start=start))
        assert main(["job", str(folder / "j.toml"), "-o", str(folder / "j.gcode"), "--no-record"]) == 0
        assert "G92" not in (folder / "j.gcode").read_text()


def test_an_unknown_placement_is_named(folder):
    (folder / "j.toml").write_text(JOB.format(start="here"))
    with pytest.raises(InputError, match='start_from = \'here\'; expected one of "absolute", "origin", "current"'):
        read_job(folder / "j.toml")


def test_compose_current_starts_from_the_origin_it_makes(folder):
    composed = compose_job(read_job(folder / "j.toml"))
    assert composed.moves.start[0][:2] == pytest.approx((0, 0))
    assert [r.text for r in composed.moves.records] == ["G92 X0 Y0", "G92.1"]
