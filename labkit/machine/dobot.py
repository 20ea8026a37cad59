"""The Dobot Magician ([DobotLaser]): its binary protocol, the canvas → arm transform, a job streamer
and an emulator.

Frames are ``AA AA len id ctrl params… checksum`` with ``len = 2 + len(params)``,
``ctrl`` bit 0 = write and bit 1 = queued, and ``checksum = (−(id + ctrl + Σ
params)) mod 256``; numbers are little-endian, floats float32. A queued write
is answered with its uint64 queue index (``<Q``: 8 bytes — a common Python
library reads only 4 and is wrong past 2³² commands or on a garbled high
word). The reader resynchronises on the ``AA AA`` header after garbage and
drops frames whose length or checksum is wrong.

A G-code job becomes queued commands: SetPTPCmd (84) in MOVL mode for lines
and rapids, SetARCCmd (101) with [DobotLaser]'s mid-arc point
(:func:`labkit.geometry.circle.mid_arc_point`) for arcs, the end-effector laser
(61) on and off, and I/O PWM (132) for power (duty % = S × 100 / S_max; S_max
= 255 in [DobotLaser]'s programs). Canvas coordinates (x′, y′) map to the arm as
X = −y′ + x0, Y = −x′ + y0 with the origin (x0, y0) = (300, 100) mm, and
every point the arm would pass is checked against the reachable annulus of
170–320 mm around its base **before anything is sent**.

The feed F is not sent: the arm draws at the speeds set on it (its PTP and
ARC parameters, e.g. in DobotStudio), so ``labkit stream`` says so with the
job's range of F.

What the arm would not draw as written is refused before anything is sent,
naming the source line, never flattened or clamped: a move that changes Z and
an arc in the XZ or YZ plane (the arm draws in one plane, at the laser's
focus), and a burning S above full power (``--s-max``: a PWM duty above 100 %
is not a power anyone asked for).

Every end of a job but completion — a fault, a protocol error (a short answer,
a queue index that goes back or beyond the last one queued), a cancel, an
exception, Ctrl-C, SIGTERM (a notebook server closing a kernel interrupts it,
then sends SIGTERM) — runs :meth:`Dobot.safe_stop` before the port closes:
force-stop the queue, laser off, PWM 0 %, clear the queue, each sent whatever
became of the one before, and a :class:`StopReport` says which were sent and
which the arm confirmed. When the link itself is gone it says "the controller
was not told to stop" and what that leaves.
"""

from __future__ import annotations

import bisect
import signal
import struct
import time
from dataclasses import dataclass

import numpy as np

from labkit.errors import MachineError

__all__ = ["frame", "checksum", "FrameReader", "Frame", "canvas_to_robot", "check_reach",
           "check_drawable", "job_commands", "Dobot", "DobotJob", "DobotEmulator", "StopReport", "StopStep",
           "CMD", "ORIGIN_MM", "REACH_MM", "STOP_TIMEOUT_S"]

HEADER = b"\xAA\xAA"

#: Command ids (Communication Protocol V1.1.5).
CMD = {"get_pose": 10, "home": 31, "laser": 61, "ptp": 84, "arc": 101, "wait": 110,
       "io_pwm": 132, "queue_start": 240, "queue_stop": 241, "queue_force_stop": 242,
       "queue_clear": 245, "queue_index": 246, "queue_free": 247}

#: PTP modes (SetPTPCmd).
PTP_JUMP, PTP_MOVJ, PTP_MOVL = 0, 1, 2

#: [DobotLaser]'s canvas origin on the arm's table, mm.
ORIGIN_MM = (300.0, 100.0)
#: The arm's reach around its base in the drawing plane, mm.
REACH_MM = (170.0, 320.0)
#: I/O address of the laser's PWM on [DobotLaser]'s set-up (the arm's EIO port 4).
LASER_PWM_ADDRESS = 4
LASER_PWM_HZ = 10_000.0


def checksum(payload: bytes) -> int:
    """(−Σ id, ctrl, params) mod 256.

    >>> hex(checksum(bytes([0x0A, 0x00])))    # GetPose
    '0xf6'
    """
    return (-sum(payload)) % 256


def frame(cmd_id: int, params: bytes = b"", *, write: bool = False, queued: bool = False) -> bytes:
    """One frame.

    >>> frame(10).hex(" ")
    'aa aa 02 0a 00 f6'
    >>> frame(240, write=True).hex(" ")
    'aa aa 02 f0 01 0f'
    """
    if len(params) > 253:
        raise MachineError(f"Dobot frame parameters too long ({len(params)} bytes, at most 253)")
    ctrl = (1 if write else 0) | (2 if queued else 0)
    payload = bytes([cmd_id, ctrl]) + params
    return HEADER + bytes([len(payload)]) + payload + bytes([checksum(payload)])


