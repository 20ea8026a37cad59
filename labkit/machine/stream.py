"""The job runner: stream a G-code job safely, with progress, faults and resume.

:func:`run_job` sends a :class:`Job` to a :class:`~labkit.machine.grbl.Grbl`
machine — through a :class:`JobRunner`, whose steps (send, poll, acknowledge,
fault, finish) and state a test can drive and read — by character counting (keep the bytes of unanswered lines, newline
included, within the RX buffer; every ``ok``/``error`` retires the oldest) or
send-response (one line at a time), polls status reports, and reports
progress by source line with an ETA from :func:`labkit.motion.plan`.

Before the first line: answers that no line asked for refuse the job, and
:func:`preflight_check` compares the job with what the controller says (state,
``$30``, units and distance mode, travel with the work offset); a job that would
alarm or burn where it should not is refused with the fix named.

Faults — ``error:N`` (policy ``stop`` or ``skip``), an alarm, a reset, a lost
link, no status replies (the watchdog), no answer while the machine idles (a
lost byte), answers out of step with the lines (an unsolicited, doubled or
missing ``ok``: a protocol error naming the lines in doubt), a cancel, SIGINT or
SIGTERM, an exception, the process exiting under the job — stop the job, and
every end, a completed job's included, goes through one place,
:meth:`Grbl.stop_safely`: feed hold, a bounded wait for the stop, soft reset
(which flushes every buffered line and turns the beam off), ``M5 S0``; the report
says what was sent and what was confirmed, or that the link was gone and the
controller was not told. The :class:`JobReport` names the last acknowledged line
and the last *executed* line (from the planner occupancy in status reports:
acknowledged is not executed), the position where motion stopped, and the line to
resume from.

Resume (:func:`labkit.machine.resume.resume_text`, re-exported here) rebuilds
the modal state in effect at a line from the parse, moves to the stop point with
the beam off, finishes the interrupted line from there, and continues with the
next lines — so every line runs exactly once.
"""

from __future__ import annotations

import atexit
import bisect
import math
import threading
import time
from collections import deque
from dataclasses import dataclass, field

import numpy as np

from labkit._jit import expecting, job
from labkit.errors import AlarmCode, InputError, LabkitError, MachineError
from labkit.gcode.reader import strip_comments
from labkit.gcode.state import line_states
from labkit.machine.grbl import Grbl, alarm_message, error_message, grbl_reply
from labkit.machine.resume import frame_text, resume_text

__all__ = ["Job", "JobReport", "run_job", "JobRunner", "resume_text", "frame_text", "strip_line", "Controls",
           "StopSignals", "preflight_check", "check_job"]


