"""The job runner: stream a G-code job safely, with progress, faults and resume.

:func:`run_job` sends a :class:`Job` to a :class:`~labkit.machine.grbl.Grbl`
machine by character counting (keep the bytes of unanswered lines, newline
included, within the RX buffer; every ``ok``/``error`` retires the oldest) or
send-response (one line at a time), polls status reports, and reports
progress by source line with an ETA from :func:`labkit.motion.plan`.

Faults — ``error:N`` (policy ``stop`` or ``skip``), an alarm, a reset, a lost
link, no status replies (the watchdog), no answer while the machine idles (a
lost byte), a cancel — stop the job. labkit then does the safe thing it can:
feed hold, soft reset (which flushes every buffered line and turns the beam
off), and ``M5 S0`` when the machine accepts lines again. The
:class:`JobReport` names the last acknowledged line and the last *executed*
line (from the planner occupancy in status reports: acknowledged is not
executed), the position where motion stopped, and the line to resume from.

Resume (:func:`resume_text`) rebuilds the modal state in effect at a line
(units, distance mode, arc-centre mode, plane, feed, laser mode and power)
from the parse, moves to the stop point with the beam off, finishes the
interrupted line from there, and continues with the next lines — so every
line runs exactly once.
"""

from __future__ import annotations

import bisect
import math
import re
import time
from collections import deque
from dataclasses import dataclass, field

import numpy as np

from labkit.errors import InputError, LabkitError, MachineError
from labkit.machine.grbl import Grbl, alarm_message, error_message

__all__ = ["Job", "JobReport", "run_job", "resume_text", "frame_text", "strip_line", "Controls"]

_COMMENT = re.compile(r"\([^)]*\)|;.*$")


def strip_line(text: str) -> str:
    """A line as it goes to the machine: comments, spaces and the line end removed.

    >>> strip_line("G1 X10 Y5 (cut) ; to the corner")
    'G1X10Y5'
    >>> strip_line("  ; only a comment")
    ''
    """
    return _COMMENT.sub("", text).replace(" ", "").replace("\t", "").strip().upper()


@dataclass
class Job:
    """A G-code program ready to stream.

    Attributes
    ----------
    source_lines : list of str
        The file's lines as written (1-based line ``k`` is ``source_lines[k-1]``).
    send : list of (int, str)
        (source line, text to send) for every line that sends something.
    moves : Moves
        The parse (strict: a file with an error never starts).
    blocks_per_line : dict
        Planner blocks GRBL makes of each source line (arcs cut by ``$12``).
    done_at_s : dict
        Planned time at which each source line's motion ends (for the ETA).
    job_time_s : float
        Planned job time (labkit.motion).
    """

    source_lines: list
    send: list
    moves: object
    blocks_per_line: dict
    done_at_s: dict
    job_time_s: float
    filename: str | None = None
    dialect: str = "grbl"

    @classmethod
    def from_text(cls, text: str, *, filename: str | None = None, dialect: str = "grbl",
                  machine=None, arc_tol_mm: float = 0.002, max_line: int = 80) -> "Job":
        """Parse and plan a program; refuse it before anything moves when it is bad.

        Raises
        ------
        GcodeError
            A line the parser rejects (file, line, column, what was expected).
        InputError
            A line longer than the controller accepts.
        """
        from labkit.gcode import parse
        from labkit.geometry.circle import grbl_segments

        moves = parse(text, dialect=dialect, filename=filename)
        source = text.split("\n")
        if source and source[-1] == "":
            source.pop()
        send = []
        for k, raw in enumerate(source, 1):
            s = strip_line(raw.rstrip("\r"))
            if s.startswith("%"):
                continue
            if s:
                if len(s) > max_line:
                    raise InputError(f"{filename or '<string>'}:{k}:1: line of {len(s)} characters "
                                     f"after removing comments and spaces; the controller takes "
                                     f"at most {max_line}")
                send.append((k, s))
        blocks: dict[int, int] = {}
        lengths = moves.lengths_mm()
        arcs = moves.is_arc
        for i in range(len(moves)):
            if lengths[i] <= 1e-9 and moves.kind[i] != 4:
                continue
            n = 1
            if arcs[i] and moves.plane[i] == 17:
                n = int(grbl_segments(float(moves.radius_mm()[i]), float(moves.sweep_rad()[i]),
                                      arc_tol_mm))
            blocks[int(moves.line[i])] = blocks.get(int(moves.line[i]), 0) + n
        done_at: dict[int, float] = {}
        job_time = 0.0
        try:
            from labkit.motion import plan

            p = plan(moves, machine)
            ends = p.block_start_s + p.block_time_s
            for ln, t in zip(p.blocks.line.tolist(), ends.tolist()):
                done_at[ln] = max(done_at.get(ln, 0.0), t)
            job_time = p.job_time_s
        except (LabkitError, ValueError) as exc:
            raise MachineError(f"cannot plan the job for its ETA: {exc}") from exc
        return cls(source, send, moves, blocks, done_at, job_time, filename, dialect)

    @classmethod
    def from_file(cls, path, **kw) -> "Job":
        from labkit._files import check_input_file

        check_input_file(path, what="G-code job")
        with open(path, "rb") as fh:
            text = fh.read().decode("utf-8", "replace")
        return cls.from_text(text, filename=str(path), **kw)

    @property
    def burns(self) -> bool:
        return bool(np.any(self.moves.laser_on))

    def eta_s(self, executed_line: int) -> float:
        """Planned time left after ``executed_line`` has run."""
        done = 0.0
        for ln, t in self.done_at_s.items():
            if ln <= executed_line:
                done = max(done, t)
        return max(0.0, self.job_time_s - done)