@dataclass(frozen=True)
class Frame:
    cmd_id: int
    ctrl: int
    params: bytes

    @property
    def write(self) -> bool:
        return bool(self.ctrl & 1)

    @property
    def queued(self) -> bool:
        return bool(self.ctrl & 2)


class FrameReader:
    """Bytes in, whole frames out; garbage and bad frames are skipped (and counted).

    >>> r = FrameReader()
    >>> r.feed(b"\\x00garbage" + frame(10) + b"\\xAA")
    [Frame(cmd_id=10, ctrl=0, params=b'')]
    >>> r.skipped_bytes
    8
    """

    def __init__(self):
        self.buf = bytearray()
        self.skipped_bytes = 0
        self.bad_checksums = 0

    def feed(self, data: bytes) -> list[Frame]:
        self.buf += data
        out = []
        while True:
            start = self.buf.find(HEADER)
            if start < 0:
                keep = 1 if self.buf.endswith(b"\xAA") else 0
                self.skipped_bytes += len(self.buf) - keep
                del self.buf[:len(self.buf) - keep]
                return out
            if start:
                self.skipped_bytes += start
                del self.buf[:start]
            if len(self.buf) < 3:
                return out
            n = self.buf[2]
            if n < 2:                                  # impossible length: not a header
                self.skipped_bytes += 1
                del self.buf[:1]
                continue
            if len(self.buf) < 3 + n + 1:
                return out
            payload = bytes(self.buf[3:3 + n])
            if checksum(payload) != self.buf[3 + n]:
                self.bad_checksums += 1
                self.skipped_bytes += 1
                del self.buf[:1]                       # resynchronise on the next header
                continue
            del self.buf[:3 + n + 1]
            out.append(Frame(payload[0], payload[1], payload[2:]))


# -- geometry -----------------------------------------------------------------------------------

def canvas_to_robot(x, y, origin=ORIGIN_MM):
    """[DobotLaser]'s transform: X = −y′ + x0, Y = −x′ + y0 (mm).

    >>> canvas_to_robot(0, 0)
    (300.0, 100.0)
    >>> canvas_to_robot(10, 20)
    (280.0, 90.0)
    """
    x0, y0 = origin
    if np.ndim(x) == 0:
        return (float(-y + x0), float(-x + y0))
    return (-np.asarray(y, float) + x0, -np.asarray(x, float) + y0)


def _where(moves, i: int) -> str:
    return f"{moves.source or '<string>'}:{int(moves.line[i])}"


def _segment_min_dist(a, b) -> float:
    d = b - a
    L2 = float(d @ d)
    t = 0.0 if L2 == 0 else max(0.0, min(1.0, float(-(a @ d)) / L2))
    return float(np.linalg.norm(a + t * d))


def check_reach(moves, origin=ORIGIN_MM, reach=REACH_MM, *, tol_mm: float = 0.05) -> None:
    """Refuse a job any point of which the arm cannot reach (before anything moves).

    Every line's nearest and farthest point from the base and every arc
    (sampled at ``tol_mm``) must lie within the annulus ``reach``.

    Raises
    ------
    MachineError
        Naming the source line, the point and its distance from the base.
    InputError
        When ``moves`` is not a :class:`~labkit.toolpath.Moves` or holds a
        position that is not finite.
    """
    from labkit.gcode.arcs import arc_polyline
    from labkit.toolpath.moves import check_moves

    check_moves(moves)
    lo, hi = reach
    for i in range(len(moves)):
        if moves.kind[i] == 4:
            continue
        if moves.is_arc[i]:
            pts = arc_polyline(moves.start[i], moves.end[i], moves.centre[i], moves.kind[i] == 2,
                               plane=int(moves.plane[i]), tol_mm=tol_mm)[:, :2]
        else:
            pts = np.array([moves.start[i, :2], moves.end[i, :2]])
        X, Y = canvas_to_robot(pts[:, 0], pts[:, 1], origin)
        P = np.column_stack([X, Y])
        far = float(np.hypot(X, Y).max())
        near = min(_segment_min_dist(P[k], P[k + 1]) for k in range(len(P) - 1))
        if near < lo - 1e-9 or far > hi + 1e-9:
            bad = near if near < lo else far
            raise MachineError(f"{_where(moves, i)}: the arm cannot reach this move: it passes "
                               f"{bad:.1f} mm from the base; the reach is {lo:g}–{hi:g} mm (move "
                               f"the canvas origin or scale the drawing)")


# -- commands -----------------------------------------------------------------------------------

