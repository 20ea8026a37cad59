"""Raster benchmark: labkit vs its peers, measured in the same run, printed as ratios.

1. Edge detectors on a 4096×4096 image: labkit's Sobel, Prewitt and Roberts
   vs scikit-image's, time ratio (labkit / scikit-image, ≤ 1.0 wanted) and
   the largest difference after scikit-image's normalisation.
2. A 4096×4096 binary image to G-code, zig-zag and spiral: labkit vs a
   straightforward pure-Python implementation of the same algorithms
   (below, checked to give the same tool lines in the same order).
3. Connecting 100,000 segments greedily: grid index vs the seed's O(n²)
   scan, same order.
4. The whole command, ``labkit img2gcode --mode zigzag`` on a 4096×4096 PNG at one
   pixel per beam (a fresh process, as a user runs it), vs a plain pure-Python
   program that reads the same PNG with Pillow and scans its rows into G-code
   (boustrophedon runs, no reordering); ratio = pure Python / labkit, ≥ 2 wanted.
5. The preview of a raster job of ≥ 200,000 moves: the command line's
   (``labkit.viz.preview.write_job_preview``, numpy and Pillow) and the notebooks'
   (``save_job_preview``, matplotlib), ≤ 1 s wanted.

Run: .venv/bin/python benchmarks/bench_raster.py   (a few minutes; 2 cores)
"""

from __future__ import annotations

import sys
import time

import numpy as np
from skimage import data, filters, transform

from _process import process_time
from labkit.gcode import emit
from labkit.raster import (SKIMAGE_FACTOR, Segments, connect, mask_job, prewitt, roberts, sobel)
from labkit.raster.pathing import zigzag_segments

PIXEL_MM = 0.1
FEED = 1000.0
POWER = 1000.0


def best_of(fn, repeat=3):
    best, out = float("inf"), None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


# --------------------------------------------------------------------------- pure-Python baseline
# The same algorithms as labkit.raster.pathing, written the plain way: Python lists and loops.

def py_zigzag_runs(mask_rows, columns):
    """Runs of marked pixels per line, as ((x0, y0), (x1, y1)) in half-pixel units."""
    h = len(mask_rows)
    w = len(mask_rows[0])
    segs = []
    if columns:
        for c in range(w):
            r = 0
            while r < h:
                if mask_rows[r][c]:
                    r0 = r
                    while r < h and mask_rows[r][c]:
                        r += 1
                    segs.append(((2 * c + 1, 2 * (h - r)), (2 * c + 1, 2 * (h - r0))))
                else:
                    r += 1
    else:
        for r in range(h):
            row = mask_rows[r]
            c = 0
            while c < w:
                if row[c]:
                    c0 = c
                    while c < w and row[c]:
                        c += 1
                    y = 2 * (h - r) - 1
                    segs.append(((2 * c0, y), (2 * c, y)))
                else:
                    c += 1
    return segs


def py_spiral(mask_rows):
    """The seed's corner walk: bottom-left start, heading up, try left/straight/right."""
    h = len(mask_rows)
    w = len(mask_rows[0])
    free = [bytearray(row) for row in mask_rows]
    steps = [(-1, 0), (0, 1), (1, 0), (0, -1)]      # up, right, down, left (clockwise)
    paths = []
    for scan in range(h * w):
        r0, c0 = h - 1 - scan // w, scan % w
        if not free[r0][c0]:
            continue
        r, c, heading = r0, c0, 0
        free[r][c] = 0
        verts = [(r, c)]
        while True:
            for turn in (3, 0, 1):
                nh = (heading + turn) % 4
                rr, cc = r + steps[nh][0], c + steps[nh][1]
                if 0 <= rr < h and 0 <= cc < w and free[rr][cc]:
                    break
            else:
                if verts[-1] != (r, c):
                    verts.append((r, c))
                break
            if nh != heading:
                if verts[-1] != (r, c):
                    verts.append((r, c))
                heading = nh
            r, c = rr, cc
            free[r][c] = 0
        pts = [(2 * cc + 1, 2 * (h - rr) - 1) for rr, cc in verts]
        if len(pts) == 1:
            x, y = pts[0]
            pts = [(x - 1, y), (x + 1, y)]
        else:
            for end, nxt in ((0, 1), (-1, -2)):
                x, y = pts[end]
                nx, ny = pts[nxt]
                pts[end] = (x + (x > nx) - (x < nx), y + (y > ny) - (y < ny))
        paths.append(pts)
    return paths


