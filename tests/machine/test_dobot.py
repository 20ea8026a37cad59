"""Dobot Magician protocol (seed 003) against the emulator and hand-worked frames."""

import struct
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from labkit.errors import MachineError
from labkit.gcode import parse
from labkit.machine.dobot import (
    CMD,
    Dobot,
    DobotEmulator,
    FrameReader,
    canvas_to_robot,
    check_reach,
    frame,
    job_commands,
)


def test_get_pose_frame_matches_the_protocol_document():
    assert frame(10) == bytes.fromhex("AAAA020A00F6")


def test_ptp_frame_layout():
    f = frame(84, struct.pack("<B4f", 2, 250.0, 0.0, -10.0, 0.0), write=True, queued=True)
    assert f[:2] == b"\xAA\xAA" and f[2] == 2 + 17 and f[3] == 84 and f[4] == 0b11
    assert (f[3] + f[4] + sum(f[5:-1]) + f[-1]) % 256 == 0


@settings(max_examples=80, deadline=None)
@given(st.lists(st.tuples(st.binary(max_size=12).map(lambda b: b.replace(b"\xAA", b"\x00")),
                          st.integers(0, 255), st.binary(max_size=40)), max_size=6),
       st.integers(1, 7))
def test_reader_resynchronises_after_garbage(parts, chunk):
    stream = b"".join(g + frame(i, p) for g, i, p in parts)
    r = FrameReader()
    got = []
    for k in range(0, len(stream), chunk):
        got += r.feed(stream[k:k + chunk])
    assert [(f.cmd_id, f.params) for f in got] == [(i, p) for _, i, p in parts]


def test_bad_checksum_frame_is_dropped_and_next_frame_survives():
    bad = bytearray(frame(84, b"\x01\x02"))
    bad[-1] ^= 0xFF
    r = FrameReader()
    got = r.feed(bytes(bad) + frame(10))
    assert [f.cmd_id for f in got] == [10] and r.bad_checksums == 1


def test_queue_index_is_uint64():
    emu = DobotEmulator()
    emu.next_index = 2 ** 32 + 5            # a 4-byte reader would answer 5
    bot = Dobot(emu)
    assert bot.queued(CMD["ptp"], struct.pack("<B4f", 2, 250, 0, 0, 0)) == 2 ** 32 + 5


def test_transform_and_reach_hand_worked():
    assert canvas_to_robot(0, 0) == (300.0, 100.0)
    assert canvas_to_robot(50, -20) == (320.0, 50.0)
    # (0, 0) on the canvas is 316.2 mm from the base: inside the 170-320 mm annulus
    check_reach(parse("G0 X0 Y0\nG1 X10 Y10 F600\n"))
    # canvas y' = 100 puts the pen at X = 200, x' = 100 at Y = 0: 200 mm, fine; y' = 150 → 150 mm
    with pytest.raises(MachineError, match=r"<string>:2: the arm cannot reach.*150\.0 mm"):
        check_reach(parse("G0 X100 Y100\nG1 Y150 F600\n"))
    # a line whose ends are reachable but which passes too near the base is refused
    with pytest.raises(MachineError, match="cannot reach"):
        check_reach(parse("G0 X100 Y290\nG1 X-150 Y40 F600\n"))


def test_nothing_moves_when_out_of_reach():
    emu = DobotEmulator()
    with pytest.raises(MachineError, match="cannot reach"):
        Dobot(emu).run(job_commands(parse("G0 X0 Y0\nG1 X0 Y400 F600\n")))
    assert emu.frames == 0


def test_arc_uses_the_mid_arc_point_and_power_scales():
    m = parse("G0 X10 Y0\nM3 S128\nG3 X-10 Y0 I-10 J0 F600\nM5\n", dialect="labkit-fw")
    cmds = job_commands(m)
    kinds = [c[0] for c in cmds]
    assert kinds == [CMD["laser"], CMD["ptp"], CMD["io_pwm"], CMD["laser"], CMD["arc"],
                     CMD["laser"]]
    pwm = struct.unpack("<Bff", cmds[2][1])
    assert pwm[2] == pytest.approx(128 * 100 / 255, rel=1e-6)          # float32 on the wire
    arc = struct.unpack("<8f", cmds[4][1])
    # CCW half circle (10,0) → (-10,0) about the origin passes (0, 10): robot (290, 100)
    assert arc[:2] == pytest.approx((290.0, 100.0))
    assert arc[4:6] == pytest.approx(canvas_to_robot(-10, 0))