def ptp_params(mode: int, x, y, z, r=0.0) -> bytes:
    return struct.pack("<B4f", mode, x, y, z, r)


def arc_params(via, end, z, r=0.0) -> bytes:
    return struct.pack("<8f", via[0], via[1], z, r, end[0], end[1], z, r)


def laser_params(on: bool) -> bytes:
    return struct.pack("<BB", 1, 1 if on else 0)


def pwm_params(duty_percent: float, address: int = LASER_PWM_ADDRESS,
               freq_hz: float = LASER_PWM_HZ) -> bytes:
    return struct.pack("<Bff", address, freq_hz, duty_percent)


def check_drawable(moves, *, s_max: float | None = None) -> float:
    """Refuse what the arm would not draw as written, before anything moves.

    The Dobot path draws in one plane (the arm's Z stays where the laser is
    focused), so a move that changes Z and an arc in the XZ (G18) or YZ (G19)
    plane are refused rather than flattened; a burning move whose S is above
    full power is refused rather than sent as a PWM duty above 100 %.

    Parameters
    ----------
    moves : Moves
        The job.
    s_max : float, optional
        The S value that means full laser power (100 % PWM duty); default
        ``moves.s_max`` (the dialect's: GRBL's ``$30`` default 1000, 255 for
        labkit-fw and [DobotLaser]'s programs).

    Returns
    -------
    float
        The ``s_max`` in use.

    Raises
    ------
    MachineError
        Naming the source line, what it asks for and what the arm can do.
    InputError
        When ``moves`` is not a :class:`~labkit.toolpath.Moves` or holds a
        value that is not finite.

    Examples
    --------
    >>> from labkit.gcode import parse
    >>> check_drawable(parse("M3 S500\\nG1 X10 F600\\n"))
    1000.0
    >>> check_drawable(parse("G0 X10\\nG0 Z5\\n"))
    Traceback (most recent call last):
    ...
    labkit.errors.MachineError: <string>:2: the Dobot draws in one plane ...
    """
    from labkit.toolpath.moves import check_moves
    from labkit.units import s_within

    check_moves(moves)
    s_max = float(moves.s_max if s_max is None else s_max)
    if not (np.isfinite(s_max) and s_max > 0):
        raise MachineError(f"s_max must be a finite number > 0 (the S of full laser power), "
                           f"got {s_max!r}")
    on = moves.laser_on
    for i in range(len(moves)):
        if moves.kind[i] == 4:
            continue
        if moves.is_arc[i] and int(moves.plane[i]) != 17:
            name = {18: "XZ (G18)", 19: "YZ (G19)"}.get(int(moves.plane[i]), "?")
            raise MachineError(f"{_where(moves, i)}: an arc in the {name} plane leaves the "
                               f"drawing plane; the Dobot draws arcs in XY only (G17): select "
                               f"G17 or write the arc as XY moves")
        z0, z1 = float(moves.start[i, 2]), float(moves.end[i, 2])
        if abs(z1 - z0) > 1e-9:
            raise MachineError(f"{_where(moves, i)}: the Dobot draws in one plane (the arm's Z "
                               f"stays where the laser is focused); this move goes from Z{z0:g} "
                               f"to Z{z1:g} mm: remove the Z words from the program")
        s = float(moves.s_word[i])
        if on[i] and not s_within(s, s_max):
            raise MachineError(f"{_where(moves, i)}: S{s:g} is above full laser power "
                               f"S{s_max:g}: it would be sent as a PWM duty of "
                               f"{s * 100 / s_max:.0f} %; lower S, or give the S of full power "
                               f"the program was written for (--s-max)")
    return s_max


