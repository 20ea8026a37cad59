"""Cross-check the firmware against labkit.motion on random jobs (not part of ``make test``).

Writes random jobs (lines, rapids, dwells, power changes, I J K arcs in the three planes,
helices, full circles) as motion vectors with ``tests/vectors/motion/generate.py``'s
``make_vector`` into a temporary repository-like folder, for every planner and several
look-ahead depths on both machines, then runs ``build/tests/test_vectors`` on that folder.

    cd firmware && make build/tests/test_vectors
    PYTHONPATH=.. ../.venv/bin/python tests/random_vectors.py --seeds 1 2 3

Jobs that the reference itself refuses (``MotionError``: a helix steeper than its arc) are
skipped and counted. Seeds 1–8: 473 jobs equal, 7 refused, all helices (before blocks were
planned down to their floor only, 38 of 322 on seeds 1–6 were refused: short blocks whose
window ended lower than a later window could keep).
"""

from __future__ import annotations

import argparse
import math
import random
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
sys.path.insert(0, str(ROOT / "tests" / "vectors" / "motion"))

import generate as G  # noqa: E402  (the vector writer of the reference)


def lines_job(rng: random.Random, n: int, *, arcs: bool, z: bool, fscale: int) -> str:
    out = ["G21 G90", rng.choice([f"M3 S{rng.randint(1, 1000)}", f"M4 S{rng.randint(1, 1000)}", "M5"]),
           "G1 X0 Y0 F600"]
    x = y = zz = 0.0
    for _ in range(n):
        r = rng.random()
        if r < 0.05:
            out.append(f"G4 P{rng.uniform(0, 0.01):.3f}")
        elif r < 0.15:
            x, y = round(rng.uniform(-0.05, 0.05), 4), round(rng.uniform(-0.05, 0.05), 4)
            out.append(f"G0 X{x:.4f} Y{y:.4f}")
        elif arcs and r < 0.35:
            rad, ang = rng.uniform(0.003, 0.02), rng.uniform(0, 2 * math.pi)
            cx, cy = x - rad * math.cos(ang), y - rad * math.sin(ang)
            a2 = ang + rng.uniform(-6, 6)
            ex, ey = round(cx + rad * math.cos(a2), 4), round(cy + rad * math.sin(a2), 4)
            i, j = round(cx - x, 5), round(cy - y, 5)
            if abs(math.hypot(ex - x - i, ey - y - j) - math.hypot(i, j)) > 0.004:
                continue
            out.append(f"{rng.choice(['G2', 'G3'])} X{ex:.4f} Y{ey:.4f} I{i:.5f} J{j:.5f} "
                       f"F{rng.randint(30, 2000) * fscale}")
            x, y = ex, ey
        else:
            x, y = round(x + rng.uniform(-0.03, 0.03), 4), round(y + rng.uniform(-0.03, 0.03), 4)
            w = f"G1 X{x:.4f} Y{y:.4f}"
            if z:
                zz = round(zz + rng.uniform(-0.005, 0.005), 4)
                w += f" Z{zz:.4f}"
            if rng.random() < 0.5:
                w += f" F{rng.randint(30, 3000) * fscale}"
            if rng.random() < 0.3:
                w += f" S{rng.randint(0, 1000)}"
            out.append(w)
    return "\n".join(out + ["M5"]) + "\n"