def test_full_circle_is_split_in_two_arcs():
    m = parse("G0 X30 Y20\nM3 S255\nG2 X30 Y20 I-10 J0 F600\n", dialect="labkit-fw")
    arcs = [struct.unpack("<8f", p) for c, p, _ in job_commands(m) if c == CMD["arc"]]
    assert len(arcs) == 2
    assert arcs[0][4:6] == pytest.approx(canvas_to_robot(10, 20))
    assert arcs[1][4:6] == pytest.approx(canvas_to_robot(30, 20))
    # clockwise from the rightmost point the first half passes below the centre, (20, 10)
    assert arcs[0][:2] == pytest.approx(canvas_to_robot(20, 10))


def test_job_runs_on_the_emulator_and_ends_laser_off():
    text = "G0 X0 Y0\nM3 S200\n" + "".join(f"G1 X{5 * (k % 2)} Y{k} F600\n" for k in range(30))
    m = parse(text + "M5\nG0 X0 Y0\n", dialect="labkit-fw")
    cmds = job_commands(m)
    emu = DobotEmulator(per_poll=2)
    last = Dobot(emu).run(cmds, ahead=8)
    assert last == len(cmds) - 1
    assert [(f.cmd_id, f.params) for f in emu.executed] == [(c, p) for c, p, _ in cmds]
    assert emu.laser_on is False and emu.reader.bad_checksums == 0
    assert emu.pose[:2] == pytest.approx(canvas_to_robot(0, 0))


def test_cancel_force_stops_and_switches_the_laser_off():
    m = parse("G0 X0 Y0\nM3 S200\n" + "".join(f"G1 X{k % 7} Y{k % 5} F600\n" for k in range(60)),
              dialect="labkit-fw")
    emu = DobotEmulator(per_poll=1)
    with pytest.raises(MachineError, match="cancelled"):
        Dobot(emu).run(job_commands(m), ahead=4, cancel=lambda: len(emu.executed) > 10)
    assert emu.laser_on is False and emu.running is False and emu.queue == []


def test_cli_dobot_on_the_emulator(tmp_path, capsys):
    from labkit.cli import main

    p = tmp_path / "draw.gcode"
    p.write_text("G0 X0 Y0\nM3 S500\nG1 X20 Y0 F600\nG2 X20 Y20 I0 J10\nM5\n")
    assert main(["stream", str(p), "--protocol", "dobot"]) == 0
    note, done, record = capsys.readouterr().out.splitlines()
    assert note == ("note: F is not sent to the Dobot: the arm draws at the speed set on it (its "
                    "PTP and ARC parameters), not at the job's F600 mm/min")
    # laser off + rapid, PWM + laser on + line, the arc, the closing laser off
    assert done.startswith("completed: 7 commands queued and executed (last queue index 6)")
    assert record.startswith("record: ") and Path(record[8:]).is_file()      # on by default, as for GRBL


# -- issue 25 §5: what the arm would not draw as written is refused, naming the line ------------

def test_s_above_full_power_is_refused_before_anything_moves():
    text = "G0 X0 Y20\nM3 S800\nG1 X10 F600\nG1 X20 S5000\nM5\n"
    # grbl's full power is S1000 ($30's default): S5000 would be a PWM duty of 500 %
    with pytest.raises(MachineError, match=r"^<string>:4: S5000 is above full laser power "
                                           r"S1000: it would be sent as a PWM duty of 500 %"):
        job_commands(parse(text))
    # the S of full power the program was written for: S5000 is then 100 %
    cmds = job_commands(parse(text), s_max=5000)
    duties = [struct.unpack("<Bff", p)[2] for c, p, _ in cmds if c == CMD["io_pwm"]]
    assert duties == pytest.approx([16.0, 100.0])
    with pytest.raises(MachineError, match="s_max must be a finite number > 0"):
        job_commands(parse(text), s_max=float("nan"))


def test_job_commands_given_text_names_the_argument():
    from labkit.errors import InputError

    with pytest.raises(InputError, match="^moves must be a labkit.toolpath.Moves, got str; G-code "
                                         "text becomes Moves with labkit.gcode.parse"):
        job_commands("G0 X0 Y20\nG1 X10 F600\n")


def test_s_above_full_power_off_the_beam_is_not_refused():
    # S is only sent while burning: a rapid carrying S5000 with M5 in effect burns nothing
    cmds = job_commands(parse("G0 X0 Y20 S5000\nM3 S100\nG1 X10 F600\nM5\n"))
    duties = [struct.unpack("<Bff", p)[2] for c, p, _ in cmds if c == CMD["io_pwm"]]
    assert duties == pytest.approx([10.0])            # the cut's S100 of S1000; S5000 never sent


