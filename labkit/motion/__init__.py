"""Motion: what a laser controller does between ``G1 X10`` and the step pulses.

The readable, exact reference the labkit firmware is checked against step for
step: the machine description (:mod:`~labkit.motion.spec`), Bresenham
lines and arcs on the step lattice (:mod:`~labkit.motion.bresenham`), blocks
and their FIFO (:mod:`~labkit.motion.blocks`), per-block speed profiles
(:mod:`~labkit.motion.profile`), multi-block look-ahead — [CBR40]'s three
MBLA modes and GRBL's junction-deviation planner (:mod:`~labkit.motion.planner`),
laser power that follows speed (:mod:`~labkit.motion.power`), the step timer
(:mod:`~labkit.motion.timer`) and the whole chain (:func:`plan`).
"""

from labkit.motion.blocks import BlockFifo, BlockKind, Blocks, build_blocks, expand_arcs, to_steps
from labkit.motion.bresenham import (
    arc_lattice_points,
    circle_points,
    direction_bits,
    line_points,
    line_steps,
    lines_points,
    steps_from_points,
)
from labkit.motion.pipeline import Plan, PlanSummary, default_law, plan
from labkit.motion.planner import PLANNERS, Lookahead, junction_speed_caps, lookahead
from labkit.motion.power import dose_mj_per_mm, laser_power_mw, power_ratio
from labkit.motion.profile import RAMP_LAWS, Profiles, block_profiles, ramp_distance, ramp_time, reach_speed
from labkit.motion.spec import AXES, CBR40, MACHINES_DIR, MachineSpec, load_machine, machine_files
from labkit.motion.timer import (
    StepBlocks,
    StepTrace,
    iter_step_chunks,
    step_blocks,
    step_trace,
    tick_cycles,
    tick_rates,
    timer_period,
)

__all__ = [
    # machine
    "MachineSpec", "CBR40", "AXES", "MACHINES_DIR", "load_machine", "machine_files",
    # Bresenham
    "line_points", "line_steps", "lines_points", "direction_bits", "arc_lattice_points", "circle_points",
    "steps_from_points",
    # blocks
    "Blocks", "BlockKind", "BlockFifo", "build_blocks", "expand_arcs", "to_steps",
    # profiles and look-ahead
    "RAMP_LAWS", "Profiles", "block_profiles", "reach_speed", "ramp_distance", "ramp_time",
    "PLANNERS", "Lookahead", "lookahead", "junction_speed_caps",
    # laser
    "power_ratio", "laser_power_mw", "dose_mj_per_mm",
    # plan and timing
    "Plan", "PlanSummary", "plan", "default_law",
    "timer_period", "tick_cycles", "tick_rates", "StepBlocks", "step_blocks", "StepTrace",
    "step_trace", "iter_step_chunks",
]
