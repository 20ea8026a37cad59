"""Stalls: where a controller's planner runs dry because the serial link cannot keep up.

A GRBL-family controller moves only what is in its planner buffer. When short
blocks finish faster than the link (115200 baud 8N1 is 11,520 bytes/s) and the
controller's parser can deliver new ones, the buffer empties while the job still
has lines left: the machine stops and restarts (a *starvation*, seen on a raster
job as stutter and burned dots). This module holds the record every simulated
machine reports a starvation with — the firmware's paced host simulator, the
virtual machine and the stall predictor report the same thing, so they can be
compared one to one.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Starvation"]


@dataclass(frozen=True)
class Starvation:
    """The planner stood empty while the job had lines left.

    Parameters
    ----------
    time_s : float
        When the buffer ran dry, in seconds of machine time from the job's
        first byte.
    line : int
        The source line (1-based, as ``labkit check`` numbers them) whose
        block the machine was waiting for.
    duration_s : float
        How long the machine stood without a block, s (> 0).
    """

    time_s: float
    line: int
    duration_s: float