def test_z_motion_is_refused_naming_the_line():
    with pytest.raises(MachineError, match=r"^<string>:3: the Dobot draws in one plane .* from "
                                           r"Z0 to Z5 mm: remove the Z words"):
        job_commands(parse("G0 X0 Y20\nM3 S100\nG1 X10 Z5 F600\n"))


def test_real_router_file_with_z_plunges_is_refused_at_its_first_plunge():
    # a Shapeoko calibration file from cncjs (a real tool's output): its line N4 is G1 Z-1. Its
    # first 300 lines (line 624 is an arc GRBL itself refuses with error 33)
    from pathlib import Path

    name = "Circle_Diamond_Square_Calibration.gcode"
    corpus = Path(__file__).resolve().parents[2] / "data" / "gcode" / "cncjs"
    text = (corpus / name).read_text().splitlines(keepends=True)[:300]
    with pytest.raises(MachineError, match=rf"^{name}:4: the Dobot draws in one plane .* from "
                                           r"Z0 to Z-1 mm"):
        job_commands(parse("".join(text), filename=name))


@pytest.mark.parametrize("plane, arc, name", [("G18", "X20 I5 K0", r"XZ \(G18\)"),
                                              ("G19", "Y30 J5 K0", r"YZ \(G19\)")])
def test_arcs_outside_the_xy_plane_are_refused(plane, arc, name):
    # half circles that start and end at Z0 but leave the drawing plane on the way
    text = f"G0 X10 Y20\nM3 S100\n{plane}\nG2 {arc} F600\n"
    with pytest.raises(MachineError, match=rf"^<string>:4: an arc in the {name} plane leaves the "
                                           r"drawing plane"):
        job_commands(parse(text))


class _Liar(DobotEmulator):
    """The emulator with one answer changed: ``short`` answers GetQueuedCmdCurrentIndex with two
    bytes; ``ahead_by`` reports that many commands more executed than were queued; ``repeat``
    gives every queued command the same index."""

    def __init__(self, *, short=False, ahead_by=0, repeat=False, restart_at=None):
        super().__init__(per_poll=1)
        self.short, self.ahead_by, self.repeat = short, ahead_by, repeat
        self.restart_at = restart_at

    def _answer(self, f, params=b""):
        if f.cmd_id == CMD["queue_index"] and self.short:
            params = params[:2]
        elif f.cmd_id == CMD["queue_index"] and self.restart_at is not None:
            if self.done_index >= self.restart_at:
                params = struct.pack("<Q", 0)      # as if it had been power-cycled
        elif f.cmd_id == CMD["queue_index"] and self.ahead_by:
            params = struct.pack("<Q", self.next_index - 1 + self.ahead_by)
        elif f.queued and self.repeat:
            params = struct.pack("<Q", 7)
        super()._answer(f, params)


def _job():
    return job_commands(parse("G0 X0 Y20\nM3 S200\n" + "".join(
        f"G1 X{10 * (k % 2)} Y{20 + k} F600\n" for k in range(30)) + "M5\n"))


@pytest.mark.parametrize("liar, words", [
    (dict(short=True), r"^protocol error: the Dobot answered command 246 with 2 parameter bytes, "
                       r"expected 8"),
    (dict(ahead_by=3), r"^protocol error: the Dobot reports queue index \d+ executed, but the "
                       r"last command queued has index \d+"),
    (dict(restart_at=12), r"^protocol error: the Dobot's executed queue index went back from "
                          r"\d+ to 0 \(did it restart\?\)"),
])
def test_bad_queue_index_answers_are_protocol_errors_and_the_arm_is_stopped(liar, words):
    # a 2-byte index reply used to raise struct.error; an index beyond the last one queued
    # used to count as completion
    arm = _Liar(**liar)
    bot = Dobot(arm)
    with pytest.raises(MachineError, match=words):
        bot.run(_job(), ahead=4)
    assert bot.last_stop.laser_off_confirmed and not arm.laser_on and arm.queue == []


def test_queue_indices_must_increase():
    with pytest.raises(MachineError, match="gave queue index 7 after 7: indices must increase"):
        Dobot(_Liar(repeat=True)).run(_job(), ahead=100)


