"""A safety check any laser lab can run: is the beam off whenever it has to be?

:func:`run_safety_check` drives a controller through scripted scenarios — a
feed hold during a cut, the resume, a soft reset mid-cut, the safety door, an
alarm, a rejected line, the end of a program (``M2``, ``M30``), ``M5``, a rapid
in laser mode (and, on the simulators, the same rapid with ``$32=0`` for
contrast), a lost link — and says for each whether the beam was off when it
had to be. It judges from what the controller reports (the state, the laser
value of ``FS:``, the accessory field ``A:`` that GRBL 1.1 shows while its
PWM output is on) and, on the simulators, from the beam itself: the virtual
machine's :attr:`~labkit.machine.virtual.VirtualMachine.beam_log` and the
firmware simulator's ``--beam-log`` (``time_s,duty,state,line``, a row per
change of the duty).

Each scenario first sees the beam come on (the control: a check that never saw
the beam on proves nothing and fails), then does what the scenario names,
waits until the controller says it has stopped, and watches a little longer.
It passes when the reports and the beam agree that the beam is off, and fails
with the evidence otherwise. A scenario the controller cannot take part in (no
door state) is NOT APPLICABLE.

The cuts are short relative moves (``G91``) from where the head is, at a low
power: 1 % of ``$30`` unless ``s_word`` says otherwise. GRBL 1.1 switches the
laser off once a feed hold has stopped the head, M3 and M4 alike, but when its
queue runs out (the end of a resumed cut, a lost link) M3's constant power stays
on — only M4's PWM is switched off at the end of motion. So the cuts use ``M4``
by default — what labkit writes; ``cut_mode="M3"`` checks a machine that cuts
with M3, and a GRBL 1.1 fails its resume and lost-link scenarios.
"""

from __future__ import annotations

import csv
import json
import math
import os
import subprocess
import tempfile
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

from labkit.errors import InputError, MachineError
from labkit.units import s_within

__all__ = ["SCENARIOS", "ScenarioResult", "SafetyReport", "run_safety_check", "default_sim_path",
           "end_process", "CUT_MM", "CUT_FEED_MM_MIN"]

#: scenario key → what it checks (the order they run in).
SCENARIOS: dict[str, str] = {
    "feed_hold": "feed hold during a cut",
    "resume": "resume after the hold, to the end of the cut",
    "soft_reset": "soft reset (0x18) mid-cut",
    "door": "safety door (0x84) mid-cut",
    "alarm": "alarm mid-cut, then lines that would fire the beam",
    "error_line": "a rejected line that asks for the beam",
    "program_end_m2": "end of program (M2) after an M3 cut",
    "program_end_m30": "end of program (M30) after an M3 cut",
    "m5": "M5 after an M3 cut",
    "g0_laser_mode": "G0 rapid with M3 S in effect: laser mode ($32=1) vs $32=0",
    "disconnect": "the link lost mid-cut",
}

PASS, FAIL, NOT_APPLICABLE = "PASS", "FAIL", "NOT APPLICABLE"

#: The test cuts on a real machine: length either way along X from where the head is (mm), and feed.
CUT_MM = 10.0
CUT_FEED_MM_MIN = 300.0


