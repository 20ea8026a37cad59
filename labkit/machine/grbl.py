"""GRBL 1.1 over a :class:`~labkit.machine.link.Link`.

A background reader turns the machine's bytes into lines and sorts them, as
[LaserApp]'s communication thread does with its producer–consumer queue:

* ``ok`` and ``error:N`` answer the oldest line still unanswered — they go to
  the response queue (:meth:`Grbl.next_event`);
* ``ALARM:N``, a start-up banner (a reset happened) and a lost link go to the
  same queue, so a job waiting for an answer hears about them at once;
* status reports ``<…>`` update :attr:`Grbl.status` (never answer a line);
* ``[…]`` messages and ``$N=V`` settings are collected for the command that
  asked for them (never answer a line either).

Real-time bytes (``?``, ``!``, ``~``, 0x18, 0x85, overrides) bypass the
buffers. :meth:`Grbl.command` sends one line and waits for its answer
(send-response); the job runner (:mod:`labkit.machine.stream`) streams by
character counting on top of :meth:`Grbl.send_line` and :meth:`Grbl.next_event`.
"""

from __future__ import annotations

import dataclasses
import math
import queue
import re
import threading
import time
from dataclasses import dataclass

from labkit.errors import AlarmCode, ErrorCode, Feedback, MachineError, status_code
from labkit.machine.link import Link
from labkit.units import s_within

__all__ = ["Grbl", "Status", "parse_status", "error_message", "alarm_message", "grbl_reply", "Event",
           "SafeStop", "Transcript", "REALTIME", "DEFAULT_RX_BYTES", "DEFAULT_PLANNER_BLOCKS",
           "NOT_TOLD"]

#: GRBL 1.1's serial RX buffer (bytes) and planner depth (blocks) when ``$I`` does not say.
DEFAULT_RX_BYTES = 128
DEFAULT_PLANNER_BLOCKS = 15     # GRBL 1.1 on a 328P: [OPT:V,15,128]

#: Real-time command bytes (GRBL 1.1).
REALTIME = {
    "status": b"?", "feed_hold": b"!", "cycle_start": b"~", "soft_reset": b"\x18",
    "safety_door": b"\x84", "jog_cancel": b"\x85",
    "feed_100": b"\x90", "feed_plus_10": b"\x91", "feed_minus_10": b"\x92",
    "feed_plus_1": b"\x93", "feed_minus_1": b"\x94",
    "rapid_100": b"\x95", "rapid_50": b"\x96", "rapid_25": b"\x97",
    "power_100": b"\x99", "power_plus_10": b"\x9A", "power_minus_10": b"\x9B",
    "power_plus_1": b"\x9C", "power_minus_1": b"\x9D",
}


def error_message(code: int) -> str:
    """The message of ``error:N`` (the ``error`` rows of ``labkit/status_codes.csv``).

    >>> error_message(33)
    'arc cannot be made from its words'
    >>> error_message(9)
    'G-code is locked out during an alarm or jog; unlock with $X or home with $H'
    >>> error_message(99)
    'unknown error 99'
    >>> error_message(0)              # [CBR40]'s bare 'er'
    'line rejected (the controller gave no code)'
    """
    if int(code) == 0:
        return "line rejected (the controller gave no code)"
    try:
        return status_code(int(code)).message
    except KeyError:
        return f"unknown error {code}"


def alarm_message(code: int) -> str:
    """The message of ``ALARM:N`` (the ``alarm`` rows of ``labkit/status_codes.csv``).

    >>> alarm_message(2)
    'soft limit: a move would leave the machine travel; position kept, unlock with $X'
    """
    try:
        return status_code(int(code), "alarm").message
    except KeyError:
        return f"unknown alarm {code}"


def grbl_reply(name: ErrorCode | AlarmCode | Feedback) -> str:
    """The line GRBL 1.1 sends for a row of the table, by its name.

    >>> grbl_reply(ErrorCode.OK), grbl_reply(ErrorCode.NOT_IDLE), grbl_reply(AlarmCode.SOFT_LIMIT)
    ('ok', 'error:8', 'ALARM:2')
    >>> grbl_reply(Feedback.RESET_TO_CONTINUE)
    '[MSG:Reset to continue]'
    """
    if isinstance(name, AlarmCode):
        return f"ALARM:{int(name)}"
    if isinstance(name, Feedback):
        return f"[MSG:{status_code(int(name), 'reply').message}]"
    if isinstance(name, ErrorCode):
        return "ok" if name == ErrorCode.OK else f"error:{int(name)}"
    raise TypeError(f"grbl_reply: expected an ErrorCode, AlarmCode or Feedback name, got {name!r}")