def test_cli_reports_the_protocol_error_not_completed(tmp_path, capsys, monkeypatch):
    from labkit.cli import main
    from labkit.machine import dobot

    monkeypatch.setattr(dobot, "DobotEmulator", lambda: _Liar(ahead_by=50))
    p = tmp_path / "draw.gcode"
    p.write_text("G0 X0 Y20\nM3 S200\nG1 X20 F600\nG1 Y40\nM5\n")
    assert main(["stream", str(p), "--protocol", "dobot"]) == 1
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("note: F is not sent to the Dobot")
    assert out[1].startswith("STOPPED: protocol error: the Dobot reports queue index")
    assert out[2].startswith("safe stop: force-stop confirmed, laser off confirmed")
    assert not any("completed" in line for line in out)


def test_cli_refuses_s_above_s_max_before_any_frame(tmp_path, capsys, monkeypatch):
    from labkit.cli import main
    from labkit.machine import dobot

    arms = []
    monkeypatch.setattr(dobot, "DobotEmulator", lambda: arms.append(DobotEmulator()) or arms[-1])
    p = tmp_path / "draw.gcode"
    p.write_text("G0 X0 Y20\nM3 S300\nG1 X20 F600\nM5\n")
    assert main(["stream", str(p), "--protocol", "dobot", "--dialect", "labkit-fw"]) == 1
    err = capsys.readouterr().err
    assert f"{p}:3: S300 is above full laser power S255" in err and "118 %" in err
    assert arms == []                                  # no arm was even opened
    assert main(["stream", str(p), "--protocol", "dobot", "--dialect", "labkit-fw",
                 "--s-max", "300"]) == 0
    assert [struct.unpack("<Bff", f.params)[2] for f in arms[0].executed
            if f.cmd_id == CMD["io_pwm"]] == [100.0]


class _Jammed(DobotEmulator):
    """The emulator whose arm stops executing after ``after`` commands, its queue kept (as an
    alarm leaves it) and the beam as it was."""

    def __init__(self, after):
        super().__init__(per_poll=1)
        self.after = after

    def _step(self):
        if len(self.executed) < self.after:
            super()._step()


def test_a_stalled_queue_is_stopped_and_named():
    arm = _Jammed(after=12)
    bot = Dobot(arm)
    with pytest.raises(MachineError, match=r"the Dobot executed nothing for 0\.3 s \(its queue is "
                                           r"at index 11\): an alarm"):
        bot.run(_job(), ahead=4, stall_s=0.3)
    assert arm.executed[-1].cmd_id == CMD["ptp"] and arm.laser_on is False
    assert bot.last_stop.laser_off_confirmed
    # indices 0-11 executed: laser off, the rapid, PWM, laser on and 8 lines (source lines
    # 3-10); 4 ahead of index 11 were queued: indices 12-15, source lines 11-14
    assert bot.last_stop.summary().endswith("last queued: source line 14, last reported "
                                            "executed: source line 10")
    assert bot.last_stop.resume_line == 11


def test_resume_from_a_line_starts_there_with_the_laser_off_by_a_joint_move():
    m = parse("G0 X0 Y20\nM3 S200\nG1 X10 F600\nG1 X20\nG1 X30\nM5\n")
    cmds = job_commands(m, from_line=4)
    assert [(c, ln) for c, _, ln in cmds] == [
        (CMD["laser"], 4), (CMD["ptp"], 4), (CMD["io_pwm"], 4), (CMD["laser"], 4),
        (CMD["ptp"], 4), (CMD["ptp"], 5), (CMD["laser"], 0)]
    assert cmds[0][1] == bytes([1, 0]) and cmds[3][1] == bytes([1, 1])      # off, then on
    # line 4 starts where line 3 ended, canvas (10, 20): arm (280, 90); MOVJ is mode 1
    assert struct.unpack("<B4f", cmds[1][1]) == (1, 280.0, 90.0, 0.0, 0.0)
    assert struct.unpack("<B4f", cmds[4][1]) == (2, 280.0, 80.0, 0.0, 0.0)
    assert struct.unpack("<Bff", cmds[2][1])[2] == pytest.approx(20.0)      # S200 of 1000
    # the commands from line 4 on are the whole job's from its line-4 line on
    whole = job_commands(m)
    assert cmds[4:] == whole[-3:]
    with pytest.raises(MachineError, match="^<string>: nothing to draw from line 6: the last "
                                           "move is on line 5"):
        job_commands(m, from_line=6)