def end_process(proc: subprocess.Popen, timeout_s: float = 5.0) -> None:
    """End a simulator process: SIGTERM, wait up to ``timeout_s`` s, then SIGKILL.

    Its pipes are drained (``communicate``) so that it cannot block on a full pipe
    while it exits. A process that has already ended is only reaped.
    """
    if proc.poll() is None:
        proc.terminate()
    try:
        proc.communicate(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.communicate()


def default_sim_path() -> Path:
    """Where ``make -C firmware sim`` puts the firmware's host simulator."""
    return Path(__file__).resolve().parents[2] / "firmware" / "build" / "host" / "labkit-fw-sim"


@dataclass
class ScenarioResult:
    """One scenario's verdict and its evidence."""

    key: str
    title: str
    verdict: str = NOT_APPLICABLE          #: PASS, FAIL or NOT APPLICABLE
    reason: str = ""                       #: the verdict in words
    sent: list = field(default_factory=list)        #: lines and real-time bytes sent, in order
    reported: list = field(default_factory=list)    #: answers and status reports that decided it
    beam: str = "not observed"             #: what the beam did (simulators), or why unobserved

    def line(self) -> str:
        """One line for a terminal: verdict, title, reason and evidence."""
        return (f"{self.verdict:<14} {self.title}: {self.reason} | sent {' '.join(self.sent) or '-'}"
                f" | reported {' '.join(self.reported) or '-'} | beam {self.beam}")


@dataclass
class SafetyReport:
    """What :func:`run_safety_check` found.

    Attributes
    ----------
    target : str
        ``virtual://``, ``sim:<path>`` or the port.
    controller : str
        The start-up banner.
    s_word : float
        The S word the cuts used.
    cut_mode : str
        ``M4`` or ``M3``.
    beam_observed : bool
        True on the simulators (the beam itself was watched), False on a real machine.
    results : list of ScenarioResult
    """

    target: str
    controller: str = ""
    s_word: float = 0.0
    cut_mode: str = "M4"
    beam_observed: bool = False
    results: list = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """Every applicable scenario passed (and at least one applied)."""
        applied = [r for r in self.results if r.verdict != NOT_APPLICABLE]
        return bool(applied) and all(r.verdict == PASS for r in applied)

    def counts(self) -> dict:
        out = {PASS: 0, FAIL: 0, NOT_APPLICABLE: 0}
        for r in self.results:
            out[r.verdict] += 1
        return out

    def format(self) -> str:
        """The report as text: a header, one line per scenario, a summary line."""
        c = self.counts()
        head = (f"safety check of {self.target} ({self.controller or 'no banner'}), cuts with "
                f"{self.cut_mode} S{self.s_word:g}; beam "
                + ("watched on the simulator" if self.beam_observed else
                   "not watched: judged from the controller's reports only"))
        tail = (f"{'all applicable scenarios passed' if self.ok else 'UNSAFE or unproven'}: "
                f"{c[PASS]} passed, {c[FAIL]} failed, {c[NOT_APPLICABLE]} not applicable")
        return "\n".join([head] + [r.line() for r in self.results] + [tail])

    def to_dict(self) -> dict:
        d = asdict(self)
        d["ok"] = self.ok
        return d

    def to_json(self) -> str:
        """A machine-readable record (``labkit safety-check --json``)."""
        return json.dumps(self.to_dict(), indent=1)

    def table(self):
        """The results as a pandas DataFrame (scenario, verdict, reason, beam)."""
        import pandas as pd

        return pd.DataFrame([{"scenario": r.title, "verdict": r.verdict, "reason": r.reason,
                              "beam": r.beam} for r in self.results])


# -- the beam, where it can be watched ----------------------------------------------------------

class _NoBeam:
    """A real machine: the beam is not watched."""

    observed = False

    def mark(self) -> int:
        return 0

    def level(self) -> float | None:
        return None

    def on_since(self, mark: int) -> list:
        return []

    def describe_since(self, mark: int) -> str:
        return "not observed (a real machine: judged from its reports)"


class _VirtualBeam:
    """The virtual machine's beam (``vm.beam_log``: simulated s, fraction, state, line)."""

    observed = True

    def __init__(self, vm):
        self.vm = vm

    def _rows(self) -> list:
        return list(self.vm.beam_log)

    def mark(self) -> int:
        return len(self._rows())

    def level(self) -> float:
        _ = self.vm.in_waiting                     # let simulated time catch up
        return self.vm.laser_output()

    def on_since(self, mark: int) -> list:
        return [r for r in self._rows()[mark:] if r[1] > 0]

    def describe_since(self, mark: int) -> str:
        rows = self._rows()[mark:]
        now = self.level()
        text = ", ".join(f"{lv:.3f} at {t:.2f} s ({st})" for t, lv, st, _ in rows[-4:]) or "no change"
        return f"now {now:.3f} of full; changes since: {text}"


class _SimBeam:
    """The firmware simulator's ``--beam-log`` CSV (``time_s,duty,state,line``)."""

    observed = True

    def __init__(self, path: Path):
        self.path = Path(path)
        self.rows: list = []
        self._offset = 0

    def _read(self) -> list:
        try:
            with open(self.path, encoding="ascii", errors="replace") as fh:
                fh.seek(self._offset)
                chunk = fh.read()
        except FileNotFoundError:
            return self.rows
        end = chunk.rfind("\n")
        if end < 0:
            return self.rows
        self._offset += len(chunk[:end + 1].encode("ascii", "replace"))
        for rec in csv.reader(chunk[:end + 1].splitlines()):
            if not rec or rec[0] == "time_s":
                continue
            try:
                self.rows.append((float(rec[0]), int(rec[1]), rec[2], int(rec[3])))
            except (ValueError, IndexError):
                raise MachineError(f"{self.path}: malformed beam-log row {rec!r} (expected "
                                   f"time_s,duty,state,line)") from None
        return self.rows

    def mark(self) -> int:
        return len(self._read())

    def level(self) -> float:
        rows = self._read()
        return float(rows[-1][1]) if rows else 0.0

    def on_since(self, mark: int) -> list:
        return [r for r in self._read()[mark:] if r[1] > 0]

    def describe_since(self, mark: int) -> str:
        rows = self._read()[mark:]
        text = ", ".join(f"duty {d} at {t:.3f} s ({st})" for t, d, st, _ in rows[-4:]) or "no change"
        return f"duty now {self.level():g}; changes since: {text}"


# -- targets: how to reach the controller (and to reach it again after a disconnect) ------------

def _cable(vm):
    """A port to the virtual machine whose ``close`` pulls the cable: the machine keeps going."""
    from labkit.machine.faults import FaultyPort

    class Cable(FaultyPort):
        def close(self):
            self.dead = True

    return Cable(vm)


class _Target:
    kind = "port"
    cut_mm = CUT_MM
    cut_feed_mm_min = CUT_FEED_MM_MIN
    rapids = 1                                     # G0 moves in the rapid scenario

    def __init__(self, name: str):
        self.name = name
        self.beam = _NoBeam()

    def open(self, *, fresh: bool = True):
        raise NotImplementedError

    def idle(self, seconds: float) -> None:
        time.sleep(seconds)

    def run_out_s(self) -> float:
        """Wall time within which a cut left to itself has surely ended, s."""
        return 2.0 * self.cut_mm / self.cut_feed_mm_min * 60.0 + 2.0

    def close(self) -> None:
        pass


class _VirtualTarget(_Target):
    kind = "virtual"

    def __init__(self, vm):
        super().__init__("virtual://")
        self.vm = vm
        self.beam = _VirtualBeam(vm)

    def open(self, *, fresh: bool = True):
        from labkit.machine.grbl import Grbl
        from labkit.machine.link import Link

        g = Grbl(Link(_cable(self.vm), self.name))
        if not fresh:
            g.realtime("soft_reset")                # no banner on a reopened port
        g.connect(timeout_s=5.0)
        return g

    def idle(self, seconds: float) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            _ = self.vm.in_waiting                  # the machine runs on while polled
            time.sleep(0.005)

    def run_out_s(self) -> float:
        cut_s = self.cut_mm / self.cut_feed_mm_min * 60.0
        return 2.0 * cut_s / self.vm.time_scale + 2.0 if self.vm.time_scale > 0 else 30.0


class _SimTarget(_Target):
    kind = "sim"
    # the simulator runs as fast as the host allows (millions of step ticks a second, whatever
    # the feed): a cut long in steps lasts long enough in wall time to be caught mid-way
    cut_mm = 1000.0
    cut_feed_mm_min = 600.0

    def __init__(self, sim_path: Path, folder: Path):
        super().__init__(f"sim:{sim_path}")
        log = folder / "beam-log.csv"
        cmd = [str(sim_path), "--pty", "--dialect", "grbl", "--beam-log", str(log)]
        self.proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                     stderr=subprocess.PIPE, text=True)
        first = self.proc.stderr.readline()
        if "pty " not in first:
            self.close()
            raise MachineError(f"the firmware simulator {sim_path} did not start with --beam-log "
                               f"({first.strip() or 'no output'}); rebuild it: make -C firmware sim")
        self.pty = first.split("pty ", 1)[1].strip()
        self.beam = _SimBeam(log)

    def run_out_s(self) -> float:
        return 10.0                                # it runs far faster than real time

    def open(self, *, fresh: bool = True):
        from labkit.machine.grbl import Grbl
        from labkit.machine.link import open_link

        g = Grbl(open_link(self.pty))
        g.realtime("soft_reset")                    # its banner went out before the pty was opened
        g.connect(timeout_s=5.0)
        return g

    def close(self) -> None:
        end_process(self.proc)


