"""Compact raster G-code (issue 30 §3): bytes per burned pixel and per S change, and the highest
feed the serial link lets each format run without a starvation — labkit's compact format against
its readable one and a LaserGRBL-style format, on a photo (gray) and a dithered image; every
program read back and burned, so no format wins by burning less.

The images: data/images/photo_500x450_72dpi.jpg (a camera photo, public domain) at its own
72 dpi and a 0.1 mm beam: 1764 × 1587 pixels, in gray mode (power follows darkness) and
dithered (Floyd–Steinberg dots at full power), 6,000 mm/min.

The LaserGRBL-style formatter (``_lasergrbl.py``) follows how LaserGRBL builds a grayscale
line-to-line job, read in its own source (arkypita/LaserGRBL ``GrblFile.cs``, never copied):
absolute X, one ``X… S…`` line per run of equal power, three decimals at most, ``G1`` after
each white gap, white runs and row changes gathered into one ``G0 X… Y… S0``, a lone ``S0``
after a row that ends burning, whole rows scanned in both directions. An earlier version of
this benchmark followed a file LaserGRBL wrote (shown in a third-party README) and counted the
file's bytes, spaces included (a share of 0.76 for the gray photo); LaserGRBL's sender strips the spaces
(``GrblCommand.SerialData``), so the bytes that matter — those on the link, which the
controller must receive and which decide stalls — are counted here as each program's own
sender sends them (labkit's ``labkit stream``: comments and spaces removed; LaserGRBL's: the
same). The file's bytes are printed beside them. LightBurn's GRBL output is not documented
publicly in enough detail to reproduce, so it is not compared.

An S change is one run of equal S between a row's first and last burned pixel (white runs
inside a row count): the same count for every format, a property of the image. The floor is
what any GRBL program needs for those runs: GRBL takes one S word per line (a second is
error 25) and each run needs a motion, so one line per run with the shortest axis word, the
S word and the line end. On the gray photo nearly every pixel has its own three-digit S, so
the floor is 7.96 link bytes per S change, 0.79 of the LaserGRBL-style program's 10.10: the
issue's 0.60 cannot be reached without changing the burn (coarser S steps, or fewer of them).
Measured (2 cores, shared; bytes on the link, the file's in brackets):

    image   format            B/burned px  B/S change  share of LaserGRBL-style
    gray    labkit compact        6.84        8.47       0.84  (file 0.76)
    gray    LaserGRBL-style       8.15       10.10       1.00
    gray    floor, any program                7.96       0.79
    dither  labkit compact        7.57        8.03       0.54  (file 0.47)
    dither  LaserGRBL-style      13.90       14.75       1.00
    dither  floor, any program                7.51       0.51

The stall-free feed per format is measured on the firmware's paced host simulator
(``labkit-fw-sim --baud``) with GRBL's stream.py counting characters, on the machine
``labkit-diode`` (grbl-diode's belts on the labkit firmware: 6,000 mm/min, 2,000 mm/s², a
34-block look-ahead), for a 20 mm wide print of the same photo (200 × 180 pixels at 0.1 mm,
about 33,000 lines): each program at a feed streamed, starvations counted, the feed raised or
lowered 3 % at a time and then halved to 1 %; beside it the stall predictor's figure
(``labkit.motion.stall.stall_free_feed`` with stream.py's byte counts). The simulator is told
what stream.py writes (``--expect``), so load on the machine does not move these figures;
stops of at most a byte's time, no more of them than stream.py's ``?``s, are the ``?``'s and
do not count. Measured (2026-12-06, after the simulator's main loop was made to run between
ticks as on the board): at 115200 baud both formats stream without a starvation up to the
machine's 6,000 mm/min; at 57600 labkit compact 4,375 mm/min (predicted 4,279, 2.2 % low) and
LaserGRBL-style 3,973 (predicted 3,858, 2.9 % low): 1.10 times the feed. (Before that fix the
simulator read a line's last bytes and sent its ``ok`` a batch of ticks late: 4,248 and
3,691–3,718, and a 2 ms stop at line 33,124 of the LaserGRBL-style job no prediction had.)

Run: .venv/bin/python benchmarks/bench_raster_gcode.py [--no-stream]   (about 10 minutes; 2 cores:
2.5 for the formats, the rest streaming)
"""