@dataclass
class Controls:
    """Pause, resume and cancel a running job from another thread (a notebook button)."""

    pause_requested: bool = False
    cancel_requested: bool = False

    def pause(self):
        self.pause_requested = True

    def resume(self):
        self.pause_requested = False

    def cancel(self):
        self.cancel_requested = True


@dataclass
class JobReport:
    """What happened to a job."""

    ok: bool
    lines_total: int
    lines_sent: int = 0
    lines_acknowledged: int = 0
    last_acknowledged_line: int = 0        #: source line of the last ok/error received
    last_executed_line: int = 0            #: source line whose motion completed last
    stop_position: tuple | None = None     #: where motion stopped, job coordinates (WPos; MPos if no WCO seen)
    resume_line: int | None = None         #: first source line not (fully) executed
    fault: str | None = None               #: what stopped the job, in words
    errors: list = field(default_factory=list)   #: (source line, code, message)
    elapsed_s: float = 0.0
    planned_s: float = 0.0
    max_rx_used: int = 0
    safe_actions: list = field(default_factory=list)
    warnings: list = field(default_factory=list)
    answers_lost: int = 0                  #: ok/error answers the link lost (re-synchronised)

    def summary(self) -> str:
        state = "completed" if self.ok else ("completed over a faulty link" if self.answers_lost
                                             and not self.fault and not self.errors else "STOPPED")
        lines = [f"{state}: {self.lines_acknowledged}/"
                 f"{self.lines_total} lines acknowledged in {self.elapsed_s:.1f} s "
                 f"(planned {self.planned_s:.1f} s)"]
        for ln, code, msg in self.errors:
            lines.append(f"  line {ln}: error:{code}: {msg}")
        if self.fault:
            lines.append(f"  fault: {self.fault}")
            lines.append(f"  last acknowledged line {self.last_acknowledged_line}, last executed "
                         f"line {self.last_executed_line}"
                         + (f", stopped at {_fmt_xyz(self.stop_position)}" if self.stop_position
                            else ""))
            if self.safe_actions:
                lines.append(f"  safe actions: {', '.join(self.safe_actions)}")
            if self.resume_line:
                lines.append(f"  resume with --resume-from {self.resume_line}")
        for w in self.warnings:
            lines.append(f"  {w}")
        return "\n".join(lines)


def _fmt_xyz(p) -> str:
    return "(" + ", ".join(f"{v:.3f}" for v in p) + ")"


class _Fault(Exception):
    def __init__(self, text: str, *, reset: bool = True, hold: bool = True):
        super().__init__(text)
        self.reset = reset
        self.hold = hold


