"""Small jobs from the command line: ``labkit check``, ``info`` and ``svg2gcode`` on a
file of a few thousand lines, against starting Python and parsing the same file with a
pure-Python G-code parser (gcodeparser), measured in the same run and printed as ratios.

Each command runs as a fresh process (what a student or a script pays), best of
``--repeat`` after one warm-up run that fills the bytecode and numba caches. The
reference is ``python -c pass`` plus gcodeparser's ``parse_gcode_lines`` over the file
(import included), also as one process; the target is a ratio ≤ 2. A big file
(898 KB, 40,299 lines) is timed too: above the size where kernels run as Python it
loads the compiled kernel, so its time shows what the small-file path saves. Starting
Python and importing numpy is printed too: every labkit command works on numpy arrays,
so that is the floor no command can go below.

Run:  .venv/bin/python benchmarks/bench_startup.py [--repeat K]
(``make bench`` installs gcodeparser first: ``pip install -e '.[bench]'``.)
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

from _process import ROOT, process_time

SMALL = ROOT / "data" / "gcode" / "cncjs" / "jsdc-laser.gcode"
BIG = ROOT / "data" / "gcode" / "cncjs" / "tball-pocket-laser.gcode"
SVG = ROOT / "data" / "gcode" / "cncjs" / "jsdc.svg"
TARGET_RATIO = 2.0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    py = sys.executable
    lines = SMALL.read_bytes().count(b"\n")
    t_pass = process_time([py, "-c", "pass"], args.repeat)
    reference = process_time([py, "-c", "import sys; from gcodeparser import parse_gcode_lines; "
                              "list(parse_gcode_lines(open(sys.argv[1]).read()))", str(SMALL)],
                             args.repeat)
    t_numpy = process_time([py, "-c", "import numpy"], args.repeat)
    print(f"python -c pass                              {t_pass * 1e3:7.0f} ms")
    print(f"python + gcodeparser on {SMALL.name} ({lines} lines)"
          f" {reference * 1e3:5.0f} ms   (the reference)")
    # labkit's data model is numpy arrays: no command can start faster than this.
    print(f"python -c 'import numpy'                    {t_numpy * 1e3:7.0f} ms   "
          f"ratio {t_numpy / reference:4.2f} (the floor of any command using numpy)")
    worst = 0.0
    with tempfile.TemporaryDirectory() as tmp:
        out = str(Path(tmp) / "out.gcode")
        cases = [("check", [str(SMALL)]), ("info", [str(SMALL)]),
                 ("svg2gcode", [str(SVG), "-o", out])]
        for name, rest in cases:
            t = process_time([py, "-m", "labkit", name, *rest], args.repeat)
            ratio = t / reference
            worst = max(worst, ratio)
            print(f"labkit {name:<10} {Path(rest[0]).name:<26}      {t * 1e3:7.0f} ms   "
                  f"ratio {ratio:4.2f} (target ≤ {TARGET_RATIO:g})")
        t_big = process_time([py, "-m", "labkit", "check", str(BIG)], args.repeat)
        big_lines = BIG.read_bytes().count(b"\n")
        print(f"labkit check      {BIG.name} ({big_lines} lines, compiled) {t_big * 1e3:7.0f} ms")
    print(f"worst ratio {worst:.2f}: {'met' if worst <= TARGET_RATIO else 'NOT met'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