from __future__ import annotations

import argparse
import importlib.util
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from _lasergrbl import lasergrbl_line_to_line, lasergrbl_number, lasergrbl_sent_bytes
from _process import ROOT

PHOTO = ROOT / "data" / "images" / "photo_500x450_72dpi.jpg"
FEED_MM_MIN = 6000.0
PITCH_MM = 0.1
#: Issue 30 §3: bytes per S change at most this share of the LaserGRBL-style format's.
TARGET_SHARE = 0.60
#: The paced simulator's machine, the print's width and the link speeds streamed.
STREAM_MACHINE = "labkit-diode"
STREAM_WIDTH_MM = 20.0
STREAM_BAUDS = (115200, 57600)


def _row_runs(row: np.ndarray):
    """Runs of equal S from a row's first to its last burned pixel: (start, end) pixel arrays
    and the S of each run; None for a row with nothing burned."""
    burned = np.flatnonzero(row)
    if not len(burned):
        return None
    a, b = int(burned[0]), int(burned[-1]) + 1
    cut = np.flatnonzero(np.diff(row[a:b])) + a + 1
    starts, ends = np.r_[a, cut], np.r_[cut, b]
    return starts, ends, row[starts]


def s_changes(power: np.ndarray) -> int:
    """Runs of equal S between each row's first and last burned pixel."""
    return sum(len(found[0]) for found in map(_row_runs, power) if found is not None)


def fewest_bytes(power: np.ndarray, pitch_mm: float) -> int:
    """A floor for any GRBL program burning ``power`` run by run: GRBL takes one motion and one
    S a line, so each run of equal S needs at least its axis word (the shorter of the absolute
    end and the unsigned relative length, without a leading 0), its S word and a line end."""
    total = 0
    for found in map(_row_runs, power):
        if found is None:
            continue
        for start, end, value in zip(*(column.tolist() for column in found)):
            rel = lasergrbl_number((end - start) * pitch_mm).lstrip("0") or "0"
            ab = lasergrbl_number(end * pitch_mm)
            ab = ab[1:] if ab.startswith("0.") else ab
            total += 1 + min(len(rel), len(ab)) + 1 + len(str(int(value))) + 1
    return total


def _burns_the_target(text: str, target: np.ndarray) -> bool:
    from labkit.gcode import parse
    from labkit.raster.coverage import burn_map

    count, power = burn_map(parse(text), target.shape, PITCH_MM)
    burned = target > 0
    return bool(np.array_equal(count, burned.astype(count.dtype)) and np.array_equal(power[burned], target[burned]))


def _formats(job):
    """name -> (make the program, bytes its sender puts on the link)."""
    from labkit.gcode import emit
    from labkit.motion.stall import sent_line_bytes

    def labkit_sent(text):
        return int(sent_line_bytes(text).sum())

    return {"labkit compact": (lambda: emit(job.moves, compact=True), labkit_sent),
            "labkit readable": (lambda: emit(job.moves), labkit_sent),
            "LaserGRBL-style": (lambda: lasergrbl_line_to_line(job.target, PITCH_MM, FEED_MM_MIN),
                                lasergrbl_sent_bytes)}