def run_job(grbl: Grbl, job: Job, *, mode: str = "counting", on_error: str = "stop",
            check_first: bool = False, resume_from: int | None = None,
            resume_position=None, progress=None, controls: Controls | None = None,
            status_interval_s: float = 0.1, watchdog_s: float = 3.0, stall_s: float = 2.0,
            allow_spindle_mode: bool = False) -> JobReport:
    """Stream a job; return a report (a fault never raises: it is in the report).

    Parameters
    ----------
    grbl : Grbl
        A connected machine.
    job : Job
    mode : {"counting", "send-response"}
    on_error : {"stop", "skip"}
        ``stop``: an ``error:N`` stops the job safely. ``skip``: the line is
        reported and the job goes on (the controller already skipped it).
    check_first : bool
        Run the whole job in GRBL's check mode (``$C``) first; stop if any
        line is rejected.
    resume_from : int, optional
        Source line to start from (see :func:`resume_text`).
    resume_position : sequence of 3 floats, optional
        Where the interrupted line stopped (``report.stop_position``): the
        line is finished from there instead of being run again from its start.
    progress : callable, optional
        ``progress(executed_line, acknowledged_line, total_lines, eta_s)``.
    controls : Controls, optional
        Pause / resume / cancel from another thread.
    watchdog_s : float
        Stop when no status report arrives for this long during the job.
    stall_s : float
        Stop when lines stay unanswered this long while the machine idles with
        an empty RX buffer (a lost byte: character counting would wait forever).

    Raises
    ------
    MachineError
        Before anything is sent: a burning job with ``$32=0`` (unless
        ``allow_spindle_mode``), a bad option.
    """
    if mode not in ("counting", "send-response"):
        raise InputError(f"mode must be 'counting' or 'send-response', got {mode!r}")
    if on_error not in ("stop", "skip"):
        raise InputError(f"on_error must be 'stop' or 'skip', got {on_error!r}")
    controls = controls or Controls()
    report = JobReport(ok=False, lines_total=len(job.source_lines), planned_s=job.job_time_s)
    warn = grbl.check_laser_job(job.burns, allow_spindle_mode=allow_spindle_mode)
    if warn:
        report.warnings.append(warn)
    if check_first:
        bad = check_job(grbl, job)
        if bad:
            report.errors.extend(bad)
            report.fault = f"check mode ($C) rejected {len(bad)} line(s); nothing was cut"
            return report
    send = list(job.send)
    if resume_from is not None:
        send = _resume_send(job, int(resume_from), resume_position)
    rx_limit = grbl.info.rx_bytes - 1 if mode == "counting" else 10 ** 9
    inflight: deque = deque()          # (source line, bytes)
    used = 0
    i = 0
    t0 = time.monotonic()
    last_poll = 0.0
    last_status_seen = grbl.status_count
    last_status_t = time.monotonic()
    stall_since = None
    acked: list[tuple[int, int]] = []  # (source line, blocks) of acknowledged motion lines
    paused = False
    grbl.drain_events()
    # Re-synchronisation after a lost answer (character counting): the bytes sent before each '?'
    # are in the controller (one ordered link), so bytes sent − its RX fill is a lower bound on what
    # it has consumed; every consumed line but the one it may be blocked on has been answered.
    answers_base = grbl.answer_count
    answers_start = answers_base
    events_taken = 0                   # ok/error events taken from the queue
    line_ends: list[int] = []          # cumulative bytes at the end of each line sent
    sent_texts: list[str] = []
    sent_bytes = 0
    q_marks: deque = deque()           # sent_bytes when each '?' went out

    def _drop_lost(lost: int, *, ran: bool = True) -> int:
        """Count the oldest ``lost`` lines in flight as answered (``ran``: as executed too);
        returns their bytes."""
        freed = 0
        for _ in range(min(lost, len(inflight))):
            ln, n = inflight.popleft()
            freed += abs(n)
            report.lines_acknowledged += 1
            report.last_acknowledged_line = max(report.last_acknowledged_line, ln)
            if ran and ln in job.blocks_per_line:
                acked.append((ln, job.blocks_per_line[ln]))
            report.answers_lost += 1
            report.warnings.append(
                f"an answer (or a line end) was lost on the link near line {ln}: re-synchronised "
                f"from the controller's buffer report, so later errors name the right line; check "
                f"the work there (a lost line end merges two lines)")
        return freed

    try:
        while i < len(send) or inflight:
            now = time.monotonic()
            if controls.cancel_requested:
                raise _Fault("cancelled by the user")
            if controls.pause_requested and not paused:
                grbl.feed_hold()
                paused = True
            elif paused and not controls.pause_requested:
                grbl.resume()
                paused = False
            if now - last_poll >= status_interval_s:
                q_marks.append(sent_bytes)
                grbl.realtime("status")
                last_poll = now
            if grbl.status_count != last_status_seen:
                fresh = grbl.status_count - last_status_seen
                last_status_seen = grbl.status_count
                last_status_t = now
                snap = None
                for _ in range(min(fresh, len(q_marks))):
                    snap = q_marks.popleft()
                st = grbl.status
                # only once every answer before this report has been taken: an error among them
                # must first be named (below), not skipped over
                if (mode == "counting" and st is not None
                        and st.answers_before - answers_start == events_taken):
                    lost = _answers_lost(grbl, snap, line_ends, sent_texts, answers_base)
                    used -= _drop_lost(lost)
                    answers_base -= lost
            elif now - last_status_t > watchdog_s:
                raise _Fault(f"watchdog: no status report for {watchdog_s:g} s; stopped sending",
                             reset=True)
            # send what fits
            sent_any = False
            while i < len(send) and not paused:
                ln, text = send[i]
                n = len(text) + 1
                settings_line = text.startswith("$")
                if inflight and (mode == "send-response" or settings_line
                                 or inflight[0][1] < 0 or used + n > rx_limit):
                    break
                grbl.send_line(text)
                inflight.append((ln, -n if settings_line else n))
                sent_bytes += n
                line_ends.append(sent_bytes)
                sent_texts.append(text)
                used += n
                report.max_rx_used = max(report.max_rx_used, used)
                report.lines_sent += 1
                i += 1
                sent_any = True
                if settings_line or mode == "send-response":
                    break
            ev = grbl.next_event(0.0 if sent_any else 0.01)
            if ev is None:
                st = grbl.status
                if (inflight and st is not None and st.state == "Idle" and st.rx_free is not None
                        and st.rx_free >= grbl.info.rx_bytes - 1 and st.received_s > now - 0.5):
                    stall_since = stall_since or now
                    if now - stall_since > stall_s:
                        raise _Fault(f"no answer for line {inflight[0][0]} while the machine is "
                                     f"idle with an empty buffer (a byte was lost on the link)")
                else:
                    stall_since = None
                continue
            stall_since = None
            if ev.kind in ("ok", "error"):
                if not inflight:
                    report.warnings.append(f"unexpected '{ev.text}' with no line in flight")
                    continue
                if ev.kind == "error" and mode == "counting":
                    # before naming the line: ask for a report after this error, in case an
                    # earlier answer was lost and the oldest line in flight is not this one
                    # (a full planner leaves one line possibly unanswered for a while: wait for a
                    # free block so that the report tells a blocked line from a lost answer)
                    snap = None
                    deadline = time.monotonic() + 1.0
                    while True:
                        q_marks.append(sent_bytes)
                        grbl.realtime("status")
                        wanted = last_status_seen + len(q_marks)      # every '?' in flight answered
                        while grbl.status_count < wanted and time.monotonic() < deadline:
                            time.sleep(0.005)
                        for _ in range(min(grbl.status_count - last_status_seen, len(q_marks))):
                            snap = q_marks.popleft()
                        last_status_seen = grbl.status_count
                        st = grbl.status
                        if (time.monotonic() >= deadline or st is None or not st.planner_free == 0
                                or st.state not in ("Run", "Jog")):
                            break
                    lost = min(_answers_lost(grbl, snap, line_ends, sent_texts, answers_base),
                                len(inflight) - 1)
                else:
                    lost = 0
                events_taken += 1
                if lost:
                    # An answer was lost just before this error: the error belongs to one of the
                    # oldest lost + 1 lines in flight (a lost 'ok': the later one; a lost line
                    # end merging two lines: the earlier). Name the earliest, so that a resume
                    # from it runs every line at least once, and say so.
                    first, last = inflight[0][0], inflight[lost][0]
                    report.warnings.append(
                        f"an answer was lost on the link just before this error: it rejected one "
                        f"of lines {first}…{last}; reported on line {first}, the earliest, so a "
                        f"resume from it runs every line at least once — check the work near "
                        f"lines {first}…{last} before resuming")
                ln, n = inflight.popleft()
                used -= abs(n)
                report.lines_acknowledged += 1
                report.last_acknowledged_line = ln
                if ev.kind == "ok" and ln in job.blocks_per_line:   # a rejected line plans nothing
                    acked.append((ln, job.blocks_per_line[ln]))
                if lost:
                    # the later candidates: answered, but not known to have run (a resume from
                    # the named line runs them again rather than skip one)
                    used -= _drop_lost(lost, ran=False)
                    answers_base -= lost
                if ev.kind == "error":
                    report.errors.append((ln, ev.code, error_message(ev.code)))
                    if on_error == "stop":
                        raise _Fault(f"line {ln} rejected: error:{ev.code}: "
                                     f"{error_message(ev.code)}")
                if progress is not None:
                    ex = _executed_line(grbl, acked, report.last_acknowledged_line)
                    progress(ex, ln, len(job.source_lines), job.eta_s(ex))
            elif ev.kind == "alarm":
                raise _Fault(f"ALARM:{ev.code}: {alarm_message(ev.code)}", reset=True)
            elif ev.kind == "reset":
                raise _Fault("the machine reset during the job (power, cable, or a reset)",
                             reset=False, hold=False)
            elif ev.kind == "disconnect":
                raise _Fault(f"link lost: {ev.text}", reset=False, hold=False)
        # everything acknowledged: wait for the motion to finish
        deadline_idle = time.monotonic() + max(10.0, 3 * job.job_time_s + 10.0)
        while True:
            if controls.cancel_requested:
                raise _Fault("cancelled by the user")
            try:
                st = grbl.get_status(watchdog_s)
            except MachineError as exc:
                raise _Fault(f"watchdog: {exc}") from exc
            ev = grbl.next_event(0.0)
            if ev is not None and ev.kind == "alarm":
                raise _Fault(f"ALARM:{ev.code}: {alarm_message(ev.code)}")
            if ev is not None and ev.kind in ("reset", "disconnect"):
                raise _Fault(f"link lost or machine reset: {ev.text}", reset=False, hold=False)
            if st.state in ("Idle", "Check") and (st.planner_free is None
                                                  or st.planner_free >= grbl.info.planner_blocks):
                break
            if st.state == "Alarm":
                raise _Fault(f"machine in alarm: {alarm_message(grbl.alarm or 0)}")
            if time.monotonic() > deadline_idle:
                raise _Fault("the machine never finished the job (still running long after the "
                             "planned time)")
            if controls.pause_requested and st.state == "Run":
                grbl.feed_hold()
            elif not controls.pause_requested and st.state == "Hold":
                grbl.resume()
            time.sleep(min(0.05, status_interval_s))
        # A link that lost bytes is not a clean run, even when every line was answered.
        report.ok = not report.errors and not report.answers_lost
        report.last_executed_line = report.last_acknowledged_line
        if progress is not None:
            progress(report.last_executed_line, report.last_acknowledged_line,
                     len(job.source_lines), 0.0)
    except _Fault as fault:
        report.fault = str(fault)
        _make_safe(grbl, fault, report, acked, inflight, job)
    except MachineError as exc:             # a write failed: the link is gone
        grbl.disconnected = grbl.disconnected or str(exc)
        report.fault = f"link lost: {exc}"
        _make_safe(grbl, _Fault(str(exc), reset=False, hold=False), report, acked, inflight, job)
    report.elapsed_s = time.monotonic() - t0
    return report


