"""Fault injection: a GRBL link that drops, garbles or delays bytes, goes silent, resets or vanishes.

:class:`FaultyPort` wraps a :class:`labkit.machine.virtual.VirtualMachine` (a
GRBL behaviour model) and injects one fault at a chosen point of the host →
machine byte stream or the machine → host line stream. The tests of the job
runner and chapter 14 use it to show that every fault ends safely and that a
resume runs every line exactly once.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import KW_ONLY, dataclass

from labkit.machine.virtual import VirtualMachine

__all__ = ["FaultyPort"]


@dataclass(eq=False, repr=False)   # the options are the fields: one list, not an __init__ repeating it
class FaultyPort:
    """A pyserial-like port between the host and a virtual machine, with one injected fault.

    Parameters
    ----------
    vm : VirtualMachine
    garble_line : int, optional
        The k-th G-code line the host sends (1-based, ``$`` and real-time
        bytes not counted) arrives as ``G999`` (the machine answers error:20).
    drop_newline_of : int, optional
        The k-th line's ``\\n`` is lost on the wire (two lines merge).
    drop_byte_at : int, optional
        The k-th byte written (0-based, over the whole session) is lost.
    disconnect_after_lines : int, optional
        After k lines every read and write fails (cable pulled).
    silent_after_lines : int, optional
        After k lines the machine stops answering anything (a stalled device).
    reset_after_lines : int, optional
        After k lines the machine resets by itself (power glitch): it flushes
        everything and prints its banner.
    drop_ok : int, optional
        The k-th ``ok`` the machine sends is lost on the way back (a
        character-counting sender would wait for it forever).
    delay_s : float
        Delay added to every read that returns data.
    double_ok : int, optional
        The k-th ``ok`` after the first G-code line comes twice (an answer
        that is not owed).
    oks_after_banner : int
        This many unsolicited ``ok`` lines follow the first start-up banner.
    oks_at_first_line : int
        This many unsolicited ``ok`` lines come back when the first G-code
        line arrives.
    mute_answers_after : int, optional
        After k lines every ``ok``/``error`` is lost (status reports still come:
        a controller that takes lines without answering).
    status_rewrite : callable, optional
        ``f(report) -> report`` applied to every status report (absurd fields).
    disconnect_after_oks : int, optional
        Once the k-th ``ok`` after the first G-code line has come back, every
        read and write fails (the cable pulled mid-job).
    """

    vm: VirtualMachine
    _: KW_ONLY
    garble_line: int | None = None
    drop_newline_of: int | None = None
    drop_byte_at: int | None = None
    disconnect_after_lines: int | None = None
    silent_after_lines: int | None = None
    reset_after_lines: int | None = None
    drop_ok: int | None = None
    delay_s: float = 0.0
    double_ok: int | None = None
    oks_after_banner: int = 0
    oks_at_first_line: int = 0
    mute_answers_after: int | None = None
    status_rewrite: Callable[[str], str] | None = None
    disconnect_after_oks: int | None = None

    def __post_init__(self):
        self.job_oks = 0                 # oks since the first G-code line
        self._banner_seen = False
        self._filter = any(v is not None and v is not False and v != 0 for v in (
            self.drop_ok, self.double_ok, self.oks_after_banner, self.mute_answers_after,
            self.status_rewrite, self.disconnect_after_oks))
        self.oks = 0
        self._reply = bytearray()
        self.lines = 0
        self.bytes = 0
        self._line = bytearray()
        self.dead = False
        self.silent = False

    @property
    def timeout(self):
        return self.vm.timeout

    @timeout.setter
    def timeout(self, value):
        self.vm.timeout = value

    @property
    def in_waiting(self):
        if self.dead:
            raise OSError("device disconnected")
        if self.silent:
            self.vm.reset_input_buffer()
            return 0
        return self.vm.in_waiting + self._reply.rfind(b"\n") + 1     # whole lines held back

    def write(self, data: bytes) -> int:
        if self.dead:
            raise OSError("device disconnected")
        out = bytearray()
        for b in bytes(data):
            self.bytes += 1
            if self.drop_byte_at is not None and self.bytes - 1 == self.drop_byte_at:
                continue
            if b in (0x3F, 0x21, 0x7E, 0x18, 0x85) or b >= 0x80:
                out.append(b)
                continue
            self._line.append(b)
            if b != 0x0A:
                continue
            line = bytes(self._line)
            self._line.clear()
            if not line.startswith(b"$"):
                self.lines += 1
                if self.lines == 1 and self.oks_at_first_line:
                    self._reply[:0] = b"ok\r\n" * self.oks_at_first_line
                    self._filter = True
                if self.lines == self.garble_line:
                    line = b"G999\n"
                if self.lines == self.drop_newline_of:
                    line = line[:-1]
            out += line
            if self.lines == self.reset_after_lines and not line.startswith(b"$"):
                self.vm.write(bytes(out))
                out.clear()
                self.vm._realtime("reset")     # the machine resets by itself
                self.reset_after_lines = None
            if self.lines == self.disconnect_after_lines:
                self.dead = True
            if self.lines == self.silent_after_lines:
                self.silent = True
        if out:
            self.vm.write(bytes(out))
        return len(data)

    def read(self, size=1):
        if self.dead:
            raise OSError("device disconnected")
        data = self.vm.read(size)
        if self.silent:
            return b""
        if self._filter and (data or self._reply):
            self._reply += data
            data = self._filter_replies()
        if data and self.delay_s:
            time.sleep(self.delay_s)
        return data

    def inject(self, data: bytes) -> None:
        """Bytes the controller sends unasked (say ``b"ok\\r\\n"``), ahead of its own replies."""
        self._reply[:0] = data
        self._filter = True

    def _filter_replies(self) -> bytes:
        """The complete reply lines waiting, with the answer faults applied."""
        out = bytearray()
        while b"\n" in self._reply:
            cut = self._reply.index(b"\n") + 1
            line, self._reply = bytes(self._reply[:cut]), self._reply[cut:]
            text = line.strip()
            if text.startswith(b"<") and self.status_rewrite is not None:
                line = self.status_rewrite(text.decode()).encode() + b"\r\n"
            answer = text == b"ok" or text.startswith(b"error")
            if answer and self.mute_answers_after is not None and self.lines >= self.mute_answers_after:
                continue
            if text == b"ok":
                self.oks += 1
                if self.oks == self.drop_ok:
                    continue
            out += line
            if text.startswith(b"Grbl") and not self._banner_seen:
                self._banner_seen = True
                out += b"ok\r\n" * self.oks_after_banner
            if text == b"ok" and self.lines:
                self.job_oks += 1
                if self.job_oks == self.double_ok:
                    out += line
                if self.job_oks == self.disconnect_after_oks:
                    self.dead = True             # this read still delivers; the next fails
                    break
        return bytes(out)

    def flush(self):
        pass

    def close(self):
        self.vm.close()