# -- status reports -----------------------------------------------------------------------------

@dataclass(frozen=True)
class Status:
    """One parsed status report (``<Idle|MPos:…|FS:…>``); absent fields are None.

    Attributes
    ----------
    state : str
        ``Idle``, ``Run``, ``Hold``, ``Jog``, ``Alarm``, ``Door``, ``Check``,
        ``Home``, ``Sleep`` (the sub-state of Hold/Door is in ``substate``).
    mpos, wpos : tuple of float or None
        Machine and work position, mm; one is computed from the other with the
        work coordinate offset (``WCO``, reported now or remembered).
    wco : tuple of float or None
    feed_mm_min, spindle : float or None
        ``FS`` (or ``F`` alone).
    planner_free, rx_free : int or None
        ``Bf``: free planner blocks and free RX bytes.
    line : int or None
        ``Ln``: the N number of the block executing.
    overrides : tuple of int or None
        ``Ov``: feed, rapid, spindle/laser override in %.
    pins : str
        ``Pn``: input pins (X Y Z limits, P probe, D door, H hold, R reset, S start).
    received_s : float
        When it arrived (monotonic clock).
    """

    state: str
    substate: int | None = None
    mpos: tuple | None = None
    wpos: tuple | None = None
    wco: tuple | None = None
    feed_mm_min: float | None = None
    spindle: float | None = None
    planner_free: int | None = None
    rx_free: int | None = None
    line: int | None = None
    overrides: tuple | None = None
    pins: str = ""
    raw: str = ""
    received_s: float = 0.0
    answers_before: int = 0    #: ok/error answers received before this report (wire order)

    @property
    def moving(self) -> bool:
        """True while the machine runs a job or a jog (not held, idle or in alarm)."""
        return self.state in ("Run", "Jog", "Home")


_STATES = ("Idle", "Run", "Hold", "Jog", "Alarm", "Door", "Check", "Home", "Sleep")


def _floats(text: str, name: str, raw: str) -> tuple:
    try:
        vals = tuple(float(v) for v in text.split(","))
    except ValueError:
        raise MachineError(f"malformed {name} field in status report {raw!r}") from None
    if not all(math.isfinite(v) for v in vals):
        raise MachineError(f"non-finite {name} in status report {raw!r}")
    return vals


def parse_status(raw: str, wco: tuple | None = None, *, received_s: float = 0.0) -> Status:
    """Parse a GRBL 1.1 status report; fields may come in any order and may be absent.

    Parameters
    ----------
    raw : str
        ``<State|field:value|…>``.
    wco : tuple, optional
        The last work coordinate offset reported (GRBL sends ``WCO`` only now and then).

    Raises
    ------
    MachineError
        Not a status report, an unknown state or a malformed field.

    Examples
    --------
    >>> s = parse_status("<Run|MPos:10.000,5.000,0.000|Bf:15,128|FS:600,300|WCO:1.000,2.000,0.000>")
    >>> s.state, s.mpos, s.wpos, s.planner_free, s.rx_free, s.feed_mm_min, s.spindle
    ('Run', (10.0, 5.0, 0.0), (9.0, 3.0, 0.0), 15, 128, 600.0, 300.0)
    >>> parse_status("<Hold:0|WPos:1,2,3>", wco=(1.0, 1.0, 1.0)).mpos
    (2.0, 3.0, 4.0)
    >>> parse_status("<Idle|MPos:0,0,0|Ov:100,50,120|Pn:XP>").overrides
    (100, 50, 120)
    """
    text = raw.strip()
    if not (text.startswith("<") and text.endswith(">")):
        raise MachineError(f"not a status report: {raw!r} (expected <State|…>)")
    parts = text[1:-1].split("|")
    head = parts[0]
    name, _, sub = head.partition(":")
    if name not in _STATES:
        raise MachineError(f"unknown machine state {head!r} in status report {raw!r}")
    fields: dict = {"state": name, "substate": int(sub) if sub.isdigit() else None,
                    "raw": text, "received_s": received_s}
    mpos = wpos = None
    for part in parts[1:]:
        key, sep, value = part.partition(":")
        if not sep:
            continue
        if key == "MPos":
            mpos = _floats(value, key, raw)
        elif key == "WPos":
            wpos = _floats(value, key, raw)
        elif key == "WCO":
            wco = _floats(value, key, raw)
        elif key == "FS":
            f = _floats(value, key, raw)
            fields["feed_mm_min"], fields["spindle"] = f[0], (f[1] if len(f) > 1 else None)
        elif key == "F":
            fields["feed_mm_min"] = _floats(value, key, raw)[0]
        elif key == "Bf":
            b = _floats(value, key, raw)
            fields["planner_free"], fields["rx_free"] = int(b[0]), int(b[1]) if len(b) > 1 else None
        elif key == "Ln":
            fields["line"] = int(_floats(value, key, raw)[0])
        elif key == "Ov":
            fields["overrides"] = tuple(int(v) for v in _floats(value, key, raw))
        elif key == "Pn":
            fields["pins"] = value
        # unknown fields (A:, grblHAL extras) are ignored on purpose
    if wco is not None:
        if mpos is not None and wpos is None:
            wpos = tuple(m - o for m, o in zip(mpos, wco))
        elif wpos is not None and mpos is None:
            mpos = tuple(w + o for w, o in zip(wpos, wco))
    return Status(mpos=mpos, wpos=wpos, wco=wco, **fields)


