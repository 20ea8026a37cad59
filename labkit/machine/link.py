"""Serial links: one code path to a real board, a simulator, a TCP bridge or a test double.

:func:`open_link` takes a port name (``/dev/ttyUSB0``, ``COM3``) or any
pyserial URL — ``socket://host:port`` (the firmware simulator, QEMU's UART over
TCP, ser2net), ``rfc2217://host:port``, ``loop://`` — and ``virtual://`` for
labkit's simulated GRBL machine (:mod:`labkit.machine.virtual`, the default when
no port is given). Lines are ended by ``\\n`` only: GRBL treats ``\\r`` as a line
end of its own, so ``\\r\\n`` would make it answer every line twice.

:func:`list_ports` names what each USB serial port looks like (CH340, FTDI,
CP210x, STM32 VCP, Arduino) from its VID:PID. Opening a port that is missing,
busy or forbidden raises :class:`~labkit.errors.MachineError` that says how to
fix it on this operating system. :func:`load_config` / :func:`save_config`
remember the last port, baud rate, protocol and machine between runs, as seed
000's application keeps its connection settings in a file.
"""

from __future__ import annotations

import dataclasses
import errno
import json
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from labkit.errors import MachineError

__all__ = ["Link", "PortInfo", "list_ports", "describe_usb", "open_link", "MachineConfig",
           "load_config", "save_config", "config_path", "DEFAULT_BAUD", "is_virtual_port"]

#: GRBL 1.1's and the labkit firmware's baud rate (and the Dobot's).
DEFAULT_BAUD = 115200

#: The port name of the simulated machine (``virtual://`` and anything after it).
VIRTUAL_PORT = "virtual://"


def is_virtual_port(port: str | None) -> bool:
    """Whether ``port`` names the simulated machine (None, the default, or ``virtual://…``)
    rather than a device or URL: the one place that decides it.

    >>> is_virtual_port(None), is_virtual_port("virtual://"), is_virtual_port("/dev/ttyUSB0")
    (True, True, False)
    """
    return port is None or port.startswith(VIRTUAL_PORT)

#: (VID, PID or None for any) → what the chip or board is. Public USB ids.
_USB_IDS: dict[tuple[int, int | None], str] = {
    (0x1A86, 0x7523): "CH340", (0x1A86, 0x5523): "CH341", (0x1A86, 0x55D4): "CH9102",
    (0x0403, 0x6001): "FTDI FT232R", (0x0403, 0x6010): "FTDI FT2232", (0x0403, 0x6011): "FTDI FT4232",
    (0x0403, 0x6014): "FTDI FT232H", (0x0403, 0x6015): "FTDI FT231X", (0x0403, None): "FTDI",
    (0x10C4, 0xEA60): "CP210x", (0x10C4, 0xEA70): "CP2105", (0x10C4, None): "Silicon Labs",
    (0x0483, 0x5740): "STM32 VCP", (0x0483, None): "STMicroelectronics",
    (0x2341, None): "Arduino", (0x2A03, None): "Arduino", (0x1B4F, None): "SparkFun (Arduino)",
    (0x067B, 0x2303): "Prolific PL2303",
}


def describe_usb(vid: int | None, pid: int | None) -> str:
    """What a USB serial device is, from its vendor and product ids.

    >>> describe_usb(0x1A86, 0x7523)
    'CH340'
    >>> describe_usb(0x2341, 0x0043)
    'Arduino'
    >>> describe_usb(0x1234, 0x5678)
    'USB serial'
    >>> describe_usb(None, None)
    ''
    """
    if vid is None:
        return ""
    return _USB_IDS.get((vid, pid)) or _USB_IDS.get((vid, None)) or "USB serial"


@dataclass(frozen=True)
class PortInfo:
    """One serial port as :func:`list_ports` found it."""

    device: str
    kind: str          #: CH340, FTDI …, "" for a port without USB ids
    vid_pid: str       #: "1A86:7523" or ""
    description: str
    serial_number: str = ""

    def label(self) -> str:
        """One line for a port list: device, kind, VID:PID, description."""
        parts = [self.device]
        if self.kind:
            parts.append(self.kind)
        if self.vid_pid:
            parts.append(f"[{self.vid_pid}]")
        if self.description and self.description not in ("n/a", self.device):
            parts.append(f"— {self.description}")
        return " ".join(parts)