def job_commands(moves, *, origin=ORIGIN_MM, z_mm: float = 0.0, s_max: float | None = None,
                 from_line: int | None = None) -> list[tuple[int, bytes, int]]:
    """The queued commands that draw ``moves``: (command id, params, source line).

    Before anything is made, :func:`check_drawable` (one plane, S within full
    power) and :func:`check_reach`. The laser is switched off before every
    rapid and on (with its PWM duty, S × 100 / ``s_max`` %) before a burning
    move whose power changed; the job ends with the laser off. Every command
    depends only on its own move, so a job resumes at any line: with the
    laser off, a joint move (MOVJ: the arm is wherever it stopped) takes it to
    where that line starts.

    Parameters
    ----------
    moves : Moves
        The job, in canvas millimetres.
    origin : (float, float)
        The canvas origin on the arm's table, mm.
    z_mm : float
        The drawing plane's Z in the arm's frame, mm.
    s_max : float, optional
        The S of full laser power (default ``moves.s_max``).
    from_line : int, optional
        Resume: draw only the moves of this source line and after.

    Raises
    ------
    MachineError
        What the arm cannot draw or reach, naming the line; no move at or
        after ``from_line``.
    """
    from labkit.geometry.circle import mid_arc_point

    s_max = check_drawable(moves, s_max=s_max)
    check_reach(moves, origin)
    out = []
    beam = None
    duty = None
    on = moves.laser_on
    resumed = from_line is None
    for i in range(len(moves)):
        k = int(moves.kind[i])
        ln = int(moves.line[i])
        if k == 4 or (not resumed and ln < from_line):
            continue
        if not resumed:
            resumed = True
            sx, sy = canvas_to_robot(moves.start[i, 0], moves.start[i, 1], origin)
            out += [(CMD["laser"], laser_params(False), ln),
                    (CMD["ptp"], ptp_params(PTP_MOVJ, sx, sy, z_mm), ln)]
            beam = False
        want_duty = float(moves.s_word[i]) * 100.0 / s_max if on[i] else 0.0
        if not on[i] and beam is not False:
            out.append((CMD["laser"], laser_params(False), ln))
            beam = False
        if on[i]:
            if duty != want_duty:
                out.append((CMD["io_pwm"], pwm_params(want_duty), ln))
                duty = want_duty
            if beam is not True:
                out.append((CMD["laser"], laser_params(True), ln))
                beam = True
        ex, ey = canvas_to_robot(moves.end[i, 0], moves.end[i, 1], origin)
        if moves.is_arc[i]:
            s2, e2, c2 = moves.start[i, :2], moves.end[i, :2], moves.centre[i, :2]
            cw = k == 2
            if np.allclose(s2, e2):                  # a full circle: two half arcs
                opposite = 2 * c2 - s2
                halves = [(s2, opposite), (opposite, e2)]
            else:
                halves = [(s2, e2)]
            for a, b in halves:
                via = mid_arc_point(a, b, c2, cw)
                vx, vy = canvas_to_robot(via[0], via[1], origin)
                bx, by = canvas_to_robot(b[0], b[1], origin)
                out.append((CMD["arc"], arc_params((vx, vy), (bx, by), z_mm), ln))
        else:
            out.append((CMD["ptp"], ptp_params(PTP_MOVL, ex, ey, z_mm), ln))
    if not resumed:
        last = int(moves.line[moves.is_motion].max()) if moves.is_motion.any() else 0
        raise MachineError(f"{moves.source or '<string>'}: nothing to draw from line "
                           f"{from_line}: the last move is on line {last}")
    if beam is not False:
        out.append((CMD["laser"], laser_params(False), 0))
    return out


#: How long each step of the safe stop waits for the Dobot's answer, s. Short enough that all
#: four fit before a notebook server, having interrupted a kernel, sends it SIGTERM (2.5 s).
STOP_TIMEOUT_S = 0.5

#: The safe stop, in order: the queue first (a queued laser-on cannot follow), then the beam.
_STOP_STEPS = (("force-stop", CMD["queue_force_stop"], b""),
               ("laser off", CMD["laser"], laser_params(False)),
               ("PWM 0 %", CMD["io_pwm"], pwm_params(0.0)),
               ("queue clear", CMD["queue_clear"], b""))


class _LinkGone(MachineError):
    """The port itself failed (unplugged cable, closed device): nothing more can be sent."""


@dataclass
class StopStep:
    """One command of the safe stop and what became of it."""

    what: str
    sent: bool
    confirmed: bool
    problem: str = ""        #: why it was not sent, or not confirmed

    def state(self, timeout_s: float) -> str:
        if self.confirmed:
            return "confirmed"
        if self.sent:
            return f"sent, {self.problem or f'no answer within {timeout_s:g} s'}"
        return f"not sent ({self.problem})"