#: Lines GRBL may still be executing, unanswered, after taking them from its RX buffer: it waits for
#: the planner to empty first (dwell, offsets, homing positions, program end, spindle/coolant sync).
_SYNCING = re.compile(r"G0*4(?![.\d])|G10|G28|G30|G92|M0*[0-2](?!\d)|M30|M0*[3-9](?!\d)", re.IGNORECASE)


def _answers_lost(grbl: Grbl, sent_at_query, line_ends: list, sent_texts: list, answers_base: int) -> int:
    """How many ok/error answers the link lost, from the status report just received.

    ``sent_at_query`` bytes had been sent when the report's ``?`` went out, so they had reached
    the controller; minus its RX fill (``Bf``) that bounds from below what it has consumed.
    Every wholly consumed line has been answered before the report — except the one the
    controller may still be working on: blocked on a full planner, or a line that waits for the
    planner to empty. More unanswered lines than that: answers were lost.
    """
    st = grbl.status
    if sent_at_query is None or st is None or st.rx_free is None:
        return 0
    rx_used = max(0, grbl.info.rx_bytes - 1 - st.rx_free)
    consumed = sent_at_query - rx_used
    whole_lines = bisect.bisect_right(line_ends, consumed)
    answered = st.answers_before - answers_base
    if whole_lines <= answered:
        return 0
    busy = (st.planner_free is None or st.planner_free == 0
            or bool(_SYNCING.search(sent_texts[answered])))
    return max(0, whole_lines - answered - (1 if busy else 0))


