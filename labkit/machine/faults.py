"""Fault injection: a GRBL link that drops, garbles or delays bytes, goes silent, resets or vanishes.

:class:`FaultyPort` wraps a :class:`labkit.machine.virtual.VirtualMachine` (a
GRBL behaviour model) and injects one fault at a chosen point of the host →
machine byte stream or the machine → host line stream. The tests of the job
runner and chapter 14 use it to show that every fault ends safely and that a
resume runs every line exactly once.
"""

from __future__ import annotations

import time

from labkit.machine.virtual import VirtualMachine

__all__ = ["FaultyPort"]


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
    """

    def __init__(self, vm: VirtualMachine, *, garble_line=None, drop_newline_of=None,
                 drop_byte_at=None, disconnect_after_lines=None, silent_after_lines=None,
                 reset_after_lines=None, drop_ok=None, delay_s=0.0):
        self.vm = vm
        self.garble_line = garble_line
        self.drop_newline_of = drop_newline_of
        self.drop_byte_at = drop_byte_at
        self.disconnect_after_lines = disconnect_after_lines
        self.silent_after_lines = silent_after_lines
        self.reset_after_lines = reset_after_lines
        self.drop_ok = drop_ok
        self.oks = 0
        self._reply = bytearray()
        self.delay_s = delay_s
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
        return self.vm.in_waiting

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
        if self.drop_ok is not None and data:
            self._reply += data
            out = bytearray()
            while b"\n" in self._reply:
                cut = self._reply.index(b"\n") + 1
                line, self._reply = bytes(self._reply[:cut]), self._reply[cut:]
                if line.strip() == b"ok":
                    self.oks += 1
                    if self.oks == self.drop_ok:
                        continue
                out += line
            data = bytes(out)
        if data and self.delay_s:
            time.sleep(self.delay_s)
        return data

    def flush(self):
        pass

    def close(self):
        self.vm.close()