@dataclass
class StopReport:
    """What the safe stop sent and what the Dobot confirmed (:meth:`Dobot.safe_stop`)."""

    steps: list[StopStep]
    timeout_s: float
    queued_line: int | None = None       #: source line of the last command queued
    executed_line: int | None = None     #: source line of the last command reported executed
    resume_line: int | None = None       #: first source line not reported done (None: none left)

    def step(self, what: str) -> StopStep:
        return next(s for s in self.steps if s.what == what)

    @property
    def told_to_stop(self) -> bool:
        """At least one stop command reached the port."""
        return any(s.sent for s in self.steps)

    @property
    def laser_off_confirmed(self) -> bool:
        """The Dobot answered the (immediate) laser-off command."""
        return self.step("laser off").confirmed

    def summary(self) -> str:
        """One paragraph that claims nothing that did not happen."""
        lines = []
        if self.queued_line is not None:
            ran = ("none reported executed" if self.executed_line is None
                   else f"last reported executed: source line {self.executed_line}")
            lines.append(f"last queued: source line {self.queued_line}, {ran}")
        if not self.told_to_stop:
            why = self.steps[0].problem if self.steps else "no stop was attempted"
            return "; ".join([f"the controller was not told to stop: {why}; its own behaviour "
                              f"is all that applies: the Dobot goes on executing the commands "
                              f"already in its queue and leaves the laser as they leave it — "
                              f"switch the arm off at its power switch"] + lines)
        states = ", ".join(f"{s.what} {s.state(self.timeout_s)}" for s in self.steps)
        laser = self.step("laser off")
        if laser.confirmed:
            verdict = "the Dobot acknowledged the laser-off command"
        elif laser.sent:
            verdict = ("the laser-off command was sent but not acknowledged: check the beam and "
                       "switch the arm off if it is still on")
        else:
            verdict = "the laser-off command was NOT sent: switch the arm off at its power switch"
        return "; ".join([f"safe stop: {states} — {verdict}"] + lines)


def _raise_for(name: str) -> None:
    """The first SIGINT or SIGTERM of a job leaves whatever it interrupts, so the safe stop runs:
    KeyboardInterrupt, and SystemExit(143) for SIGTERM (which otherwise ends Python at once)."""
    if name == "SIGINT":
        raise KeyboardInterrupt
    raise SystemExit(128 + signal.SIGTERM)