# -- the protocol client --------------------------------------------------------------------------

@dataclass(frozen=True)
class Event:
    """Something that answers or interrupts a line: ``ok``, ``error``, ``alarm``, ``reset``
    (a start-up banner arrived), ``disconnect``."""

    kind: str
    code: int = 0
    text: str = ""
    t: float = 0.0
    seq: int = 0        #: for ok/error: how many answers came before this one


_ERROR = re.compile(r"^(?:error|er):?(\d*)$", re.IGNORECASE)
_ALARM = re.compile(r"^ALARM:(\d+)$")
_SETTING = re.compile(r"^\$(\d+)=(.*)$")
_BANNER = re.compile(r"^(Grbl|GrblHAL|labkit)\b.*", re.IGNORECASE)


#: What a report says when the link is gone before labkit could stop the machine.
NOT_TOLD = ("the controller was not told to stop: its own buffer-empty/alarm behaviour is all "
            "that applies")


class Transcript(list):
    """A transcript that is also written to a text file as it grows, one flushed line per entry.

    Each entry ``(seconds since connect, direction, text)`` becomes the line
    ``"   12.3456 > G1X10"``; the file is flushed after every line, so whatever
    ends the session (a fault, a signal, a lost link) leaves every line sent and
    received so far on disk. A write that fails (a full disk) does not stop the
    session: the first failure is kept in :attr:`error` and the rest are dropped.

    Parameters
    ----------
    fh : text file
        Open for writing.
    """

    def __init__(self, fh):
        super().__init__()
        self.fh = fh
        self.error: str | None = None

    def append(self, entry) -> None:
        super().append(entry)
        if self.error is not None:
            return
        t, direction, text = entry
        try:
            self.fh.write(f"{t:10.4f} {direction} {text}\n")
            self.fh.flush()
        except (OSError, ValueError) as exc:
            self.error = f"the transcript stopped being written: {exc}"


@dataclass
class SafeStop:
    """What :meth:`Grbl.stop_safely` sent and what the controller confirmed.

    Attributes
    ----------
    steps : list of str
        One entry per step, saying whether it was confirmed (see :meth:`Grbl.stop_safely`).
    told : bool
        False when nothing could be sent (the link was already gone).
    beam_off_confirmed : bool
        The controller confirmed the beam off: ``ok`` to ``M5 S0``, or the start-up
        banner after the soft reset (GRBL's reset switches the spindle/laser off).
    stopped_status : Status or None
        The status report taken once motion had stopped (before the reset): the
        planner occupancy in it tells which lines ran.
    events : list of Event
        Answers and interruptions that arrived before ``M5 S0`` was sent, for the
        caller's line accounting.
    """

    steps: list = dataclasses.field(default_factory=list)
    told: bool = True
    beam_off_confirmed: bool = False
    stopped_status: Status | None = None
    events: list = dataclasses.field(default_factory=list)


@dataclass
class MachineInfo:
    """What ``$I`` and the banner said."""

    banner: str = ""
    version: str = ""
    options: str = ""
    planner_blocks: int = DEFAULT_PLANNER_BLOCKS
    rx_bytes: int = DEFAULT_RX_BYTES
    from_machine: bool = False       #: False when ``[OPT:…]`` was missing and defaults are used