def list_ports() -> list[PortInfo]:
    """The serial ports of this computer, USB ones labelled by VID:PID, sorted by device."""
    from serial.tools import list_ports as lp

    out = []
    for p in lp.comports():
        vid_pid = f"{p.vid:04X}:{p.pid:04X}" if p.vid is not None else ""
        out.append(PortInfo(p.device, describe_usb(p.vid, p.pid), vid_pid, p.description or "",
                            p.serial_number or ""))
    return sorted(out, key=lambda q: q.device)


def _open_hint(port: str, exc: Exception) -> str:
    """What to do about a port that would not open, for this operating system."""
    code = getattr(exc, "errno", None)
    text = str(exc)
    if code == errno.ENOENT or "No such file" in text or "FileNotFoundError" in text:
        return (f"serial port {port!r} does not exist; plug the board in, check the cable, "
                f"and run 'labkit ports' to see the ports there are")
    if code in (errno.EBUSY, errno.EAGAIN) or "busy" in text.lower() or "lock" in text.lower():
        return (f"serial port {port!r} is busy: another program (a sender, a serial monitor, "
                f"another notebook) has it open; close it and connect again")
    if code in (errno.EACCES, errno.EPERM) or "Permission" in text or "Access is denied" in text:
        if sys.platform.startswith("win"):
            return (f"serial port {port!r} cannot be opened: on Windows this means {port} is in "
                    f"use by another program; close it (Device Manager shows the COM number)")
        if sys.platform == "darwin":
            return (f"permission denied on {port!r}: on macOS use the /dev/cu.* device, not "
                    f"/dev/tty.*, and allow the terminal access to USB devices")
        return (f"permission denied on {port!r}: add yourself to the serial group "
                f"('sudo usermod -aG dialout $USER' on Debian/Ubuntu, 'uucp' on Arch), then log "
                f"out and in again")
    return f"cannot open serial port {port!r}: {text}"


class Link:
    """A byte link to a machine: a pyserial object (or anything with its read/write API).

    Parameters
    ----------
    port : serial-like
        An open object with ``write(bytes)``, ``read(n)``, ``in_waiting``,
        ``timeout`` and ``close()``.
    name : str
        What it is connected to (for messages and transcripts).
    """

    def __init__(self, port, name: str = "?"):
        self.port = port
        self.name = name
        self.closed = False
        self.lost: str | None = None     #: why the link failed (a read or write error), or None

    def write(self, data: bytes) -> None:
        """Send bytes; a vanished port raises :class:`MachineError` (disconnect)."""
        if self.closed:
            raise MachineError(f"link to {self.name} is closed")
        try:
            self.port.write(data)
            flush = getattr(self.port, "flush", None)
            if flush is not None:
                flush()
        except (OSError, ValueError) as exc:     # SerialException is an OSError
            self.lost = self.lost or f"disconnected from {self.name}: {exc}"
            raise MachineError(f"disconnected from {self.name}: {exc}") from exc

    def write_line(self, line: str) -> None:
        """Send one line ended by ``\\n`` only (never ``\\r\\n``)."""
        self.write(line.encode("ascii", "replace") + b"\n")

    def read(self, timeout_s: float = 0.05) -> bytes:
        """Whatever arrived within ``timeout_s`` (possibly ``b""``)."""
        if self.closed:
            raise MachineError(f"link to {self.name} is closed")
        try:
            waiting = self.port.in_waiting
            if waiting:
                return self.port.read(waiting)
            self.port.timeout = timeout_s
            data = self.port.read(1)
            if data:
                more = self.port.in_waiting
                if more:
                    data += self.port.read(more)
            return data
        except (OSError, ValueError, TypeError, AttributeError) as exc:
            if self.closed:
                return b""
            self.lost = self.lost or f"disconnected from {self.name}: {exc}"
            raise MachineError(f"disconnected from {self.name}: {exc}") from exc

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            try:
                self.port.close()
            except (OSError, ValueError):
                pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def open_link(port: str | None = None, baud: int = DEFAULT_BAUD, *, exclusive: bool = True,
              virtual_options: dict | None = None) -> Link:
    """Open a link to a machine.

    Parameters
    ----------
    port : str or None
        Device (``/dev/ttyUSB0``, ``COM3``), pyserial URL (``socket://…``,
        ``rfc2217://…``, ``loop://``) or ``virtual://`` (also when None): the
        simulated GRBL machine.
    baud : int
        Baud rate (ignored by sockets and the virtual machine).
    exclusive : bool
        Lock a real port so that a second program cannot open it too.
    virtual_options : dict, optional
        Keyword arguments of :class:`~labkit.machine.virtual.VirtualMachine`.

    Raises
    ------
    MachineError
        The port is missing, busy or forbidden (with the fix), or the URL is bad.

    Examples
    --------
    >>> link = open_link("virtual://", virtual_options={"time_scale": 0})
    >>> link.name
    'virtual://'
    >>> link.close()
    """
    if port is not None and not isinstance(port, str):
        raise MachineError(f"open_link: port must be a device name or URL (a str such as "
                           f"'/dev/ttyUSB0' or 'virtual://') or None, got {type(port).__name__}")
    if isinstance(baud, bool) or not isinstance(baud, int) or baud <= 0:
        raise MachineError(f"open_link: baud must be a positive whole number (e.g. 115200), got "
                           f"{baud!r}")
    if virtual_options is not None and not isinstance(virtual_options, dict):
        raise MachineError(f"open_link: virtual_options must be a dict of VirtualMachine "
                           f"options (e.g. {{'time_scale': 0}}), got {type(virtual_options).__name__}")
    if is_virtual_port(port):
        import inspect

        from labkit.errors import LabkitError
        from labkit.machine.virtual import VirtualMachine

        opts = dict(virtual_options or {})
        known = set(inspect.signature(VirtualMachine).parameters)
        unknown = sorted(set(opts) - known)
        if unknown:
            raise MachineError(f"open_link: virtual_options has {', '.join(map(repr, unknown))}, "
                               f"which the virtual machine does not take (it takes "
                               f"{', '.join(sorted(known))})")
        try:
            vm = VirtualMachine(**opts)
        except LabkitError as exc:
            raise MachineError(f"open_link: virtual_options['machine']: {exc}") from None
        return Link(vm, VIRTUAL_PORT)
    import serial

    try:
        if "://" in port:
            dev = serial.serial_for_url(port, baudrate=baud, timeout=0.05, write_timeout=2.0)
        else:
            dev = serial.Serial(port, baudrate=baud, timeout=0.05, write_timeout=2.0,
                                exclusive=exclusive if os.name == "posix" else None)
    except ValueError as exc:
        raise MachineError(f"cannot open {port!r}: {exc}") from exc
    except (serial.SerialException, OSError) as exc:
        raise MachineError(_open_hint(port, exc)) from exc
    return Link(dev, port)