def arcs_job(rng: random.Random, n: int) -> str:
    out = ["G21 G90", f"M4 S{rng.randint(1, 1000)}", "G1 X0 Y0 Z0 F600"]
    p = [0.0, 0.0, 0.0]
    plane = 17
    for _ in range(n):
        if rng.random() < 0.2:
            plane = rng.choice([17, 18, 19])
            out.append(f"G{plane}")
        a0, a1, lin = {17: (0, 1, 2), 18: (2, 0, 1), 19: (1, 2, 0)}[plane]
        rad = rng.choice([0.0008, 0.001, 0.003, 0.01, 0.05, 0.3])
        ang = rng.uniform(0, 2 * math.pi)
        c = [p[a0] - rad * math.cos(ang), p[a1] - rad * math.sin(ang)]
        if rng.random() < 0.15:
            e = [p[a0], p[a1]]                       # full circle
        else:
            a2 = ang + rng.uniform(-7, 7)
            e = [round(c[0] + rad * math.cos(a2), 4), round(c[1] + rad * math.sin(a2), 4)]
        off = [round(c[0] - p[a0], 5), round(c[1] - p[a1], 5)]
        if abs(math.hypot(e[0] - p[a0] - off[0], e[1] - p[a1] - off[1]) - math.hypot(*off)) > 0.004:
            continue
        words = [rng.choice(["G2", "G3"]), f"{'XYZ'[a0]}{e[0]:.4f}", f"{'XYZ'[a1]}{e[1]:.4f}"]
        if rng.random() < 0.3:
            p[lin] = round(p[lin] + rng.uniform(-0.3, 0.3) * rad, 4)
            words.append(f"{'XYZ'[lin]}{p[lin]:.4f}")
        words += [f"{'IJK'[a0]}{off[0]:.5f}", f"{'IJK'[a1]}{off[1]:.5f}", f"F{rng.randint(20, 1500)}"]
        out.append(" ".join(words))
        p[a0], p[a1] = e
    return "\n".join(out + ["M5"]) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1])
    ap.add_argument("--binary", default=str(HERE.parent / "build" / "tests" / "test_vectors"))
    ap.add_argument("--dialect", default="grbl", choices=["grbl", "labkit-fw"],
                    help="dialect the jobs are read in (the same text: F, S and P mean other units)")
    args = ap.parse_args(argv)
    if args.dialect != "grbl":   # the vector writer reads grbl; read the jobs in the other dialect
        from labkit.gcode import parse as _parse
        G.parse = lambda text, dialect="grbl": _parse(text, dialect=args.dialect)
    bad = skipped = written = 0
    for seed in args.seeds:
        rng = random.Random(seed)
        cases = {}
        for planner in ("junction", "fast", "normal", "hq"):
            for depth in (1, 2, 3, 5, 16):
                for mach in ("cbr40-laser", "grbl-diode"):
                    cases[f"r{seed}_{planner}_{depth}_{mach}"] = dict(
                        description="random lines", machine=mach, planner=planner, buffer_blocks=depth,
                        gcode=lines_job(rng, rng.randint(5, 40), arcs=mach == "cbr40-laser",
                                        z=rng.random() < 0.3, fscale=3 if mach == "grbl-diode" else 1))
                cases[f"a{seed}_{planner}_{depth}"] = dict(
                    description="random arcs", machine="cbr40-laser", planner=planner,
                    buffer_blocks=depth, gcode=arcs_job(rng, rng.randint(4, 14)))
        G.CASES.clear()
        G.CASES.update(cases)
        with tempfile.TemporaryDirectory() as tmp:
            folder = Path(tmp) / "tests" / "vectors" / "motion"
            folder.mkdir(parents=True)
            for name in cases:
                try:
                    v = G.make_vector(name)
                except Exception as exc:   # the reference refuses the job
                    skipped += 1
                    print(f"seed {seed}: {name} skipped: {type(exc).__name__}: {str(exc)[:100]}")
                    continue
                v["dialect"] = args.dialect
                (folder / f"{name}.json").write_text(G.dumps(v) + "\n")
                written += 1
            res = subprocess.run([args.binary, tmp], capture_output=True, text=True)
            print(f"seed {seed}: {res.stdout.strip().splitlines()[-1] if res.stdout.strip() else res.stderr}")
            if res.returncode != 0:
                print(res.stdout)
                bad += 1
    print(f"random_vectors: {written} jobs compared, {skipped} refused by the reference, "
          f"{bad} seed(s) with a mismatch")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