def _executed_line(grbl: Grbl, acked: list, last_ack: int) -> int:
    """The last source line whose motion has completed, from the planner occupancy."""
    st = grbl.status
    if st is None or st.planner_free is None:
        return acked[-1][0] if acked else last_ack
    if st.line is not None and st.line > 0:
        return st.line - 1
    in_planner = max(0, grbl.info.planner_blocks - st.planner_free)
    remaining = in_planner
    for idx in range(len(acked) - 1, -1, -1):
        if remaining <= 0:
            return acked[idx][0]
        remaining -= acked[idx][1]
    return 0


def _first_unfinished(acked: list, in_planner: int) -> int | None:
    """Source line of the oldest block still in the planner (None when it is empty)."""
    remaining = in_planner
    for idx in range(len(acked) - 1, -1, -1):
        remaining -= acked[idx][1]
        if remaining <= 0:
            return acked[idx][0]
    return acked[0][0] if acked else None


def _make_safe(grbl: Grbl, fault: _Fault, report: JobReport, acked: list, inflight: deque,
               job: Job) -> None:
    """Feed hold, note where motion stopped, soft reset (beam off, buffers flushed), M5 S0.

    Which lines ran is worked out in wire order: the status report taken in
    hold counts the blocks still in the planner, and only the answers that
    arrived before that report are matched to the lines in flight.
    """
    st = None
    if grbl.disconnected:
        report.safe_actions.append("link lost: the controller's own buffer-empty laser-off is "
                                   "all that applies")
    else:
        try:
            if fault.hold:
                grbl.feed_hold()
                report.safe_actions.append("feed hold")
                st = grbl.wait_status(lambda s: s.state in ("Hold", "Idle", "Alarm", "Check")
                                      and (s.state != "Hold" or s.substate in (0, None)), 3.0)
            else:
                st = grbl.get_status(1.0)
            report.stop_position = _job_position(st)
        except MachineError as exc:
            report.safe_actions.append(f"no status after the hold ({exc})")
            st = None
        if fault.reset:
            try:
                grbl.soft_reset()
                report.safe_actions.append("soft reset (buffers flushed, laser off)")
            except MachineError as exc:
                report.safe_actions.append(f"soft reset unanswered ({exc})")
    # answers that arrived before the hold's status report retire lines in flight
    limit = st.answers_before if st is not None else grbl.answer_count
    for ev in grbl.drain_events():
        if ev.kind in ("ok", "error") and ev.seq < limit and inflight:
            ln, n = inflight.popleft()
            report.lines_acknowledged += 1
            report.last_acknowledged_line = ln
            if ev.kind == "ok" and ln in job.blocks_per_line:
                acked.append((ln, job.blocks_per_line[ln]))
            if ev.kind == "error":
                report.errors.append((ln, ev.code, error_message(ev.code)))
    if not grbl.disconnected:
        try:
            st2 = grbl.get_status(1.0)
            if st2.state != "Alarm":
                grbl.command("M5 S0", 2.0)
                report.safe_actions.append("M5 S0")
            if report.stop_position is None:
                report.stop_position = _job_position(st2)
        except MachineError:
            pass
    if st is None or st.planner_free is None:
        report.resume_line = None          # unknown: the position must be checked by hand
        return
    if st.state == "Alarm":
        # the alarm flushed the planner before this report: how far it got is not known
        report.warnings.append("the alarm flushed the machine's buffers: check the position "
                               "and choose the resume line by hand (--resume-from)")
        return
    else:
        in_planner = max(0, grbl.info.planner_blocks - st.planner_free)
    first = _first_unfinished(acked, in_planner)
    if first is None:
        report.last_executed_line = report.last_acknowledged_line
        nxt = [ln for ln, _ in job.send if ln > report.last_acknowledged_line]
        report.resume_line = nxt[0] if nxt else None
    else:
        report.last_executed_line = max((ln for ln, _ in acked if ln < first), default=0)
        report.resume_line = first
    # a rejected line never ran: resume from it when no motion line ran after it
    for ln, code, _ in report.errors:
        if report.resume_line is None or ln < report.resume_line:
            ran_after = [a for a, _ in acked if a > ln and (report.resume_line is None
                                                            or a < report.resume_line)]
            if not ran_after:
                report.resume_line = ln
            else:
                report.warnings.append(f"line {ln} was rejected but lines after it already ran "
                                       f"(up to line {max(ran_after)}): run line {ln} on its own")
            break


