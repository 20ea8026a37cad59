"""Regression: short blocks through a one-block look-ahead (found with the firmware's
random vectors). The backward pass started from the rest speed at the end of the
window, faster than the block past it could slow down from to its own rest speed,
and plan() refused the job ("entry speed cannot be reached"). Blocks are now planned
down to their floor (rest speed) only; slow_neighbour_* in tests/vectors/motion are the
cases the firmware and labkit.motion share."""
import pytest

from labkit.gcode import parse
from labkit.motion import load_machine, plan

GCODE = """G21 G90
M3 S583
G1 X0 Y0 F600
G1 X-0.0554 Y-0.0073 F8070
G1 X-0.0361 Y-0.0211 F8406 S470
G1 X0.0488 Y0.0710 S248
G1 X0.0183 Y0.0907 F2100
"""


@pytest.mark.parametrize("buffer_blocks", [1, 2, 16])
def test_short_blocks_small_buffer(buffer_blocks):
    p = plan(parse(GCODE), "grbl-diode", planner="fast", buffer_blocks=buffer_blocks)
    assert p.law == "linear"
    v, length = p.lookahead.speed_mm_s, p.blocks.length_mm[p.motion]
    a = p.machine.accel_hz_per_step      # linear ramps: Δv = slope · distance (mm/s per mm)
    d = p.machine.decel_hz_per_step
    assert len(v) == 5                   # four motion blocks (G1 X0 Y0 does not move)
    floor = p.blocks.rest_mm_s[p.motion]
    entry, exit_ = p.profiles.entry_mm_s, p.profiles.exit_mm_s
    for k in range(4):                   # every block ramps between its two ends ...
        assert exit_[k] - entry[k] <= a * length[k] * (1 + 1e-9) + 1e-12, (k, v)
        assert entry[k] - exit_[k] <= d * length[k] * (1 + 1e-9) + 1e-12, (k, v)
        # ... which are the junction speeds, or its floor where a junction is slower
        assert entry[k] == max(v[k], floor[k]) and exit_[k] == max(v[k + 1], floor[k])
    assert v[0] == pytest.approx(p.lookahead.junction_rest_mm_s[0])
    assert v[-1] == pytest.approx(p.lookahead.junction_rest_mm_s[-1])
    assert (v <= p.lookahead.junction_cap_mm_s * (1 + 1e-12)).all()
    assert p.job_time_s > 0


def test_short_blocks_window_end_speed():
    """With a one-block window, junction 3 (the end of block 2's window) is limited to
    what block 3 can slow down from to its rest speed within its length:
    rest[3] + decel · L[3] (3.29404 + 20 · 0.03953 = 4.08461 mm/s, below the
    junction's rest speed 4.15240 mm/s that the old planner used); the job ends at rest[3].
    On grbl-diode with the 250 Hz start/stop floor it had until issue 29 (GRBL's own floor,
    31 Hz, leaves the junction's rest speed too low for this limit to arise)."""
    machine = load_machine("grbl-diode").replace(start_rate_hz=250, prescaler=0)
    p = plan(parse(GCODE), machine, planner="fast", buffer_blocks=1)
    v = p.lookahead.speed_mm_s
    L = p.blocks.length_mm[p.motion]
    rest = p.blocks.rest_mm_s[p.motion]
    assert v[3] == pytest.approx(rest[3] + p.machine.decel_hz_per_step * L[3], rel=1e-12)
    assert v[4] == pytest.approx(rest[3], rel=1e-12)
