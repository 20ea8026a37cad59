"""Gray-mode benchmark (issue 27): an ordinary photo to G-code, time and memory, against a
plain peer measured in the same run.

The photo is data/images/photo_500x450_72dpi.jpg (500 × 450 px at 72 dpi: a 176 × 159 mm
job, 1764 × 1587 beam pixels at 0.1 mm, about 2.26 million moves — one per change of power).

1. The whole command, ``labkit img2gcode --mode gray``, with its default preview and without,
   as a user runs it (a fresh process, best of 2 after a warm-up): CPU time (user + system,
   what the command costs whatever else the 2 cores run), wall time and peak resident memory;
   against a plain program that reads the JPEG with Pillow, resizes it bicubically to the beam
   with Pillow, maps darkness to S with numpy and writes one G1 per run of equal S in Python
   (bidirectional lines, no overscan, no white skipping, no report: less work than labkit).
   Ratios without the preview: CPU peer / labkit, memory labkit / peer (what labkit's imports,
   its Moves model and the job summary cost on top of writing the text).
2. Where labkit's time goes, in one process (kernels and imports warm): reading, the job
   (resampling, power map, scan lines into Moves, summary), the G-code text, the preview;
   and the Moves' bytes per move.

Issue 27 measured 25 s and 1.1 GB for this command before the fix (the scan's cuts were
held as arrays, then copied into Moves; the summary copied every column twice; the preview
rasterised all moves at once). A second round (issue 29's previews) took it, measured
alternately in the same minutes on the loaded 2-core machine, from 4.2 s CPU and 800 MB
(3.1 s, 656 MB without the preview) to 3.3 s and 600 MB (2.8 s, 580 MB): the preview drawn
with numpy and Pillow instead of matplotlib (whose import and 2.8-megapixel image were the
peak), the summary and the G-code text made in blocks of rows instead of full-length
temporaries. What remains is the Moves (123 B a move), scikit-image's resampling and numba.
A third round (issue 27 with issue 30's compact text; ``--before`` at 6ab2a74, alternately in one
run at load 10–11): without the preview 2.63 s CPU and 529 MB before, 2.10 s and 340 MB after
(with it 2.95 s / 548 MB → 2.48 s / 410 MB; the preview's own cost is issue 29's): a move now
holds 29 B instead of 87 (start and end are views of one array of points; feed, laser mode,
arc centre and plane, one value for the whole job, are views of that value), the writer checks
whole columns by their min and max instead of a second of temporaries, scikit-image is no
longer imported (its resize is two scipy calls), the power map works in one array, and the text
is a fifth smaller. Left: numba (imported for the scan and the writer: ~70 MB and 0.5 s of
loading), scipy.ndimage (~30 MB, 0.2 s), the job summary (0.15 s) and the preview.

Run: .venv/bin/python benchmarks/bench_raster_gray.py   (about a minute; 2 cores)
     .venv/bin/python benchmarks/bench_raster_gray.py --before DIR   (also the command of another
     labkit tree, e.g. ``git archive <commit> | tar -x -C DIR``, run alternately in the same minutes:
     before and after measured under the same load)
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from _process import ROOT

PHOTO = ROOT / "data" / "images" / "photo_500x450_72dpi.jpg"

#: The plain peer: Pillow, numpy, and a Python loop writing the text.
PEER = r"""
import sys
import numpy as np
from PIL import Image

src, out = sys.argv[1], sys.argv[2]
beam = 0.1
im = Image.open(src).convert("L")
dpi = im.info.get("dpi", (96, 96))[0]
cols = round(im.width * 25.4 / dpi / beam)
rows = round(im.height * 25.4 / dpi / beam)
gray = np.asarray(im.resize((cols, rows), Image.BICUBIC), dtype=float)
power = np.rint(1000 * (1 - gray / 255)).astype(int)
lines = ["G21 G90", "M4 S0", "F1000"]
for k, r in enumerate(range(rows - 1, -1, -1)):
    row = power[r].tolist()
    y = (rows - r - 0.5) * beam
    order = range(cols) if k % 2 == 0 else range(cols - 1, -1, -1)
    first = order[0]
    lines.append(f"G0 X{(first if k % 2 == 0 else first + 1) * beam:.3f} Y{y:.3f}")
    c_prev, s_prev = None, None
    for c in order:
        s = row[c]
        if s_prev is not None and s != s_prev:
            x = c * beam if k % 2 == 0 else (c + 1) * beam
            lines.append(f"G1 X{x:.3f} S{s_prev}")
        s_prev = s
    end = cols * beam if k % 2 == 0 else 0.0
    lines.append(f"G1 X{end:.3f} S{s_prev}")
lines += ["M5", "M2"]
with open(out, "w") as fh:
    fh.write("\n".join(lines) + "\n")
