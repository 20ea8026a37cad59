"""Driving machines: GRBL, the labkit firmware and the Dobot Magician over pyserial.

:mod:`~labkit.machine.link` opens a serial link (a real port or a pyserial URL:
``socket://``, ``rfc2217://``, ``loop://``, and ``virtual://`` for the simulated
machine) and lists ports; :mod:`~labkit.machine.grbl` speaks GRBL 1.1
(banner, ``$I``, send-response and character counting, real-time bytes,
status reports, settings); :mod:`~labkit.machine.virtual` is a simulated GRBL
machine, the default when no port is given; :mod:`~labkit.machine.stream` runs
a job with progress, pause, resume, cancel and laser-off on every fault;
:mod:`~labkit.machine.dobot` drives [DobotLaser]'s arm.

pyserial is imported here, never by :mod:`labkit.gcode`, so parsing stays
headless and fast.
"""

from labkit.machine.grbl import Grbl, Status, alarm_message, error_message, parse_status
from labkit.machine.link import (
    Link,
    MachineConfig,
    PortInfo,
    list_ports,
    load_config,
    open_link,
    save_config,
)
from labkit.machine.stream import Job, JobReport, run_job
from labkit.machine.virtual import VirtualMachine

__all__ = [
    "Link", "PortInfo", "list_ports", "open_link", "MachineConfig", "load_config", "save_config",
    "Grbl", "Status", "parse_status", "error_message", "alarm_message",
    "VirtualMachine",
    "Job", "JobReport", "run_job",
]
