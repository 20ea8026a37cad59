"""Preview benchmark (issue 29): what drawing the PNG adds to a command, against the same
command without it and against the matplotlib drawing it replaced, measured in the same run.

Every figure is a fresh process as a user runs it (best of 3 after a warm-up: numba's cache
and Python's bytecode filled), as CPU time (user + system: what the command costs whatever
else the 2 cores run) with the wall time beside it.

1. ``labkit preview`` of a 200,000-move job (100,000 burning G1 and 100,000 G0 lines, the
   hostile suite's job) against ``labkit info`` on the same file (the same read and parse,
   no drawing): the difference is what the preview adds (≤ 0.3 s wanted), and the old
   drawing (``labkit.viz.gcode.save_preview``, matplotlib) after the same parse.
2. The same for cncjs's 2,418-line laser job (data/gcode/cncjs/jsdc-laser.gcode) and
   ``python -c "import numpy"`` (the floor of any numpy command).
3. ``labkit img2gcode --mode zigzag`` on a 4096 × 4096 binary PNG at one pixel per beam,
   with its default preview and with ``--preview none``, against bench_raster's pure-Python
   row scan of the same pixels (≥ 3× wanted, both ways).

Run: .venv/bin/python benchmarks/bench_preview.py [moves|small|img2gcode]   (a few minutes)
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np

from _process import ROOT
from bench_raster_gray import usage

PY = sys.executable
#: The drawing labkit preview did before issue 29: parse, then matplotlib's figure.
MATPLOTLIB_PREVIEW = ("import sys; from labkit.gcode import parse; from labkit.viz.gcode import save_preview; "
                      "save_preview(parse(open(sys.argv[1], 'rb').read(), filename=sys.argv[1]), sys.argv[2])")


def _row(name, figures, reference=None):
    wall, cpu, rss = figures
    extra = "" if reference is None else f"   adds {cpu - reference[1]:+6.2f} s CPU"
    print(f"   {name:38s} CPU {cpu:6.2f} s   wall {wall:6.2f} s   peak {rss:5.0f} MB{extra}")


def _preview_against_info(job, tmp, label, floor=False):
    png = str(Path(tmp) / "p.png")
    info = usage([PY, "-m", "labkit", "info", str(job)], repeat=3)
    ours = usage([PY, "-m", "labkit", "preview", str(job), "-o", png], repeat=3)
    old = usage([PY, "-c", MATPLOTLIB_PREVIEW, str(job), str(Path(tmp) / "m.png")], repeat=3)
    print(label)
    if floor:
        _row('python -c "import numpy"', usage([PY, "-c", "import numpy"], repeat=3))
    _row("labkit info (no drawing)", info)
    _row("labkit preview (numpy + Pillow)", ours, info)
    _row("parse + matplotlib save_preview", old, info)
    print(f"   the preview adds {ours[1] - info[1]:.2f} s CPU (want ≤ 0.3 s); matplotlib's added "
          f"{old[1] - info[1]:.2f} s: {(old[1] - info[1]) / max(ours[1] - info[1], 1e-3):.1f}× as much")


def bench_moves():
    with tempfile.TemporaryDirectory() as tmp:
        job = Path(tmp) / "raster.gcode"
        with open(job, "w") as fh:
            fh.write("G21 G90 M3 S500 F3000\n")
            for k in range(100_000):
                fh.write(f"G1 X{50 * (k % 2 == 0)} Y{k * 0.01:.2f}\n"
                         f"G0 X{50 * (k % 2 == 0)} Y{(k + 1) * 0.01:.2f}\n")
        _preview_against_info(job, tmp, "1. a 200,000-move job (200,001 lines), fresh process, best of 3")


def bench_small():
    job = ROOT / "data" / "gcode" / "cncjs" / "jsdc-laser.gcode"
    with tempfile.TemporaryDirectory() as tmp:
        _preview_against_info(job, tmp, "2. cncjs's jsdc-laser.gcode (2,418 lines), fresh process, best of 3",
                              floor=True)


def bench_img2gcode():
    from PIL import Image

    from bench_raster import PY_ROW_SCAN, compact_mask

    mask = compact_mask()
    with tempfile.TemporaryDirectory() as tmp:
        png = str(Path(tmp) / "horse.png")
        Image.fromarray(np.where(mask, 0, 255).astype(np.uint8)).save(png, dpi=(254, 254))
        command = [PY, "-m", "labkit", "img2gcode", png, "-o", str(Path(tmp) / "a.gcode"), "--mode", "zigzag",
                   "--beam", "0.1", "--force"]
        rows = {"pure-Python row scan": usage([PY, "-c", PY_ROW_SCAN, png, str(Path(tmp) / "b.gcode")], repeat=3),
                "labkit --preview none": usage(command + ["--preview", "none"], repeat=3),
                "labkit, default preview": usage(command, repeat=3)}
    print(f"3. img2gcode --mode zigzag, 4096 × 4096 PNG (horse, {int(mask.sum()):,} marked pixels), "
          "fresh process, best of 3")
    scan = rows["pure-Python row scan"]
    for name, figures in rows.items():
        _row(name, figures, None if name == "pure-Python row scan" else rows["labkit --preview none"]
             if name == "labkit, default preview" else None)
    for name in ("labkit --preview none", "labkit, default preview"):
        wall, cpu, _ = rows[name]
        print(f"   row scan / {name}: {scan[1] / cpu:4.2f}× CPU, {scan[0] / wall:4.2f}× wall (want ≥ 3×)")


if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).parent))
    only = sys.argv[1:]
    for name, fn in (("moves", bench_moves), ("small", bench_small), ("img2gcode", bench_img2gcode)):
        if not only or name in only:
            fn()
