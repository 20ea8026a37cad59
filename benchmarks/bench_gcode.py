"""G-code parsing speed: labkit against pygcode and gcodeparser on the same 1,000,000-line job.

Run:  .venv/bin/python benchmarks/bench_gcode.py [--lines N] [--repeat K]
(``make bench`` installs the peers first: ``pip install -e '.[bench]'``.)

The job is deterministic (seeded): a laser program of G0/G1 with X Y F S,
G2/G3 arcs by I J and by R, comments of both kinds, N numbers on every line
and M3/M4/M5 switching. Each parser reads the same text from memory:

- labkit: ``labkit.gcode.parse`` → Moves (words, modal state, units, arc
  centres and their radius check: the full interpretation);
- gcodeparser: ``parse_gcode_lines`` → a list of GcodeLine (words only);
- pygcode: ``pygcode.Line`` per line (words and their G-code classes only; its
  ``Machine`` interpreter is far slower still and is not timed).

The peers do less work than labkit, so the ratios are conservative. Each
parser is timed best-of-``repeat`` after one warm-up on a small file (which
also loads labkit's cached compiled kernel). Printed: lines/s for each, the
ratios, the bytes per line of the Moves result, and labkit's emit rate
(``labkit.gcode.emit`` of the parsed Moves back to text, moves/s; no peer).
"""

from __future__ import annotations

import argparse
import gc
import math
import time

import numpy as np

TARGET_VS_PYGCODE = 20.0
TARGET_VS_GCODEPARSER = 3.0
TARGET_BYTES_PER_LINE = 150.0


def make_job(n_lines: int, seed: int = 2026) -> str:
    """A deterministic laser job of ``n_lines`` lines (see the module docstring)."""
    rng = np.random.default_rng(seed)
    out = ["G21 G90 G17", "M4 S0"]
    x = y = 100.0
    kinds = rng.choice(7, size=n_lines, p=[0.12, 0.5, 0.08, 0.08, 0.07, 0.1, 0.05])
    steps = rng.uniform(-3.0, 3.0, size=(n_lines, 2))
    powers = rng.integers(0, 1000, size=n_lines)
    feeds = rng.choice([600, 1200, 1800, 3000], size=n_lines)
    radii = rng.uniform(1.0, 8.0, size=n_lines)
    turns = rng.uniform(0.2, 2.5, size=n_lines)
    angles = rng.uniform(0.0, 2 * math.pi, size=n_lines)
    n = 3
    while len(out) < n_lines:
        k = int(kinds[len(out) % n_lines])
        i = len(out) % n_lines
        if k == 0:
            x, y = round(x + 10 * steps[i, 0], 3), round(y + 10 * steps[i, 1], 3)
            out.append(f"N{n} G0 X{x:.3f} Y{y:.3f}")
        elif k == 1:
            x, y = round(x + steps[i, 0], 3), round(y + steps[i, 1], 3)
            out.append(f"N{n} G1 X{x:.3f} Y{y:.3f} F{feeds[i]} S{powers[i]}")
        elif k in (2, 3):     # arc by I J, end exactly on the circle to 3 decimals
            r, a0, turn = radii[i], angles[i], turns[i]
            cx, cy = x - r * math.cos(a0), y - r * math.sin(a0)
            a1 = a0 + (turn if k == 3 else -turn)
            ex, ey = round(cx + r * math.cos(a1), 3), round(cy + r * math.sin(a1), 3)
            out.append(f"N{n} G{k} X{ex:.3f} Y{ey:.3f} I{cx - x:.3f} J{cy - y:.3f} F{feeds[i]}")
            x, y = ex, ey
        elif k == 4:          # arc by R
            r = radii[i]
            chord = min(1.8 * r, 1.0 + abs(steps[i, 0]))
            ex, ey = round(x + chord * math.cos(angles[i]), 3), round(y + chord * math.sin(angles[i]), 3)
            out.append(f"N{n} G{2 + (i % 2)} X{ex:.3f} Y{ey:.3f} R{r:.3f} ; radius arc")
            x, y = ex, ey
        elif k == 5:
            out.append(f"N{n} (pass {i}) M{(3, 4, 5)[i % 3]} S{powers[i]}")
        else:
            out.append(f"; layer {i}, power {powers[i]}")
        n += 1
    return "\n".join(out[:n_lines]) + "\n"


def best_of(fn, repeat):
    best = math.inf
    result = None
    for _ in range(repeat):
        gc.collect()
        t0 = time.perf_counter()
        result = fn()
        best = min(best, time.perf_counter() - t0)
    return best, result


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--lines", type=int, default=1_000_000)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--pygcode-repeat", type=int, default=1,
                        help="pygcode takes ~20 s per million lines; one run by default")
    args = parser.parse_args(argv)

    from gcodeparser import parse_gcode_lines
    from pygcode import Line

    from labkit.gcode import emit, parse

    text = make_job(args.lines)
    data = text.encode()
    lines = text.splitlines()
    n = len(lines)
    print(f"job: {n:,} lines, {len(data) / 1e6:.1f} MB")

    warm = make_job(2000)
    parse(warm)
    list(parse_gcode_lines(warm))
    [Line(s) for s in warm.splitlines()[:200]]

    t_lab, moves = best_of(lambda: parse(data), args.repeat)
    t_gp, gp = best_of(lambda: list(parse_gcode_lines(text)), args.repeat)
    t_py, _ = best_of(lambda: [Line(s) for s in lines], args.pygcode_repeat)

    emit(parse(warm))
    t_emit, emitted = best_of(lambda: emit(moves), args.repeat)

    rate = {name: n / t for name, t in (("labkit", t_lab), ("gcodeparser", t_gp), ("pygcode", t_py))}
    for name, r in rate.items():
        print(f"{name:<12} {r:>14,.0f} lines/s")
    print(f"{'labkit emit':<12} {len(moves) / t_emit:>14,.0f} moves/s "
          f"({len(emitted) / 1e6 / t_emit:.0f} MB/s of text)")
    vs_py = rate["labkit"] / rate["pygcode"]
    vs_gp = rate["labkit"] / rate["gcodeparser"]
    bytes_per_line = moves.nbytes / n
    print(f"labkit / pygcode      {vs_py:8.1f}x   (target >= {TARGET_VS_PYGCODE:g}x)")
    print(f"labkit / gcodeparser  {vs_gp:8.1f}x   (target >= {TARGET_VS_GCODEPARSER:g}x)")
    print(f"Moves memory          {bytes_per_line:8.1f} bytes/line ({len(moves):,} moves, "
          f"{moves.nbytes / 1e6:.1f} MB; target <= {TARGET_BYTES_PER_LINE:g})")
    print(f"checks: moves {len(moves):,}, gcodeparser lines {len(gp):,}")
    ok = vs_py >= TARGET_VS_PYGCODE and vs_gp >= TARGET_VS_GCODEPARSER and \
        bytes_per_line <= TARGET_BYTES_PER_LINE
    print("targets met" if ok else "TARGETS NOT MET")
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
