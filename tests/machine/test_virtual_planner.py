"""The virtual machine plans with labkit.motion's junction-deviation planner (issue 28 §1).

A job streamed so that the planner stays full runs in the time ``labkit plan --planner
junction`` gives the whole job (same planner depth, same ``$12`` chords), once GRBL's
planner syncs are full stops in both (a new M3/M4/M5 or S, which GRBL runs only when its
planner is empty: :func:`grbl_stops` puts a ``G4 P0`` there for the plan); a job that starves
the planner runs slower. The stream here is a character-counting sender (GRBL's
``stream.py`` rule: at most 127 bytes unanswered) with the machine's time advanced in
explicit 1 ms steps, so the sender is never the slow part.
"""

import json
import re
from pathlib import Path

import numpy as np
import pytest

from labkit.gcode.reader import parse
from labkit.machine.virtual import VirtualMachine
from labkit.motion import MachineSpec, load_machine, plan

#: grbl-diode with the rest speed (250 Hz, planned from: not GRBL's 0) and planner depth the
#: hand-worked numbers use
DIODE = load_machine("grbl-diode").replace(start_rate_hz=250, rest_at_zero=False, planner_blocks=15,
                                           block_parse_s=0.0)

VECTORS = sorted((Path(__file__).resolve().parents[1] / "vectors" / "motion").glob("*.json"))


def stream(machine, lines, *, window_bytes=127, step_s=0.001, **options):
    """Stream ``lines`` with character counting (``window_bytes=1``: send-response); returns
    (job time s, the machine).

    The job time runs from the first step of machine time to the end of the last block."""
    options.setdefault("baud", 0)     # an instant link: only the sender's window limits it
    options.setdefault("parse_s", 0.0)  # and an instant parser: the planner is always full
    vm = VirtualMachine(machine, time_scale=0, tick_s=0.0, banner=False, **options)
    sent = 0
    unanswered: list[int] = []
    replies = b""

    def read_replies():
        nonlocal replies
        while vm.in_waiting:
            replies += vm.read(vm.in_waiting)
        *done, replies = replies.split(b"\n")
        for reply in done:
            reply = reply.strip()
            assert reply in (b"ok", b""), reply
            if reply == b"ok":
                unanswered.pop(0)

    t0 = vm.sim_time_s
    while sent < len(lines) or unanswered:
        while sent < len(lines) and (not unanswered
                                      or sum(unanswered) + len(lines[sent]) + 1 <= window_bytes):
            data = (lines[sent] + "\n").encode()
            vm.write(data)
            unanswered.append(len(data))
            sent += 1
        vm.tick_s = step_s
        vm.in_waiting                              # one step of machine time
        vm.tick_s = 0.0
        read_replies()
    vm.tick_s = step_s
    while vm.state != "Idle":
        vm.in_waiting
    return vm.executed[-1].t_end - t0, vm


def grbl_stops(lines, laser_mode: bool) -> list[str]:
    """``lines`` with a ``G4 P0`` (a full stop of no time, for the whole-job plan) before every
    line GRBL 1.1h runs only once its planner is empty (spindle_sync, coolant_sync in gcode.c):
    a new M3/M4/M5, a new M8/M9, a new S while the spindle is on — in laser mode ($32=1) only
    on a line without axis words, whose power does not ride with a move. (These programs use
    no other syncing words: no G10, G92, G43.1, G5x change or probe.)"""
    out, spindle, s_word, flood = [], 5, 0.0, False
    for line in lines:
        words = re.findall(r"([A-Z])([-+]?[0-9.]+)", line.upper().replace(" ", ""))
        m = {float(v) for k, v in words if k == "M"}
        new_spindle = next((int(w) for w in m if w in (3.0, 4.0, 5.0)), spindle)
        new_s = next((float(v) for k, v in words if k == "S"), s_word)
        new_flood = (flood or 8.0 in m) and 9.0 not in m
        moves = any(k in "XYZ" for k, _ in words)
        sync = (new_spindle != spindle or new_flood != flood
                or (spindle != 5 and new_s != s_word and not (laser_mode and moves)))
        out += ["G4 P0", line] if sync else [line]
        spindle, s_word, flood = new_spindle, new_s, new_flood
    return out