def check_job(grbl: Grbl, job: Job) -> list:
    """Run the job in check mode (``$C``): every line parsed by the controller, nothing moves."""
    grbl.check_mode(True)
    bad = []
    try:
        for ln, text in job.send:
            grbl.send_line(text)
            while True:
                ev = grbl.next_event(5.0)
                if ev is None:
                    raise MachineError(f"no answer in check mode for line {ln}")
                if ev.kind == "ok":
                    break
                if ev.kind == "error":
                    bad.append((ln, ev.code, error_message(ev.code)))
                    break
                if ev.kind in ("alarm", "reset", "disconnect"):
                    raise MachineError(f"check mode interrupted at line {ln}: {ev.text}")
    finally:
        grbl.check_mode(False)
    return bad


# -- resume -------------------------------------------------------------------------------------

def _modal_at(job: Job, line: int):
    """The modal state in effect *before* source line ``line`` (a pandas row, offsets
    included), and whether the job set a G92 offset or a tool length offset before it."""
    from labkit.gcode.reader import modal_trace

    text = "\n".join(job.source_lines[: max(0, line - 1)])
    if line <= 1 or not text:
        return None, False
    trace = modal_trace(text, dialect=job.dialect, offsets=True)
    volatile = bool((trace[["g92_x", "g92_y", "g92_z", "tool_offset"]] != 0).to_numpy().any())
    return trace.iloc[-1], volatile