class Dobot:
    """A Dobot Magician on a pyserial-like port.

    Parameters
    ----------
    port : serial-like
        An open object with ``write(bytes)``, ``read(n)`` and ``in_waiting``
        (pyserial's ``Serial``, or :class:`DobotEmulator`).
    timeout_s : float
        How long a request waits for its answer, s.
    """

    def __init__(self, port, *, timeout_s: float = 2.0):
        self.port = port
        self.timeout_s = timeout_s
        self.reader = FrameReader()
        self.sent_frames = 0
        self.last_stop: StopReport | None = None

    def _send(self, data: bytes) -> None:
        try:
            self.port.write(data)
        except (OSError, ValueError) as exc:     # pyserial's SerialException is an OSError
            raise _LinkGone(f"the link to the Dobot is gone: {exc}") from exc
        self.sent_frames += 1

    def _answer(self, cmd_id: int, timeout_s: float) -> Frame:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            try:
                data = self.port.read(max(1, getattr(self.port, "in_waiting", 0) or 1))
            except (OSError, ValueError, TypeError) as exc:
                raise _LinkGone(f"the link to the Dobot is gone: {exc}") from exc
            for f in self.reader.feed(data):
                if f.cmd_id == cmd_id:
                    return f
        raise MachineError(f"no answer from the Dobot to command {cmd_id} within "
                           f"{timeout_s:g} s (cable, power, 115200 baud?)")

    def request(self, cmd_id: int, params: bytes = b"", *, write=False, queued=False,
                timeout_s: float | None = None) -> Frame:
        """Send a frame and wait for the reply with the same id (other frames are dropped)."""
        self._send(frame(cmd_id, params, write=write, queued=queued))
        return self._answer(cmd_id, self.timeout_s if timeout_s is None else timeout_s)

    def _reply(self, cmd_id: int, params: bytes = b"", size: int = 0, what: str = "",
               **kw) -> bytes:
        """A request whose answer must carry ``size`` parameter bytes (a protocol error if not)."""
        f = self.request(cmd_id, params, **kw)
        if len(f.params) != size:
            raise MachineError(f"protocol error: the Dobot answered command {cmd_id} with "
                               f"{len(f.params)} parameter bytes, expected {size} ({what})")
        return f.params

    def queued(self, cmd_id: int, params: bytes) -> int:
        """Send a queued write; returns its queue index (uint64)."""
        got = self._reply(cmd_id, params, 8, "its uint64 queue index", write=True, queued=True)
        return struct.unpack("<Q", got)[0]

    def current_index(self) -> int:
        """The queue index of the last command the arm executed (uint64)."""
        got = self._reply(CMD["queue_index"], b"", 8, "the uint64 index of the executed command")
        return struct.unpack("<Q", got)[0]

    def pose(self) -> tuple:
        """X, Y, Z, R (mm, degrees) and the four joint angles (degrees)."""
        return struct.unpack("<8f", self._reply(CMD["get_pose"], b"", 32, "eight float32"))

    def queue(self, what: str) -> None:
        """``start``, ``stop``, ``force_stop`` or ``clear`` the command queue."""
        self.request(CMD[f"queue_{what}"], write=True)

    def safe_stop(self, timeout_s: float = STOP_TIMEOUT_S) -> StopReport:
        """Stop the arm and the beam now: force-stop the queue, laser off, PWM 0 %, clear.

        Every step is tried whatever became of the one before (a force-stop
        without an answer does not skip the laser-off frame), each waiting at
        most ``timeout_s`` for its answer.

        Returns
        -------
        StopReport
            Which commands were sent and which the Dobot confirmed.
        """
        steps = []
        for what, cmd_id, params in _STOP_STEPS:
            try:
                self._send(frame(cmd_id, params, write=True))
            except _LinkGone as exc:
                steps.append(StopStep(what, False, False, str(exc)))
                continue
            try:
                self._answer(cmd_id, timeout_s)
                steps.append(StopStep(what, True, True))
            except _LinkGone as exc:
                steps.append(StopStep(what, True, False, f"then {exc}"))
            except MachineError:
                steps.append(StopStep(what, True, False))
        return StopReport(steps, timeout_s)

    def _executed(self, indices: list[int], done: int) -> int:
        """The executed queue index, checked against what this job queued."""
        now = self.current_index()
        if now > indices[-1]:
            raise MachineError(f"protocol error: the Dobot reports queue index {now} executed, "
                               f"but the last command queued has index {indices[-1]}: its "
                               f"answers cannot be trusted")
        if now < done:
            raise MachineError(f"protocol error: the Dobot's executed queue index went back "
                               f"from {done} to {now} (did it restart?)")
        return now

    def run(self, commands, *, ahead: int = 20, progress=None, cancel=None,
            timeout_s: float = 600.0, stall_s: float = 20.0,
            stop_timeout_s: float = STOP_TIMEOUT_S) -> int:
        """Queue the commands, at most ``ahead`` beyond the executed one; returns the last index.

        Any end but completion — a fault, a protocol error, a queue that
        stalls, ``cancel()`` returning true, an exception from ``progress``, Ctrl-C or SIGTERM
        (handled while the job runs, from the main thread) — runs
        :meth:`safe_stop` before the exception goes on; its report is kept in
        :attr:`last_stop` and added as a note to the exception.

        Parameters
        ----------
        commands : list of (int, bytes, int)
            :func:`job_commands`'s output.
        ahead : int
            How many commands may wait in the arm's queue.
        progress : callable, optional
            ``progress(source_line, n_queued, n_total)`` after each command.
        cancel : callable, optional
            Polled while waiting; true stops the job.
        timeout_s : float
            The whole job's time limit, s.
        stall_s : float
            How long the arm may execute nothing while commands wait, s: an
            alarm (a limit, a collision) stops its queue and may leave the
            beam on one spot.
        stop_timeout_s : float
            How long each step of the safe stop waits for its answer, s.
        """
        self.last_stop = None
        commands = list(commands)
        indices: list[int] = []
        lines: list[int] = []
        done = -1
        from labkit.machine.stream import StopSignals

        steps = ", ".join(what for what, _, _ in _STOP_STEPS)
        signals = StopSignals(_raise_for, stop_steps=f"{steps}; at most about "
                                                    f"{len(_STOP_STEPS) * stop_timeout_s:g} s")
        with signals:
            try:
                self.queue("stop")
                self.queue("clear")
                self.queue("start")
                deadline = time.monotonic() + timeout_s
                moved = time.monotonic()

                def wait(until) -> None:
                    nonlocal done, moved
                    while until():
                        before, done = done, self._executed(indices, done)
                        now = time.monotonic()
                        if done != before:
                            moved = now
                        else:
                            time.sleep(0.002)           # poll a busy arm at most ~500 times/s
                        if now - moved > stall_s:
                            raise MachineError(f"the Dobot executed nothing for {stall_s:g} s "
                                               f"(its queue is at index {done}): an alarm (a "
                                               f"limit, a collision) stops its queue; check "
                                               f"the arm")
                        if now > deadline:
                            raise MachineError(f"the Dobot job took longer than {timeout_s:g} s "
                                               f"(its queue is at index {done})")
                        if cancel is not None and cancel():
                            raise MachineError("cancelled by the user")

                for n, (cmd_id, params, line) in enumerate(commands):
                    wait(lambda: indices and indices[-1] - done >= ahead)
                    index = self.queued(cmd_id, params)
                    if indices and index <= indices[-1]:
                        raise MachineError(f"protocol error: the Dobot gave queue index {index} "
                                           f"after {indices[-1]}: indices must increase")
                    indices.append(index)
                    lines.append(line)
                    if progress is not None:
                        progress(line, n + 1, len(commands))
                wait(lambda: indices and done < indices[-1])
                return indices[-1] if indices else 0
            except BaseException as exc:
                signals.stopping()
                report = self.safe_stop(stop_timeout_s)
                # the closing laser-off has no source line (0): name the last line that has one
                named = [ln for ln in lines if ln > 0]
                if named:
                    report.queued_line = named[-1]
                    k = bisect.bisect_right(indices, done)       # commands reported executed
                    ran = [ln for ln in lines[:k] if ln > 0]
                    report.executed_line = ran[-1] if ran else None
                    todo = [ln for _, _, ln in commands[k:] if ln > 0]
                    report.resume_line = todo[0] if todo else None
                self.last_stop = report
                exc.add_note(report.summary())
                raise


