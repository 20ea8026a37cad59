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
"""

from __future__ import annotations

import struct
import time
from dataclasses import dataclass

import numpy as np

from labkit.errors import MachineError

__all__ = ["frame", "checksum", "FrameReader", "Frame", "canvas_to_robot", "check_reach",
           "job_commands", "Dobot", "DobotEmulator", "CMD", "ORIGIN_MM", "REACH_MM"]

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
    """
    from labkit.gcode.arcs import arc_polyline

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
            where = f"{moves.source or '<string>'}:{int(moves.line[i])}"
            bad = near if near < lo else far
            raise MachineError(f"{where}: the arm cannot reach this move: it passes {bad:.1f} mm "
                               f"from the base; the reach is {lo:g}–{hi:g} mm (move the canvas "
                               f"origin or scale the drawing)")


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


def job_commands(moves, *, origin=ORIGIN_MM, z_mm: float = 0.0) -> list[tuple[int, bytes, int]]:
    """The queued commands that draw ``moves``: (command id, params, source line).

    Reach is checked first (:func:`check_reach`). The laser is switched off
    before every rapid and on (with its PWM duty) before a burning move whose
    power changed; the job ends with the laser off.
    """
    from labkit.geometry.circle import mid_arc_point

    check_reach(moves, origin)
    out = []
    beam = None
    duty = None
    s_max = float(moves.s_max) or 255.0
    on = moves.laser_on
    for i in range(len(moves)):
        k = int(moves.kind[i])
        ln = int(moves.line[i])
        if k == 4:
            continue
        want_duty = float(moves.power_s[i]) * 100.0 / s_max if on[i] else 0.0
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
        if moves.is_arc[i] and int(moves.plane[i]) == 17:
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
    if beam is not False:
        out.append((CMD["laser"], laser_params(False), 0))
    return out


class Dobot:
    """A Dobot Magician on a pyserial-like port."""

    def __init__(self, port, *, timeout_s: float = 2.0):
        self.port = port
        self.timeout_s = timeout_s
        self.reader = FrameReader()
        self.pending: list[Frame] = []
        self.sent_frames = 0

    def request(self, cmd_id: int, params: bytes = b"", *, write=False, queued=False) -> Frame:
        """Send a frame and wait for the reply with the same id (other frames are dropped)."""
        self.port.write(frame(cmd_id, params, write=write, queued=queued))
        self.sent_frames += 1
        deadline = time.monotonic() + self.timeout_s
        while time.monotonic() < deadline:
            data = self.port.read(max(1, getattr(self.port, "in_waiting", 0) or 1))
            for f in self.reader.feed(data):
                if f.cmd_id == cmd_id:
                    return f
        raise MachineError(f"no answer from the Dobot to command {cmd_id} within "
                           f"{self.timeout_s:g} s (cable, power, 115200 baud?)")

    def queued(self, cmd_id: int, params: bytes) -> int:
        """Send a queued write; returns its queue index (uint64)."""
        f = self.request(cmd_id, params, write=True, queued=True)
        if len(f.params) != 8:
            raise MachineError(f"queued command {cmd_id} answered {len(f.params)} bytes, "
                               f"expected an 8-byte queue index")
        return struct.unpack("<Q", f.params)[0]

    def current_index(self) -> int:
        f = self.request(CMD["queue_index"])
        return struct.unpack("<Q", f.params[:8])[0]

    def pose(self) -> tuple:
        f = self.request(CMD["get_pose"])
        return struct.unpack("<8f", f.params[:32])

    def queue(self, what: str) -> None:
        """``start``, ``stop``, ``force_stop`` or ``clear`` the command queue."""
        self.request(CMD[f"queue_{what}"], write=True)

    def laser_off_now(self) -> None:
        """Laser off immediately (not queued): force-stop the queue, then switch it off."""
        self.queue("force_stop")
        self.request(CMD["laser"], laser_params(False), write=True)

    def run(self, commands, *, ahead: int = 20, progress=None, cancel=None,
            timeout_s: float = 600.0) -> int:
        """Queue the commands, at most ``ahead`` beyond the executed one; returns the last index.

        Any fault or a cancel stops the queue and switches the laser off.
        """
        self.queue("stop")
        self.queue("clear")
        indices = []
        try:
            self.queue("start")
            done = -1
            deadline = time.monotonic() + timeout_s
            for n, (cmd_id, params, line) in enumerate(commands):
                while indices and indices[-1] - done >= ahead:
                    done = self.current_index()
                    if time.monotonic() > deadline:
                        raise MachineError("the Dobot queue stopped advancing")
                    if cancel is not None and cancel():
                        raise MachineError("cancelled by the user")
                indices.append(self.queued(cmd_id, params))
                if progress is not None:
                    progress(line, n + 1, len(commands))
            last = indices[-1] if indices else 0
            while done < last:
                done = self.current_index()
                if time.monotonic() > deadline:
                    raise MachineError("the Dobot queue stopped advancing")
            return last
        except BaseException:
            try:
                self.laser_off_now()
            except MachineError:
                pass
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
        self.laser_on_while_stopped = 0
        self.frames = 0
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


def stream_file(args, port, baud) -> int:
    """``labkit stream --protocol dobot``: draw a G-code file with the arm (or its emulator)."""
    from labkit.gcode import parse_file

    moves = parse_file(args.file, dialect=args.dialect or "grbl")
    commands = job_commands(moves)            # reach checked before anything moves
    if port is None or port.startswith("virtual://"):
        dev = DobotEmulator()
    else:
        from labkit.machine.link import open_link

        dev = open_link(port, baud).port
    bot = Dobot(dev)
    t0 = time.monotonic()
    try:
        last = bot.run(commands)
    except MachineError as exc:
        print(f"STOPPED: {exc}; the queue was force-stopped and the laser switched off")
        return 1
    print(f"completed: {len(commands)} commands queued and executed (last queue index {last}) "
          f"in {time.monotonic() - t0:.1f} s")
    return 0
