"""The labkit firmware (firmware/README.md) in its native dialect.

It answers ``ok`` or ``er:N`` (``N`` from ``labkit/status_codes.csv``; seed
004's bare ``er`` is accepted too), reads F in mm/s, G4 P in ms and S 0–255.
Apart from its dialect it is driven like GRBL: the same reader, real-time
bytes, status reports and job runner (:mod:`labkit.machine.grbl` already reads
``er:N`` as an error). Its GRBL mode is simply :class:`~labkit.machine.grbl.Grbl`.
"""

from __future__ import annotations

from labkit.machine.grbl import Grbl

__all__ = ["LabkitFirmware"]


class LabkitFirmware(Grbl):
    """A machine running the labkit firmware in its native dialect (``labkit-fw``)."""

    protocol = "labkit-fw"
    dialect = "labkit-fw"