class _PortTarget(_Target):
    def __init__(self, port: str, baud: int):
        super().__init__(port)
        self.baud = baud
        self.reset_on_open = False

    def open(self, *, fresh: bool = True):
        g = self.reopen()
        g.connect(timeout_s=5.0)
        return g

    def reopen(self):
        """The port opened again without a reset (``connect`` would provoke one): what the
        controller reports then is what it did on its own. A board that resets when its port
        opens (DTR) sends its banner by itself: ``info.banner`` is set after this."""
        from labkit.machine.grbl import Grbl
        from labkit.machine.link import open_link

        g = Grbl(open_link(self.name, self.baud))
        time.sleep(2.5)
        return g


# -- the scenarios --------------------------------------------------------------------------------

def _accessories(raw: str) -> str | None:
    """The ``A:`` field of a status report ('' when the report has ``Ov:`` but no ``A:``: nothing
    on), or None when the report does not say (GRBL shows both only now and then)."""
    fields = raw.strip("<>").split("|")
    for f in fields:
        if f.startswith("A:"):
            return f[2:]
    return "" if any(f.startswith("Ov:") for f in fields) else None


class _Run:
    """One scenario in progress: sends, records, judges."""

    def __init__(self, check: "_Check", key: str):
        self.check = check
        self.result = ScenarioResult(key, SCENARIOS[key])
        self.mark = 0

    @property
    def g(self):
        """The controller's client now (a new one after the link was lost and reopened)."""
        return self.check.g

    # -- talking ---------------------------------------------------------------------------------

    def send(self, line: str) -> None:
        self.result.sent.append(line)
        self.g.send_line(line)

    def command(self, line: str, timeout_s: float = 30.0) -> str:
        """Send a line and wait for its answer; returns 'ok' or 'error:N' (recorded)."""
        self.result.sent.append(line)
        try:
            self.g.command(line, timeout_s)
            answer = "ok"
        except MachineError as exc:
            text = str(exc)
            if "error:" not in text:
                raise
            answer = "error:" + text.split("error:", 1)[1].split(":", 1)[0]
        self.result.reported.append(f"{line} → {answer}")
        return answer

    def realtime(self, name: str, label: str) -> None:
        self.result.sent.append(label)
        self.g.realtime(name)

    def soft_reset(self) -> None:
        """Send the soft reset (Ctrl-X, recorded as 0x18)."""
        self.result.sent.append("0x18")
        self.g.soft_reset()

    def status(self):
        return self.g.get_status(5.0)

    def wait(self, pred, timeout_s: float, what: str):
        """Poll status until ``pred``; returns the status or None (recorded as the evidence)."""
        deadline = time.monotonic() + timeout_s
        st = None
        while time.monotonic() < deadline:
            try:
                st = self.g.get_status(2.0)
            except MachineError:
                st = None
                break
            if pred(st):
                return st
            time.sleep(0.005)
        self.result.reported.append(f"waited {timeout_s:g} s for {what}; last "
                                    + (st.raw if st is not None else "no status"))
        return None

    # -- the cut and the control -----------------------------------------------------------------

    def start_cut(self, mode: str | None = None) -> bool:
        """Start a slow relative cut and wait until it burns: the controller reports the laser
        value (or A:) and, on a simulator, the beam is on. False when it never did; the
        scenario has then failed, saying that nothing was checked."""
        if self._burning_cut(mode or self.check.cut_mode):
            return True
        self.fail(f"the beam never came on during the {mode + ' ' if mode else ''}cut: nothing was checked")
        return False

    def _burning_cut(self, mode: str) -> bool:
        """:meth:`start_cut`'s cut and wait (a second cut is tried when the first ended
        unseen, e.g. while the host was busy)."""
        for _attempt in range(2):
            dx = self.check.next_dx()
            answer = self.command(f"G21 G91 G1 X{dx:g} F{self.check.target.cut_feed_mm_min:g} "
                                  f"S{self.check.s_word:g} {mode}")
            if answer != "ok":
                return False
            t_ok = time.monotonic()
            t_end = t_ok + 10.0
            st, seen_run = None, False
            while time.monotonic() < t_end:
                st = self.status()
                acc = _accessories(st.raw)
                if acc:
                    self.check.shows_accessories = True
                reported_on = (st.spindle or 0) > 0 or bool(acc)
                beam = self.check.target.beam.level()
                if st.state == "Run" and reported_on and (beam is None or beam > 0):
                    self.result.reported.append(st.raw)
                    return True
                seen_run = seen_run or st.state == "Run"
                if st.state == "Idle" and (seen_run or time.monotonic() > t_ok + 1.0):
                    break                          # the cut ended unseen
                time.sleep(0.002)
        self.result.reported.append("the cut never reported the beam on"
                                    + (f" (last {st.raw})" if st is not None else ""))
        return False

    def off_now(self, st, *, check_a: bool = True) -> list:
        """What says the beam is not off: the report's laser value, its A: field, the beam."""
        bad = []
        if st.spindle is not None and st.spindle > 0:
            bad.append(f"FS laser value {st.spindle:g}")
        if check_a and self.check.shows_accessories:      # only from a controller that reports A:
            acc = self.accessories_now()
            if acc:
                bad.append(f"A:{acc} (the laser output is enabled)")
        beam = self.check.target.beam
        level = beam.level()
        if level is not None and level > 0:
            bad.append(f"the beam is on ({level:g})")
        return bad

    def accessories_now(self) -> str | None:
        """Poll until a report carries Ov: (GRBL adds A: to it); None when none does."""
        for _ in range(25):
            st = self.status()
            acc = _accessories(st.raw)
            if acc is not None:
                self.result.reported.append(st.raw)
                return acc
        return None

    def watch(self, seconds: float | None = None) -> list:
        """Keep watching after the must-be-off moment; beam-on rows since then."""
        self.check.target.idle(seconds if seconds is not None else self.check.watch_s)
        return self.check.target.beam.on_since(self.mark)

    def judge(self, st, what: str, *, check_a: bool = True) -> None:
        """PASS when nothing says the beam is on at ``st`` and while watched after it."""
        r = self.result
        r.reported.append(st.raw)
        bad = self.off_now(st, check_a=check_a)
        later = self.watch()
        if later:
            t, lv, state, _ = later[0]
            bad.append(f"the beam came on again at {t:.3f} s ({state}, {lv:g})")
        r.beam = self.check.target.beam.describe_since(self.mark)
        if bad:
            r.verdict, r.reason = FAIL, f"{what}, but: " + "; ".join(bad)
        else:
            r.verdict, r.reason = PASS, f"{what}; the beam was off and stayed off"

    def fail(self, reason: str) -> None:
        self.result.verdict, self.result.reason = FAIL, reason
        if self.result.beam == "not observed":          # keep what the scenario recorded
            self.result.beam = self.check.target.beam.describe_since(self.mark)

    def set_mark(self) -> None:
        self.mark = self.check.target.beam.mark()