def bench_formats():
    from labkit.raster.engrave import RasterSettings, image_to_job, placed_size
    from labkit.raster.io import read_image

    img = read_image(PHOTO)
    size = placed_size(img.pixels.shape, file_dpi=img.dpi, pixel_aspect=img.pixel_aspect)[2]
    print(f"raster G-code formats: {PHOTO.name} at {FEED_MM_MIN:g} mm/min, {PITCH_MM:g} mm pixels "
          "(bytes on the link as each format's sender sends them; every program read back and burned: "
          "'same burn' = every target pixel once at its S)")
    print(f"   {'image':8s} {'format':20s} {'file MB':>7s} {'link MB':>7s} {'B/burned px':>11s} "
          f"{'B/S change':>10s} {'share':>6s} {'file share':>10s} {'write s':>7s}  same burn")
    shares = {}
    for mode in ("gray", "dither"):
        job = image_to_job(img, RasterSettings(mode=mode, beam_mm=PITCH_MM, feed_mm_min=FEED_MM_MIN, **size))
        target = job.target
        burned = int(np.count_nonzero(target))
        changes = s_changes(target)
        made = {}
        for name, (make, sent) in _formats(job).items():
            t = time.process_time()
            text = make()
            made[name] = text, sent(text), time.process_time() - t
        anchor_text, anchor_link, _ = made["LaserGRBL-style"]
        for name, (text, link, seconds) in made.items():
            print(f"   {mode:8s} {name:20s} {len(text) / 1e6:7.2f} {link / 1e6:7.2f} {link / burned:11.2f} "
                  f"{link / changes:10.2f} {link / anchor_link:6.2f} {len(text) / len(anchor_text):10.2f} "
                  f"{seconds:7.2f}  {_burns_the_target(text, target)}")
        floor = fewest_bytes(target, PITCH_MM)
        shares[mode] = made["labkit compact"][1] / anchor_link, floor / anchor_link
        print(f"   {mode:8s} {'floor (any program)':20s} {'':7s} {floor / 1e6:7.2f} {'':11s} "
              f"{floor / changes:10.2f} {floor / anchor_link:6.2f}")
        print(f"   {mode}: {burned:,} burned pixels, {changes:,} S changes, {len(job.moves):,} moves")
    for mode, (share, floor_share) in shares.items():
        verdict = ("met" if share <= TARGET_SHARE else
                   f"NOT met; not reachable without changing the burn: any program needs {floor_share:.2f}"
                   if floor_share > TARGET_SHARE else "NOT met")
        print(f"   {mode}: compact link bytes per S change = {share:.2f} of LaserGRBL-style "
              f"(target <= {TARGET_SHARE:.2f}: {verdict})")


# ---------------------------------------------------------------- stall-free feed, streamed