class Grbl:
    """A GRBL 1.1 machine on a link.

    Parameters
    ----------
    link : Link
    transcript : list, optional
        Where every line sent (``">"``) and received (``"<"``) goes, as
        ``(seconds since connect, direction, text)``; status polls are left
        out unless ``log_status``.
    log_status : bool
        Also record ``?`` and status reports in the transcript.

    Examples
    --------
    >>> from labkit.machine.link import open_link
    >>> g = Grbl(open_link(virtual_options={"time_scale": 0}))
    >>> info = g.connect()
    >>> info.rx_bytes, info.planner_blocks
    (128, 15)
    >>> g.command("G21 G90")
    []
    >>> g.get_status().state
    'Idle'
    >>> g.close()
    """

    protocol = "grbl"
    dialect = "grbl"

    def __init__(self, link: Link, *, transcript: list | None = None, log_status: bool = False):
        if not isinstance(link, Link):
            raise MachineError(f"{type(self).__name__}: link must be an open Link "
                               f"(labkit.machine.open_link(port)), got {type(link).__name__}")
        self.link = link
        self.transcript = transcript if transcript is not None else []
        self.log_status = log_status
        self.events: queue.Queue[Event] = queue.Queue()
        self.messages: list[str] = []
        self.settings: dict[int, str] = {}
        self.status: Status | None = None
        self.status_count = 0
        self.answer_count = 0
        self.info = MachineInfo()
        self.alarm: int | None = None
        #: the answers GRBL sent at the last :meth:`soft_reset` for the line it was in (after
        #: ALARM:1/2, or with ALARM:3): they acknowledge a line that never ran (or ran part way)
        self.reset_answers: list[Event] = []
        self._alarm_mark: int | None = None     # answers before the last alarm since a banner
        self._reset_owed_from: int | None = None
        self.disconnected: str | None = None
        self.warnings: list[str] = []          #: what the reader noticed (absurd status reports)
        self._warned: set = set()
        self._wco = None
        self._t0 = time.monotonic()
        self._status_cond = threading.Condition()
        self._banner = threading.Event()
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._listeners: list = []
        self._reader = threading.Thread(target=self._read_loop, name="labkit-grbl-reader",
                                        daemon=True)
        self._reader.start()

    # -- plumbing -------------------------------------------------------------------------------

    def _log(self, direction: str, text: str) -> None:
        self.transcript.append((round(time.monotonic() - self._t0, 4), direction, text))

    def _warn(self, text: str, key: str) -> None:
        """Keep a warning, once per ``key`` (a flood of bad reports stays one line)."""
        if key not in self._warned:
            self._warned.add(key)
            self.warnings.append(text)
        self._log("<", f"[{text}]")

    #: Largest coordinate a status report may give, mm (100 m: beyond any laser's travel).
    _MAX_POSITION_MM = 1e5

    def _absurd_fields(self, st: Status) -> str | None:
        """Why a parsed status report cannot be used for accounting (None when it can)."""
        if st.planner_free is not None and not 0 <= st.planner_free <= self.info.planner_blocks:
            return (f"Bf planner blocks {st.planner_free} outside 0…{self.info.planner_blocks} "
                    f"(the planner's depth)")
        if st.rx_free is not None and not 0 <= st.rx_free <= self.info.rx_bytes:
            return f"Bf RX bytes {st.rx_free} outside 0…{self.info.rx_bytes} (the RX buffer's size)"
        for name, pos in (("MPos", st.mpos), ("WPos", st.wpos), ("WCO", st.wco)):
            if pos is not None and (len(pos) < 2 or max(abs(v) for v in pos) > self._MAX_POSITION_MM):
                return f"{name} {pos} is not a position on a machine"
        return None

    def add_listener(self, fn) -> None:
        """Call ``fn(line)`` for every line received (the notebook console uses this)."""
        self._listeners.append(fn)

    def _read_loop(self) -> None:
        buf = b""
        while not self._stop.is_set():
            try:
                data = self.link.read(0.02)
            except MachineError as exc:
                if not self._stop.is_set():
                    self.disconnected = str(exc)
                    self.events.put(Event("disconnect", 0, str(exc), time.monotonic()))
                    with self._status_cond:
                        self._status_cond.notify_all()
                return
            if not data:
                continue
            buf += data
            while True:
                cut = buf.find(b"\n")
                if cut < 0:
                    break
                line, buf = buf[:cut], buf[cut + 1:]
                text = line.decode("ascii", "replace").strip("\r \x00")
                if text:
                    self._handle(text)
            if len(buf) > 4096:             # garbage without line ends: keep the tail only
                buf = buf[-256:]

    def _handle(self, text: str) -> None:
        now = time.monotonic()
        for fn in self._listeners:
            try:
                fn(text)
            except Exception:                # a listener must never stop the reader
                pass
        if text.startswith("<"):
            try:
                st = parse_status(text, self._wco, received_s=now)
                absurd = self._absurd_fields(st)
            except MachineError as exc:
                name = text[1:].split("|")[0].split(":")[0].rstrip(">")
                if name not in _STATES:
                    self._log("<", text + "   [garbled status ignored]")
                    return
                # a live controller with a field that makes no sense: the report still counts
                # as a sign of life and its state is kept, but none of its numbers are used
                st, absurd = Status(name, raw=text, received_s=now), str(exc)
            if absurd:
                self._warn(f"status report {text!r} ignored for accounting: {absurd}",
                           absurd.split(" ")[0])
                st = Status(st.state, substate=st.substate, raw=text, received_s=now)
            self._wco = st.wco if st.wco is not None else self._wco
            st = dataclasses.replace(st, answers_before=self.answer_count)
            with self._status_cond:
                self.status = st
                self.status_count += 1
                self._status_cond.notify_all()
            if self.log_status:
                self._log("<", text)
            return
        self._log("<", text)
        if text == "ok":
            self.events.put(Event("ok", 0, text, now, self.answer_count))
            self.answer_count += 1
            return
        m = _ERROR.match(text)
        if m:
            self.events.put(Event("error", int(m.group(1) or 0), text, now, self.answer_count))
            self.answer_count += 1
            return
        m = _ALARM.match(text)
        if m:
            self.alarm = int(m.group(1))
            self._alarm_mark = self.answer_count
            self.events.put(Event("alarm", self.alarm, text, now))
            return
        m = _SETTING.match(text)
        if m:
            self.settings[int(m.group(1))] = m.group(2).strip()
        if _BANNER.match(text):
            self.info.banner = text
            # an answer between an alarm and this banner is GRBL's answer, at the reset, to the
            # line it was in (soft_reset sets it aside)
            self._reset_owed_from, self._alarm_mark = self._alarm_mark, None
            self._banner.set()
            self.events.put(Event("reset", 0, text, now))
            return
        with self._lock:
            self.messages.append(text)

    def send_line(self, line: str) -> int:
        """Send one line (``\\n`` appended) without waiting; returns the bytes it takes."""
        self._log(">", line)
        self.link.write_line(line)
        return len(line) + 1

    def realtime(self, name: str) -> None:
        """Send a real-time byte by name (see :data:`REALTIME`)."""
        byte = REALTIME[name]
        if name != "status" or self.log_status:
            self._log(">", f"<{name}>")
        self.link.write(byte)

    def next_event(self, timeout_s: float) -> Event | None:
        """The next answer or interruption, or None after ``timeout_s``."""
        try:
            return self.events.get(timeout=timeout_s)
        except queue.Empty:
            return None

    def drain_events(self) -> list[Event]:
        out = []
        while True:
            try:
                out.append(self.events.get_nowait())
            except queue.Empty:
                return out

    def take_messages(self) -> list[str]:
        with self._lock:
            out, self.messages = self.messages, []
        return out

    # -- connection -------------------------------------------------------------------------------

    def connect(self, timeout_s: float = 5.0) -> MachineInfo:
        """Wait for the banner (provoking one with a soft reset), then read ``$I`` and ``$$``.

        Raises
        ------
        MachineError
            No banner within ``timeout_s``: wrong port, wrong baud rate or not a GRBL.
        """
        if not self._banner.wait(min(timeout_s, 2.5)):
            self.realtime("soft_reset")
            if not self._banner.wait(timeout_s):
                raise MachineError(
                    f"no GRBL start-up banner from {self.link.name} within {timeout_s:g} s: is it "
                    f"the right port, 115200 baud, and a GRBL-compatible controller?")
        time.sleep(0.05)
        self._refuse_unasked_answers(self.drain_events())
        self.read_info()
        self.read_settings()
        return self.info

    def _refuse_unasked_answers(self, events: list) -> None:
        """An ``ok``/``error`` after the start-up banner, before any line was sent, answers
        nothing: the controller (or something else on the line) is not in step with labkit,
        and every later answer would be matched to the wrong line."""
        resets = [k for k, ev in enumerate(events) if ev.kind == "reset"]
        after = events[resets[-1] + 1:] if resets else events
        stray = [ev for ev in after if ev.kind in ("ok", "error")]
        if stray:
            raise MachineError(
                f"protocol error: {self.link.name} sent {len(stray)} answer(s) ('{stray[0].text}') "
                f"after its start-up banner, before any line was sent: another program may be "
                f"talking to it, or it is not a GRBL in step with labkit; nothing was sent")

    def read_info(self) -> MachineInfo:
        """``$I``: version and ``[OPT:flags,planner blocks,RX bytes]`` (grblHAL: 1024 bytes)."""
        lines = self.command("$I")
        for text in lines:
            if text.startswith("[VER:"):
                self.info.version = text[5:-1]
            elif text.startswith("[OPT:"):
                self.info.options = text[5:-1]
                parts = self.info.options.split(",")
                try:
                    if len(parts) >= 3:
                        self.info.planner_blocks = int(parts[1])
                        self.info.rx_bytes = int(parts[2])
                        self.info.from_machine = True
                except ValueError:
                    pass
        return self.info

    def close(self) -> None:
        self._stop.set()
        self.link.close()
        self._reader.join(timeout=1.0)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    # -- send-response commands ---------------------------------------------------------------

    def command(self, line: str, timeout_s: float = 10.0) -> list[str]:
        """Send one line, wait for its ``ok``; returns the messages that came with it.

        Raises
        ------
        MachineError
            ``error:N`` (with its message), an alarm, a reset, a lost link or
            no answer within ``timeout_s``.
        """
        self.take_messages()
        self.send_line(line)
        deadline = time.monotonic() + timeout_s
        while True:
            ev = self.next_event(max(0.0, deadline - time.monotonic()))
            if ev is None:
                raise MachineError(f"no answer to {line!r} from {self.link.name} within "
                                   f"{timeout_s:g} s")
            if ev.kind == "ok":
                return self.take_messages()
            if ev.kind == "error":
                raise MachineError(f"{line!r} rejected: error:{ev.code}: {error_message(ev.code)}")
            if ev.kind == "alarm":
                raise MachineError(f"ALARM:{ev.code} while sending {line!r}: {alarm_message(ev.code)}")
            if ev.kind == "disconnect":
                raise MachineError(ev.text)
            if ev.kind == "reset":
                raise MachineError(f"the machine reset while sending {line!r}")

    def get_status(self, timeout_s: float = 2.0) -> Status:
        """Ask with ``?`` and wait for the next status report."""
        with self._status_cond:
            seen = self.status_count
        self.realtime("status")
        deadline = time.monotonic() + timeout_s
        with self._status_cond:
            while self.status_count == seen:
                left = deadline - time.monotonic()
                if left <= 0 or self.disconnected:
                    raise MachineError(self.disconnected or f"no status report from "
                                       f"{self.link.name} within {timeout_s:g} s")
                self._status_cond.wait(left)
            return self.status

    def wait_status(self, predicate, timeout_s: float, poll_s: float = 0.05) -> Status:
        """Poll ``?`` until ``predicate(status)``; raises MachineError after ``timeout_s``."""
        deadline = time.monotonic() + timeout_s
        while True:
            st = self.get_status(max(0.1, deadline - time.monotonic()))
            if predicate(st):
                return st
            if time.monotonic() > deadline:
                raise MachineError(f"machine state stayed {st.state} for {timeout_s:g} s")
            time.sleep(poll_s)

    def read_settings(self) -> dict[int, str]:
        """``$$``: every setting as ``{number: text}`` (also kept in :attr:`settings`)."""
        self.command("$$")
        return dict(self.settings)

    def set_setting(self, number: int, value) -> None:
        """``$N=V`` (always send-response: GRBL writes EEPROM and stops reading meanwhile)."""
        self.command(f"${int(number)}={value}")
        self.settings[int(number)] = str(value)

    def setting(self, number: int, default: float = math.nan) -> float:
        try:
            return float(self.settings[number])
        except (KeyError, ValueError):
            return default

    def parser_state(self) -> str:
        """``$G``: the modal state, e.g. ``G0 G54 G17 G21 G90 G94 M5 M9 T0 F0 S0``."""
        for text in self.command("$G"):
            if text.startswith("[GC:"):
                return text[4:-1]
        raise MachineError("no [GC:…] answer to $G")

    def offsets(self) -> dict[str, str]:
        """``$#``: work coordinate offsets, G28/G30 positions, tool length, probe."""
        out = {}
        for text in self.command("$#"):
            if text.startswith("[") and ":" in text:
                key, _, value = text[1:-1].partition(":")
                out[key] = value
        return out

    def set_origin(self, axes: str = "XY") -> None:
        """Make the current position the work zero of the active coordinate system
        (``G10 L20 P0 X0 Y0``): the drawing's origin goes where the head is now."""
        axes = "".join(dict.fromkeys(a.upper() for a in axes))
        if not axes or set(axes) - set("XYZ"):
            raise MachineError(f"set_origin: axes must be a choice of X, Y, Z, got {axes!r}")
        self.command("G10 L20 P0 " + " ".join(f"{a}0" for a in axes))

    def test_pulse(self, s_word: float, duration_s: float = 0.2, *, step_mm: float = 0.05) -> None:
        """Fire the laser briefly at ``s_word`` where the head is, to find the focus or the beam.

        GRBL's laser mode (``$32=1``) with M4 keeps the beam off unless the machine moves (M3
        would leave it on at rest until M5 arrives), so the pulse is an M4 slow step of
        ``step_mm`` out and back (the head ends where it was), each half in
        ``duration_s / 2``; then ``M5``, and the distance mode and feed rate in effect before
        are restored.

        Parameters
        ----------
        s_word : float
            Laser power word S (0 < S ≤ ``$30``); keep it low (1–5 % of ``$30``).
        duration_s : float
            How long the beam is on, s (0.01…5).
        step_mm : float
            Length of the step out and back, mm (a few motor steps).
        """
        s_max = self.setting(30, 1000.0)
        if not s_within(s_word, s_max, positive=True):
            raise MachineError(f"test pulse power S{s_word:g}: expected 0 < S ≤ $30 = {s_max:g}")
        if not 0.01 <= duration_s <= 5.0:
            raise MachineError(f"test pulse of {duration_s:g} s: expected 0.01…5 s")
        state = self.parser_state().split()
        relative = "G91" in state
        feed = next((w[1:] for w in state if w.startswith("F")), "0")
        f = 60.0 * step_mm / (duration_s / 2.0)
        try:
            self.command(f"G91 G1 X{step_mm:g} F{f:.4g} S{s_word:g} M4")
            self.command(f"X{-step_mm:g}")
        finally:
            self.command(f"M5 {'G91' if relative else 'G90'}" + (f" F{feed}" if float(feed) > 0 else ""))

    def unlock(self) -> None:
        """``$X``: leave the alarm state (position may be wrong after a hard limit)."""
        self.command("$X")
        self.alarm = None

    def home(self, timeout_s: float = 120.0) -> None:
        """``$H``: the homing cycle (answers ``ok`` when done)."""
        self.command("$H", timeout_s)
        self.alarm = None

    def jog(self, *, x=None, y=None, z=None, feed_mm_min: float, relative: bool = True) -> None:
        """``$J=…``: a jog (cancel with :meth:`jog_cancel`); the laser stays off."""
        words = " ".join(f"{a}{v:.3f}" for a, v in (("X", x), ("Y", y), ("Z", z)) if v is not None)
        if not words:
            raise MachineError("a jog needs at least one of x, y, z")
        self.command(f"$J={'G91' if relative else 'G90'} G21 {words} F{feed_mm_min:g}")

    def jog_cancel(self) -> None:
        self.realtime("jog_cancel")

    def check_mode(self, on: bool) -> None:
        """``$C`` toggles check mode; switch it only when it differs (off resets GRBL)."""
        st = self.get_status()
        if (st.state == "Check") != on:
            self.take_messages()
            self.send_line("$C")
            deadline = time.monotonic() + 5
            while time.monotonic() < deadline:
                ev = self.next_event(0.1)
                if ev is not None and ev.kind in ("ok", "reset"):
                    if ev.kind == "reset" or on:
                        break
            if not on:
                self._banner.wait(2.0)
            time.sleep(0.05)
            self.drain_events()

    def feed_hold(self) -> None:
        self.realtime("feed_hold")

    def resume(self) -> None:
        self.realtime("cycle_start")

    def soft_reset(self, timeout_s: float = 3.0) -> None:
        """0x18: stop at once, flush every buffer, laser off; waits for the banner.

        GRBL answers, at the reset, the line it was in: after a critical alarm (ALARM:1/2,
        when it answers nothing until the reset) and after the reset's own ALARM:3 that
        ``ok`` acknowledges a line that never ran (or ran part way). It is taken out of the
        answers here, into :attr:`reset_answers`, so that no later :meth:`command` takes it as
        its own.
        """
        self._banner.clear()
        self.realtime("soft_reset")
        if not self._banner.wait(timeout_s):
            raise MachineError(f"no start-up banner after a soft reset of {self.link.name}")
        time.sleep(0.05)                     # let the lines after the banner arrive
        self._set_aside_reset_answers()

    def _set_aside_reset_answers(self) -> None:
        """Move the ok/error events between the alarm and the last banner out of the queue."""
        owed_from, self.reset_answers = self._reset_owed_from, []
        if owed_from is None:
            return
        with self.events.mutex:                  # the reader appends under the same lock
            pending = list(self.events.queue)
            last_reset = max((k for k, ev in enumerate(pending) if ev.kind == "reset"), default=-1)
            kept = []
            for k, ev in enumerate(pending):
                if k < last_reset and ev.kind in ("ok", "error") and ev.seq >= owed_from:
                    self.reset_answers.append(ev)
                else:
                    kept.append(ev)
            self.events.queue.clear()
            self.events.queue.extend(kept)

    def stop_safely(self, *, hold: bool = True, reset: bool = True, hold_timeout_s: float = 3.0,
                    reset_timeout_s: float = 3.0, answer_timeout_s: float = 2.0) -> SafeStop:
        """Stop the machine and switch the beam off; say what was sent and what was confirmed.

        The one way every stream, console and panel session ends: feed hold ``!``,
        wait (bounded) for the motion to stop, soft reset 0x18 (GRBL and the labkit
        firmware: every buffered line flushed, the spindle/laser off), then
        ``M5 S0`` (the modal laser state off too, so that nothing sent later burns).
        Each step is attempted even when the one before was not confirmed; nothing
        here raises. Where the link is gone nothing can be sent, and the record says
        so (:data:`NOT_TOLD`).

        Parameters
        ----------
        hold : bool
            Send ``!`` and wait for the stop (False: the machine is known to be idle,
            e.g. after a job that completed).
        reset : bool
            Send the soft reset (False after a completed job: a reset would clear the
            G92 offset the user may rely on; nothing is buffered then).
        hold_timeout_s, reset_timeout_s, answer_timeout_s : float
            How long to wait for the stop, for the banner after the reset and for the
            answer to ``M5 S0``, s.

        Returns
        -------
        SafeStop
            ``steps`` reads e.g. ``["feed hold", "stopped (Hold:0)", "soft reset (buffers
            flushed, laser off)", "M5 S0"]``; a step that was sent but not confirmed says so.
        """
        rec = SafeStop()
        self.disconnected = self.disconnected or self.link.lost
        if self.disconnected or self.link.closed:
            rec.told = False
            rec.steps.append(f"link lost ({self.disconnected or 'closed'}): {NOT_TOLD}")
            self._log("#", rec.steps[-1])
            return rec

        def gone() -> bool:                  # a write failed: nothing more reaches the controller
            return bool(self.link.lost or self.link.closed)

        try:
            if hold:
                self.feed_hold()
                rec.steps.append("feed hold")
                try:
                    st = self.wait_status(lambda s: s.state in ("Hold", "Idle", "Alarm", "Check")
                                          and (s.state != "Hold" or s.substate in (0, None)),
                                          hold_timeout_s)
                    rec.stopped_status = st
                    rec.steps.append(f"stopped ({st.state}"
                                     + (f":{st.substate}" if st.substate is not None else "") + ")")
                except MachineError as exc:
                    if gone():
                        raise
                    rec.steps.append(f"stop not confirmed ({exc})")
            else:
                try:
                    rec.stopped_status = self.get_status(1.0)
                except MachineError as exc:
                    if gone():
                        raise
                    rec.steps.append(f"no status ({exc})")
            if reset:
                try:
                    self.soft_reset(reset_timeout_s)
                    rec.steps.append("soft reset (buffers flushed, laser off)")
                    rec.beam_off_confirmed = True
                except MachineError as exc:
                    if gone():
                        raise
                    rec.steps.append(f"soft reset sent, not confirmed ({exc})")
            rec.events = self.drain_events()
            try:
                self.command("M5 S0", answer_timeout_s)
                rec.steps.append("M5 S0")
                rec.beam_off_confirmed = True
            except MachineError as exc:
                if gone():
                    raise
                why = str(exc)
                if grbl_reply(ErrorCode.GCODE_LOCKED) in why or "ALARM" in why:
                    why += " (the controller is in alarm: the reset had already switched the beam off)"
                rec.steps.append(f"M5 S0 sent, not confirmed: {why}")
        except MachineError as exc:              # a write failed: the link went during the stop
            self.disconnected = self.disconnected or self.link.lost or str(exc)
            rec.told = bool(rec.steps)
            rec.steps.append(f"link lost while stopping ({self.disconnected}): "
                             + ("nothing after this reached the controller; its own "
                                "buffer-empty/alarm behaviour is all that applies" if rec.told
                                else NOT_TOLD))
        for step in rec.steps:
            self._log("#", f"safe stop: {step}")
        return rec

    def laser_mode(self) -> bool:
        """True when ``$32=1`` (laser mode: beam off on rapids and when stopped)."""
        return self.setting(32, 0.0) == 1.0

    def check_laser_job(self, burns: bool, *, allow_spindle_mode: bool = False) -> str | None:
        """Refuse (or warn about) a job that burns while ``$32=0``.

        With laser mode off GRBL treats the laser as a spindle: it stays on
        during rapids and while the machine stops between moves, burning the
        work wherever it travels. Returns a warning text when allowed, None
        when nothing is wrong.

        Raises
        ------
        MachineError
            The job burns, ``$32`` is 0 and ``allow_spindle_mode`` is False.
        """
        if not burns or self.laser_mode():
            return None
        text = ("laser mode is off on the machine ($32=0): the beam would stay on during rapids "
                "and stops; set it with '$32=1' before a laser job")
        if not allow_spindle_mode:
            raise MachineError(text)
        return "warning: " + text
