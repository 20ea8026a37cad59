"""Motion: what a laser controller does between ``G1 X10`` and the step pulses.

The readable, exact reference the labkit firmware is checked against step for
step: the machine description, Bresenham lines and arcs on the step lattice,
blocks, per-block speed profiles, multi-block look-ahead (seed 004's three
MBLA modes and GRBL's junction-deviation planner), laser power that follows
speed, and the step timer.
"""

from labkit.motion.bresenham import (
    arc_points,
    circle_points,
    direction_bits,
    line_points,
    line_steps,
    lines_points,
    steps_from_points,
)
from labkit.motion.machine import AXES, CBR40, MACHINES_DIR, Machine, load_machine, machine_files

__all__ = [
    "Machine",
    "CBR40",
    "AXES",
    "MACHINES_DIR",
    "load_machine",
    "machine_files",
    "line_points",
    "line_steps",
    "lines_points",
    "direction_bits",
    "arc_points",
    "circle_points",
    "steps_from_points",
]