class DobotEmulator:
    """A pyserial-like Dobot: decodes every frame, checks checksum and length, answers queue
    indices, executes its queue when started (``per_poll`` commands per read)."""

    def __init__(self, *, per_poll: int = 4):
        self.reader = FrameReader()
        self.out = bytearray()
        self.queue: list[tuple[int, Frame]] = []
        self.executed: list[Frame] = []
        self.next_index = 0
        self.done_index = -1
        self.running = False
        self.per_poll = per_poll
        self.pose = [200.0, 0.0, 0.0, 0.0]
        self.laser_on = False
        self.pwm_duty = 0.0
        self.laser_on_while_stopped = 0
        self.frames = 0
        self.received: list[Frame] = []        #: every frame, in order of arrival
        self.timeout = 0.05

    @property
    def in_waiting(self) -> int:
        self._step()
        return len(self.out)

    def _answer(self, f: Frame, params: bytes = b"") -> None:
        self.out += frame(f.cmd_id, params, write=f.write, queued=f.queued)

    def write(self, data: bytes) -> int:
        for f in self.reader.feed(bytes(data)):
            self.frames += 1
            self.received.append(f)
            if f.queued:
                self.queue.append((self.next_index, f))
                self._answer(f, struct.pack("<Q", self.next_index))
                self.next_index += 1
            elif f.cmd_id == CMD["queue_start"]:
                self.running = True
                self._answer(f)
            elif f.cmd_id in (CMD["queue_stop"], CMD["queue_force_stop"]):
                self.running = False
                if f.cmd_id == CMD["queue_force_stop"]:
                    self.queue.clear()
                self._answer(f)
            elif f.cmd_id == CMD["queue_clear"]:
                self.queue.clear()
                self._answer(f)
            elif f.cmd_id == CMD["queue_index"]:
                self._answer(f, struct.pack("<Q", max(self.done_index, 0)
                                            if self.done_index >= 0 else 0))
            elif f.cmd_id == CMD["get_pose"]:
                self._answer(f, struct.pack("<8f", *self.pose, 0, 0, 0, 0))
            elif f.cmd_id == CMD["laser"]:
                self.laser_on = bool(f.params[1])
                self._answer(f)
            elif f.cmd_id == CMD["io_pwm"]:
                self.pwm_duty = struct.unpack("<Bff", f.params)[2]
                self._answer(f)
            else:
                self._answer(f)
        return len(data)

    def _step(self) -> None:
        if not self.running:
            return
        for _ in range(self.per_poll):
            if not self.queue:
                if self.laser_on:                  # the arm stands still with the beam on
                    self.laser_on_while_stopped += 1
                return
            idx, f = self.queue.pop(0)
            self.executed.append(f)
            self.done_index = idx
            if f.cmd_id == CMD["laser"]:
                self.laser_on = bool(f.params[1])
            elif f.cmd_id == CMD["io_pwm"]:
                self.pwm_duty = struct.unpack("<Bff", f.params)[2]
            elif f.cmd_id == CMD["ptp"]:
                self.pose[:2] = struct.unpack("<B4f", f.params)[1:3]
            elif f.cmd_id == CMD["arc"]:
                self.pose[:2] = struct.unpack("<8f", f.params)[4:6]

    def read(self, size: int = 1) -> bytes:
        self._step()
        data = bytes(self.out[:size])
        del self.out[:size]
        return data

    def flush(self):
        pass

    def close(self):
        pass