def resume_text(job: Job, line: int, position=None) -> list[str]:
    """Lines that restore the state before ``line``, go there with the beam off, and finish it.

    Everything is said in the job's own coordinates (the work coordinates its X Y Z
    words mean), so a resume lands where the job would have been whatever origin the
    controller holds: G54–G59 origins stay on the controller (GRBL keeps them in
    EEPROM) and the coordinate system in use is restated; a G92 or G43.1 offset the job
    itself set is restated too, since GRBL's reset clears them — G92.1, the move, then
    G92 with the position the job's words give there.

    Parameters
    ----------
    job : Job
    line : int
        First source line to run (1-based).
    position : sequence of 3 floats, optional
        Where the machine stopped inside ``line``, in the job's coordinates (a
        status report's WPos: ``report.stop_position``). The line's remaining
        motion is sent from there instead of the whole line, so nothing is
        burned twice. None: go to the line's start.

    Returns
    -------
    list of str
        The preamble; the job's own lines follow from ``line + 1`` (with a
        position) or from ``line`` (without).

    Examples
    --------
    >>> job = Job.from_text("G21 G90\\nM4 S300 F600\\nG1 X10\\nG1 Y10\\nM5\\n")
    >>> resume_text(job, 4)
    ['M5 S0', 'G21 G90 G91.1 G17 G54', 'G0 X10 Y0 Z0', 'G1 F600 S300', 'M4']
    >>> resume_text(job, 4, position=(10, 4, 0))[-1]
    'G1 X10 Y10 Z0 F600 S300'

    A job that sets its own origin with G92 gets it back:

    >>> job = Job.from_text("G0 X50 Y50\\nG92 X0 Y0\\nM4 S300 F600\\nG1 X10\\nG1 Y10\\nM5\\n")
    >>> resume_text(job, 5)[1:5]
    ['G21 G90 G91.1 G17 G54', 'G92.1', 'G0 X60 Y50 Z0', 'G92 X10 Y0 Z0']
    """
    if not 1 <= line <= len(job.source_lines):
        raise InputError(f"resume line {line} is outside the file (1–{len(job.source_lines)})")
    st, volatile = _modal_at(job, line)
    out = ["M5 S0"]
    g92 = np.zeros(3)                    # the job's own G92 and G43.1 at the line (restated below)
    tool = 0.0
    if st is None:
        start = np.zeros(3)
        units, distance, arc, plane, coords = "G21", "G90", "G91.1", "G17", "G54"
        feed, s, laser = math.nan, 0.0, "M5"
    else:
        start = np.array([st["wx"], st["wy"], st["wz"]], float)
        units, distance, arc, plane, coords = st["units"], st["distance"], st["arc_centres"], st["plane"], st["coords"]
        feed, s, laser = float(st["feed_mm_min"]), float(st["S"]), st["laser"]
        if volatile:
            tool = float(st["tool_offset"])
            g92 = np.array([st["g92_x"], st["g92_y"], st["g92_z"]], float)
    out.append(f"G21 G90 {arc} {plane} {coords}")
    here = np.asarray(position, float) if position is not None else start
    if volatile:
        # from the bare origin (G92.1; the tool offset restated), the move, then G92 so that
        # the point reads `here` again
        out.append("G92.1")
        if tool:
            out.append(f"G43.1 Z{tool:g}")
        out.append("G0 " + _xyz(here + g92))
        if np.any(g92 != 0):
            out.append("G92 " + _xyz(here))
    else:
        out.append("G0 " + _xyz(here))
    words = []
    if math.isfinite(feed):
        words.append(f"F{feed:g}")
    words.append(f"S{s:g}")
    out.append("G1 " + " ".join(words))
    if laser != "M5":
        out.append(laser)
    if position is not None:
        m = job.moves
        rows = np.flatnonzero(m.line == line)
        if len(rows) == 0:
            raise InputError(f"line {line} has no motion to finish")
        r = rows[-1]
        kind = int(m.kind[r])
        offset = m.work_offset[r]                    # Moves are machine coordinates
        end = m.end[r] - offset
        # the rest of the line burns with the line's own F, S and M3/M4 (its words may set them)
        own, _ = _modal_at(job, line + 1)
        if own["laser"] != laser:
            out.append(own["laser"])
        words = (f" F{float(own['feed_mm_min']):g}" if math.isfinite(own["feed_mm_min"]) else "") + \
            f" S{float(own['S']):g}"
        if kind in (2, 3):
            c = m.centre[r] - offset - here
            out.append(f"G{kind} {_xyz(end)} I{c[0]:.4f} J{c[1]:.4f}{words}")
        else:
            out.append(f"G{kind} {_xyz(end)}{words}")
    # back to the file's own units and distance mode for the lines that follow
    if units != "G21" or distance != "G90":
        out.append(f"{units} {distance}")
    return out


