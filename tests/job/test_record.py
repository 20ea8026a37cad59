"""Provenance records (labkit.record, --record on the converters and labkit stream, labkit record
show|diff), checked against hashes computed here, a job time worked by hand and the stream's own
report."""

import hashlib
import json

import pytest

from labkit.cli import main
from labkit.errors import InputError
from labkit.record import diff_records, read_record

SVG = ('<svg xmlns="http://www.w3.org/2000/svg" width="40mm" height="30mm" viewBox="0 0 40 30">'
       '<rect x="5" y="5" width="30" height="20" fill="none" stroke="#000"/></svg>')   # written by hand


def _run(capsys, *argv):
    code = main([*map(str, argv)])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture
def svg(tmp_path, monkeypatch):
    monkeypatch.setenv("LABKIT_CONFIG_DIR", str(tmp_path / "cfg"))
    p = tmp_path / "card.svg"
    p.write_text(SVG)
    return p


def test_program_record_holds_hashes_options_and_the_planned_time(svg, tmp_path, capsys):
    out = tmp_path / "card.gcode"
    code, text, err = _run(capsys, "svg2gcode", svg, "-o", out, "--feed", 600, "--power", 500, "--record")
    assert code == 0, err
    rec = read_record(tmp_path / "card.gcode.record.json")
    assert rec["kind"] == "program" and rec["command"] == "svg2gcode" and rec["version"] == 1
    (inp,) = rec["inputs"]
    assert inp["sha256"] == hashlib.sha256(svg.read_bytes()).hexdigest() and inp["bytes"] == len(SVG)
    assert rec["outputs"][0]["sha256"] == hashlib.sha256(out.read_bytes()).hexdigest()
    assert rec["options"]["feed"] == 600 and rec["options"]["power"] == 500 and rec["material"] is None
    assert rec["machine"]["name"] == "cbr40-laser" and rec["machine"]["laser_max_power_mw"] == 2500
    # by hand: a 100 mm outline at 600 mm/min is 10 s; the rapid from the origin to (5, 5) is
    # sqrt(50) mm at the summary's 6000 mm/min
    planned = rec["planned"]
    assert planned["laser_on_time_s"] == pytest.approx(10.0, abs=1e-6)
    assert planned["estimated_time_s"] == pytest.approx(10.0 + 50 ** 0.5 / 100, abs=1e-6)


def test_record_names_the_material_and_its_fit(svg, tmp_path, capsys):
    assert _run(capsys, "materials", "add", "card", "--power-mw", 1250, "--speed", 600, "--kerf", 0.2)[0] == 0
    rec_path = tmp_path / "r.json"
    assert _run(capsys, "svg2gcode", svg, "-o", tmp_path / "a.gcode", "--material", "card", "--record",
                rec_path)[0] == 0
    mat = read_record(rec_path)["material"]
    lib = tmp_path / "cfg" / "materials" / "cbr40-laser.toml"
    assert mat["spec"] == "card:cut" and mat["entry"]["power_mw"] == 1250 and mat["entry"]["origin"] == "typed"
    assert mat["library"]["sha256"] == hashlib.sha256(lib.read_bytes()).hexdigest()


def test_diff_names_what_changed(svg, tmp_path, capsys):
    for name, feed in (("a", 600), ("b", 900), ("c", 600)):
        assert _run(capsys, "svg2gcode", svg, "-o", tmp_path / "x.gcode", "--feed", feed,
                    "--record", tmp_path / f"{name}.json")[0] == 0
    a, b, c = (read_record(tmp_path / f"{n}.json") for n in "abc")
    keys = {k for k, _, _ in diff_records(a, b)}
    assert {"options.feed", "planned.laser_on_time_s", "outputs.program.sha256"} <= keys
    assert not any(k.startswith(("inputs.", "machine.")) for k in keys)
    assert diff_records(a, c) == []                      # the same burn made twice
    code, out, _ = _run(capsys, "record", "diff", tmp_path / "a.json", tmp_path / "b.json")
    assert code == 1 and "options.feed" in out and "600.0  →  900.0" in out
    code, out, _ = _run(capsys, "record", "diff", tmp_path / "a.json", tmp_path / "c.json")
    assert code == 0 and "the same" in out
    code, out, _ = _run(capsys, "record", "show", tmp_path / "a.json")
    assert code == 0 and "labkit svg2gcode" in out and "planned 10.1 s" in out


def test_stream_writes_a_record_by_default(tmp_path, capsys):
    job = tmp_path / "job.gcode"
    job.write_text("G21 G90\nM4 S500 F1200\nG0 X5 Y5\nG1 X20\nG1 Y10\nG1 X5\nM5\nG0 X0 Y0\n")   # by hand
    code, out, err = _run(capsys, "stream", job)
    assert code == 0, err
    (path,) = tmp_path.glob("job.gcode.stream-*.record.json")
    rec = read_record(path)
    s = rec["stream"]
    assert s["ok"] and s["lines_total"] == 8 and s["lines_acknowledged"] == 8 and s["fault"] is None
    assert s["started"] <= s["ended"] and s["summary"].startswith("completed: 8/8")
    assert rec["inputs"][0]["sha256"] == hashlib.sha256(job.read_bytes()).hexdigest()
    assert f"record: {path}" in out
    assert _run(capsys, "stream", job, "--no-record")[0] == 0
    assert len(list(tmp_path.glob("*.record.json"))) == 1