def _held(st) -> bool:
    """Stopped in a feed hold (Hold:0; a controller without sub-states: Hold)."""
    return st.state == "Hold" and st.substate in (0, None)


class _Check:
    def __init__(self, target: _Target, s_word, cut_mode: str, watch_s: float):
        self.target = target
        self.g = target.open()
        self.controller = self.g.info.banner
        s_max = self.g.setting(30, 1000.0)
        if s_word is None:
            s_word = max(1.0, round(0.01 * s_max))
        if not (isinstance(s_word, (int, float)) and math.isfinite(s_word)
                and s_within(s_word, s_max, positive=True)):
            raise InputError(f"s_word: expected 0 < S ≤ $30 = {s_max:g}, got {s_word!r}")
        if cut_mode not in ("M3", "M4"):
            raise InputError(f"cut_mode: expected 'M3' or 'M4', got {cut_mode!r}")
        self.s_word = float(s_word)
        self.cut_mode = cut_mode
        self.watch_s = watch_s
        self.shows_accessories = False      # the controller reported A: while its beam was on
        self._dx_sign = 1.0
        st = self.g.get_status(5.0)
        if st.state not in ("Idle", "Alarm"):
            raise MachineError(f"the controller is {st.state}, not idle: finish or stop its job first")
        if st.state == "Alarm":
            raise MachineError("the controller is in an alarm: home it ($H) or unlock it ($X) "
                               "and check the position, then run the safety check")
        here = st.wpos if st.wpos is not None else st.mpos      # work coordinates (MPos: no WCO)
        self.home_x = here[0] if here is not None else 0.0

    def next_dx(self) -> float:
        self._dx_sign = -self._dx_sign
        return -self._dx_sign * self.target.cut_mm

    # -- keeping the controller usable between scenarios --------------------------------------------

    def settle(self) -> None:
        """Back to Idle with the beam off: resume a hold, unlock an alarm, M5 S0, G90."""
        g = self.g
        try:
            st = g.get_status(3.0)
            if st.state in ("Hold", "Door"):
                g.resume()
                st = g.wait_status(lambda s: s.state not in ("Hold", "Door"), 10.0)
            if st.state == "Run":
                st = g.wait_status(lambda s: s.state != "Run", 60.0)
            g.drain_events()                   # answers no scenario waited for
            if st.state == "Alarm":
                g.unlock()
            g.command("M5 S0", 30.0)
            g.command(f"G90 G0 X{self.home_x:.3f}", 30.0)   # back where it started, beam off
            g.wait_status(lambda s: s.state == "Idle", 60.0)
        except MachineError:
            g.soft_reset()
            g.drain_events()
            if g.get_status(3.0).state == "Alarm":
                g.unlock()
            g.command("M5 S0", 30.0)

    # -- scenarios ------------------------------------------------------------------------------------

    def feed_hold_and_resume(self, keys) -> list:
        hold, resume = _Run(self, "feed_hold"), _Run(self, "resume")
        out = [r.result for r, k in ((hold, "feed_hold"), (resume, "resume")) if k in keys]
        if not hold.start_cut():
            resume.fail("no hold to resume from")
            return out
        hold.realtime("feed_hold", "!")
        st = hold.wait(_held, 10.0, "Hold:0")
        if st is None:
            hold.fail("the controller did not stop in a feed hold")
            resume.fail("no hold to resume from")
            return out
        hold.set_mark()
        hold.judge(st, f"stopped in {st.raw.split('|')[0][1:]}")
        resume.realtime("cycle_start", "~")
        resume.set_mark()
        st = resume.wait(lambda s: s.state == "Idle", 60.0, "Idle at the end of the cut")
        if st is None:
            resume.fail("the cut did not end after the resume")
            return out
        burned = resume.check.target.beam.on_since(resume.mark)
        resume.set_mark()
        resume.judge(st, "the resumed cut ended and the machine idles")
        if resume.result.verdict == PASS and self.target.beam.observed and not burned:
            resume.result.reason += " (the beam did not come back on for the rest of the cut)"
        return out

    def soft_reset(self, _keys) -> list:
        run = _Run(self, "soft_reset")
        if not run.start_cut():
            return [run.result]
        run.set_mark()
        run.soft_reset()
        self.g.drain_events()                   # the reset's ALARM:3 and banner answer no line
        st = run.status()
        gc = self.g.parser_state()
        run.result.reported.append(f"$G [GC:{gc}]")
        run.judge(st, f"after the reset the controller is in {st.state}"
                  + (f" (ALARM:{self.g.alarm})" if st.state == "Alarm" and self.g.alarm else ""))
        if "M5" not in gc.split() and run.result.verdict == PASS:
            run.fail(f"the reset left the spindle/laser mode on: $G says {gc}")
        return [run.result]

    def door(self, _keys) -> list:
        run = _Run(self, "door")
        if not run.start_cut():
            return [run.result]
        run.realtime("safety_door", "0x84")
        st = run.wait(lambda s: (s.state == "Door" and s.substate in (0, 1, None)) or _held(s)
                      or s.state in ("Idle", "Alarm"), 15.0, "Door:0")
        if st is None or st.state in ("Idle", "Alarm"):
            run.result.verdict = NOT_APPLICABLE
            run.result.reason = ("the controller has no safety door: 0x84 did not stop the cut"
                                 + (f" (it ended in {st.state})" if st is not None else ""))
            return [run.result]
        run.set_mark()
        what = ("stopped in " + st.raw.split("|")[0][1:]
                + ("" if st.state == "Door" else ": the controller takes 0x84 as a feed hold"))
        run.judge(st, what)
        return [run.result]

    def alarm(self, _keys) -> list:
        run = _Run(self, "alarm")
        soft = self.g.setting(20, 0.0) == 1.0
        if not run.start_cut():
            return [run.result]
        run.set_mark()
        if soft:
            # far beyond any travel: refused before it moves; GRBL holds, raises ALARM:2 and
            # waits for a reset ("Reset to continue"), answering nothing meanwhile
            run.send("G91 G0 X-100000")
            how = "a line beyond the soft limits ($20=1)"
            alarmed = self._wait_alarm(run)
            run.soft_reset()
        else:
            run.soft_reset()
            how = "a reset mid-cut ($20=0: no soft limits to trip)"
            alarmed = self._wait_alarm(run)
        self.g.drain_events()
        st = run.status()
        if not alarmed or st.state != "Alarm":
            run.result.verdict = NOT_APPLICABLE
            run.result.reason = f"{how} raised no alarm on this controller ({st.raw})"
            return [run.result]
        refused = [run.command(f"G1 X0.1 F{self.target.cut_feed_mm_min:g} S{self.s_word:g} M3", 5.0),
                   run.command(f"M3 S{self.s_word:g}", 5.0)]
        st = run.status()
        run.judge(st, f"ALARM:{self.g.alarm} after {how}; beam-firing lines answered "
                  + ", ".join(refused))
        if run.result.verdict == PASS and any(a == "ok" for a in refused):
            run.fail("a line that fires the beam was accepted in the alarm state")
        return [run.result]

    def _wait_alarm(self, run: _Run) -> bool:
        """Wait for an ALARM:N line (a controller in a critical alarm answers no status)."""
        if self.g.alarm:
            run.result.reported.append(f"ALARM:{self.g.alarm}")
            return True
        deadline = time.monotonic() + 10.0
        while time.monotonic() < deadline:
            ev = self.g.next_event(0.1)
            if ev is not None and ev.kind == "alarm":
                run.result.reported.append(ev.text)
                return True
        return False

    def error_line(self, _keys) -> list:
        run = _Run(self, "error_line")
        st0 = run.status()
        if st0.state != "Idle":
            run.fail(f"not idle before the check ({st0.raw})")
            return [run.result]
        run.set_mark()
        dx = self.target.cut_mm
        answer = run.command(f"G91 G1 X{dx:g} X{-dx:g} F{self.target.cut_feed_mm_min:g} "
                             f"S{self.s_word:g} M3")
        st = run.status()
        gc = self.g.parser_state()
        run.result.reported.append(f"$G [GC:{gc}]")
        run.judge(st, f"the line was answered {answer}")
        if answer == "ok":
            run.fail("the controller accepted a line with X given twice (GRBL: error:25)")
        elif run.result.verdict == PASS and "M3" in gc.split():
            run.fail(f"the rejected line changed the laser mode: $G says {gc}")
        return [run.result]

    def _after_m3_cut(self, key: str, word: str) -> list:
        run = _Run(self, key)
        if not run.start_cut("M3"):
            return [run.result]
        answer = run.command(word, 60.0)
        run.set_mark()
        st = run.wait(lambda s: s.state == "Idle", 30.0, "Idle")
        if st is None:
            run.fail(f"the controller did not idle after {word}")
            return [run.result]
        gc = self.g.parser_state()
        run.result.reported.append(f"$G [GC:{gc}]")
        run.judge(st, f"{word} answered {answer}")
        if run.result.verdict == PASS and "M5" not in gc.split():
            run.fail(f"{word} left the laser mode on: $G says {gc}")
        return [run.result]

    def program_end_m2(self, _keys) -> list:
        return self._after_m3_cut("program_end_m2", "M2")

    def program_end_m30(self, _keys) -> list:
        return self._after_m3_cut("program_end_m30", "M30")

    def m5(self, _keys) -> list:
        return self._after_m3_cut("m5", "M5")

    def _rapid(self, run: _Run) -> list:
        """A G0 with M3 S in effect; returns the status reports taken during the rapid."""
        run.command(f"G91 G0 M3 S{self.s_word:g}")
        run.set_mark()
        dx = self.next_dx()
        for k in range(self.target.rapids):
            run.send(f"G0 X{dx if k % 2 == 0 else -dx:g}")
        seen, t_end = [], time.monotonic() + 30.0
        while time.monotonic() < t_end:
            st = run.status()
            seen.append(st)
            if st.state == "Idle" and any(s.state == "Run" for s in seen):
                break
            if st.state == "Idle" and len(seen) > 200:
                break
            time.sleep(0.002)
        for _ in range(self.target.rapids):      # their answers, so that none answers a later line
            self.g.next_event(5.0)
        return seen

    def g0_laser_mode(self, _keys) -> list:
        run = _Run(self, "g0_laser_mode")
        if self.g.setting(32, 0.0) != 1.0:
            run.fail("laser mode is off ($32=0): GRBL keeps the beam on during every rapid and "
                     "stop; set $32=1 for a laser")
            return [run.result]
        seen = self._rapid(run)
        moving = [s for s in seen if s.state == "Run"]
        if not moving:
            run.fail("the rapid was not seen moving: nothing was checked")
            return [run.result]
        lit = [s.raw for s in moving if (s.spindle or 0) > 0 or _accessories(s.raw)]
        run.result.reported += [moving[0].raw, moving[-1].raw]
        on = self.target.beam.on_since(run.mark)
        run.result.beam = self.target.beam.describe_since(run.mark)
        bad = ([f"reported on while moving: {lit[0]}"] if lit else []) + \
              ([f"the beam was on during the rapid ({on[0][1]:g} at {on[0][0]:.3f} s)"] if on else [])
        if bad:
            run.fail("G0 with M3 S in effect in laser mode: " + "; ".join(bad))
        else:
            run.result.verdict = PASS
            run.result.reason = (f"G0 with M3 S{self.s_word:g} in effect: off through "
                                 f"{len(moving)} reports while moving")
        self.g.command("M5 S0")
        if self.target.beam.observed:          # the contrast, where no real beam burns a line
            self._spindle_mode_contrast(run)
        return [run.result]

    def _spindle_mode_contrast(self, run: _Run) -> None:
        try:
            self.g.set_setting(32, 0)
            run.result.sent.append("$32=0")
            seen = self._rapid(run)
            on = self.target.beam.on_since(run.mark)
            lit = [s.raw for s in seen if (s.spindle or 0) > 0 or _accessories(s.raw)]
            run.result.reason += ("; with $32=0 the same rapid " +
                                  ("burned: beam on" + (f" ({lit[0]})" if lit else "")
                                   if on or lit else "kept the beam off")
                                  + " — labkit refuses burning jobs on a machine with $32=0")
        finally:
            self.g.command("M5 S0")
            self.g.set_setting(32, 1)
            run.result.sent += ["M5 S0", "$32=1"]

    def disconnect(self, _keys) -> list:
        run = _Run(self, "disconnect")
        if not run.start_cut():
            return [run.result]
        run.result.sent.append("(link closed)")
        run.set_mark()
        self.g.close()
        beam = self.target.beam
        if beam.observed:
            # the controller runs its buffer out on its own; the beam must be off when it stops
            t_end = time.monotonic() + self.target.run_out_s()
            while time.monotonic() < t_end and beam.level() > 0:
                self.target.idle(0.01)
            level = beam.level()
            self.target.idle(self.watch_s)
            rows = beam.on_since(run.mark)
            late = [r for r in rows if r[2] in ("Idle", "Alarm", "Hold", "Door", "Check")]
            run.result.beam = beam.describe_since(run.mark)
            self.g = self.target.open(fresh=False)
            if level > 0 or beam.level() > 0 or late:
                run.fail(f"after the link was lost the beam stayed on ({max(level, beam.level()):g})"
                         + (f" while {late[0][2]}" if late else " after the controller had run "
                            "out its buffer"))
            else:
                run.result.verdict = PASS
                run.result.reason = ("the controller ran out its buffer and stopped with the beam "
                                     "off; nobody told it to stop")
            return [run.result]
        self.target.idle(self.target.run_out_s())
        self.g = self.target.reopen()
        if self.g.info.banner:
            run.result.verdict = NOT_APPLICABLE
            run.result.reason = ("the board reset when its port was opened again (DTR), so what it "
                                 "did after the link was lost cannot be read from it; watch the beam")
        else:
            st = run.status()
            run.judge(st, f"the controller ran out its buffer and reports {st.state}")
        self.g.connect(timeout_s=5.0)
        return [run.result]


