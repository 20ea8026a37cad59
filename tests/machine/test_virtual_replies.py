"""When the virtual GRBL answers (issue 26), hand-worked from GRBL 1.1h's documented behaviour:
G4 is answered once its dwell has ended, M0 holds (Hold:0) and is answered only after cycle
start, M2/M30 say [MSG:Pgm End] before their ok, start-up lines run after a reset."""

import pytest

from labkit.machine.virtual import VirtualMachine


def _answers(vm, seconds, step_s=0.01):
    """Advance the machine ``seconds`` in steps; every reply line with the time it came."""
    out, t_end = [], vm.sim_time_s + seconds
    vm.tick_s = step_s
    while vm.sim_time_s < t_end - 1e-9:
        data = vm.read(vm.in_waiting) if vm.in_waiting else b""
        out += [(vm.sim_time_s, ln.strip().decode()) for ln in data.splitlines() if ln.strip()]
    vm.tick_s = 0.0
    return out


def _vm():
    return VirtualMachine(time_scale=0, tick_s=0.0, banner=False)


def test_g4_is_answered_when_its_dwell_ends():
    vm = _vm()
    vm.write(b"G4 P0.5\n")
    answers = _answers(vm, 1.0)
    assert [a for _, a in answers] == ["ok"]
    # seen within one look (in_waiting and read each advance 10 ms) after the dwell's end
    assert 0.5 <= answers[0][0] <= 0.5 + 0.021


def test_g4_waits_for_the_moves_before_it_and_nothing_is_read_meanwhile():
    """10 mm at F600 (about 1 s) then a 0.2 s dwell: the dwell's ok after ~1.2 s; the line
    after it is read (and answered) only then."""
    vm = _vm()
    vm.write(b"G1 X10 F600\nG4 P0.2\nG1 X11\n")
    answers = _answers(vm, 2.0)
    assert [a for _, a in answers] == ["ok", "ok", "ok"]
    assert answers[0][0] < 0.05 and answers[1][0] > 1.19 and answers[2][0] >= answers[1][0]


def test_m0_holds_unanswered_until_cycle_start():
    vm = _vm()
    vm.write(b"G1 X1 F600\nM0\nG1 X2\n")
    answers = _answers(vm, 1.0)
    assert [a for _, a in answers] == ["ok"]                 # G1 only: M0 waits, G1 X2 unread
    vm.write(b"?")
    assert any(a.startswith("<Hold:0|") for _, a in _answers(vm, 0.05))
    vm.write(b"~")
    assert [a for _, a in _answers(vm, 0.5)][:2] == ["ok", "ok"]   # M0's, then G1 X2's
    assert vm.state in ("Run", "Idle")


def test_program_end_says_so_before_its_ok():
    vm = _vm()
    vm.write(b"G1 X1 F600\nM2\n")
    assert [a for _, a in _answers(vm, 0.5)] == ["ok", "[MSG:Pgm End]", "ok"]


def test_start_up_lines_run_after_a_reset():
    vm = _vm()
    vm.write(b"$N0=G20 G91\n")
    vm.write(b"\x18")
    answers = [a for _, a in _answers(vm, 0.05)]
    assert answers == ["ok", "Grbl 1.1h ['$' for help]", ">G20G91:ok"]
    assert (vm.units, vm.distance) == (20, 91)