# -- remembered settings -----------------------------------------------------------------------

@dataclass
class MachineConfig:
    """Connection settings remembered between runs."""

    port: str | None = None
    baud: int = DEFAULT_BAUD
    protocol: str = "grbl"
    machine: str | None = None


def config_path() -> Path:
    """``machine.json`` in labkit's folder of the user's configuration directory.

    ``$LABKIT_CONFIG_DIR`` overrides it; otherwise ``%APPDATA%\\labkit`` on
    Windows, ``~/Library/Application Support/labkit`` on macOS and
    ``$XDG_CONFIG_HOME/labkit`` (``~/.config/labkit``) elsewhere.
    """
    env = os.environ.get("LABKIT_CONFIG_DIR")
    if env:
        return Path(env) / "machine.json"
    if sys.platform.startswith("win"):
        base = Path(os.environ.get("APPDATA") or Path.home() / "AppData" / "Roaming")
    elif sys.platform == "darwin":
        base = Path.home() / "Library" / "Application Support"
    else:
        base = Path(os.environ.get("XDG_CONFIG_HOME") or Path.home() / ".config")
    return base / "labkit" / "machine.json"


def load_config() -> MachineConfig:
    """The remembered settings (defaults when there are none or the file is unreadable)."""
    path = config_path()
    try:
        data = json.loads(path.read_text("utf-8"))
    except (OSError, ValueError):
        return MachineConfig()
    fields = {f.name for f in dataclasses.fields(MachineConfig)}
    clean = {k: v for k, v in data.items() if k in fields} if isinstance(data, dict) else {}
    try:
        cfg = MachineConfig(**clean)
        cfg.baud = int(cfg.baud)
    except (TypeError, ValueError):
        return MachineConfig()
    return cfg


def save_config(cfg: MachineConfig) -> Path:
    """Write the settings (atomically: a crash never leaves half a file); returns the path."""
    from labkit._files import atomic_output

    path = config_path()
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_output(path) as fh:
        json.dump(dataclasses.asdict(cfg), fh, indent=1)
    return path


def monotonic() -> float:
    """The clock transcripts and timeouts use (seconds)."""
    return time.monotonic()
