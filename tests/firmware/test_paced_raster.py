"""A grayscale photo at 6,000 mm/min over 115200 baud on the labkit firmware (issue 30 §3).

The machine is ``labkit-diode``: grbl-diode's belts (80 steps/mm, 6,000 mm/min, 2,000 mm/s²)
driven by the labkit firmware with its deepest look-ahead (34 blocks), its 128-byte RX buffer,
36-block planner and 20 µs a line of parsing; the simulator gets the mechanics as settings
lines (``paced_stream.firmware_settings``). The job is what ``labkit img2gcode`` writes by
default (compact G-code) for a real photograph (data/images/photo_500x450_72dpi.jpg) in gray
mode at 0.1 mm pixels, 30 mm wide (300 × 270 pixels, about 75,000 lines: more S changes per
millimetre than the whole photo at its own 72 dpi, whose 1764 × 1587 pixels the issue's
closing note reports). GRBL's stream.py counts characters over the firmware simulator's paced
link (``--baud 115200 --parse-us 20``).

Checked: not a single starvation, and the beam's first switch-on to its last switch-off takes
exactly as long as when the same program is read from stdin with no link at all (the link
costs nothing); the stall predictor agrees (no starvation). Then that the check can fail: a
firmware that parsed a line in 1.1 ms instead of 20 µs cannot keep up with 0.1 mm pixels at
6,000 mm/min (about one block a millisecond) and starves where the predictor says (but a few
stops shorter than a parse, out of thousands); and a sender that falls silent for a second while it has room starves
the machine, and the simulator says the sender was late (so a loaded machine is told apart
from a slow link) — unless it was told what the sender will write (``--expect``, as every
stream here is): then it waits for the sender, and nothing starves.
"""
from __future__ import annotations

import re
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest
import serial

import paced_stream
from labkit.cli import main
from labkit.machine.safety import end_process
from labkit.motion import load_machine
from labkit.motion.stall import predict_stalls, read_starvation_log, sent_line_bytes

ROOT = Path(__file__).resolve().parents[2]
PHOTO = ROOT / "data" / "images" / "photo_500x450_72dpi.jpg"
MACHINE = load_machine("labkit-diode")
FEED_MM_MIN = 6000.0
sim = paced_stream.REAL_SENDERS.sim          # the fixture that builds the simulator


def _photo_job(tmp: Path, width_mm: float) -> str:
    out = tmp / f"photo-{width_mm:g}.gcode"
    assert main(["img2gcode", str(PHOTO), "-o", str(out), "--mode", "gray", "--beam", "0.1",
                 "--width", str(width_mm), "--feed", f"{FEED_MM_MIN:g}", "--preview", "none",
                 "--dialect", "grbl", "--machine", MACHINE.name]) == 0
    return out.read_text("ascii")