def test_stream_record_keeps_the_fault(tmp_path, capsys):
    job = tmp_path / "far.gcode"
    # line 4 is refused: a $ command while the head moves is GRBL's error:8 (recorded from GRBL 1.1h)
    job.write_text("G21 G90\nM4 S100 F600\nG1 X10\n$Q\nG1 X20\n")
    code, out, _ = _run(capsys, "stream", job, "--record", tmp_path / "r.json")
    assert code == 1
    s = read_record(tmp_path / "r.json")["stream"]
    assert not s["ok"] and s["errors"][0][:2] == [4, 8]
    assert s["resume_line"] and f"--resume-from {s['resume_line']}" in s["summary"]
    code, out, _ = _run(capsys, "record", "show", tmp_path / "r.json")
    assert "STOPPED" in out and "line 4: error:8" in out


def test_bad_records_are_clear_errors(tmp_path, capsys):
    p = tmp_path / "r.json"
    p.write_text(json.dumps({"format": "labkit-record", "version": 7}))
    with pytest.raises(InputError, match="record version 7; this labkit reads version 1"):
        read_record(p)
    p.write_text("{")
    code, _, err = _run(capsys, "record", "show", p)
    assert code == 1 and "not JSON" in err
    p.write_text("[]")
    code, _, err = _run(capsys, "record", "show", p)
    assert code == 1 and "not a labkit record" in err
    job = tmp_path / "job.gcode"
    job.write_text("G0 X1\n")
    code, _, err = _run(capsys, "stream", job, "--record", job)
    assert code == 1 and "--record" in err


def test_rerun_makes_the_recorded_program_again(svg, tmp_path, capsys, monkeypatch):
    """A record is enough to make its program again: the command line it holds, run on inputs
    with the recorded hashes, writes the recorded bytes; a changed input is refused."""
    monkeypatch.chdir(tmp_path)
    code, _, err = _run(capsys, "svg2gcode", "card.svg", "-o", "card.gcode", "--feed", 600,
                        "--record", "card.json")
    assert code == 0, err
    rec = read_record(tmp_path / "card.json")
    assert rec["argv"] == ["svg2gcode", "card.svg", "-o", "card.gcode", "--feed", "600", "--record", "card.json"]
    assert "_argv" not in rec["options"]
    code, text, err = _run(capsys, "record", "rerun", "card.json", "-o", "again.gcode")
    assert code == 0 and "byte for byte" in text, err
    assert (tmp_path / "again.gcode").read_bytes() == (tmp_path / "card.gcode").read_bytes()
    assert not (tmp_path / "again.gcode.record.json").exists()      # the rerun writes no record
    # a record whose program another labkit wrote (its hash is not what this one writes)
    other = json.loads((tmp_path / "card.json").read_text())
    other["outputs"][0]["sha256"] = hashlib.sha256(b"another program").hexdigest()
    (tmp_path / "other.json").write_text(json.dumps(other))
    code, text, _ = _run(capsys, "record", "rerun", "other.json", "-o", "again.gcode")
    assert code == 1 and "differs from the recorded program" in text
    # an input changed since: refused, nothing written
    (tmp_path / "card.svg").write_text(SVG.replace('width="30"', 'width="31"'))
    code, _, err = _run(capsys, "record", "rerun", "card.json", "-o", "third.gcode")
    assert code == 1 and "card.svg has changed since the record" in err
    assert not (tmp_path / "third.gcode").exists()
    code, _, err = _run(capsys, "record", "rerun", "card.json", "-o", "card.gcode")
    assert code == 1 and "recorded program itself" in err
    # a record without its command line cannot be rerun
    del rec["argv"]
    (tmp_path / "old.json").write_text(json.dumps(rec))
    code, _, err = _run(capsys, "record", "rerun", "old.json", "-o", "x.gcode")
    assert code == 1 and "command line" in err


def test_rerun_a_job_that_records_by_default(svg, tmp_path, capsys, monkeypatch):
    """`labkit job` writes its record unasked; its rerun must not write one beside the new program."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "card.toml").write_text('format = "labkit-job"\nversion = 1\nmachine = "cbr40-laser"\n\n[[layer]]\nsource = "card.svg"\n'
                                        'operation = "cut"\npower_mw = 1200.0\nspeed_mm_min = 600.0\n')
    code, _, err = _run(capsys, "job", "card.toml", "-o", "card.gcode")
    assert code == 0, err
    records = sorted(p.name for p in tmp_path.glob("*.record.json"))
    assert len(records) == 1
    code, text, err = _run(capsys, "record", "rerun", records[0], "-o", "again.gcode")
    assert code == 0 and "byte for byte" in text, err
    assert sorted(p.name for p in tmp_path.glob("*.record.json")) == records
