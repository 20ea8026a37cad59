"""A GRBL controller behind a real pseudo-terminal, recording every byte labkit sends it.

labkit opens the pty's device (``/dev/pts/N``) as a serial port, exactly as it opens a USB
adapter. Behind it runs :class:`labkit.machine.virtual.VirtualMachine` (GRBL's behaviour
model) through :class:`labkit.machine.faults.FaultyPort`, which injects the faults (doubled,
unsolicited or missing answers, absurd status reports, a garbled line, a controller that
goes silent or whose cable is pulled). When that port fails, the bridge closes its end of the
pty, as a vanished USB device does. Every byte that arrives from labkit is kept with its
arrival time in :attr:`PtyController.received`, so a test can check which bytes reached the
controller before the port closed.
"""

from __future__ import annotations

import os
import re
import select
import threading
import time
import tty

from labkit.machine.faults import FaultyPort
from labkit.machine.virtual import VirtualMachine


class PtyController:
    """A virtual GRBL on a pty.

    Parameters
    ----------
    vm : VirtualMachine, optional
        The machine (default: ``grbl-diode`` in real time with ``$10=3``, so that status
        reports carry the buffer state, ``$20=0`` and ``$32=1``).
    reset_delay_s : float
        Replies after a soft reset (the banner first) come this much later: a slow controller.
    **faults
        :class:`~labkit.machine.faults.FaultyPort`'s faults (``double_ok``,
        ``oks_after_banner``, ``garble_line``, ``mute_answers_after``,
        ``silent_after_lines``, ``status_rewrite``, ``disconnect_after_oks`` …).
    """

    def __init__(self, vm: VirtualMachine | None = None, *, reset_delay_s: float = 0.0,
                 **faults):
        _warm_up()
        if vm is None:
            vm = VirtualMachine("grbl-diode", time_scale=1.0, tick_s=0.01)
            # GRBL's soft limits off, laser mode on, the buffer state in status reports
            vm.settings.update({10: "3", 20: "0", 32: "1"})
        self.vm = vm
        # a real board's power-on banner goes out before the port is opened, and pyserial
        # flushes what came before; labkit provokes one with a soft reset
        vm.read(vm.in_waiting)
        self.faulty = FaultyPort(vm, **faults)
        self.reset_delay_s = reset_delay_s
        self.received: list[tuple[float, bytes]] = []
        self.closed = False
        self.closed_at: float | None = None      #: when the controller's end closed
        self._held = bytearray()
        self._held_until = 0.0
        self.master, self._slave = os.openpty()
        tty.setraw(self._slave)
        self.port = os.ttyname(self._slave)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="pty-controller", daemon=True)
        self._thread.start()

    @property
    def lines(self) -> int:
        """G-code lines received (``$`` lines not counted)."""
        return self.faulty.lines

    def data(self, since: float = 0.0) -> bytes:
        """Every byte received at or after ``since`` (monotonic clock), in order."""
        return b"".join(chunk for t, chunk in self.received if t >= since)

    def wait_lines(self, n: int, timeout_s: float = 20.0) -> None:
        deadline = time.monotonic() + timeout_s
        while self.lines < n:
            if time.monotonic() > deadline:
                raise AssertionError(f"only {self.lines} of {n} lines arrived")
            time.sleep(0.01)

    def close(self) -> None:
        self._stop.set()
        self._thread.join(2.0)
        for fd in (self.master, self._slave):
            try:
                os.close(fd)
            except OSError:
                pass
        self.vm.close()

    def _run(self) -> None:
        while not self._stop.is_set() and not self.closed:
            ready, _, _ = select.select([self.master], [], [], 0.005)
            try:
                if ready:
                    data = os.read(self.master, 4096)
                    if data:
                        self.received.append((time.monotonic(), data))
                        if b"\x18" in data and self.reset_delay_s:
                            self._held_until = time.monotonic() + self.reset_delay_s
                        self.faulty.write(data)
                waiting = self.faulty.in_waiting
                self._held += self.faulty.read(waiting) if waiting else b""
            except OSError:                      # the controller's port failed: unplugged
                time.sleep(0.05)                 # the host reads what was already sent
                self._hang_up()
                return
            if self._held and time.monotonic() >= self._held_until:
                try:
                    os.write(self.master, bytes(self._held))
                except OSError:
                    pass
                self._held.clear()

    def _hang_up(self) -> None:
        if self._held:
            try:
                os.write(self.master, bytes(self._held))
            except OSError:
                pass
        self.closed = True
        self.closed_at = time.monotonic()
        try:
            os.close(self.master)
        except OSError:
            pass


_warm = threading.Lock()
_warmed = []


def _warm_up() -> None:
    """Plan one line on a throwaway machine, once per process: the planner's compiled kernels
    load (or compile, after a change to their sources: seconds to a minute) here, not while
    labkit waits for the bridge's answers — its watchdog would count that time."""
    with _warm:
        if not _warmed:
            vm = VirtualMachine("grbl-diode", time_scale=0)
            vm.write(b"G1 X1 F600\n")
            vm.read(vm.in_waiting)
            vm.close()
            _warmed.append(True)


def bad_buffer(report: str) -> str:
    """A status report whose Bf field is absurd (a negative planner count, a huge RX count)."""
    return re.sub(r"Bf:\d+,\d+", "Bf:-5,99999", report)


def nan_position(report: str) -> str:
    """A status report whose MPos is not a number."""
    return re.sub(r"MPos:[^|>]*", "MPos:nan,nan,0.000", report)