def test_cli_names_the_resume_command_and_it_finishes_the_job(tmp_path, capsys, monkeypatch):
    from labkit.cli import main
    from labkit.machine import dobot

    p = tmp_path / "draw.gcode"
    p.write_text("G0 X0 Y20\nM3 S200\n" + "".join(f"G1 X{10 * (k % 2)} Y{20 + k} F600\n"
                                                   for k in range(30)) + "M5\n")
    monkeypatch.setattr(dobot, "DobotEmulator", lambda: _Jammed(after=12))
    monkeypatch.setattr(dobot.Dobot, "run", lambda self, c, _run=dobot.Dobot.run:
                        _run(self, c, ahead=4, stall_s=0.3))
    assert main(["stream", str(p), "--protocol", "dobot", "--s-max", "255"]) == 1
    *_, last, record = capsys.readouterr().out.splitlines()
    assert record.startswith("record: ")                      # the stream's record, written last
    assert last == ("to go on from there (the laser off, a joint move to where that line starts): "
                    f"labkit stream {p} --protocol dobot --s-max 255 --resume-from 11")
    arms = []
    monkeypatch.setattr(dobot, "DobotEmulator", lambda: arms.append(DobotEmulator()) or arms[-1])
    assert main(last.split(": ", 1)[1].split()[1:]) == 0
    drawn = [struct.unpack("<B4f", f.params)[1:3] for f in arms[0].executed
             if f.cmd_id == CMD["ptp"]]
    # from where line 11 starts (the end of line 10: canvas (10, 27)) through line 32's end
    assert drawn[0] == pytest.approx(canvas_to_robot(10, 27))
    assert drawn[1:] == [pytest.approx(canvas_to_robot(10 * (k % 2), 20 + k))
                         for k in range(8, 30)]


def test_cli_refuses_options_the_dobot_path_does_not_have(tmp_path, capsys):
    # silently ignored, --check-first would send the job without a check; --log would leave
    # no transcript
    from labkit.cli import main

    p = tmp_path / "draw.gcode"
    p.write_text("G0 X0 Y20\nM3 S200\nG1 X20 F600\nM5\n")
    assert main(["stream", str(p), "--protocol", "dobot", "--check-first",
                 "--log", str(tmp_path / "t.log")]) == 1
    assert capsys.readouterr().err == ("labkit stream: --check-first, --log: not available with "
                                       "--protocol dobot (it sends the job as it is, and keeps "
                                       "no transcript)\n")
    assert not (tmp_path / "t.log").exists()
    assert main(["stream", str(p), "--s-max", "255"]) == 1
    assert "--s-max is for --protocol dobot" in capsys.readouterr().err


def test_dobot_job_runs_from_plain_values_and_keeps_what_happened():
    """The library's entry (issue 28 §3): a job built from Moves, run on a port name (the
    emulator for the virtual machine's), its commands, queue index and stop report kept."""
    from labkit.machine.dobot import DobotJob

    text = "G0 X0 Y0\nM3 S200\n" + "".join(f"G1 X{k % 7} Y{k % 5} F{600 + 100 * (k % 3)}\n"
                                           for k in range(40))
    job = DobotJob(parse(text + "M5\n", dialect="labkit-fw"))
    assert job.commands == job_commands(parse(text + "M5\n", dialect="labkit-fw"))
    assert job.feed_range_mm_min() == (600.0 * 60, 800.0 * 60)     # labkit-fw's F is mm/s
    assert job.run("virtual://") == len(job.commands) - 1 == job.last_index
    assert job.last_stop is None and job.elapsed_s >= 0.0
    # an early end: the safe stop's report is kept, naming where to go on from
    executed = iter(range(10 ** 6))
    with pytest.raises(MachineError, match="cancelled"):
        job.run(None, ahead=4, cancel=lambda: next(executed) > 3)
    assert job.last_index is None and job.last_stop is not None
    assert job.last_stop.laser_off_confirmed and job.last_stop.resume_line is not None
    resumed = DobotJob(parse(text + "M5\n", dialect="labkit-fw"), from_line=job.last_stop.resume_line)
    assert resumed.run(None) == len(resumed.commands) - 1


# -- issue 31 §3: a Dobot stream writes the same record as labkit stream does for GRBL ----------

DRAW = "G0 X0 Y0\nM3 S500\nG1 X20 Y0 F600\nG2 X20 Y20 I0 J10\nM5\n"