def py_greedy(paths, reversible):
    """Seed 000's segment connection: nearest start (or end) to the current point, O(n²)."""
    remaining = list(range(len(paths)))
    x, y = 0, 0
    out = []
    while remaining:
        best = None
        for k, i in enumerate(remaining):
            sx, sy = paths[i][0]
            d = (sx - x) ** 2 + (sy - y) ** 2
            if best is None or d < best[0]:
                best = (d, k, False)
            if reversible:
                ex, ey = paths[i][-1]
                d = (ex - x) ** 2 + (ey - y) ** 2
                if d < best[0]:
                    best = (d, k, True)
        _, k, flip = best
        pts = paths[remaining.pop(k)]
        pts = pts[::-1] if flip else pts
        out.append(pts)
        x, y = pts[-1]
    return out


def py_gcode(ordered):
    lines = ["G21 G90", "M5", f"M3 S{POWER:g}"]
    scale = PIXEL_MM / 2
    pos = (0, 0)
    for pts in ordered:
        if pts[0] != pos:
            lines.append(f"G0 X{pts[0][0] * scale:.3f} Y{pts[0][1] * scale:.3f}")
        for x, y in pts[1:]:
            lines.append(f"G1 X{x * scale:.3f} Y{y * scale:.3f} F{FEED:g}")
        pos = pts[-1]
    lines += ["M5", "M2"]
    return "\n".join(lines) + "\n", ordered


def py_job(mask, mode):
    rows = mask.tolist()
    if mode == "zigzag":
        paths = [list(s) for s in py_zigzag_runs(rows, columns=mask.shape[0] >= mask.shape[1])]
        return py_gcode(py_greedy(paths, reversible=True))
    return py_gcode(py_greedy(py_spiral(rows), reversible=False))


def labkit_job(mask, mode):
    job = mask_job(mask, pixel_mm=PIXEL_MM, mode=mode, feed_mm_min=FEED, s_word=POWER)
    return emit(job.moves), job


def same_tool_lines(py_ordered, job):
    """The baseline's cuts, in order, equal labkit's laser-on moves."""
    scale = PIXEL_MM / 2
    a = np.array([p for pts in py_ordered for p in pts[:-1]], dtype=float) * scale
    b = np.array([p for pts in py_ordered for p in pts[1:]], dtype=float) * scale
    on = job.moves[job.moves.laser_on]
    return (len(a) == len(on) and np.allclose(on.start[:, :2], a) and np.allclose(on.end[:, :2], b))


# --------------------------------------------------------------------------- the benchmark

def bench_edges():
    print("1. edge detectors, 4096×4096 uint8 (camera, bilinear ×8); ratio = labkit / scikit-image")
    img = (transform.resize(data.camera(), (4096, 4096), order=1) * 255).round().astype(np.uint8)
    ours = {"sobel": sobel, "prewitt": prewitt, "roberts": roberts}
    theirs = {"sobel": filters.sobel, "prewitt": filters.prewitt, "roberts": filters.roberts}
    for name in ours:
        ours[name](img[:8, :8])  # compile outside the timing
        t_ours, a = best_of(lambda: ours[name](img))
        t_them, b = best_of(lambda: theirs[name](img))
        diff = float(np.abs(a / SKIMAGE_FACTOR[name] - b).max())
        print(f"   {name:8s} labkit {t_ours * 1e3:7.1f} ms   scikit-image {t_them * 1e3:7.1f} ms   "
              f"ratio {t_ours / t_them:5.3f}   max |diff| {diff:.1e}")


def compact_mask(size=4096):
    """The horse (scikit-image), nearest-upscaled: one compact island, like the seed's image A."""
    horse = ~data.horse()
    big = transform.resize(horse, (size, size), order=0, anti_aliasing=False)
    return big.astype(bool)


def bench_pipeline():
    mask = compact_mask()
    print(f"2. 4096×4096 binary image → G-code (horse, {int(mask.sum())} marked pixels); "
          f"ratio = pure Python / labkit")
    for mode, wanted in (("zigzag", 20), ("spiral", 10)):
        labkit_job(mask[:64, :64], mode)  # compile outside the timing
        t_ours, (text, job) = best_of(lambda: labkit_job(mask, mode))
        t0 = time.perf_counter()
        py_text, py_ordered = py_job(mask, mode)
        t_py = time.perf_counter() - t0
        ok = same_tool_lines(py_ordered, job)
        print(f"   {mode:7s} labkit {t_ours:6.3f} s   pure Python {t_py:7.2f} s   "
              f"speed-up {t_py / t_ours:6.1f}× (want ≥ {wanted}×)   segments {job.report.segments}, "
              f"G-code lines {text.count(chr(10))}, same tool lines: {ok}")