class DobotJob:
    """A G-code job for the arm, checked and turned into queued commands, then run on a port.

    Constructing it refuses, before anything is sent, what the arm cannot draw
    as written (:func:`job_commands`). :meth:`run` opens the port (the emulator
    for the virtual machine's port names), runs the commands with
    :meth:`Dobot.run` and closes the port on every end; what it did stays on the
    object for the caller to read.

    Parameters
    ----------
    moves : Moves
        The job, canvas millimetres.
    s_max : float, optional
        The S of full laser power (default ``moves.s_max``).
    from_line : int, optional
        Resume: draw only the moves of this source line and after.
    origin : (float, float)
        The canvas origin on the arm's table, mm.
    z_mm : float
        The drawing plane's Z in the arm's frame, mm.

    Attributes
    ----------
    commands : list of (int, bytes, int)
        The queued commands (:func:`job_commands`).
    last_index : int or None
        The arm's last queue index when the job completed.
    last_stop : StopReport or None
        What the safe stop sent and the arm confirmed, when the job ended early.
    elapsed_s : float or None
        Wall time of the last :meth:`run`, s.

    Examples
    --------
    >>> from labkit.gcode import parse
    >>> job = DobotJob(parse("M3 S500\\nG1 X10 F600\\nM5\\n"))
    >>> job.feed_range_mm_min()
    (600.0, 600.0)
    >>> job.run(None) == job.last_index, job.last_stop
    (True, None)
    """

    def __init__(self, moves, *, s_max: float | None = None, from_line: int | None = None,
                 origin=ORIGIN_MM, z_mm: float = 0.0):
        self.moves = moves
        self.from_line = from_line
        self.origin, self.z_mm = tuple(float(v) for v in origin), float(z_mm)
        self.commands = job_commands(moves, origin=origin, z_mm=z_mm, s_max=s_max, from_line=from_line)
        self.last_index: int | None = None
        self.last_stop: StopReport | None = None
        self.elapsed_s: float | None = None

    def machine_description(self) -> dict:
        """The arm as a record names it (it has no machine description file: no planner runs)."""
        return dict(name="dobot-magician", description="Dobot Magician arm with its laser, driven by "
                    "queued commands over its serial protocol ([DobotLaser])", origin_mm=list(self.origin),
                    z_mm=self.z_mm, reach_mm=list(REACH_MM), laser_pwm_address=LASER_PWM_ADDRESS,
                    laser_pwm_hz=LASER_PWM_HZ)

    def outcome(self, *, started: str, ended: str, fault: str | None = None, warnings=(),
                summary: str = "") -> dict:
        """The last :meth:`run` in the terms of a stream record (:mod:`labkit.record`'s ``stream``).

        Lines count the source lines that make commands (not the closing laser-off labkit adds);
        one is acknowledged when the arm reported its last command executed. ``planned_s`` is None:
        the arm moves at the speeds set on it.
        """
        lines = sorted({line for _, _, line in self.commands if line > 0})
        stop = self.last_stop
        if fault is None:
            done = len(lines)
        else:
            executed = stop.executed_line if stop is not None else None
            done = 0 if executed is None else sum(1 for line in lines if line <= executed)
        safe = ([[step.what, step.state(stop.timeout_s)] for step in stop.steps] if stop is not None else [])
        return dict(started=started, ended=ended, ok=fault is None, lines_total=len(lines), lines_acknowledged=done,
                    elapsed_s=float(self.elapsed_s or 0.0), planned_s=None, fault=fault, errors=[],
                    resume_line=stop.resume_line if stop is not None and fault is not None else None,
                    resumed_from=self.from_line, safe_stop=safe, warnings=list(warnings), summary=summary)

    def feed_range_mm_min(self) -> tuple[float, float] | None:
        """The job's lowest and highest feed, mm/min (None without feed moves): the arm does
        not receive F, it draws at the speeds set on it."""
        m = self.moves
        feeds = m.feed_mm_min[m.is_feed & np.isfinite(m.feed_mm_min)]
        return (float(feeds.min()), float(feeds.max())) if feeds.size else None

    def run(self, port: str | None, baud: int | None = None, **run_options) -> int:
        """Draw the job on ``port``; returns the last queue index executed.

        Parameters
        ----------
        port : str or None
            Serial device or URL; None or ``virtual://`` runs the emulator
            (:func:`labkit.machine.link.is_virtual_port`).
        baud : int, optional
            Baud rate (default :data:`labkit.machine.link.DEFAULT_BAUD`).
        **run_options
            :meth:`Dobot.run`'s ``ahead``, ``progress``, ``cancel``, ``timeout_s``,
            ``stall_s``, ``stop_timeout_s``.

        Raises
        ------
        MachineError, KeyboardInterrupt, SystemExit
            After the safe stop (:attr:`last_stop` holds its report).
        """
        from labkit.machine.link import DEFAULT_BAUD, is_virtual_port, open_link

        self.last_index = self.last_stop = None
        link = None
        if is_virtual_port(port):
            dev = DobotEmulator()
        else:
            link = open_link(port, baud or DEFAULT_BAUD)
            dev = link.port
        bot = Dobot(dev)
        t0 = time.monotonic()
        try:
            self.last_index = bot.run(self.commands, **run_options)
            return self.last_index
        finally:
            self.last_stop = bot.last_stop
            self.elapsed_s = time.monotonic() - t0
            if link is not None:
                link.close()