def test_a_completed_dobot_stream_writes_its_record(tmp_path, capsys):
    import hashlib
    import json

    from labkit.cli import main

    p = tmp_path / "draw.gcode"
    p.write_text(DRAW)
    assert main(["stream", str(p), "--protocol", "dobot", "--record", str(tmp_path / "arm.json")]) == 0
    rec = json.loads((tmp_path / "arm.json").read_text())
    assert (rec["format"], rec["version"], rec["kind"], rec["command"]) == ("labkit-record", 1, "stream", "stream")
    assert rec["inputs"] == [dict(role="program", path=str(p), sha256=hashlib.sha256(DRAW.encode()).hexdigest(),
                                  bytes=len(DRAW))]
    assert rec["machine"]["name"] == "dobot-magician" and rec["machine"]["origin_mm"] == [300.0, 100.0]
    s = rec["stream"]
    # lines 1 (G0), 3 (G1) and 4 (G2) make commands; M3 rides with line 3, M5's laser-off is labkit's own
    assert s["ok"] is True and s["lines_total"] == 3 and s["lines_acknowledged"] == 3
    assert s["fault"] is None and s["safe_stop"] == [] and s["planned_s"] is None
    assert s["warnings"] == ["F is not sent to the Dobot: the arm draws at the speed set on it (its PTP and ARC "
                             "parameters), not at the job's F600 mm/min"]
    assert s["summary"].startswith("completed: 7 commands")
    assert rec["planned"] == {"estimated_time_s": None}
    capsys.readouterr()
    assert main(["record", "show", str(tmp_path / "arm.json")]) == 0
    shown = capsys.readouterr().out
    assert "machine dobot-magician" in shown and ": ok, 3/3 lines in" in shown


def test_the_record_of_a_grbl_stream_and_of_a_dobot_stream_differ_only_where_they_should(tmp_path, capsys):
    import json

    from labkit.cli import main

    p = tmp_path / "draw.gcode"
    p.write_text(DRAW)
    assert main(["stream", str(p), "--record", str(tmp_path / "grbl.json")]) == 0
    assert main(["stream", str(p), "--protocol", "dobot", "--record", str(tmp_path / "arm.json")]) == 0
    a, b = (json.loads((tmp_path / f).read_text()) for f in ("grbl.json", "arm.json"))
    assert set(a) == set(b) and set(a["stream"]) == set(b["stream"])        # one format for both
    assert a["inputs"] == b["inputs"]
    capsys.readouterr()
    assert main(["record", "diff", str(tmp_path / "grbl.json"), str(tmp_path / "arm.json")]) == 1
    rows = capsys.readouterr().out
    assert "machine.name" in rows and "options.protocol" in rows and "inputs" not in rows


def test_a_stopped_dobot_stream_records_the_fault_and_each_stop_command(tmp_path, capsys, monkeypatch):
    import json

    from labkit.cli import main
    from labkit.machine import dobot

    monkeypatch.setattr(dobot, "DobotEmulator", lambda: _Liar(ahead_by=50))
    p = tmp_path / "draw.gcode"
    p.write_text("G0 X0 Y20\nM3 S200\nG1 X20 F600\nG1 Y40\nM5\n")
    (tmp_path / "draw.gcode.record.json").write_text("{}")   # the program's own record is named as an input
    assert main(["stream", str(p), "--protocol", "dobot", "--record", str(tmp_path / "arm.json")]) == 1
    rec = json.loads((tmp_path / "arm.json").read_text())
    s = rec["stream"]
    assert s["ok"] is False and s["fault"].startswith("protocol error: the Dobot reports queue index")
    assert [what for what, _ in s["safe_stop"]] == ["force-stop", "laser off", "PWM 0 %", "queue clear"]
    assert all(state == "confirmed" for _, state in s["safe_stop"])
    assert s["summary"].splitlines()[0] == "STOPPED: " + s["fault"]
    assert s["lines_acknowledged"] < s["lines_total"] == 3
    assert [i["role"] for i in rec["inputs"]] == ["program", "program record"]
    capsys.readouterr()
    assert main(["record", "show", str(tmp_path / "arm.json")]) == 0
    assert "stop: laser off confirmed" in capsys.readouterr().out


def test_no_record_writes_none(tmp_path, capsys):
    from labkit.cli import main

    p = tmp_path / "draw.gcode"
    p.write_text(DRAW)
    assert main(["stream", str(p), "--protocol", "dobot", "--no-record"]) == 0
    assert sorted(f.name for f in tmp_path.iterdir()) == ["draw.gcode"]
    assert "record:" not in capsys.readouterr().out