def diffuse_segments(n=100_000):
    """n zig-zag runs of a diffuse image (small blobs, like the seed's image B)."""
    blobs = data.binary_blobs(2048, blob_size_fraction=0.004, volume_fraction=0.5, rng=7)
    segs = zigzag_segments(blobs)
    if len(segs) < n:
        raise SystemExit(f"only {len(segs)} segments; need {n}")
    keep = 2 * n
    return Segments(segs.points[:keep], segs.offsets[:n + 1], segs.shape, segs.reversible)


def bench_connection():
    segs = diffuse_segments()
    print(f"3. greedy connection of {len(segs)} zig-zag segments (bidirectional); "
          f"ratio = O(n²) reference / indexed")
    small = Segments(segs.points[:200], segs.offsets[:101], segs.shape, True)
    connect(small, method="reference"), connect(small)  # compile
    t_idx, idx = best_of(lambda: connect(segs, method="indexed"))
    t0 = time.perf_counter()
    ref = connect(segs, method="reference")
    t_ref = time.perf_counter() - t0
    same = np.array_equal(ref.order, idx.order) and np.array_equal(ref.flipped, idx.flipped)
    print(f"   reference {t_ref:6.2f} s ({ref.examined:.3e} distances)   indexed {t_idx * 1e3:6.1f} ms "
          f"({idx.examined:.3e} distances)   speed-up {t_ref / t_idx:6.1f}× (want ≥ 50×)   "
          f"identical order: {same}")


PY_ROW_SCAN = r"""
import sys
from PIL import Image
im = Image.open(sys.argv[1]).convert("L")
w, h = im.size
data = im.tobytes()
px = 0.1
out = ["G21 G90", "M5", "M3 S1000"]
for r in range(h):
    row = data[r * w:(r + 1) * w]
    y = (h - r - 0.5) * px
    runs = []
    c = 0
    while c < w:
        if row[c] < 128:
            c0 = c
            while c < w and row[c] < 128:
                c += 1
            runs.append((c0, c))
        else:
            c += 1
    if r % 2:
        runs = [(b, a) for a, b in reversed(runs)]
    for a, b in runs:
        out.append(f"G0 X{a * px:.3f} Y{y:.3f}")
        out.append(f"G1 X{b * px:.3f} Y{y:.3f} F1000")
out += ["M5", "M2"]
with open(sys.argv[2], "w") as fh:
    fh.write("\n".join(out) + "\n")
"""


def bench_command():
    import tempfile
    from pathlib import Path

    from PIL import Image

    mask = compact_mask()
    print("4. labkit img2gcode --mode zigzag, 4096×4096 PNG at one pixel per beam (fresh process); "
          "ratio = pure-Python row scan / labkit")
    with tempfile.TemporaryDirectory() as tmp:
        png = str(Path(tmp) / "horse.png")
        Image.fromarray(np.where(mask, 0, 255).astype(np.uint8)).save(png, dpi=(254, 254))
        t_ours = process_time([sys.executable, "-m", "labkit", "img2gcode", png,
                               "-o", str(Path(tmp) / "a.gcode"), "--mode", "zigzag",
                               "--beam", "0.1", "--preview", "none", "--force"], repeat=2)
        t_py = process_time([sys.executable, "-c", PY_ROW_SCAN, png, str(Path(tmp) / "b.gcode")],
                            repeat=2)
    print(f"   labkit {t_ours:6.2f} s   pure-Python row scan {t_py:6.2f} s   "
          f"speed-up {t_py / t_ours:5.2f}× (want ≥ 2×)")


def bench_preview():
    import tempfile
    from pathlib import Path

    from labkit.viz.preview import write_job_preview
    from labkit.viz.raster import save_job_preview

    rng = np.random.default_rng(3)
    mask = rng.random((700, 700)) < 0.5
    job = mask_job(mask, pixel_mm=0.1, mode="zigzag", feed_mm_min=FEED, s_word=POWER)
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "p.png"
        save_job_preview(job, out)                       # loads matplotlib and the kernels
        write_job_preview(job, out)
        t_mpl, _ = best_of(lambda: save_job_preview(job, out))
        t_pil, _ = best_of(lambda: write_job_preview(job, out))
    print(f"5. preview of a {len(job.moves):,}-move raster job: the command line's (numpy + Pillow) "
          f"{t_pil:5.2f} s, the notebooks' (matplotlib) {t_mpl:5.2f} s (want ≤ 1 s)")


if __name__ == "__main__":
    only = sys.argv[1:]             # e.g. `bench_raster.py command preview`
    for name, fn in (("edges", bench_edges), ("pipeline", bench_pipeline),
                     ("connection", bench_connection), ("command", bench_command),
                     ("preview", bench_preview)):
        if not only or name in only:
            fn()
