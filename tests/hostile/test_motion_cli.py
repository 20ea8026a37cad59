"""Large but legal arcs and lines for ``labkit plan`` and ``labkit steps`` (issue 9): memory
follows an arc's length, not its radius; beyond the held-steps budget a named error."""

from __future__ import annotations

import math
import re

import pytest

from labkit.motion import load_machine


def job(tmp_path, body):
    path = tmp_path / "job.gcode"
    path.write_text(f"G21 G90\nM3 S100\nG1 X0 Y0 F600\n{body}\nM5\n")
    return path


@pytest.mark.parametrize("radius", [30000, 5000])
def test_a_short_arc_of_huge_radius_plans_like_its_chord(tmp_path, run_labkit, radius):
    # G2 X10 Y0 R30000: a 10 mm arc whose radius is 30 m; it took all memory before.
    path = job(tmp_path, f"G2 X10 Y0 R{radius}")
    plan = run_labkit(["plan", path], time_s=120, memory_mb=400)
    assert plan.code == 0, plan.stderr
    assert "laser on                    1.018 s over 10.000 mm" in plan.stdout
    steps = run_labkit(["steps", path, "-o", tmp_path / "s.csv"], time_s=120, memory_mb=400)
    assert steps.code == 0, steps.stderr
    spm = load_machine("cbr40-laser").steps_per_mm[0]
    # 8-connected ticks of a 10 mm arc this flat: its length in steps along X, rounded
    ticks = int(re.search(r"(\d+) ticks", steps.stdout + steps.stderr).group(1))
    assert abs(ticks - round(10 * spm)) <= 1


def test_an_arc_longer_than_the_budget_is_refused_by_name(tmp_path, run_labkit):
    # R-30000: the major arc, 188 m of steps — refused before any allocation
    path = job(tmp_path, "G2 X10 Y0 R-30000")
    r = run_labkit(["steps", path, "-o", tmp_path / "s.csv"], time_s=120, memory_mb=400)
    assert r.code == 1
    assert "held steps (budget 50,000,000) from an arc of radius 6.4e+07 steps" in r.stderr
    assert "--arc-tol" in r.stderr


def test_a_100_m_line_is_refused_not_swapped(tmp_path, run_labkit):
    path = job(tmp_path, "G1 X100000 F6000")
    r = run_labkit(["steps", path, "-o", tmp_path / "s.csv"], time_s=120, memory_mb=400)
    assert r.code == 1
    assert "too much work: 213,333,334 held steps" in r.stderr or "held steps (budget" in r.stderr


def test_exact_walk_keeps_int64_exact_for_radii_past_the_fixed_point_range():
    from labkit.motion.bresenham import arc_lattice_points

    r = 2.0e7                                        # (r + 4) × 256 > 3e9: fewer sub-steps
    a = math.radians(0.001)
    start = [round(r), 0]
    end = [round(r * math.cos(a)), round(r * math.sin(a))]
    pts = arc_lattice_points(start, end, [0.0, 0.0], clockwise=False)
    radii = (pts[:, 0].astype(float) ** 2 + pts[:, 1].astype(float) ** 2) ** 0.5
    assert pts[0].tolist() == start and pts[-1].tolist() == end
    assert abs(radii - r).max() <= 0.75              # within a step of the true circle
