"""``labkit pattern``: every pattern writes G-code that parses back to its Moves; options are validated."""

import numpy as np
import pytest

from labkit.cli import main
from labkit.gcode import parse_file
from labkit.toolpath import patterns

CASES = {
    "helix": (["--x", "3", "--radius", "1.5", "--pitch", "0.4", "--turns", "3"],
              lambda: patterns.helix((3, 0), 1.5, 0.4, 3)),
    "spiral": (["--radius", "4", "--step", "0.3", "--tol", "0.002"],
               lambda: patterns.archimedean_spiral((0, 0), 4, 0.3, tol_mm=0.002)),
    "square-spiral": (["--size", "3", "--step", "0.5"], lambda: patterns.square_spiral((0, 0), 3, 0.5)[0]),
    "zigzag": (["--width", "6", "--height", "4", "--step", "1", "--plane", "xz", "--along", "z", "--lead", "0.5"],
               lambda: patterns.zigzag((0, 0, 0), 6, 4, 1, plane="xz", along="z", lead_mm=0.5)),
    "cone": (["--d1", "6", "--d2", "2", "--height", "2", "--levels", "3", "--beam", "0.4"],
             lambda: patterns.cone((0, 0), 6, 2, 2, 3, 0.4)),
}


@pytest.mark.parametrize("name", list(CASES))
def test_pattern_writes_the_generator(name, tmp_path, capsys):
    argv, make = CASES[name]
    out = tmp_path / "p.gcode"
    assert main(["pattern", name, *argv, "-o", str(out)]) == 0
    back = parse_file(str(out))
    ref = make()
    assert len(back) == len(ref)
    assert np.array_equal(back.kind, ref.kind)
    assert np.allclose(back.end, ref.end, atol=1e-3)
    assert np.array_equal(back.laser_on, ref.laser_on)
    assert f"{len(ref)} moves" in capsys.readouterr().out


@pytest.mark.parametrize("argv,needle", [
    (["helix", "--turns", "inf"], "--turns"),
    (["helix", "--radius", "0"], "--radius"),
    (["spiral", "--tol", "nan"], "--tol"),
    (["spiral", "--step", "-1"], "--step"),
    (["cone", "--levels", "2.5"], "--levels"),
    (["zigzag", "--feed", "0"], "--feed"),
    (["square-spiral", "--x", "1e9"], "--x"),
])
def test_options_validated_by_name(argv, needle, tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["pattern", *argv, "-o", str(tmp_path / "x.gcode")])
    assert exc.value.code == 2
    assert needle in capsys.readouterr().err


@pytest.mark.parametrize("argv,needle", [
    (["spiral", "--radius", "10000", "--step", "0.001", "--tol", "0.0001"], "too much work"),
    (["spiral", "--inner", "6", "--radius", "5"], "inner_radius_mm"),
    (["zigzag", "--plane", "xz", "--along", "y"], "along"),
    (["cone", "--d1", "1", "--d2", "0.5", "--beam", "0.9"], "beam_mm"),
])
def test_errors_are_one_line(argv, needle, tmp_path, capsys):
    out = tmp_path / "x.gcode"
    assert main(["pattern", *argv, "-o", str(out)]) == 1
    err = capsys.readouterr().err
    assert needle in err and err.count("\n") == 1 and not out.exists()