def _job_position(st):
    """A status report's position in the job's coordinates: WPos (MPos − WCO), or MPos while
    the controller has not reported its WCO yet (offsets taken as zero)."""
    return st.wpos if st.wpos is not None else st.mpos


def _xyz(p) -> str:
    return " ".join(f"{a}{float(v):.4f}".rstrip("0").rstrip(".") for a, v in zip("XYZ", p))


def _resume_send(job: Job, line: int, position) -> list:
    pre = [(line, strip_line(t)) for t in resume_text(job, line, position)]
    first = line + 1 if position is not None else line
    return pre + [(ln, s) for ln, s in job.send if ln >= first]


def frame_text(job: Job, *, power_s: float = 0.0, feed_mm_min: float = 3000.0) -> list[str]:
    """Trace the job's bounding box with the beam off (or at a low visible power).

    Parameters
    ----------
    power_s : float
        0 (default): beam off. A small S (about 1 % of ``$30``) shows the
        frame on the work without marking it.
    feed_mm_min : float
        Speed of the trace.

    Examples
    --------
    >>> job = Job.from_text("G0 X5 Y5\\nM3 S500\\nG1 X15 Y8 F600\\nM5\\n")
    >>> frame_text(job)[2:5]
    ['G0 X5.000 Y5.000', 'M5 S0', 'G0 X15.000 Y5.000 F3000']
    """
    box = job.moves.bounds(job.moves.laser_on)
    if np.isnan(box).any():
        box = job.moves.bounds()
    if np.isnan(box).any():
        raise InputError("the job has no motion to frame")
    (x0, y0), (x1, y1) = box[0, :2], box[1, :2]
    beam = ["M5 S0"] if power_s <= 0 else [f"M3 S{power_s:g}"]
    cmd = "G1" if power_s > 0 else "G0"
    return (["G21 G90", "M5 S0", f"G0 X{x0:.3f} Y{y0:.3f}"] + beam +
            [f"{cmd} X{x1:.3f} Y{y0:.3f} F{feed_mm_min:g}", f"{cmd} X{x1:.3f} Y{y1:.3f}",
             f"{cmd} X{x0:.3f} Y{y1:.3f}", f"{cmd} X{x0:.3f} Y{y0:.3f}", "M5 S0"])
