"""Motion benchmark: planning speed per planner, Bresenham lines against scikit-image.

    .venv/bin/python benchmarks/bench_motion.py [--blocks N] [--lines N] [--repeat R]

1. Planning: a real raster job — scikit-image's ``camera`` photograph engraved
   by ``labkit.raster.gray_job`` (0.1 mm pixels, power follows darkness, one
   G1 per power change) — repeated row-block by row-block until it holds
   ``--blocks`` moves (default 1 000 000), then planned from Moves to profiles
   (blocks, look-ahead, profiles) with GRBL's junction-deviation planner and
   each of [CBR40]'s MBLA modes. Prints blocks per second.
2. Bresenham: ``--lines`` random lines (default 1 000 000, end points in a
   64 × 64 grid) drawn by ``skimage.draw.line`` one call per line (its API),
   by labkit's batch ``lines_points`` and by its numpy closed form, all in this
   run; prints lines per second and the ratio to scikit-image, after checking
   that all three give the same points.

Times are the best of ``--repeat`` runs (wall clock, one process).
"""

from __future__ import annotations

import argparse
import time

import numpy as np


def _best(fn, repeat):
    best = float("inf")
    out = None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def raster_job(n_blocks: int):
    """The camera photograph as a gray engraving, tiled in Y until it has n_blocks moves."""
    from skimage import data

    from labkit.raster import gray_job
    from labkit.toolpath import Moves

    base = gray_job(data.camera(), pixel_mm=0.1, feed_mm_min=1500.0).moves
    height = float(base.bounds()[1, 1] - base.bounds()[0, 1]) + 0.1
    parts, total, k = [], 0, 0
    while total < n_blocks:
        shift = np.array([0.0, k * height, 0.0])
        part = base.copy()
        part.start[:] += shift
        part.end[:] += shift
        parts.append(part)
        total += len(part)
        k += 1
    job = Moves.concat(parts)
    job = job[:n_blocks]
    # join the tiles: each tile starts where the previous one ended
    job.start[1:] = job.end[:-1]
    return job


def bench_planning(n_blocks: int, repeat: int) -> None:
    from labkit.motion import build_blocks, plan

    t0 = time.perf_counter()
    job = raster_job(n_blocks)
    t_job = time.perf_counter() - t0
    print(f"raster job: {len(job)} moves from skimage.data.camera() (built in {t_job:.2f} s)")
    t_blocks, blocks = _best(lambda: build_blocks(job), repeat)
    print(f"  build_blocks            {t_blocks:8.3f} s  {len(blocks) / t_blocks:12,.0f} blocks/s")
    for planner in ("junction", "fast", "normal", "hq"):
        plan(blocks[:1000], planner=planner)        # compile outside the timing
        t, p = _best(lambda: plan(blocks, planner=planner), repeat)
        s = p.summary()
        print(f"  plan {planner:<9} ({s.law:>6})  {t:8.3f} s  {len(blocks) / t:12,.0f} blocks/s"
              f"   (with build_blocks: {len(blocks) / (t + t_blocks):12,.0f} blocks/s)"
              f"   job {s.job_time_s / 3600:6.2f} h, {s.super_blocks} super blocks")


def bench_lines(n_lines: int, repeat: int) -> None:
    from skimage.draw import line

    from labkit.motion.bresenham import lines_points, lines_points_closed_form

    rng = np.random.default_rng(12345)
    starts = rng.integers(0, 64, (n_lines, 2))
    ends = rng.integers(0, 64, (n_lines, 2))
    lines_points(starts[:10], ends[:10])             # compile outside the timing

    s_list, e_list = starts.tolist(), ends.tolist()    # Python ints: skimage's fastest call

    def sk():
        total = 0
        for (x0, y0), (x1, y1) in zip(s_list, e_list):
            rr, cc = line(y0, x0, y1, x1)
            total += len(rr)
        return total

    t_sk, sk_points = _best(sk, repeat)
    t_lk, (pts, off) = _best(lambda: lines_points(starts, ends), repeat)
    t_cf, (pts2, _) = _best(lambda: lines_points_closed_form(starts, ends), 1)
    # same points, line by line (a sample of 10 000 lines, and the totals)
    assert np.array_equal(pts, pts2)
    assert sk_points == len(pts)
    for j in rng.choice(n_lines, 10_000, replace=False):
        rr, cc = line(s_list[j][1], s_list[j][0], e_list[j][1], e_list[j][0])
        seg = pts[off[j]:off[j + 1]]
        assert np.array_equal(seg[:, 0], cc) and np.array_equal(seg[:, 1], rr)
    print(f"Bresenham: {n_lines:,} random lines in a 64 × 64 grid, {len(pts):,} points (identical in all three)")
    print(f"  skimage.draw.line (one call per line)  {t_sk:8.3f} s  {n_lines / t_sk:14,.0f} lines/s   1.00×")
    print(f"  labkit lines_points (batch)            {t_lk:8.3f} s  {n_lines / t_lk:14,.0f} lines/s  "
          f"{t_sk / t_lk:5.2f}× skimage")
    print(f"  labkit lines_points_closed_form (numpy){t_cf:8.3f} s  {n_lines / t_cf:14,.0f} lines/s  "
          f"{t_sk / t_cf:5.2f}× skimage")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description="labkit.motion benchmark")
    ap.add_argument("--blocks", type=int, default=1_000_000, help="blocks of the raster job to plan")
    ap.add_argument("--lines", type=int, default=1_000_000, help="random lines for Bresenham")
    ap.add_argument("--repeat", type=int, default=3, help="runs per timing (best kept)")
    args = ap.parse_args(argv)
    bench_planning(args.blocks, args.repeat)
    bench_lines(args.lines, args.repeat)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
