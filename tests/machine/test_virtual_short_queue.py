"""The stall predictor against the virtual machine's GRBL planner (issue 30 §2).

GRBL runs whatever its planner holds and plans each queue to stop at its end: when the link
falls behind, the block that starts with nothing queued behind it is slowed down to rest at
its end, and the next line usually arrives before it gets there, so the machine seldom
stands (the virtual machine logs no starvation at 1.3 times the feed where the predictor
sees hundreds). For GRBL-family machines the predictor and the virtual machine are compared
on that event, a *short queue* (:func:`labkit.motion.stall.short_queues`, the virtual
machine's ``short_queues``): a block started before the line of the block after it was
parsed. Checked on ten jobs (photos and a gray card in gray, dither and zig-zag at several
pixel pitches, feeds and baud rates; vector drawings cut into many short segments) streamed
by a character-counting sender on ``grbl-diode`` (15 blocks, 128-byte RX buffer, 3.7 ms a
line): the predicted short-queue-free feed F* (``stall_free_feed(criterion="short_queue")``)
is within 5 % of the virtual machine's (none at 0.95 F*, some at 1.05 F*), and every short
queue the virtual machine reports is predicted at its line.
"""
from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

import pytest

from labkit.cli import main
from labkit.gcode.reader import strip_comments
from labkit.machine.virtual import VirtualMachine
from labkit.motion import load_machine
from labkit.gcode import grbl_sync_lines
from labkit.motion.stall import predict_stalls, short_queues, stall_free_feed, with_feed

ROOT = Path(__file__).resolve().parents[2]


def _sent(text: str):
    """(source line, bytes) of every line ``labkit stream`` sends: comments and blanks out."""
    out = []
    for n, raw in enumerate(text.splitlines(), start=1):
        body = re.sub(r"\s", "", strip_comments(raw)).upper()
        if body:
            out.append((n, body.encode("ascii") + b"\n"))
    return out


def stream_vm(text: str, machine, *, tick_s: float = 0.0005):
    """Stream ``text`` into a virtual machine on ``machine``'s link with GRBL's character
    counting (at most 127 bytes unanswered). The sender writes within ``tick_s`` of an answer,
    not at once as the predictor's: on vector jobs 1 ms let a short queue fall a line early.
    Returns its (short queues, starvations) by source line."""
    vm = VirtualMachine(machine, time_scale=0, tick_s=0.0, banner=False, baud=machine.link_baud,
                        parse_s=machine.block_parse_s)
    lines = _sent(text)
    start, first = vm.sim_time_s, vm.lines_run
    sent, unanswered, replies, answers = 0, [], b"", 0
    while sent < len(lines) or unanswered:
        while sent < len(lines) and sum(unanswered) + len(lines[sent][1]) < 127:
            vm.write(lines[sent][1])
            unanswered.append(len(lines[sent][1]))
            sent += 1
        vm.tick_s = tick_s
        replies += vm.read(vm.in_waiting) if vm.in_waiting else b""
        vm.tick_s = 0.0
        *done, replies = replies.split(b"\n")
        for reply in done:
            reply = reply.strip()
            if reply and not reply.startswith(b"["):       # [MSG:Pgm End] at M2
                assert reply == b"ok", (reply, answers)
                unanswered.pop(0)
                answers += 1
    assert answers == len(lines)
    numbers = [n for n, _ in lines]
    return (vm.starvations_since(start, first, numbers, vm.short_queues),
            vm.starvations_since(start, first, numbers))


def _image_job(tmp: Path, image: str, mode: str, pitch: float, width_mm: float) -> str:
    out = tmp / f"{Path(image).stem}-{mode}-{pitch}.gcode"
    assert main(["img2gcode", str(ROOT / "data/images" / image), "-o", str(out), "--mode", mode,
                 "--beam", str(pitch), "--width", str(width_mm), "--feed", "1000",
                 "--preview", "none", "--dialect", "grbl", "--machine", "grbl-diode"]) == 0
    return out.read_text("ascii")


def _svg_job(tmp: Path, svg: str, tol: float) -> str:
    out = tmp / f"{Path(svg).stem}-{tol}.gcode"
    assert main(["svg2gcode", str(ROOT / "data/svg" / svg), "-o", str(out), "--tol", str(tol),
                 "--feed", "1000", "--dialect", "grbl"]) == 0
    return out.read_text("ascii")