_ORDER = (("feed_hold", "feed_hold_and_resume"), ("resume", "feed_hold_and_resume"),
          ("soft_reset", "soft_reset"), ("door", "door"), ("alarm", "alarm"),
          ("error_line", "error_line"), ("program_end_m2", "program_end_m2"),
          ("program_end_m30", "program_end_m30"), ("m5", "m5"),
          ("g0_laser_mode", "g0_laser_mode"), ("disconnect", "disconnect"))


def run_safety_check(port: str | None = None, *, sim=None, virtual=None, machine=None,
                     s_word: float | None = None, cut_mode: str = "M4", scenarios=None,
                     baud: int | None = None, time_scale: float = 5.0, watch_s: float = 0.3,
                     progress=None) -> SafetyReport:
    """Run the safety scenarios against a controller and report each one.

    Parameters
    ----------
    port : str, optional
        A serial device or pyserial URL of a real controller (GRBL 1.1 protocol). None: the
        virtual machine, or the firmware simulator with ``sim``.
    sim : str, Path or True, optional
        The firmware's host simulator (``True``: :func:`default_sim_path`), started over a pty
        with ``--beam-log``; its beam is watched.
    virtual : VirtualMachine, optional
        The virtual machine to check (a test can give a deliberately unsafe one); default a
        new one of ``machine`` running ``time_scale`` times real time.
    machine : str, optional
        Machine description of the virtual machine (default ``grbl-diode``).
    s_word : float, optional
        The S word of the cuts, 0 < S ≤ ``$30`` (default 1 % of ``$30``): keep it low on a
        real machine.
    cut_mode : {"M4", "M3"}
        How the stop scenarios cut (the M2/M30/M5/G0 scenarios always use M3, whose constant
        power is what they must turn off).
    scenarios : iterable of str, optional
        Keys of :data:`SCENARIOS` to run (default all, in that order).
    baud : int, optional
        Baud rate of a real port (default 115200).
    time_scale : float
        Simulated seconds per real second of a new virtual machine.
    watch_s : float
        How long the beam is watched after each must-be-off moment, s.
    progress : callable, optional
        ``progress(result)`` after each scenario.

    Returns
    -------
    SafetyReport

    Raises
    ------
    InputError
        An unknown scenario, a bad power or mode.
    MachineError
        The controller cannot be reached (or the simulator lacks ``--beam-log``), or it stopped
        answering during a scenario: the machine is then stopped (feed hold, soft reset,
        ``M5 S0``: :meth:`~labkit.machine.grbl.Grbl.stop_safely`) and the message says what was
        confirmed. An interrupt (Ctrl-C) stops the machine the same way before it goes on.

    Notes
    -----
    The library asks nobody before it drives a port; ``labkit safety-check --port`` warns and
    asks for confirmation first.

    Examples
    --------
    >>> report = run_safety_check(scenarios=["feed_hold", "m5"])
    >>> [(r.key, r.verdict) for r in report.results]
    [('feed_hold', 'PASS'), ('m5', 'PASS')]
    >>> report.ok
    True
    """
    from labkit.machine.link import DEFAULT_BAUD

    keys = list(SCENARIOS) if scenarios is None else list(scenarios)
    unknown = [k for k in keys if k not in SCENARIOS]
    if unknown:
        raise InputError(f"scenarios: unknown {unknown}; expected some of {', '.join(SCENARIOS)}")
    if sum(x is not None for x in (port, sim, virtual)) > 1:
        raise InputError("give at most one of port, sim and virtual")
    tmp = None
    if sim is not None:
        path = default_sim_path() if sim is True else Path(sim)
        if not path.is_file():
            raise MachineError(f"no firmware simulator at {path}: build it with 'make -C firmware sim'")
        tmp = tempfile.TemporaryDirectory(prefix="labkit-safety-")
        target = _SimTarget(path, Path(tmp.name))
    elif port is not None:
        target = _PortTarget(port, baud or DEFAULT_BAUD)
    else:
        if virtual is None:
            from labkit.machine.virtual import VirtualMachine

            virtual = VirtualMachine(machine, time_scale=time_scale)
        target = _VirtualTarget(virtual)
    try:
        check = _Check(target, s_word, cut_mode, watch_s)
        report = SafetyReport(target.name, check.controller, check.s_word, cut_mode,
                              target.beam.observed)
        done = set()
        for key, method in _ORDER:
            if key not in keys or method in done:
                continue
            done.add(method)
            try:
                results = getattr(check, method)(set(keys))
                check.settle()
            except BaseException as exc:
                # whatever went wrong (no answer, Ctrl-C), the test cut must not go on burning
                stop = check.g.stop_safely()
                check.g.close()
                if not isinstance(exc, MachineError):
                    raise
                raise MachineError(f"the safety check stopped in '{key}': {exc}; then: "
                                   f"{', '.join(stop.steps)}") from exc
            for result in results:
                report.results.append(result)
                if progress is not None:
                    progress(result)
        check.g.close()
        return report
    finally:
        target.close()
        if tmp is not None:
            tmp.cleanup()