"""

#: Runs argv as a child; prints its wall time, CPU time (user + system) and peak resident memory.
CHILD_USAGE = (
    "import resource, subprocess, sys, time; t = time.perf_counter(); "
    "r = subprocess.run(sys.argv[1:], capture_output=True); t = time.perf_counter() - t; "
    "u = resource.getrusage(resource.RUSAGE_CHILDREN); "
    "sys.exit(r.stderr.decode()) if r.returncode else print(t, u.ru_utime + u.ru_stime, u.ru_maxrss)")


def usage(argv, repeat=2, root=ROOT):
    """Best wall and CPU seconds and the peak resident MB of ``argv`` as a fresh process, after
    a warm-up run (compiled kernels and bytecode cached, as on a user's second run). CPU time
    is what the command costs whatever else the machine runs; wall time shows the waiting.
    ``root``: the labkit tree that runs it."""
    env = dict(os.environ, PYTHONPATH=str(root))
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    runs = []
    for _ in range(repeat + 1):
        done = subprocess.run([sys.executable, "-c", CHILD_USAGE, *argv], cwd=root, capture_output=True,
                              text=True, env=env)
        if done.returncode:
            raise SystemExit(f"{' '.join(argv)} failed:\n{done.stderr}")
        wall, cpu, rss_kb = done.stdout.split()[-3:]
        runs.append((float(wall), float(cpu), int(rss_kb) / 1024.0))
    runs = runs[1:]
    return min(r[0] for r in runs), min(r[1] for r in runs), max(r[2] for r in runs)


def bench_command(before=None):
    print("1. labkit img2gcode --mode gray, 500 × 450 px photo at 72 dpi (176 × 159 mm at 0.1 mm), "
          "fresh process, best of 2")
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "a.gcode"
        ours = [sys.executable, "-m", "labkit", "img2gcode", str(PHOTO), "-o", str(out), "--mode", "gray",
                "--force"]
        peer = [sys.executable, "-c", PEER, str(PHOTO), str(Path(tmp) / "b.gcode")]
        rows = {}
        if before:
            rows["before, with its preview"] = usage(ours, root=before)
        rows["labkit, with its preview"] = usage(ours)
        if before:
            rows["before --preview none"] = usage(ours + ["--preview", "none"], root=before)
        rows["labkit --preview none"] = usage(ours + ["--preview", "none"])
        rows["plain Pillow + Python"] = usage(peer)
        lines = sum(1 for _ in open(out))
    for name, (wall, cpu, rss) in rows.items():
        print(f"   {name:26s} CPU {cpu:5.2f} s   wall {wall:5.2f} s   peak {rss:5.0f} MB")
    _, cpu_ours, rss_ours = rows["labkit --preview none"]
    _, cpu_peer, rss_peer = rows["plain Pillow + Python"]
    print(f"   {lines:,} G-code lines; without the preview: CPU peer / labkit {cpu_peer / cpu_ours:4.2f}×, "
          f"memory labkit / peer {rss_ours / rss_peer:4.2f}×")


def _held_bytes(moves) -> int:
    """Bytes allocated for the Moves' columns: each underlying array once (start and end of a
    gray job are views of one array; a column of one value is a view of that value). Columns
    of zeros nobody writes are counted though the system gives them no memory until written."""
    roots = {}
    for name in moves.column_names():
        root = getattr(moves, name)
        while root.base is not None and isinstance(root.base, np.ndarray):
            root = root.base
        roots[id(root)] = root.nbytes
    return sum(roots.values())


def bench_stages():
    from labkit.gcode import emit
    from labkit.raster.engrave import RasterSettings, image_to_job, placed_size
    from labkit.raster.io import read_image
    from labkit.viz.preview import write_job_preview

    def job():
        img = read_image(PHOTO)
        size = placed_size(img.pixels.shape, file_dpi=img.dpi, pixel_aspect=img.pixel_aspect)[2]
        return image_to_job(img, RasterSettings(mode="gray", beam_mm=0.1, feed_mm_min=1000.0, **size))

    with tempfile.TemporaryDirectory() as tmp:
        warm = job()                                  # imports, kernels
        write_job_preview(warm, Path(tmp) / "w.png")
        del warm
        times = {}
        t = time.perf_counter()
        read_image(PHOTO)
        times["read"] = time.perf_counter() - t
        t = time.perf_counter()
        j = job()
        times["job (incl. read)"] = time.perf_counter() - t
        t = time.perf_counter()
        text = emit(j.moves, compact=True)          # what the command writes
        times["G-code text"] = time.perf_counter() - t
        t = time.perf_counter()
        write_job_preview(j, Path(tmp) / "p.png")
        times["preview"] = time.perf_counter() - t
    print(f"2. stages in one process (warm): {len(j.moves):,} moves, "
          f"{_held_bytes(j.moves) / len(j.moves):.0f} B per move allocated, {len(text) / 1e6:.1f} MB of text")
    print("   " + "   ".join(f"{k} {v:5.2f} s" for k, v in times.items()))


if __name__ == "__main__":
    args = sys.argv[1:]             # e.g. `bench_raster_gray.py command --before /tmp/old`
    before = None
    if "--before" in args:
        at = args.index("--before")
        before = Path(args[at + 1]).resolve()
        del args[at:at + 2]
    if not args or "command" in args:
        bench_command(before)
    if not args or "stages" in args:
        bench_stages()