#: (name, how the job is made, baud): small jobs (a few hundred lines) whose feed the link
#: limits on grbl-diode (3.7 ms a line, 6000 mm/min top).
JOBS = [
    ("photo gray 0.1 mm @ 4800", lambda t: _image_job(t, "photo_500x450_72dpi.jpg", "gray", 0.1, 1.5), 4800),
    ("photo gray 0.05 mm @ 9600", lambda t: _image_job(t, "photo_500x450_72dpi.jpg", "gray", 0.05, 0.8), 9600),
    ("photo gray 0.2 mm @ 2400", lambda t: _image_job(t, "photo_500x450_72dpi.jpg", "gray", 0.2, 3.0), 2400),
    ("photo dither 0.1 mm @ 4800", lambda t: _image_job(t, "photo_500x450_72dpi.jpg", "dither", 0.1, 1.5), 4800),
    ("gray card dither 0.05 mm @ 4800", lambda t: _image_job(t, "gray_card.png", "dither", 0.05, 1.0), 4800),
    ("gray card gray 0.1 mm @ 9600", lambda t: _image_job(t, "gray_card.png", "gray", 0.1, 2.0), 9600),
    # a zig-zag program starts with a 0.1 mm rapid and a 0.1 mm cut: above about 23 mm/min
    # the cut starts before the third line can have come, at any baud rate
    ("waves zigzag 0.05 mm @ 2400", lambda t: _image_job(t, "waves.png", "zigzag", 0.05, 1.0), 2400),
    ("waves zigzag 0.1 mm @ 9600", lambda t: _image_job(t, "waves.png", "zigzag", 0.1, 2.0), 9600),
    ("shapes 0.005 mm @ 9600", lambda t: _svg_job(t, "svg2gcode/shapes.svg", 0.005), 9600),
    ("jsdc 0.01 mm @ 9600", lambda t: _svg_job(t, "cncjs/jsdc.svg", 0.01), 9600),
]


@pytest.mark.parametrize("name,make,baud", JOBS, ids=[j[0] for j in JOBS])
def test_predicted_short_queues_and_feed_match_the_virtual_machine(tmp_path, name, make, baud, capsys):
    with contextlib.redirect_stdout(io.StringIO()):           # img2gcode's and svg2gcode's summaries
        text = make(tmp_path)
    machine = load_machine("grbl-diode").replace(link_baud=baud)
    found = stall_free_feed(text, machine, rel_tol=0.005, rows=False, criterion="short_queue")
    f_star = found.feed_mm_min
    assert found.limited_by == "link", f"{name}: the link never limits this job (F* = {f_star:.0f})"
    report = [f"{name}: predicted short-queue-free feed {f_star:.1f} mm/min"] + _around_f_star(name, text, machine, f_star)
    with capsys.disabled():
        print("\n" + "\n".join(report))


def _around_f_star(name: str, text: str, machine, f_star: float) -> list[str]:
    """Stream ``text`` into the virtual machine at 0.95 and 1.05 times ``f_star``: no short
    queue at the first, some at the second, every one of them predicted at its line.
    Returns a report line per feed."""
    report = []
    for factor, must_run_short in ((0.95, False), (1.05, True)):
        job = with_feed(text, f_star * factor)
        short, starved = stream_vm(job, machine)
        predicted = short_queues(predict_stalls(job, machine))
        lines = {s.line for s in predicted}
        missed = [s for s in short if s.line not in lines]
        assert not missed, f"{name} at {factor} F*: short queues of the virtual machine not predicted: {missed[:5]}"
        assert bool(short) == must_run_short, f"{name} at {factor} F*: {len(short)} short queues: {short[:3]}"
        report.append(f"  {factor:.2f} F*: virtual machine {len(short)} short queues ({len(starved)} "
                      f"starvations), predicted {len(predicted)}")
    return report


def test_grbl_stops_at_laser_changes_as_the_virtual_machine_does(tmp_path, capsys):
    """GRBL waits for its planner to empty at every change of M3/M4/M5 (``spindle_sync``, laser
    mode included): shapes.svg as svg2gcode writes it for a controller that burns on G0
    (``--travel-beam-off``: M5 before each of its 7 rapids, M3 after), 14 such lines, at 9600
    baud. The predictor models the stop (``laser_change_syncs`` of grbl-diode): its
    short-queue-free feed F* holds against the virtual machine (none at 0.95 F*, some at
    1.05 F*, each of the virtual machine's predicted at its line). Without the stop the
    predictor's F* is higher and wrong: at 0.95 of it the virtual machine runs short."""
    out = tmp_path / "shapes-m5.gcode"
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(["svg2gcode", str(ROOT / "data/svg/svg2gcode/shapes.svg"), "-o", str(out), "--tol", "0.005",
                     "--feed", "1000", "--dialect", "grbl", "--travel-beam-off"]) == 0
    text = out.read_text("ascii")
    assert len(grbl_sync_lines(text)) == 14
    machine = load_machine("grbl-diode").replace(link_baud=9600)
    f_star = stall_free_feed(text, machine, rel_tol=0.005, rows=False, criterion="short_queue").feed_mm_min
    blind = stall_free_feed(text, machine.replace(laser_change_syncs=False), rel_tol=0.005, rows=False,
                            criterion="short_queue").feed_mm_min
    name = "shapes --travel-beam-off @ 9600"
    report = [f"{name}: predicted F* {f_star:.1f} mm/min (without the stop {blind:.1f})"]
    report += _around_f_star(name, text, machine, f_star)
    assert blind > 1.2 * f_star
    short, _ = stream_vm(with_feed(text, 0.95 * blind), machine)
    assert short, "the stop at M5/M3 should matter on this job"
    report.append(f"  0.95 x the blind F*: virtual machine {len(short)} short queues")
    with capsys.disabled():
        print("\n" + "\n".join(report))