def whole_job_time(machine, lines, depth, laser_mode: bool | None = None):
    """The job's time by labkit.motion's whole-job plan, GRBL's planner syncs as full stops
    (``laser_mode``: GRBL's $32, by default the machine description's)."""
    m = load_machine(machine)
    if laser_mode is None:
        laser_mode = dict(m.grbl_settings).get(32, 0) == 1
    text = "\n".join(grbl_stops(lines, laser_mode))
    return plan(parse(text, dialect="grbl"), m, planner="junction", buffer_blocks=depth,
                arc_tol_mm=m.arc_tolerance_mm).job_time_s


@pytest.mark.parametrize("path", VECTORS, ids=[p.stem for p in VECTORS])
def test_vector_jobs_take_the_planned_time(path):
    """Every planner vector's program (lines, 3-D lines, arcs cut at $12, dwells, rapids)."""
    vector = json.loads(path.read_text())
    machine = MachineSpec(**vector["machine"])
    lines = [ln for ln in vector["gcode"].splitlines() if ln.strip()]
    took, vm = stream(machine, lines)
    assert took == pytest.approx(whole_job_time(machine, lines, vm.planner_blocks), rel=1e-9)


def test_one_line_by_hand():
    """10 mm at F600 on grbl-diode: from the rest speed 250 Hz / 80 steps/mm = 3.125 mm/s to
    10 mm/s at 1000 mm/s² takes 6.875 ms over 0.0451172 mm, the same down; the 9.909766 mm
    between take 0.9909766 s: 1.0047266 s."""
    took, _ = stream(DIODE, ["G1 X10 F600"])
    ramp_mm = (10.0 ** 2 - 3.125 ** 2) / 2000.0
    assert took == pytest.approx(2 * 6.875e-3 + (10.0 - 2 * ramp_mm) / 10.0, rel=1e-12)
    assert took == pytest.approx(1.0047266, abs=1e-7)


def _raster_row(n):
    return (["G21 G90 M4", "G0 X10 Y10"]
            + [f"G1 X{10 + 0.2 * (k + 1):.3f} S{(k * 37) % 1000} F6000" for k in range(n)] + ["M5"])


@pytest.mark.parametrize("depth", [4, 15])
def test_short_blocks_the_planner_depth_limits(depth):
    """A row of 0.2 mm blocks at 6000 mm/min: the speed is set by how far ahead the planner
    sees, so the streamed job re-plans as blocks arrive exactly as the whole-job plan does."""
    lines = _raster_row(300)
    took, vm = stream("grbl-diode", lines, planner_blocks=depth)
    assert vm.planner_blocks == depth
    assert took == pytest.approx(whole_job_time("grbl-diode", lines, depth), rel=1e-9)


def test_depth_changes_the_time():
    """The comparison above can fail: a shallower planner is slower on short blocks."""
    lines = _raster_row(300)
    shallow = whole_job_time("grbl-diode", lines, 4)
    deep = whole_job_time("grbl-diode", lines, 15)
    assert shallow > 1.5 * deep


def test_send_response_starves_the_planner():
    """One line at a time, answered only at the sender's next 50 ms poll, keeps the planner
    short of blocks: the job takes longer than the whole-job plan, and the machine says where
    it stood waiting."""
    lines = _raster_row(40)
    took, vm = stream("grbl-diode", lines, window_bytes=1, step_s=0.05)
    assert took > 1.3 * whole_job_time("grbl-diode", lines, vm.planner_blocks)
    assert np.isfinite(took)
    assert vm.starvations and all(s.duration_s > 0 for s in vm.starvations)
