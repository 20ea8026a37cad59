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

# The names load on first use: a command that needs one module (svg2gcode's machine check,
# motion.spec) does not import the planner, the step timer and the rest (~15 ms).
from labkit._lazy import lazy_names

_WHERE = {
    'BlockFifo': 'blocks',
    'BlockKind': 'blocks',
    'Blocks': 'blocks',
    'build_blocks': 'blocks',
    'expand_arcs': 'blocks',
    'to_steps': 'blocks',
    'arc_lattice_points': 'bresenham',
    'circle_points': 'bresenham',
    'direction_bits': 'bresenham',
    'line_points': 'bresenham',
    'line_steps': 'bresenham',
    'lines_points': 'bresenham',
    'steps_from_points': 'bresenham',
    'Plan': 'pipeline',
    'PlanSummary': 'pipeline',
    'default_law': 'pipeline',
    'plan': 'pipeline',
    'PLANNERS': 'planner',
    'Lookahead': 'planner',
    'junction_speed_caps': 'planner',
    'lookahead': 'planner',
    'dose_mj_per_mm': 'power',
    'laser_power_mw': 'power',
    'power_ratio': 'power',
    'RAMP_LAWS': 'profile',
    'Profiles': 'profile',
    'block_profiles': 'profile',
    'ramp_distance': 'profile',
    'ramp_time': 'profile',
    'reach_speed': 'profile',
    'AXES': 'spec',
    'CBR40': 'spec',
    'MACHINES_DIR': 'spec',
    'MachineSpec': 'spec',
    'load_machine': 'spec',
    'machine_files': 'spec',
    'StepBlocks': 'timer',
    'StepTrace': 'timer',
    'iter_step_chunks': 'timer',
    'step_blocks': 'timer',
    'step_trace': 'timer',
    'tick_cycles': 'timer',
    'tick_rates': 'timer',
    'timer_period': 'timer',
}

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


__getattr__, __dir__ = lazy_names(__name__, _WHERE, __all__)