def strip_line(text: str) -> str:
    """A line as it goes to the machine: comments (:func:`~labkit.gcode.reader.strip_comments`),
    spaces and the line end removed.

    >>> strip_line("G1 X10 Y5 (cut) ; to the corner")
    'G1X10Y5'
    >>> strip_line("  ; only a comment")
    ''
    """
    return strip_comments(text).replace(" ", "").replace("\t", "").strip().upper()


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
    syncing : list of bool
        Per entry of ``send``: the line waits for the planner to empty before it is answered
        (the interpreter trace's ``syncing``; read once here, not per line sent).
    axis_words : list of bool
        Per entry of ``send``: an accepted G-code line with X, Y or Z (the trace's ``axis_words``).
    trace : ndarray
        Per entry of ``send``: the interpreter's trace row (:func:`labkit.gcode.state.line_states`),
        whose flags say what each line states (units, distance mode, coordinate system, offsets).
    """

    source_lines: list
    send: list
    moves: object
    blocks_per_line: dict
    done_at_s: dict
    job_time_s: float
    filename: str | None = None
    dialect: str = "grbl"
    syncing: list | None = None
    axis_words: list | None = None
    trace: np.ndarray | None = None

    def __post_init__(self):
        # for eta_s: the source lines rising, and the latest planned end of any line up to each
        self._done_lines = sorted(self.done_at_s)
        self._done_by_line = (np.maximum.accumulate([self.done_at_s[ln] for ln in self._done_lines]).tolist()
                              if self._done_lines else [])
        if self.trace is None:              # not from from_text: read the lines
            self.trace = _send_trace([t for _, t in self.send], self.dialect)
        if self.syncing is None:
            self.syncing = _syncing([t for _, t in self.send], self.trace)
        if self.axis_words is None:
            self.axis_words = [bool(v) for v in self.trace["axis_words"]]

    @classmethod
    def from_text(cls, text: str, *, filename: str | None = None, dialect: str = "grbl",
                  machine=None, arc_tol_mm: float = 0.002, max_line: int | None = None,
                  virtual_machine: bool = False) -> "Job":
        """Parse and plan a program; refuse it before anything moves when it is bad.

        ``max_line`` is the longest line the controller takes once comments and spaces are
        removed; by default GRBL 1.1's 79 (its 80-byte line buffer answers error:11 to 80).
        ``virtual_machine``: the job will stream to labkit's virtual machine, which reads
        and plans each line again; that work is declared to the rule of :mod:`labkit._jit`
        while the program is read (:func:`labkit.machine.virtual.stream_work`), so a job
        whose stream will load numba reads its file compiled too.

        Raises
        ------
        GcodeError
            A line the parser rejects (file, line, column, what was expected).
        InputError
            A line longer than the controller accepts.
        """
        from labkit.gcode import parse_with_states
        from labkit.geometry.circle import grbl_segments

        ahead = {}          # nothing for another controller
        if virtual_machine:  # it reads and plans every line again: declared for this reading and plan
            from labkit.machine.virtual import stream_work

            ahead = stream_work(text.count("\n") + 1)
        with expecting(ahead, later=True):
            # one reading gives the moves (to plan) and what each line states (trace, below)
            moves, trace = parse_with_states(text, dialect=dialect, filename=filename)
            source = text.split("\n")
            if source and source[-1] == "":
                source.pop()
            if max_line is None:
                from labkit.gcode.writer import LINE_CHARS

                max_line = LINE_CHARS
            send = []
            for k, raw in enumerate(source, 1):
                s = strip_line(raw.rstrip("\r"))
                if s.startswith("%"):
                    continue
                if s:
                    if len(s) > max_line:
                        shown = s if len(s) <= 40 else s[:37] + "..."
                        raise InputError(f"{filename or '<string>'}:{k}:1: line {k} ({shown}) has "
                                         f"{len(s)} characters after removing comments and spaces; "
                                         f"the controller takes at most {max_line} (write fewer "
                                         f"decimals or split the block)")
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
                from labkit.motion import load_machine, plan
                from labkit.motion.stall import controller_sync_lines

                # the motion stops where the controller waits for its planner to empty (read
                # from this reading's trace; later asks for the same program find it kept)
                spec = load_machine(machine)
                sync = controller_sync_lines(text, spec, dialect, trace=trace)
                p = plan(moves, spec, sync_lines=sync)
                ends = p.block_start_s + p.block_time_s
                for ln, t in zip(p.blocks.line.tolist(), ends.tolist()):
                    done_at[ln] = max(done_at.get(ln, 0.0), t)
                job_time = p.job_time_s
            except (LabkitError, ValueError) as exc:
                raise MachineError(f"cannot plan the job for its ETA: {exc}") from exc
            rows = trace[[k - 1 for k, _ in send]]      # the interpreter numbers lines as split here
            return cls(source, send, moves, blocks, done_at, job_time, filename, dialect,
                       _syncing([t for _, t in send], rows), [bool(v) for v in rows["axis_words"]], rows)

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
        """Planned time left after ``executed_line`` has run, s.

        Asked at every acknowledged line: a bisection over the lines' ends in line order,
        taken once (a scan of every line per ask made a 40,000-line stream quadratic)."""
        k = bisect.bisect_right(self._done_lines, executed_line)
        return max(0.0, self.job_time_s - (self._done_by_line[k - 1] if k else 0.0))


@dataclass
class Controls:
    """Pause, resume and cancel a running job from another thread (a notebook button).

    ``stop_reason`` (set by :meth:`cancel`'s ``reason``) is what the report calls the
    cancel: the notebook's exit hook uses it when the kernel closes under a job.
    """

    pause_requested: bool = False
    cancel_requested: bool = False
    stop_reason: str | None = None

    def pause(self):
        self.pause_requested = True

    def resume(self):
        self.pause_requested = False

    def cancel(self, reason: str | None = None):
        self.stop_reason = self.stop_reason or reason
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
    safe_actions: list = field(default_factory=list)   #: each step of the safe stop, sent / confirmed
    warnings: list = field(default_factory=list)
    answers_lost: int = 0                  #: ok/error answers the link lost (re-synchronised)
    refused: bool = False                  #: stopped before anything was sent (pre-flight check)
    controller_told: bool = True           #: False: the link was gone before the stop could be sent
    exception: BaseException | None = None  #: what raised inside the run, when that ended it
    #: on the virtual machine: every time its planner ran dry during the job
    #: (:class:`labkit.motion.stall.Starvation`, s from the job's start, source lines)
    starvations: list = field(default_factory=list)

    def summary(self, command: list | None = None) -> str:
        """The report in words.

        Parameters
        ----------
        command : list of str, optional
            The command line that ran the job (without ``--resume-from``): the
            resume advice then gives the whole command to type.
        """
        state = "completed" if self.ok else ("completed over a faulty link" if self.answers_lost
                                             and not self.fault and not self.errors else "STOPPED")
        if self.refused:
            state = "STOPPED before anything was sent"
        lost = (f" ({self.answers_lost} of them without an answer, re-synchronised from the "
                f"controller's buffer report)" if self.answers_lost else "")
        lines = [f"{state}: {self.lines_acknowledged}/"
                 f"{self.lines_total} lines acknowledged{lost} in {self.elapsed_s:.1f} s "
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
                lines.append(f"  safe stop: {'; '.join(self.safe_actions)}")
            if self.resume_line:
                if command:
                    import shlex

                    cmd = _without_resume(list(command)) + ["--resume-from", str(self.resume_line)]
                    lines.append(f"  resume with: {shlex.join(cmd)}")
                else:
                    lines.append(f"  resume with --resume-from {self.resume_line}")
        if self.starvations:
            first = "; ".join(f"line {s.line} at {s.time_s:.3f} s for {s.duration_s * 1000:.1f} ms"
                              for s in self.starvations[:3])
            lines.append(f"  planner ran dry {len(self.starvations)} time(s), "
                         f"{sum(s.duration_s for s in self.starvations):.3f} s in all: {first}"
                         + (" …" if len(self.starvations) > 3 else ""))
        for w in self.warnings:
            lines.append(f"  {w}")
        return "\n".join(lines)


def _without_resume(argv: list) -> list:
    out, skip = [], False
    for a in argv:
        if skip:
            skip = False
            continue
        if a == "--resume-from":
            skip = True
            continue
        if not a.startswith("--resume-from="):
            out.append(a)
    return out


def _fmt_xyz(p) -> str:
    return "(" + ", ".join(f"{v:.3f}" for v in p) + ")"


class _Fault(Exception):
    def __init__(self, text: str, *, reset: bool = True, hold: bool = True):
        super().__init__(text)
        self.reset = reset
        self.hold = hold


# -- signals and the end of the process ------------------------------------------------------

class StopSignals:
    """SIGINT and SIGTERM ask for a safe stop instead of ending the program at once.

    Installed for the duration of a stream (``with StopSignals(): …``) and restored
    after, in the main thread only (Python delivers signals there; elsewhere this does
    nothing). The first signal is recorded in :attr:`name` and passed to ``on_signal``
    (which may raise to leave a blocking read, as the console does); every later one
    only prints that the safe stop is still running — it never skips it.

    Parameters
    ----------
    on_signal : callable, optional
        ``on_signal(name)`` on the first signal.
    stop_steps : str
        What the safe stop does, for the message a later signal prints.
    """

    def __init__(self, on_signal=None, *,
                 stop_steps: str = "feed hold, soft reset, laser off; at most about 10 s"):
        self.on_signal = on_signal
        self.stop_steps = stop_steps
        self.name: str | None = None
        self._stopping = False
        self._old: dict = {}

    def stopping(self) -> None:
        """The safe stop has begun: from now on a signal only says it is still running."""
        self._stopping = True

    def _handler(self, signum, frame):
        import signal
        import sys

        name = signal.Signals(signum).name
        if self.name is None and not self._stopping:
            self.name = name
            if self.on_signal is not None:
                self.on_signal(name)
            return
        self.name = self.name or name
        try:
            sys.stderr.write(f"\nlabkit: {name} again — still stopping the machine safely "
                             f"({self.stop_steps}); the port closes after that. To cut the "
                             f"power at once use the machine's emergency stop.\n")
            sys.stderr.flush()
        except (OSError, ValueError):
            pass

    def __enter__(self):
        import signal
        import threading

        if threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGINT, signal.SIGTERM):
                try:
                    self._old[sig] = signal.signal(sig, self._handler)
                except (ValueError, OSError):        # an embedded interpreter without signals
                    pass
        return self

    def __exit__(self, *exc):
        import signal

        for sig, old in self._old.items():
            signal.signal(sig, old)
        self._old.clear()
        return False


#: Jobs running now (a key → their Controls and an Event set once the job has stopped safely),
#: so that a process that exits under a running job (a notebook kernel closed while the panel
#: streams) stops the machine first.
_RUNNING: dict = {}
_EXIT_WAIT_S = 15.0


def _stop_running_jobs_at_exit() -> None:
    """At interpreter exit: cancel every job still running in a thread and wait (bounded) until
    each has stopped its machine (daemon threads still run while exit hooks do)."""
    running = list(_RUNNING.values())
    for controls, _ in running:
        controls.cancel("the Python process is exiting (a closed notebook kernel or the end of "
                        "the program) while the job ran")
    deadline = time.monotonic() + _EXIT_WAIT_S
    for _, done in running:
        done.wait(max(0.0, deadline - time.monotonic()))


atexit.register(_stop_running_jobs_at_exit)


def run_job(grbl: Grbl, job: Job, *, mode: str = "counting", on_error: str = "stop",
            check_first: bool = False, resume_from: int | None = None,
            resume_position=None, progress=None, controls: Controls | None = None,
            status_interval_s: float = 0.1, watchdog_s: float = 3.0, stall_s: float = 2.0,
            allow_spindle_mode: bool = False, preflight: bool = True, machine=None,
            handle_signals: bool = True) -> JobReport:
    """Stream a job; return a report (a fault never raises: it is in the report).

    Every way the run ends — done, ``error:N``, alarm, reset, cancel, a lost link, a
    protocol mismatch, SIGINT/SIGTERM, an exception (a progress callback's included),
    the process exiting under it — goes through :meth:`Grbl.stop_safely` before this
    returns: feed hold, wait for the stop, soft reset, ``M5 S0`` (after a job that
    completed, only ``M5 S0``). The report says what was sent and what was confirmed.

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
    preflight : bool
        Check the job against the controller first (:func:`preflight_check`);
        a job that would alarm or burn where it should not is refused before
        anything is sent (``report.refused``).
    machine : str or MachineSpec, optional
        The machine description the user named: its travel bounds the job's size.
    handle_signals : bool
        In the main thread, SIGINT and SIGTERM stop the job safely (see
        :class:`StopSignals`) instead of ending the program under it.

    Raises
    ------
    MachineError
        Before anything is sent: a burning job with ``$32=0`` (unless
        ``allow_spindle_mode``).
    InputError
        A bad option, or something that is not a machine or a job where one is expected.
    """
    if mode not in ("counting", "send-response"):
        raise InputError(f"mode must be 'counting' or 'send-response', got {mode!r}")
    if on_error not in ("stop", "skip"):
        raise InputError(f"on_error must be 'stop' or 'skip', got {on_error!r}")
    if not isinstance(grbl, Grbl):
        raise InputError(f"run_job: grbl must be a connected labkit.machine.Grbl, got "
                         f"{type(grbl).__name__}")
    if not isinstance(job, Job):
        raise InputError(f"run_job: job must be a labkit.machine.Job (Job.from_file or "
                         f"Job.from_text), got {type(job).__name__}")
    controls = controls or Controls()
    report = JobReport(ok=False, lines_total=len(job.source_lines), planned_s=job.job_time_s)
    warn = grbl.check_laser_job(job.burns, allow_spindle_mode=allow_spindle_mode)
    if warn:
        report.warnings.append(warn)
    warnings_seen = len(grbl.warnings)
    done = threading.Event()
    key = object()
    _RUNNING[key] = (controls, done)
    t0 = time.monotonic()
    vm = _virtual_machine(getattr(grbl, "link", None))
    vm_start = (vm.sim_time_s, vm.lines_run) if vm is not None else None
    runner = None
    try:
        with StopSignals() if handle_signals else _no_signals() as signals:
            runner = JobRunner(grbl, job, report, controls, signals, mode=mode, on_error=on_error,
                               progress=progress, status_interval_s=status_interval_s,
                               watchdog_s=watchdog_s, stall_s=stall_s)
            runner.run(check_first=check_first, resume_from=resume_from,
                       resume_position=resume_position, preflight=preflight, machine=machine)
    finally:
        _RUNNING.pop(key, None)
        done.set()
    for w in grbl.warnings[warnings_seen:]:
        report.warnings.append("warning: " + w)
    transcript_error = getattr(grbl.transcript, "error", None)
    if transcript_error:
        report.warnings.append("warning: " + transcript_error)
    report.elapsed_s = time.monotonic() - t0
    if vm is not None and runner is not None:
        gcode = [ln for ln, text in zip(runner.sent_lines, runner.sent_texts) if not text.startswith("$")]
        report.starvations = vm.starvations_since(*vm_start, gcode)
    return report


class _no_signals:
    name = None

    def stopping(self) -> None:
        pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


class JobRunner:
    """One run of a job on a controller, as steps whose state a test can inspect.

    :func:`run_job` makes one and calls :meth:`run`; the steps are :meth:`preflight`
    (before anything is sent), :meth:`send` (what fits the controller's RX buffer),
    :meth:`poll` (stop requests, pause, status reports, re-synchronisation, the
    watchdog), :meth:`acknowledge` (an ``ok``/``error`` retires the oldest line in
    flight), :meth:`fault` (every early end, through :func:`_make_safe`) and
    :meth:`finish` (wait for the motion to end, then the beam off).

    Attributes
    ----------
    phase : str
        ``"ready"``, ``"sending"``, ``"finishing"``, then ``"done"``, ``"refused"``
        (stopped before the job's first line: the pre-flight check, or check mode
        rejecting a line) or ``"faulted"``.
    lines : list of (int, str)
        (source line, text) to send, in order; ``next_index`` is the next to go.
    inflight : deque of (int, int)
        (source line, bytes) of the lines sent and not yet answered, oldest first; the
        bytes are negative for a ``$`` line (sent alone: it waits for every answer).
    rx_used, rx_limit : int
        Bytes of the unanswered lines, and how many may be (counting: the RX buffer
        less one; send-response: no limit, one line at a time).
    acked : list of (int, int, int, int)
        (source line, planner blocks, answer number, the highest answer number up to this
        entry) of the acknowledged motion lines (:func:`_ack`).
    line_syncing : list of bool
        Per entry of ``lines``: it waits for the planner to empty before its answer.
    sent_lines, sent_texts, sent_syncing, line_ends : list
        Per line sent: its source line, its text, whether it syncs, the bytes sent up to its end.
    """

    def __init__(self, grbl: Grbl, job: Job, report: JobReport, controls: Controls, signals, *,
                 mode: str = "counting", on_error: str = "stop", progress=None,
                 status_interval_s: float = 0.1, watchdog_s: float = 3.0, stall_s: float = 2.0):
        self.grbl, self.job, self.report, self.controls, self.signals = grbl, job, report, controls, signals
        self.mode, self.on_error, self.progress = mode, on_error, progress
        self.status_interval_s, self.watchdog_s, self.stall_s = status_interval_s, watchdog_s, stall_s
        self.phase = "ready"
        self.lines: list = list(job.send)
        self.line_syncing: list = list(job.syncing)
        self.start_accounting()

    def start_accounting(self) -> None:
        """Nothing in flight, the answer and status counts taken from the controller as they
        are now: at the first line sent (after the pre-flight and check-mode exchanges)."""
        grbl = self.grbl
        self.next_index = 0
        self.inflight: deque = deque()
        self.acked: list[tuple] = []
        self.rx_used = 0
        self.rx_limit = grbl.info.rx_bytes - 1 if self.mode == "counting" else 10 ** 9
        self.paused = False
        self.last_poll = 0.0
        self.last_status_seen = grbl.status_count
        self.last_status_t = time.monotonic()
        self.stall_since = None
        # Re-synchronisation after a lost answer (character counting): the bytes sent before each
        # '?' are in the controller (one ordered link), so bytes sent − its RX fill is a lower bound
        # on what it has consumed; every consumed line but the one it may be blocked on has been
        # answered. The bytes sent by the time a report is read, minus its RX fill, bound it from
        # above: more answers than lines it can have read is a surplus (an unsolicited or doubled
        # 'ok').
        self.answers_base = grbl.answer_count
        self.answers_start = self.answers_base
        self.events_taken = 0              # ok/error events taken from the queue
        self.line_ends: list[int] = []     # cumulative bytes at the end of each line sent
        self.sent_texts: list[str] = []
        self.sent_syncing: list[bool] = []
        self.sent_lines: list[int] = []    # source line of each line sent
        self.sent_bytes = 0
        self.q_marks: deque = deque()      # sent_bytes when each '?' went out
        self.synced = 0                    # lines sent whose answers are known to be theirs

    # -- the whole run ---------------------------------------------------------------------------

    def run(self, *, check_first: bool = False, resume_from: int | None = None, resume_position=None,
            preflight: bool = True, machine=None) -> None:
        """Pre-flight, sending, accounting; every end through :meth:`fault` or :meth:`finish`."""
        if not self.preflight(preflight, machine):
            self.phase = "refused"
            return
        if resume_from is not None:
            self.lines, self.line_syncing = _resume_send(self.job, int(resume_from), resume_position)
        try:
            if check_first:
                bad = check_job(self.grbl, self.job, stop=self.stop_requested)
                if bad:
                    self.report.errors.extend(bad)
                    self.report.fault = f"check mode ($C) rejected {len(bad)} line(s); nothing was cut"
                    self.phase = "refused"
                    return
            self.phase = "sending"
            self.start_accounting()
            self.send_all()
            self.phase = "finishing"
            self.finish()
        except BaseException as exc:
            self.fault(exc)
            if not isinstance(exc, Exception):      # KeyboardInterrupt without our handler, SystemExit
                raise

    def preflight(self, enabled: bool = True, machine=None) -> bool:
        """Before anything is sent: answers that no line asked for (before and after the
        pre-flight commands, which would take one as theirs), and the job against the
        controller (:func:`preflight_check`). False: refused, with ``report.fault`` saying why."""
        grbl, report = self.grbl, self.report
        for stage in ("before", "after") if enabled else ("before",):
            try:
                st0 = grbl.get_status(max(2.0, self.watchdog_s))   # in wire order after any stray answer
            except MachineError as exc:
                report.refused = True
                report.fault = f"no status report before the job ({exc}); nothing was sent"
                return False
            stray = [ev for ev in grbl.drain_events() if ev.kind in ("ok", "error")]
            if stray:
                report.refused = True
                report.fault = (f"protocol error: {len(stray)} answer(s) ('{stray[0].text}') arrived "
                                f"that no line asked for, before the job started — another program "
                                f"may be sending to this controller, or an earlier job is still "
                                f"running; nothing was sent")
                return False
            if stage == "before" and enabled:
                problems, notes = preflight_check(grbl, self.job, machine=machine, status=st0)
                report.warnings.extend(notes)
                if problems:
                    report.refused = True
                    report.fault = ("refused before anything was sent (pre-flight check against the "
                                    "controller): " + " · ".join(problems))
                    return False
        return True

    def fault(self, exc: BaseException) -> None:
        """Any early end: say what it was, then :func:`_make_safe` (stop, beam off, report)."""
        grbl, report = self.grbl, self.report
        self.phase = "faulted"
        self.signals.stopping()
        if isinstance(exc, _Fault):
            report.fault = str(exc)
            fault = exc
        elif isinstance(exc, MachineError):
            if grbl.disconnected or grbl.link.lost or grbl.link.closed:   # a write failed: the link is gone
                grbl.disconnected = grbl.disconnected or grbl.link.lost or str(exc)
                report.fault = f"link lost: {exc}"
                fault = _Fault(str(exc), reset=False, hold=False)
            else:
                report.fault = str(exc)
                fault = _Fault(str(exc))
        elif isinstance(exc, Exception):    # a bug (ours or a callback's): stop, then say so
            report.exception = exc
            report.fault = f"stopped by an exception during the run: {type(exc).__name__}: {exc}"
            fault = _Fault(report.fault)
        else:
            report.exception = exc
            report.fault = f"interrupted ({type(exc).__name__})"
            fault = _Fault(report.fault)
        _make_safe(grbl, fault, report, self.acked, self.inflight, self.job)

    def stop_requested(self) -> str | None:
        """Why the user (a signal, a cancel, the exit hook) wants the job stopped, or None."""
        return _requested_stop(self.controls, self.signals)

    # -- sending and accounting ------------------------------------------------------------------

    def send_all(self) -> None:
        """Send every line and account for every answer; raise :class:`_Fault` on any fault."""
        # The lines are one job for labkit._jit's rule: a virtual machine parses and plans each
        # line in kernels of its own (in the thread that reads the link), and their Python time per line
        # answered, projected over the lines left, decides whether numba is worth loading.
        grbl = self.grbl
        with job(len(self.lines) - self.next_index) as lines_job:
            while self.next_index < len(self.lines) or self.inflight:
                now = time.monotonic()
                self.poll(now)
                sent_any = self.send()
                ev = grbl.next_event(0.0 if sent_any else 0.01)
                if ev is None:
                    self.check_stall(now)
                    continue
                self.stall_since = None
                if ev.kind in ("ok", "error"):
                    self.acknowledge(ev)
                    lines_job.advance()
                elif ev.kind == "alarm":
                    raise _Fault(f"ALARM:{ev.code}: {alarm_message(ev.code)}", reset=True)
                elif ev.kind == "reset":
                    raise _Fault("the machine reset during the job (power, cable, or a reset)",
                                 reset=False, hold=False)
                elif ev.kind == "disconnect":
                    raise _Fault(f"link lost: {ev.text}", reset=False, hold=False)

    def poll(self, now: float) -> None:
        """Stop requests and pause, a status request every ``status_interval_s``, and what a
        fresh report tells: surplus answers, lost answers (re-synchronised), or the watchdog."""
        grbl = self.grbl
        why = self.stop_requested()
        if why:
            raise _Fault(why)
        if self.controls.pause_requested and not self.paused:
            grbl.feed_hold()
            self.paused = True
        elif self.paused and not self.controls.pause_requested:
            grbl.resume()
            self.paused = False
        if now - self.last_poll >= self.status_interval_s:
            self.q_marks.append(self.sent_bytes)
            grbl.realtime("status")
            self.last_poll = now
        if grbl.status_count != self.last_status_seen:
            fresh = grbl.status_count - self.last_status_seen
            self.last_status_seen = grbl.status_count
            self.last_status_t = now
            snap = None
            for _ in range(min(fresh, len(self.q_marks))):
                snap = self.q_marks.popleft()
            st = grbl.status
            self.check_count(st, snap)
            # only once every answer before this report has been taken: an error among them
            # must first be named (in acknowledge), not skipped over
            if (self.mode == "counting" and st is not None
                    and st.answers_before - self.answers_start == self.events_taken):
                lost = _answers_lost(grbl, snap, self.line_ends, self.sent_syncing, self.answers_base)
                if lost:
                    self.too_many_lost(lost)
                self.rx_used -= self.drop_lost(lost)
                self.answers_base -= lost
        elif now - self.last_status_t > self.watchdog_s:
            raise _Fault(f"watchdog: no status report for {self.watchdog_s:g} s; stopped sending",
                         reset=True)

    def send(self) -> bool:
        """Send the lines that fit (counting: within ``rx_limit``; a ``$`` line alone;
        send-response: one line when none is in flight). True when a line went out."""
        sent_any = False
        while self.next_index < len(self.lines) and not self.paused:
            ln, text = self.lines[self.next_index]
            n = len(text) + 1
            settings_line = text.startswith("$")
            if self.inflight and (self.mode == "send-response" or settings_line
                                  or self.inflight[0][1] < 0 or self.rx_used + n > self.rx_limit):
                break
            self.grbl.send_line(text)
            self.inflight.append((ln, -n if settings_line else n))
            self.sent_bytes += n
            self.line_ends.append(self.sent_bytes)
            self.sent_texts.append(text)
            self.sent_syncing.append(self.line_syncing[self.next_index])
            self.sent_lines.append(ln)
            self.rx_used += n
            self.report.max_rx_used = max(self.report.max_rx_used, self.rx_used)
            self.report.lines_sent += 1
            self.next_index += 1
            sent_any = True
            if settings_line or self.mode == "send-response":
                break
        return sent_any

    def check_stall(self, now: float) -> None:
        """No answer while the machine idles with an empty RX buffer: a byte was lost."""
        st = self.grbl.status
        if (self.inflight and st is not None and st.state == "Idle" and st.rx_free is not None
                and st.rx_free >= self.grbl.info.rx_bytes - 1 and st.received_s > now - 0.5):
            self.stall_since = self.stall_since or now
            if now - self.stall_since > self.stall_s:
                raise _Fault(f"no answer for line {self.inflight[0][0]} while the machine is "
                             f"idle with an empty buffer (a byte was lost on the link)")
        else:
            self.stall_since = None

    def acknowledge(self, ev) -> None:
        """An ``ok`` or ``error`` retires the oldest line in flight — after an error, once a
        status report has settled which line it belongs to."""
        grbl, report, inflight, job = self.grbl, self.report, self.inflight, self.job
        if not inflight:
            raise self.surplus(f"'{ev.text}' arrived with no line awaiting an answer")
        lost = 0
        if ev.kind == "error":
            lost = self.settle_error(ev)
        self.events_taken += 1
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
        self.rx_used -= abs(n)
        report.lines_acknowledged += 1
        report.last_acknowledged_line = ln
        if ev.kind == "ok" and ln in job.blocks_per_line:   # a rejected line plans nothing
            _ack(self.acked, ln, job.blocks_per_line[ln], ev.seq)
        if lost:
            # the later candidates: answered, but not known to have run (a resume from
            # the named line runs them again rather than skip one)
            self.rx_used -= self.drop_lost(lost, ran=False)
            self.answers_base -= lost
        if ev.kind == "error":
            report.errors.append((ln, ev.code, error_message(ev.code)))
            if self.on_error == "stop":
                raise _Fault(f"line {ln} rejected: error:{ev.code}: {error_message(ev.code)}")
        ex = _executed_line(grbl, self.acked, report.last_acknowledged_line)
        report.last_executed_line = max(report.last_executed_line, ex)
        if self.progress is not None:
            self.progress(ex, ln, len(job.source_lines), job.eta_s(ex))

    def settle_error(self, ev) -> int:
        """Before naming an error's line: ask for a report after it, in case an earlier answer
        was lost (or one was doubled) and the oldest line in flight is not this one; returns the
        answers lost just before it (counting), or raises a fault naming the lines in doubt."""
        grbl, report, inflight = self.grbl, self.report, self.inflight
        # A full planner leaves one line possibly unanswered for a while: wait for a free block
        # so that the report tells a blocked line from a lost answer. A line taken but not yet
        # answered (blocked on a full planner, or one that waits for the planner to empty) hides
        # a doubled 'ok' exactly: wait, briefly, for a report in which the controller cannot be
        # holding one.
        snap = None
        deadline = time.monotonic() + _ERROR_SETTLE_S
        drained = False        # a report already showed the planner empty and idle
        while True:
            self.q_marks.append(self.sent_bytes)
            grbl.realtime("status")
            wanted = self.last_status_seen + len(self.q_marks)      # every '?' in flight answered
            while grbl.status_count < wanted and time.monotonic() < deadline:
                time.sleep(0.005)
            for _ in range(min(grbl.status_count - self.last_status_seen, len(self.q_marks))):
                snap = self.q_marks.popleft()
            self.last_status_seen = grbl.status_count
            st = grbl.status
            if (time.monotonic() >= deadline or st is None or st.rx_free is None
                    or st.state == "Alarm"
                    or not _may_hold(st, self.sent_syncing,
                                     _lines_read(grbl, st, snap, self.line_ends) - 1, drained=drained)):
                break
            drained = drained or _drained(grbl, st)
        # answers that came after the error and before that report: more answers than
        # lines sent means one of those before it was not owed, and this error may
        # belong to an earlier line
        if grbl.answer_count - self.answers_base > len(self.line_ends):
            first, last = self.in_doubt(inflight[0][0])
            report.errors.append((first, ev.code, f"{error_message(ev.code)} — on one of "
                                  f"lines {first}…{last} (the answers were out of step)"))
            raise self.surplus(f"error:{ev.code} ({error_message(ev.code)}) came among "
                               f"{grbl.answer_count - self.answers_base} answers to "
                               f"{len(self.line_ends)} lines sent; it rejected one of the lines "
                               f"in doubt", inflight[0][0])
        try:
            self.check_count(st, snap)
        except _Fault:
            first, last = self.in_doubt(inflight[0][0])
            report.errors.append((first, ev.code, f"{error_message(ev.code)} — on one of "
                                  f"lines {first}…{last} (the answers were out of step)"))
            raise
        if self.mode != "counting":
            return 0
        _name_a_held_line(grbl, st, snap, self.line_ends, self.sent_syncing, self.sent_lines,
                          self.answers_base, report, inflight, ev, drained=drained)
        return min(_answers_lost(grbl, snap, self.line_ends, self.sent_syncing, self.answers_base),
                   len(inflight) - 1)

    def in_doubt(self, last=None) -> tuple[int, int]:
        """First and last source line acknowledged since the count was last known to be right."""
        first = (self.sent_lines[self.synced] if self.synced < len(self.sent_lines)
                 else self.report.last_acknowledged_line)
        return first, max(last or self.report.last_acknowledged_line, first)

    def surplus(self, what: str, last=None) -> _Fault:
        """The fault of answers out of step with the lines, naming the lines in doubt."""
        first, last = self.in_doubt(last)
        self.report.resume_line = first
        return _Fault(f"protocol error: {what} — the controller has answered more lines than it "
                      f"can have read (an unsolicited or doubled 'ok'), so answers no longer match "
                      f"lines: lines {first}…{last} were acknowledged by answers that may not be "
                      f"theirs; check the work from line {first}")

    def check_count(self, st, snap) -> None:
        """A fresh status report: surplus answers are a protocol fault; equal bounds re-sync."""
        if st is None or st.rx_free is None:
            return
        rx_used = max(0, self.grbl.info.rx_bytes - 1 - st.rx_free)
        answered = st.answers_before - self.answers_base
        upper = bisect.bisect_right(self.line_ends, self.sent_bytes - rx_used)
        if answered > upper:
            raise self.surplus(f"{answered} answers before a status report that shows at most "
                               f"{upper} lines read")
        if snap is not None and bisect.bisect_right(self.line_ends, snap - rx_used) == upper == answered:
            self.synced = answered

    def drop_lost(self, lost: int, *, ran: bool = True) -> int:
        """Count the oldest ``lost`` lines in flight as answered (``ran``: as executed too);
        returns their bytes."""
        grbl, report = self.grbl, self.report
        freed = 0
        seq = grbl.status.answers_before if grbl.status is not None else grbl.answer_count
        for _ in range(min(lost, len(self.inflight))):
            ln, n = self.inflight.popleft()
            freed += abs(n)
            report.lines_acknowledged += 1
            report.last_acknowledged_line = max(report.last_acknowledged_line, ln)
            if ran and ln in self.job.blocks_per_line:
                _ack(self.acked, ln, self.job.blocks_per_line[ln], seq)
            report.answers_lost += 1
            report.warnings.append(
                f"an answer (or a line end) was lost on the link near line {ln}: re-synchronised "
                f"from the controller's buffer report, so later errors name the right line; check "
                f"the work there (a lost line end merges two lines)")
        return freed

    def too_many_lost(self, lost: int) -> None:
        """A controller that takes lines without answering is not streamed to further: one lost
        answer now and then is a noisy link, more is a controller that does not answer."""
        report, inflight = self.report, self.inflight
        if lost > 1 or report.answers_lost + lost > _MAX_LOST_ANSWERS:
            first = inflight[0][0] if inflight else report.last_acknowledged_line
            last = inflight[min(lost, len(inflight)) - 1][0] if inflight else first
            raise _Fault(f"protocol error: the controller took lines {first}…{last} from its "
                         f"buffer without answering ({report.answers_lost + lost} answers missing "
                         f"in this job); a controller that does not answer cannot be streamed to "
                         f"safely — check the link (baud rate, cable) and the controller")

    # -- the end -------------------------------------------------------------------------------

    def finish(self) -> None:
        """Everything acknowledged: wait for the motion to finish (answers still arriving are a
        surplus), then the beam off whatever the file's last lines did."""
        grbl, report, job, controls = self.grbl, self.report, self.job, self.controls
        deadline_idle = time.monotonic() + max(10.0, 3 * job.job_time_s + 10.0)
        while True:
            why = self.stop_requested()
            if why:
                raise _Fault(why)
            try:
                st = grbl.get_status(self.watchdog_s)
            except MachineError as exc:
                if grbl.disconnected:
                    raise _Fault(f"link lost: {grbl.disconnected}", reset=False, hold=False) from exc
                raise _Fault(f"watchdog: {exc}") from exc
            ev = grbl.next_event(0.0)
            if ev is not None and ev.kind in ("ok", "error"):
                raise self.surplus(f"'{ev.text}' arrived after every line had its answer")
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
            time.sleep(min(0.05, self.status_interval_s))
        # A link that lost bytes is not a clean run, even when every line was answered.
        report.ok = not report.errors and not report.answers_lost
        report.last_executed_line = report.last_acknowledged_line
        if self.progress is not None:
            self.progress(report.last_executed_line, report.last_acknowledged_line,
                          len(job.source_lines), 0.0)
        # everything acknowledged and executed: the beam off whatever the file's last lines did
        self.signals.stopping()
        stop = grbl.stop_safely(hold=False, reset=False)
        if not stop.beam_off_confirmed:
            report.warnings.append("warning: the job completed but the laser-off that follows it "
                                   "was not confirmed: " + "; ".join(stop.steps))
        self.phase = "done"


def _requested_stop(controls: Controls, signals) -> str | None:
    """Why the user (a signal, a cancel, the exit hook) wants the job stopped, or None."""
    if signals.name:
        return (f"interrupted by {signals.name}" + (" (Ctrl-C)" if signals.name == "SIGINT"
                                                     else ""))
    if controls.cancel_requested:
        return controls.stop_reason or "cancelled by the user"
    return None


#: Answers a job may lose (each re-synchronised from a buffer report) before the link is
#: judged unfit: a controller that answers nothing would otherwise "complete" every job.
_MAX_LOST_ANSWERS = 3


def _send_trace(texts: list, dialect: str):
    """The interpreter trace of lines to send, read in order from power-on (one row a line)."""
    trace, _ = line_states("\n".join(texts) + "\n", dialect=dialect)
    return trace[:len(texts)]


def _syncing(texts: list, trace) -> list:
    """Whether each line waits for the planner to empty before GRBL answers it (dwell,
    offsets, homing positions, program end, laser/coolant words): the trace's ``syncing``
    (``trace``: one row per line of ``texts``). A ``$`` line never does (GRBL runs it idle,
    or as a jog), nor a line the interpreter rejects (GRBL answers its error at once)."""
    return [bool(v) and not t.startswith("$") for v, t in zip(trace["syncing"], texts)]


def _answers_lost(grbl: Grbl, sent_at_query, line_ends: list, sent_syncing: list, answers_base: int) -> int:
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
    whole_lines = _lines_read(grbl, st, sent_at_query, line_ends)
    answered = st.answers_before - answers_base
    if whole_lines <= answered:
        return 0
    # the line it may hold is the last it read (GRBL works through lines in order), which is
    # not the first unanswered one once an answer is lost
    busy = _may_hold(st, sent_syncing, whole_lines - 1)
    return max(0, whole_lines - answered - (1 if busy else 0))


#: How long an error waits (s) for a status report that settles which line it belongs to.
_ERROR_SETTLE_S = 2.0


def _lines_read(grbl: Grbl, st, sent_at_query, line_ends: list) -> int:
    """Lines wholly taken from the controller's RX buffer when report ``st`` was made: the
    bytes sent before its ``?`` (``sent_at_query``) minus its RX fill."""
    if sent_at_query is None or st is None or st.rx_free is None:
        return 0
    rx_used = max(0, grbl.info.rx_bytes - 1 - st.rx_free)
    return bisect.bisect_right(line_ends, sent_at_query - rx_used)


def _drained(grbl: Grbl, st) -> bool:
    """Whether report ``st`` shows the controller idle with its planner empty: a line that
    waited for that is answered before the next report."""
    return st.state == "Idle" and st.planner_free == grbl.info.planner_blocks


def _may_hold(st, sent_syncing: list, index: int, *, drained: bool = False) -> bool:
    """Whether the controller may have taken line ``index`` (0-based, in sent order) without
    answering it yet: blocked on a full planner (or no planner count to tell), or a line that
    waits for the planner to empty before its answer (``sent_syncing``) — even in a report that
    already says ``Idle``, which can come between the planner emptying and that answer.
    ``drained``: an earlier report showed the planner empty and idle, so no such line waits."""
    if st.planner_free is None or st.planner_free == 0:
        return True
    return not drained and 0 <= index < len(sent_syncing) and bool(sent_syncing[index])


def _name_a_held_line(grbl: Grbl, st, snap, line_ends: list, sent_syncing: list,
                      sent_lines: list, answers_base: int, report: "JobReport", inflight: deque,
                      ev, *, drained: bool = False) -> None:
    """An error whose line the answers cannot settle: raise a fault naming both candidates.

    In character counting, answers equal to the lines read fit two stories when the controller
    may be holding the last line it read unanswered: every line answered once, or one line
    still held and an earlier ``ok`` doubled (the error then belongs to the line before the
    oldest in flight). Both lines are named, the earlier as the place to resume from.
    """
    read = _lines_read(grbl, st, snap, line_ends)
    answered = st.answers_before - answers_base if st is not None else -1
    if (read == 0 or answered != read or st.state == "Alarm"
            or not _may_hold(st, sent_syncing, read - 1, drained=drained)
            or report.last_acknowledged_line <= 0):
        return
    first, last = report.last_acknowledged_line, inflight[0][0]
    report.errors.append((first, ev.code, f"{error_message(ev.code)} — on one of lines "
                          f"{first}…{last} (the answers cannot tell which)"))
    report.resume_line = first
    raise _Fault(f"line {first} or {last} rejected: error:{ev.code}: {error_message(ev.code)} — "
                 f"the answers cannot tell which: the controller may still be holding a line it "
                 f"read (line {sent_lines[read - 1]}) unanswered, or an earlier 'ok' came twice; check "
                 f"the work from line {first}")


def _ack(acked: list, line: int, blocks: int, seq: int) -> None:
    """Note an acknowledged motion line; the entry carries the highest answer number so far,
    so that a search for the lines answered after a status report stops at the first entry
    before which none was (a scan of every line at each answer made a long stream quadratic;
    a line counted answered from a buffer report may carry an earlier number)."""
    acked.append((line, blocks, seq, max(seq, acked[-1][3]) if acked else seq))


def _executed_line(grbl: Grbl, acked: list, last_ack: int) -> int:
    """The last source line whose motion has completed, from the planner occupancy.

    ``acked`` holds (source line, blocks, answer number, highest answer number so far) of the
    acknowledged motion lines (:func:`_ack`). The blocks in the planner are those of the last status report plus those of the lines
    acknowledged after it (in wire order), at most the planner's depth: without a buffer
    report (``Bf``) the planner is taken as full. GRBL answers a line when it is planned,
    so every acknowledged block but those has run — a bound that never claims a line that
    may not have run.
    """
    st = grbl.status
    depth = grbl.info.planner_blocks
    if st is not None and st.line is not None and st.line > 0:
        return st.line - 1
    if st is None or st.planner_free is None:
        in_planner = depth
    else:
        later = 0
        for a in reversed(acked):           # newest first, until no older line can count
            if a[3] < st.answers_before:
                break
            if a[2] >= st.answers_before:
                later += a[1]
        in_planner = min(depth, max(0, depth - st.planner_free) + later)
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
    """Stop the machine (:meth:`Grbl.stop_safely`), then work out which lines ran.

    Which lines ran is worked out in wire order: the status report taken once
    motion stopped counts the blocks still in the planner, and only the answers
    that arrived before that report are matched to the lines in flight.
    """
    doubt_resume = report.resume_line            # a protocol fault names where the doubt starts
    stop = grbl.stop_safely(hold=fault.hold, reset=fault.reset)
    report.safe_actions.extend(stop.steps)
    report.controller_told = stop.told
    st = stop.stopped_status
    if st is not None:
        report.stop_position = _job_position(st)
    # answers that arrived before the stopped status report retire lines in flight — unless the
    # answers are out of step (a protocol fault): then an error among them is on one of the
    # lines in doubt, and none of them acknowledges a line
    limit = st.answers_before if st is not None else grbl.answer_count
    if doubt_resume is not None:
        for ev in stop.events:
            if ev.kind == "error" and ev.seq < limit:
                naive = inflight.popleft()[0] if inflight else report.last_acknowledged_line
                report.errors.append((doubt_resume, ev.code, f"{error_message(ev.code)} — on one "
                                      f"of lines {doubt_resume}…{max(naive, doubt_resume)} (the "
                                      f"answers were out of step)"))
            elif ev.kind == "ok" and inflight:
                inflight.popleft()
        stop.events = []
    critical = (AlarmCode.HARD_LIMIT, AlarmCode.SOFT_LIMIT)
    if str(fault).startswith(tuple(grbl_reply(a) + ":" for a in critical)):
        # GRBL's critical alarm answers nothing until the reset, which then answers the line it
        # was in: that ok acknowledges a line that never ran
        stop.events = [ev for ev in stop.events if ev.kind != "ok"]
    for ev in stop.events:
        if ev.kind in ("ok", "error") and ev.seq < limit and inflight:
            ln, n = inflight.popleft()
            report.lines_acknowledged += 1
            report.last_acknowledged_line = ln
            if ev.kind == "ok" and ln in job.blocks_per_line:
                _ack(acked, ln, job.blocks_per_line[ln], ev.seq)
            if ev.kind == "error":
                report.errors.append((ln, ev.code, error_message(ev.code)))
    if report.stop_position is None and not grbl.disconnected:
        try:
            report.stop_position = _job_position(grbl.get_status(1.0))
        except MachineError:
            pass
    if doubt_resume is not None:
        report.resume_line = doubt_resume
        report.last_executed_line = min(report.last_executed_line,
                                        max((a[0] for a in acked if a[0] < doubt_resume), default=0))
        return
    if not stop.told or (st is None and grbl.disconnected):
        _after_link_loss(grbl, report, acked, job)
        return
    if st is None or st.planner_free is None:
        report.resume_line = None          # unknown: the position must be checked by hand
        return
    if st.state == "Alarm":
        # the alarm flushed the planner before this report: how far it got is not known
        report.warnings.append("the alarm flushed the machine's buffers: check the position "
                               "and choose the resume line by hand (--resume-from)")
        return
    in_planner = max(0, grbl.info.planner_blocks - st.planner_free)
    first = _first_unfinished(acked, in_planner)
    if first is None:
        report.last_executed_line = report.last_acknowledged_line
        nxt = [ln for ln, _ in job.send if ln > report.last_acknowledged_line]
        report.resume_line = nxt[0] if nxt else None
    else:
        report.last_executed_line = max((a[0] for a in acked if a[0] < first), default=0)
        report.resume_line = first
    # a rejected line never ran: resume from it when no motion line ran after it
    for ln, code, _ in report.errors:
        if report.resume_line is None or ln < report.resume_line:
            ran_after = [a for a, *_ in acked if a > ln and (report.resume_line is None
                                                            or a < report.resume_line)]
            if not ran_after:
                report.resume_line = ln
            else:
                report.warnings.append(f"line {ln} was rejected but lines after it already ran "
                                       f"(up to line {max(ran_after)}): run line {ln} on its own")
            break


def _after_link_loss(grbl: Grbl, report: JobReport, acked: list, job: Job) -> None:
    """The link went mid-job: what is known from the last status report before it went.

    The controller keeps running what it had buffered, so the last executed line is a
    lower bound and the resume line the first line not known to have run: resuming
    from it may burn again what ran after the last report, never skip a line.
    """
    executed = _executed_line(grbl, acked, report.last_acknowledged_line)
    report.last_executed_line = executed
    later = [ln for ln, _ in job.send if ln > executed]
    report.resume_line = later[0] if later else None
    doubt = (f"lines {report.resume_line}…{report.last_acknowledged_line} were acknowledged and "
             f"may have run after the last status report; resuming from line "
             f"{report.resume_line} burns again whatever of them ran — check the work there first"
             if report.resume_line and report.last_acknowledged_line >= report.resume_line
             else "")
    report.warnings.append(
        f"the link went after line {report.last_acknowledged_line} was acknowledged, and the "
        f"controller kept running what it had buffered. " + (doubt + ". " if doubt else "") +
        "After reconnecting, check the position (a controller reset while moving loses it: "
        "home with $H or set the origin again)")


def check_job(grbl: Grbl, job: Job, *, stop=None) -> list:
    """Run the job in check mode (``$C``): every line parsed by the controller, nothing moves.

    ``stop()``, when given, is asked before each line; a reason it returns ends the check
    (leaving check mode) with a :class:`MachineError`.
    """
    grbl.check_mode(True)
    bad = []
    try:
        for ln, text in job.send:
            why = stop() if stop is not None else None
            if why:
                raise MachineError(f"check mode stopped at line {ln}: {why}")
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


# -- pre-flight ---------------------------------------------------------------------------------

def _states_before_motion(job: Job, flag: str) -> bool:
    """Whether a line before (or on) the job's first line with coordinates states what the
    trace's ``flag`` names (``states_units``, ``states_distance``)."""
    for stated, moves in zip(job.trace[flag], job.axis_words):
        if stated:
            return True
        if moves:
            return False
    return False


def _virtual_machine(link):
    """The :class:`~labkit.machine.virtual.VirtualMachine` behind a link (through a test
    wrapper's ``vm``), or None for a real controller."""
    from labkit.machine.virtual import VirtualMachine

    port = getattr(link, "port", None)
    for _ in range(3):
        if isinstance(port, VirtualMachine):
            return port
        port = getattr(port, "vm", None)
    return None


def _stall_notes(job: Job, spec) -> list[str]:
    """A warning when the machine's serial link will leave its planner empty (issue 30 §2)."""
    from labkit.motion.spec import load_machine
    from labkit.motion.stall import predict_stalls, program_feeds, stall_free_feed

    text = "\n".join(job.source_lines) + "\n"
    per_line = np.zeros(len(job.source_lines), np.int64)
    for ln, sent in job.send:
        per_line[ln - 1] = len(sent) + 1
    try:
        m = load_machine(spec)
        pred = predict_stalls(text, m, line_bytes=per_line)
        if not pred.stalls:
            return []
        first = pred.stalls[0]
        msg = (f"warning: over the {m.link_baud}-baud link ({m.name}) the planner will run dry "
               f"{len(pred.stalls)} time(s), first at line {first.line} after {first.time_s:.2f} s, "
               f"standing {pred.stall_time_s:.2f} s in all (a raster job stutters and burns dots "
               f"there)")
        if program_feeds(text):
            free = stall_free_feed(text, m, line_bytes=lambda t: per_line, rel_tol=0.02, rows=False)
            if free.limited_by == "link":
                msg += (f"; the highest feed without a stall is about {free.feed_mm_min:.0f} mm/min "
                        f"(programmed {free.programmed_mm_min:g}): lower the feed or coarsen the "
                        f"pixel pitch (`labkit plan FILE --machine {m.name}` shows each row)")
        return [msg]
    except LabkitError as exc:
        return [f"note: the stall prediction could not be made: {exc}"]


def _job_extents(moves) -> tuple:
    """Per motion row (lo, hi, line) of the job, mm, without the first row's start (that is
    where the head happens to be, not part of the job)."""
    keep = np.flatnonzero(moves.is_motion)
    if len(keep) == 0:
        return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, int)
    rows = moves[keep]
    lo, hi = rows.extents()
    lo, hi = lo.copy(), hi.copy()
    if not rows.is_arc[0]:
        lo[0] = hi[0] = rows.end[0]
    return lo, hi, np.asarray(rows.line)


def _work_offset(grbl: Grbl, job: Job, parser: list, status) -> tuple:
    """The offset the controller will add to the job's coordinates (mm), and how it was found;
    None when the job sets or selects offsets of its own (then the travel is not checked)."""
    t = job.trace
    motion = np.asarray(job.moves.line)[np.asarray(job.moves.is_motion, bool)]
    last = int(motion.max()) if len(motion) else 0      # offsets set after it move nothing
    before = np.array([ln <= last for ln, _ in job.send], bool)
    if np.any((t["sets_offsets"] | t["machine_coords"]) & before):
        return None, "the job sets its own offsets (G10, G92, G53, G28/G30, G43.1/G49)"
    chosen = {f"G{int(c)}" for c in t["coord_system"][t["states_coord_system"]]}
    active = next((w for w in parser if w in ("G54", "G55", "G56", "G57", "G58", "G59")), None)
    if len(chosen) > 1:
        return None, f"the job uses several coordinate systems ({', '.join(sorted(chosen))})"
    system = next(iter(chosen)) if chosen else active
    try:
        offsets = grbl.offsets()
    except MachineError as exc:
        if status is not None and status.wco is not None and not chosen:
            return np.asarray(status.wco[:3], float), "WCO in the status report"
        return None, f"the offsets could not be read ($#: {exc})"

    def triple(key):
        vals = [float(v) for v in offsets.get(key, "0,0,0").split(":")[0].split(",")[:3]]
        return np.array(vals + [0.0] * (3 - len(vals)))

    try:
        wco = triple(system or "G54") + triple("G92")
        wco[2] += float(offsets.get("TLO", "0") or 0)
    except ValueError:
        return None, f"the offsets ($#) did not read as numbers: {offsets}"
    return wco, f"{system or 'G54'} + G92 + TLO from $#"


def preflight_check(grbl: Grbl, job: Job, *, machine=None, status=None) -> tuple[list, list]:
    """Check a job against what the controller says, before anything is sent.

    Reads the status, ``$G`` (units, distance mode, coordinate system) and ``$#``
    (work offsets), with ``$$`` as :meth:`Grbl.connect` read it, and finds what would
    alarm or burn where it should not:

    * the controller's state: in alarm, busy, held, asleep or in check mode;
    * power: an S above ``$30`` (GRBL clamps it: full power where the job asked less);
    * units and distance mode: a job that does not say them before its first move on a
      controller left in G20 (inches) or G91 (relative);
    * travel: the job's extent (arcs exact) plus the work offset, against the travel
      where it is known — soft limits on (``$20=1``: GRBL would stop with ALARM:2 at the
      first line outside, after burning the lines before it), or the machine description
      (``machine``, or the virtual machine's own) for the job's size.

    Laser mode (``$32``) is :meth:`Grbl.check_laser_job`, which :func:`run_job` calls
    first. ``--check-first`` (:func:`check_job`) stays the deeper check: every line
    parsed by the controller itself.

    Parameters
    ----------
    grbl : Grbl
    job : Job
    machine : str or MachineSpec, optional
        The machine description the user named (its travel bounds the job's size).
    status : Status, optional
        A status report just taken (one is asked for otherwise).

    Returns
    -------
    problems : list of str
        Each a reason to refuse the job, with the fix named.
    notes : list of str
        Warnings and what could not be checked.
    """
    problems: list[str] = []
    notes: list[str] = []
    st = status if status is not None else grbl.get_status()
    if st.state == "Alarm":
        problems.append("the controller is in alarm" + (f" (ALARM:{grbl.alarm}: "
                        f"{alarm_message(grbl.alarm)})" if grbl.alarm else "") +
                        ": check the machine, then unlock it with $X (or home it with $H)")
    elif st.state in ("Run", "Jog", "Home", "Hold", "Door"):
        problems.append(f"the controller is busy ({st.state}): let it finish or stop it, then "
                        f"start the job from Idle")
    elif st.state == "Check":
        problems.append("the controller is in check mode ($C): nothing would be cut; send $C to "
                        "leave it (--check-first runs the check and leaves it by itself)")
    elif st.state == "Sleep":
        problems.append("the controller is asleep: wake it with a soft reset (ctrl-x) first")
    m = job.moves
    burning = np.asarray(m.laser_on, bool)
    s30 = grbl.setting(30)
    if burning.any() and math.isfinite(s30) and s30 > 0:
        powers = np.asarray(m.s_word, float)[burning]
        k = int(np.argmax(powers))
        s_job, ln = float(powers[k]), int(np.asarray(m.line)[burning][k])
        if s_job > s30 * (1 + 1e-6):
            problems.append(f"the job's power goes up to S{s_job:g} (line {ln}) but the "
                            f"controller's $30 is {s30:g}: GRBL clamps every higher S to full "
                            f"power; send '$30={s_job:g}' if the job was written for that range, "
                            f"or scale the job's S to 0…{s30:g}")
        elif s_job * 4 <= s30:
            notes.append(f"note: the job's highest power is S{s_job:g}, {100 * s_job / s30:.0f} % "
                         f"of $30={s30:g}: was it written for $30={s_job:g}?")
    try:
        parser = grbl.parser_state().split()
    except MachineError as exc:
        parser = []
        notes.append(f"note: the parser state ($G) could not be read ({exc}): units and "
                     f"distance mode not checked")
    first_move = next((ln for (ln, _), moves in zip(job.send, job.axis_words) if moves), None)
    if "G20" in parser and not _states_before_motion(job, "states_units"):
        problems.append(f"the controller is in inches (G20) and the job does not say its units "
                        f"before its first move (line {first_move}): every coordinate would be "
                        f"read in inches, 25.4 times too far; add G21 at the top of the job")
    if "G91" in parser and not _states_before_motion(job, "states_distance"):
        problems.append(f"the controller is in relative mode (G91) and the job does not say its "
                        f"distance mode before its first move (line {first_move}): add G90 at "
                        f"the top of the job")
    lo, hi, lines = _job_extents(m)
    if len(lines) == 0:
        return problems, notes
    spec = machine
    vm = _virtual_machine(grbl.link)
    if spec is None and vm is not None:
        spec = vm.machine
    if spec is not None:
        from labkit.motion.spec import check_job_fits

        try:
            msg = check_job_fits(hi.max(axis=0) - lo.min(axis=0), spec, force=True)
        except LabkitError as exc:
            msg = None
            notes.append(f"note: the machine description could not be read: {exc}")
        if msg:
            problems.append(msg + "; scale the job down, or name the right machine (--machine)")
        notes.extend(_stall_notes(job, spec))
    if grbl.setting(20, 0.0) != 1.0:
        return problems, notes
    travel = np.array([grbl.setting(130 + a) for a in range(3)])
    if not np.all(np.isfinite(travel)):
        notes.append("note: soft limits are on but $130-$132 were not read: travel not checked")
        return problems, notes
    # GRBL's soft limits (the virtual machine's too): −$13x…0 per axis; positive on an axis
    # whose position is positive (a build that sets the origin at home, HOMING_FORCE_SET_ORIGIN)
    positive = np.asarray(st.mpos[:3], float) > 1e-3 if st.mpos is not None else np.zeros(3, bool)
    box_lo, box_hi = np.where(positive, 0.0, -travel), np.where(positive, travel, 0.0)
    rule = "GRBL's −$130…0 per axis (0…$130 where the position is positive)"
    wco, how = _work_offset(grbl, job, parser, st)
    if wco is None:
        notes.append(f"note: the travel was not checked: {how}; --check-first lets the "
                     f"controller check it")
        return problems, notes
    mlo, mhi = lo + wco, hi + wco
    out = (mlo < box_lo - 1e-3) | (mhi > box_hi + 1e-3)
    bad = np.flatnonzero(out.any(axis=1))
    if len(bad):
        r = int(bad[0])
        a = int(np.flatnonzero(out[r])[0])
        v = mlo[r, a] if mlo[r, a] < box_lo[a] - 1e-3 else mhi[r, a]
        text = dict(job.send).get(int(lines[r]), "")
        problems.append(
            f"line {int(lines[r])} ({text}) would take {'XYZ'[a]} to {v:.3f} mm in machine "
            f"coordinates (work offset {_fmt_xyz(wco)}, {how}), outside the travel "
            f"{box_lo[a]:g}…{box_hi[a]:g} mm ({rule}): with soft limits on ($20=1) GRBL stops "
            f"there with ALARM:2, after burning the lines before it; move the work origin "
            f"(jog to where the job's 0,0 belongs and send 'G10 L20 P0 X0 Y0') or move the job")
    return problems, notes


# -- resume (the text itself is machine/resume.py's) ------------------------------------

def _job_position(st):
    """A status report's position in the job's coordinates: WPos (MPos − WCO), or MPos while
    the controller has not reported its WCO yet (offsets taken as zero)."""
    return st.wpos if st.wpos is not None else st.mpos


def _resume_send(job: Job, line: int, position) -> tuple:
    """The (source line, text) to send to resume at ``line``, and whether each syncs."""
    pre = [(line, strip_line(t)) for t in resume_text(job, line, position)]
    first = line + 1 if position is not None else line
    rest = [(entry, sync) for entry, sync in zip(job.send, job.syncing) if entry[0] >= first]
    return (pre + [entry for entry, _ in rest],
            _syncing([t for _, t in pre], _send_trace([t for _, t in pre], job.dialect))
            + [sync for _, sync in rest])