def _unpaced_burn_span(sim: str, text: str, tmp: Path) -> float:
    """The program read from stdin with no link at all: beam's first on to last off, s."""
    beam = tmp / "unpaced-beam.csv"
    job = "\n".join(paced_stream.firmware_settings(MACHINE)) + "\n" + text
    run = subprocess.run([sim, "--dialect", "grbl", "--beam-log", str(beam)], input=job,
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    rows = [line.split(",") for line in beam.read_text("ascii").splitlines()[1:]]
    on = [float(t) for t, d, *_ in rows if int(d) > 0]
    off = [float(t) for t, d, *_ in rows if int(d) == 0]
    return off[-1] - on[0]


@pytest.fixture(scope="module")
def photo_30mm(tmp_path_factory):
    return _photo_job(tmp_path_factory.mktemp("photo30"), 30.0)


def test_gray_photo_at_6000_mm_min_over_115200_baud_never_starves(sim, photo_30mm, tmp_path, capsys):
    text = photo_30mm
    nbytes = sent_line_bytes(text)
    run = paced_stream.stream_paced(sim, text, MACHINE, tmp_path)
    assert not run.host_late, f"the sender was late {run.host_late} times (more than 10 s)"
    assert run.stalls == [], f"{len(run.stalls)} starvations, the first {run.stalls[:3]}"
    unpaced = _unpaced_burn_span(sim, text, tmp_path)
    # the paced run burns exactly as long as with no link: not one tick lost to the link
    assert run.burn_span_s == pytest.approx(unpaced, abs=1e-6)
    predicted = predict_stalls(text, MACHINE)
    assert predicted.stalls == []
    burned_px = 300 * 270
    with capsys.disabled():
        print(f"\nphoto gray 0.1 mm, 30 mm wide, F{FEED_MM_MIN:g} over {MACHINE.link_baud} baud: "
              f"{len(nbytes):,} lines, {nbytes.sum() / burned_px:.2f} B/px, streamed in {run.seconds:.0f} s; "
              f"starvations simulated {len(run.stalls)}, predicted "
              f"{len(predicted.stalls)}; burn {run.burn_span_s:.6f} s paced vs {unpaced:.6f} s without "
              f"a link; predicted job {predicted.job_time_s:.3f} s, planned motion {predicted.motion_time_s:.3f} s")


def test_a_firmware_parsing_slower_than_its_blocks_run_starves_as_predicted(sim, tmp_path, capsys):
    """0.1 mm pixels at 6,000 mm/min are about 1 ms each; at 1.1 ms a line of parsing the
    planner drains while the receive buffer is full of text: starvations with lines left
    (not one byte arriving in many of them), predicted at their lines."""
    text = _photo_job(tmp_path, 10.0)
    slow = MACHINE.replace(block_parse_s=1.1e-3)
    run = paced_stream.stream_paced(sim, text, slow, tmp_path)
    assert not run.host_late
    predicted = predict_stalls(text, slow, line_bytes=paced_stream.stream_py_bytes(text))
    assert len(run.stalls) > 100
    # each stop is a fraction of a millisecond, so where it falls shifts with the firmware's
    # block times (its ticks, a few % longer than the plan's) and with stream.py's '?' once a
    # second (a byte on the wire at a wall-clock moment): a few simulated stops fall on lines
    # the prediction does not name, each shorter than one line's parse
    lines = {s.line for s in predicted.stalls}
    missed = [s for s in run.stalls if s.line not in lines]
    assert len(missed) <= 0.01 * len(run.stalls), f"simulated starvations not predicted: {missed[:10]}"
    assert all(s.duration_s < slow.block_parse_s for s in missed), missed
    # the firmware's blocks are its ticks, never shorter than the plan's: it stands less
    assert 0 < run.stall_time_s <= predicted.stall_time_s
    with capsys.disabled():
        print(f"\nphoto gray 10 mm wide at 1.1 ms a line: starvations simulated {len(run.stalls)} "
              f"({run.stall_time_s:.3f} s), predicted {len(predicted.stalls)} ({predicted.stall_time_s:.3f} s)")


def test_a_sender_silent_for_a_second_starves_the_machine_and_is_called_late(sim, tmp_path):
    """A counting sender that has room but sends nothing for 1 s of wall time: the simulator
    waits 0.25 s for it, then lets the machine run dry (a starvation when the lines come
    again) and reports the late sender on stderr; the same sender without the pause is on
    time and nothing starves. Told what the sender will write (``--expect``), the simulator
    waits for it up to 10 s: the pause costs no simulated time, nothing starves and nobody
    is late (a loaded machine cannot make a starvation); told the wrong bytes, it says where
    they differ."""
    # cuts of one length: without --expect the simulator guesses the next line's length from
    # the last ones (a line longer than it guessed would read as a silent sender)
    lines = ["G21G91", "M4S0", "G1X0F6000"] + [f"X.1S{300 + k % 7}" for k in range(1, 1201)] + ["M5"]
    sent = paced_stream.firmware_settings(MACHINE) + lines
    (tmp_path / "right.txt").write_bytes("".join(f"{x}\n" for x in sent).encode("ascii"))
    wrong_at = len(sent) - len(lines) + 3 + 499             # the 500th cut, before the pause
    wrong = sent[:wrong_at] + ["X.1S399"] + sent[wrong_at + 1:]
    (tmp_path / "wrong.txt").write_bytes("".join(f"{x}\n" for x in wrong).encode("ascii"))
    for pause_at, expect, late in ((None, None, False), (600, None, True), (600, "right.txt", False),
                                   (600, "wrong.txt", True)):
        log = tmp_path / f"starve-{pause_at}-{expect}.csv"
        proc = subprocess.Popen([sim, "--pty", "--dialect", "grbl", "--baud", "115200", "--parse-us", "20",
                                 "--starvation-log", str(log)]
                                + (["--expect", str(tmp_path / expect)] if expect else []),
                                stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                text=True)
        try:
            port = proc.stderr.readline().split("pty ", 1)[1].strip()
            _counting_sender(port, sent, pause_at)
            proc.terminate()
            err = proc.communicate(timeout=30)[1]
        finally:
            end_process(proc)
        stalls = read_starvation_log(log)
        times_late, off = paced_stream.sim_complaints(err)
        if expect == "wrong.txt":
            # the first differing byte, the S's second digit in the 500th cut, comes before the
            # pause: from there on the simulator guesses, waits 0.25 s and the pause is late again
            at = len("".join(f"{x}\n" for x in sent[:wrong_at])) + len("X.1S3") + 1
            assert f"line byte {at} differs" in off, err
        else:
            assert off == "", err
        if late:
            assert times_late >= 1, err
            assert stalls, "the machine ran dry while the sender was silent"
        else:
            assert times_late == 0, err
            assert stalls == []


def _counting_sender(port: str, lines, pause_at):
    """GRBL's character counting (127 bytes in flight), pausing 1 s before line ``pause_at``
    (1-based, among the G-code lines after the settings) while it has room; waits for every
    answer and for Idle."""
    link = serial.Serial(port, 115200, timeout=paced_stream.REAL_SENDERS.TIMEOUT_S)
    try:
        link.write(b"\x18")                     # a banner and a clean start
        time.sleep(0.3)
        link.reset_input_buffer()
        in_flight, answered, gcode_line = [], 0, 0

        def take():
            reply = link.readline().decode("ascii", "replace").strip()
            assert reply, "no answer"
            if paced_stream.REAL_SENDERS._is_answer(reply):
                assert reply == "ok", reply
                in_flight.pop(0)
                return 1
            return 0

        for raw in lines:
            if not raw.startswith("$"):
                gcode_line += 1
                if gcode_line == pause_at:
                    time.sleep(1.0)
            data = raw.encode("ascii") + b"\n"
            in_flight.append(len(data))
            while sum(in_flight) >= 127:
                answered += take()
            link.write(data)
        while in_flight:
            answered += take()
        paced_stream.REAL_SENDERS._idle_status(link.write, lambda: link.readline().decode("ascii").strip())
    finally:
        link.close()
