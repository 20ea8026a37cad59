"""Compile labkit's kernels once, before parallel test workers start.

In a fresh clone numba's cache is empty: each test worker would compile the same
kernels for itself (minutes of CPU each on a 2-core machine), and a command under a
time ceiling in a subprocess test pays for it too. ``tests/conftest.py`` runs the two
groups below side by side, as commands with ``LABKIT_JIT=compiled``, before the
workers start; they fill the cache with the same argument types the tests use, and
every later process loads the kernels instead of compiling them. A failure here only
leaves a kernel to be compiled later; the tests decide what is right.

Run by hand:  .venv/bin/python tests/_warm_kernels.py [gcode|raster]
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "data" / "gcode" / "cncjs"

GROUPS = {
    "gcode": [
        ["check", DATA / "jsdc-laser.gcode"],
        ["info", DATA / "Circle_Diamond_Square_Calibration.gcode", "--lenient"],
        ["preview", DATA / "tball-engrave-laser.gcode", "-o", "{tmp}/p.png"],
        ["plan", DATA / "Circle_Diamond_Square_Calibration.gcode", "--lenient"],
        ["steps", DATA / "jsdc-laser.gcode", "-o", "{tmp}/s.txt"],
    ],
    "vector": [
        ["svg2gcode", DATA / "jsdc.svg", "-o", "{tmp}/a.gcode"],
        ["svg2gcode", DATA / "jsdc.svg", "-o", "{tmp}/b.gcode", "--fit", "biarc"],
        ["dxf2gcode", ROOT / "data" / "dxf" / "parts_mm.dxf", "-o", "{tmp}/c.gcode", "--force"],
    ],
    "raster": [
        ["img2gcode", DATA / "jsdc.png", "-o", "{tmp}/" + mode + ".gcode", "--mode", mode,
         "--force"] for mode in ("zigzag", "spiral", "edges", "gray", "dither")
    ],
}


def warm(group: str) -> list[str]:
    """Run the group's commands; returns the ones that failed (one line each)."""
    env = dict(os.environ, LABKIT_JIT="compiled", PYTHONPATH=str(ROOT))
    failed = []
    with tempfile.TemporaryDirectory() as tmp:
        for args in GROUPS[group]:
            argv = [str(a).format(tmp=tmp) for a in args]
            done = subprocess.run([sys.executable, "-m", "labkit", *argv], env=env, cwd=ROOT,
                                  capture_output=True, text=True, timeout=900)
            if done.returncode != 0:
                failed.append(f"labkit {' '.join(argv[:1])}: {done.stderr.strip()[-200:]}")
    return failed


def warm_all(timeout_s: float = 900) -> list[str]:
    """All groups side by side (one process each)."""
    procs = [subprocess.Popen([sys.executable, __file__, g], cwd=ROOT, stdout=subprocess.PIPE,
                              stderr=subprocess.STDOUT, text=True) for g in GROUPS]
    notes = []
    for p in procs:
        try:
            out, _ = p.communicate(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            p.kill()
            out = "timed out"
        if p.returncode:
            notes.append(out.strip())
    return notes


def warm_once() -> list[str]:
    """:func:`warm_all` unless this kernel cache was warmed already (the cache folder is keyed
    by labkit's sources, so an edit starts a fresh one); a clean warm-up is recorded there."""
    import labkit  # noqa: F401  (sets NUMBA_CACHE_DIR)

    cache = os.environ.get("NUMBA_CACHE_DIR")
    marker = Path(cache) / "warmed" if cache else None
    if marker is not None and marker.exists():
        return []
    notes = warm_all()
    if marker is not None and not notes:
        marker.write_text("tests/_warm_kernels.py ran here\n")
    return notes


if __name__ == "__main__":
    if sys.argv[1:] == ["--once"]:
        problems = warm_once()
    else:
        problems = warm(sys.argv[1]) if len(sys.argv) > 1 else warm_all()
    print("\n".join(problems))
    sys.exit(1 if problems else 0)
