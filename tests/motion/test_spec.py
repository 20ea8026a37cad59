"""Machine descriptions: the shipped files, derived values, and every error path."""

import pytest

from labkit.errors import MotionError
from labkit.motion import CBR40, MachineSpec, load_machine, machine_files


def test_shipped_cbr40_file_is_the_builtin_default():
    m = load_machine("cbr40-laser")
    assert m == CBR40
    assert m.description == CBR40.description


def test_cbr40_numbers():
    # eq. (1): R = d / N = 3 mm / 6400 = 0.46875 µm; table 1: 1546.0875 mm/min
    assert CBR40.resolution_um == pytest.approx((0.46875,) * 3, abs=1e-15)
    assert CBR40.max_step_rate_hz == (54972,) * 3
    assert CBR40.laser_max_power_mw == 2500.0
    assert CBR40.timer_clock_hz == 48_000_000
    assert CBR40.step_pulse_us == 5.0


def test_every_shipped_file_loads():
    files = machine_files()
    assert {p.stem for p in files} >= {"cbr40-laser", "grbl-diode"}
    for path in files:
        m = load_machine(path)
        assert m.name == path.stem
        assert load_machine(str(path)) == m


def test_scalars_broadcast_and_replace_validates():
    m = MachineSpec(steps_per_mm=80, max_rate_mm_min=6000, accel_mm_s2=1000, travel_mm=300,
                start_rate_hz=250, timer_clock_hz=16_000_000)
    assert m.steps_per_mm == (80.0, 80.0, 80.0)
    assert m.replace(prescaler=7).tick_hz == 2_000_000
    with pytest.raises(MotionError, match="prescaler must be in 0…65535"):
        m.replace(prescaler=-1)
    assert load_machine(m) is m
    assert load_machine(None) is CBR40


@pytest.mark.parametrize("changes,match", [
    (dict(steps_per_mm=(100, 0, 100)), "steps_per_mm must be > 0 and finite"),
    (dict(accel_mm_s2=float("inf")), "accel_mm_s2 must be > 0 and finite"),
    (dict(accel_hz_per_step=0), "accel_hz_per_step must be >= 1 Hz per step"),
    (dict(decel_hz_per_step=2.5), "decel_hz_per_step must be an integer"),
    (dict(buffer_blocks=0), "buffer_blocks must be >= 1 block"),
    (dict(junction_deviation_mm=0.0), "junction_deviation_mm must be > 0 mm"),
    (dict(arc_tolerance_mm=-1.0), "arc_tolerance_mm must be > 0 mm"),
    (dict(laser_max_power_mw=0.0), "laser_max_power_mw must be > 0 mW"),
    (dict(timer_bits=8), "timer_bits must be 16 or 32"),
    (dict(step_pulse_us=0.0), "step_pulse_us must be > 0"),
    (dict(start_rate_hz=100_000), "start_rate_hz .* exceeds the fastest axis step rate"),
    (dict(start_rate_hz=500), "more than a 16-bit register holds"),
    (dict(prescaler=1000), "lower the prescaler"),
    (dict(step_pulse_us=10.0), "10 µs step pulses do not fit twice in a tick at 54972 Hz"),
    (dict(timer_clock_hz=True), "timer_clock_hz must be an integer"),
    (dict(rest_at_zero="yes"), "rest_at_zero must be true or false"),
])
def test_bad_values_are_rejected_with_the_field_name(changes, match):
    with pytest.raises(MotionError, match=match):
        CBR40.replace(**changes)


def test_unknown_name_lists_the_shipped_machines():
    with pytest.raises(MotionError, match="unknown machine 'nope'.*cbr40-laser"):
        load_machine("nope")


@pytest.mark.parametrize("text,match", [
    ("steps_per_mm = [1, 2\n", "bad.toml: not valid TOML"),
    ("spindle_rpm = 12000\n", r"unknown key\(s\) \['spindle_rpm'\]"),
    ("steps_per_rev = 6400\n", "steps_per_rev and lead_mm go together"),
    ("steps_per_rev = 6400\nlead_mm = 0\n", "lead_mm must be > 0 mm"),
    ("steps_per_mm = 80\nsteps_per_rev = 6400\nlead_mm = 3\n", "not both"),
    ("[a]\nprescaler = 1\n[b]\nprescaler = 2\n", "key 'prescaler' given twice"),
    ("accel_hz_per_step = 0\n", "bad.toml: .*accel_hz_per_step must be >= 1"),
    ("steps_per_mm = 'many'\n", "bad.toml: bad value"),
])
def test_file_errors_name_the_file_and_key(tmp_path, text, match):
    bad = tmp_path / "bad.toml"
    bad.write_text(text)
    with pytest.raises(MotionError, match=match):
        load_machine(bad)


def test_steps_per_rev_and_lead(tmp_path):
    good = tmp_path / "mine.toml"
    good.write_text("[mechanics]\nsteps_per_rev = 3200\nlead_mm = 2\n")
    assert load_machine(good).steps_per_mm == (1600.0, 1600.0, 1600.0)
    assert load_machine(good).name == "mine"


def test_laser_maximum_is_stated_only_in_the_machine_description():
    """No function defaults a laser maximum of its own: the figure lives in the machine
    description (labkit/motion/spec.py and its TOML files) and is passed in."""
    import inspect
    import re
    from pathlib import Path

    import labkit
    from labkit import units

    root = Path(labkit.__file__).parent
    offenders = []
    for path in root.rglob("*.py"):
        if path.relative_to(root).as_posix() == "motion/spec.py":
            continue
        for k, line in enumerate(path.read_text("utf-8").splitlines(), 1):
            if re.search(r"max_power_mw\w*\s*(:\s*float\s*)?=\s*\d", line) and ">>>" not in line \
                    and "..." not in line:
                offenders.append(f"{path.name}:{k}: {line.strip()}")
    assert offenders == []
    for fn in (units.s_to_mw, units.mw_to_s):
        assert inspect.signature(fn).parameters["max_power_mw"].default is inspect.Parameter.empty


def test_only_grbls_planner_rests_at_zero():
    """grbl-diode plans every stop from and to 0 as GRBL's planner does, its step timer still
    clamped at 31 Hz; the labkit firmware's descriptions and [CBR40]'s plan from the start rate,
    and a linear (Hz per step) ramp always does."""
    grbl = load_machine("grbl-diode")
    assert grbl.rest_at_zero and grbl.start_rate_hz == 31
    assert (grbl.rest_rate_hz("accel"), grbl.rest_rate_hz("linear")) == (0, 31)
    for name in ("cbr40-laser", "labkit-diode"):
        m = load_machine(name)
        assert not m.rest_at_zero and m.rest_rate_hz("accel") == m.start_rate_hz