def _paced_module():
    path = ROOT / "tests" / "firmware" / "paced_stream.py"
    spec = importlib.util.spec_from_file_location("paced_stream", path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod            # its dataclass looks its module up while it is made
    spec.loader.exec_module(mod)
    return mod


def streamed_stall_free_feed(paced, sim, text, machine, start_mm_min, tmp: Path, *, step=1.03,
                             rel_tol=0.01, max_runs=8):
    """The highest feed at which the paced simulator logs no starvation (but those stream.py's
    once-a-second ``?`` explains: ``poll_shadows``), found by streaming:
    from ``start_mm_min`` up or down by ``step`` until the verdict changes, then halved to
    ``rel_tol``; never above the machine's top speed. The simulator waits up to 10 s of wall
    time for the sender (``--expect``), so load on the machine does not make starvations; a
    stream whose sender was later still (``PacedRun.host_late``) is listed. Returns (feed,
    runs, bracket, feeds whose stream was disturbed)."""
    from labkit.motion.stall import with_feed

    top = float(min(machine.max_rate_mm_min[:2]))
    cache = {}
    disturbed = []

    def starves(feed):
        if feed not in cache:
            run = paced.stream_paced(sim, with_feed(text, feed), machine, tmp)
            # stream.py's '?' once a second is a byte on the wire at a wall-clock moment: the
            # stops no longer than a byte, no more than the '?'s, are its, not the format's
            cache[feed] = bool(paced.poll_shadows(run.stalls, [], machine.link_baud, run.seconds)[1])
            if run.host_late:
                disturbed.append(feed)
        return cache[feed]

    f = min(start_mm_min, top)
    if not starves(f):
        lo, hi = f, None
        while hi is None and lo < top and len(cache) < max_runs:
            g = min(lo * step, top)
            if starves(g):
                hi = g
            else:
                lo = g
    else:
        lo, hi = None, f
        while lo is None and len(cache) < max_runs:
            g = hi / step
            if starves(g):
                hi = g
            else:
                lo = g
    while lo is not None and hi is not None and hi - lo > rel_tol * hi and len(cache) < max_runs:
        mid = 0.5 * (lo + hi)
        if starves(mid):
            hi = mid
        else:
            lo = mid
    return lo, len(cache), (lo, hi), disturbed


def bench_stall_free_feeds():
    from labkit.motion import load_machine
    from labkit.motion.stall import stall_free_feed
    from labkit.raster.engrave import RasterSettings, image_to_job
    from labkit.raster.io import read_image

    build = subprocess.run(["make", "-C", str(ROOT / "firmware"), "sim"], capture_output=True, text=True)
    if build.returncode:
        raise SystemExit(f"make -C firmware sim failed:\n{build.stderr}")
    sim = str(ROOT / "firmware" / "build" / "host" / "labkit-fw-sim")
    paced = _paced_module()
    img = read_image(PHOTO)
    job = image_to_job(img, RasterSettings(mode="gray", beam_mm=PITCH_MM, feed_mm_min=FEED_MM_MIN,
                                           width_mm=STREAM_WIDTH_MM))
    burned = int(np.count_nonzero(job.target))
    changes = s_changes(job.target)
    formats = _formats(job)
    texts = {name: formats[name][0]() for name in ("labkit compact", "LaserGRBL-style")}
    print(f"\nstall-free feed on the paced firmware simulator: {PHOTO.name} gray, {STREAM_WIDTH_MM:g} mm wide "
          f"({job.target.shape[1]} x {job.target.shape[0]} px at {PITCH_MM:g} mm), machine {STREAM_MACHINE} "
          f"(top {load_machine(STREAM_MACHINE).max_rate_mm_min[0]:g} mm/min), GRBL's stream.py counting")
    print(f"   {'baud':>6s} {'format':18s} {'lines':>7s} {'B/burned px':>11s} {'B/S change':>10s} "
          f"{'streamed F* mm/min':>18s} {'runs':>4s} {'predicted F*':>12s} {'pred/streamed':>13s} {'limited by':>10s}")
    with tempfile.TemporaryDirectory() as folder:
        tmp = Path(folder)
        for baud in STREAM_BAUDS:
            machine = load_machine(STREAM_MACHINE).replace(link_baud=baud)
            found = {}
            for name, text in texts.items():
                nbytes = paced.stream_py_bytes(text)
                predicted = stall_free_feed(text, machine, line_bytes=paced.stream_py_bytes, rel_tol=0.002, rows=False)
                streamed, runs, bracket, disturbed = streamed_stall_free_feed(paced, sim, text, machine,
                                                                              predicted.feed_mm_min, tmp)
                found[name] = streamed
                shown = "none" if streamed is None else f"{streamed:.0f}"
                if bracket[1] is None:
                    shown = f">= {shown}"
                ratio = "" if not streamed else f"{predicted.feed_mm_min / streamed:.3f}"
                print(f"   {baud:6d} {name:18s} {len(nbytes):7d} {nbytes.sum() / burned:11.2f} "
                      f"{nbytes.sum() / changes:10.2f} {shown:>18s} {runs:4d} {predicted.feed_mm_min:12.0f} "
                      f"{ratio:>13s} {predicted.limited_by:>10s}"
                      + (f"  (sender late at {', '.join(f'{f:.0f}' for f in disturbed)} mm/min: load)"
                         if disturbed else ""))
            a, b = found["labkit compact"], found["LaserGRBL-style"]
            if a and b:
                print(f"   {baud:6d} compact / LaserGRBL-style stall-free feed: {a / b:.2f}")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--no-stream", action="store_true", help="skip the paced simulator (bytes only)")
    args = parser.parse_args()
    bench_formats()
    if not args.no_stream:
        bench_stall_free_feeds()
