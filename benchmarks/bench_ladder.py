"""The size ladder (issue 29): every command at four input sizes, as a user runs it (a fresh
process, best of ``--repeat`` after one warm-up that fills the bytecode and numba caches, and
of up to ten runs for a command under ``SETTLE_S`` so that a row of 0.2 s is not one draw), in
labkit's default mode and forced to Python only (``LABKIT_JIT=python``) and compiled only
(``LABKIT_JIT=compiled``), so that the rule of :mod:`labkit._jit` is visible: the default
should be within 20 % of the better of the two at every size. The three modes of a row run in
turns (one run of each a round), as do labkit and its peer where a target is their ratio alone
(one command per file, the small drawing): a minute's change of load then weighs on both. Each row also gives the time of
the command's peer measured in the same run and the ratio labkit / peer (below 1: labkit is
faster), or peer / labkit where the target is a speed-up (marked ×):

- ``check``, ``info``: gcodeparser's ``parse_gcode_lines`` over the file, as a process (also
  at four rungs between 2,418 and 40,299 lines, where the rule switches, with ``plan`` and
  ``preview``: part ``between``);
- ``plan``, ``preview``, ``stream`` (to the virtual machine): starting Python and importing
  numpy, the floor any numpy-based command pays;
- ``dxf2gcode``: vpype (vpype-dxf's ``dread``, ``linesort``, vpype-gcode's ``gwrite``) on the
  same drawing, as a process (×: vpype's time / labkit's);
- ``plan: link`` (the stall prediction over the machine's link, on by default): ``plan --no-link``
  on the same file, as a process (issue 29: the prediction must not make plan slower than 1.5×);
- ``svg2gcode``: svg-to-gcode (``parse_file`` and ``Compiler``) on the same file, as a process;
- ``img2gcode`` (zigzag, gray, dither): a pure-Python row scan of the same pixels writing
  G-code (bench_raster's), as a process.

Then svg2gcode's targets: a set of ten raw SVGs with transforms (``_svgset.py``, 450 paths,
written by this benchmark) converted in one process at 0.1 and 0.01 mm, against svg-to-gcode
in one process — as issue 29 measures it (``bench_vector.py``'s Part 1b: both imported, the
set converted again in the same process, CPU time) and as fresh processes (start-up, imports
and numba's load included); one command per file against svg-to-gcode's process per file; the small
drawing ``data/svg/cncjs/jsdc.svg`` against the numpy floor. Last, "no regression elsewhere":
the parse, edge and planner benchmarks' own measures (``--only elsewhere``).

Inputs: real files where they exist (cncjs's G-code jobs, data/dxf, data/svg); the larger
G-code rungs repeat a real job, the SVG rungs are written by ``_svgset.py``, the images are
bench_raster's compact mask at four sizes and, for gray and dither, the photograph of
data/images resized to the same sizes — all made here, by hand, and said so.

Run:  .venv/bin/python benchmarks/bench_ladder.py [--repeat K] [--only NAME ...]
(``make bench`` installs the peers first: ``pip install -e '.[bench]'``.)
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from _process import ROOT, process_times
from _svgset import write_set

PY = sys.executable
GCODE = ROOT / "data" / "gcode" / "cncjs"
MODES = ("auto", "python", "compiled")

# the peers, each a process over the same input
GCODEPARSER = ("import sys; from gcodeparser import parse_gcode_lines; "
               "list(parse_gcode_lines(open(sys.argv[1]).read()))")
SVG_TO_GCODE = """
import sys, warnings
warnings.simplefilter("ignore")
from svg_to_gcode import TOLERANCES
from svg_to_gcode.compiler import Compiler, interfaces
from svg_to_gcode.svg_parser import parse_file
TOLERANCES["approximation"] = float(sys.argv[1])
for f in sys.argv[2:]:
    c = Compiler(interfaces.Gcode, movement_speed=1000, cutting_speed=300, pass_depth=0)
    c.append_curves(parse_file(f))
    c.compile(passes=1)
"""
VPYPE_DXF = "from vpype_cli import cli; cli()"     # vpype with the vpype-dxf and vpype-gcode plug-ins
LABKIT_SVG_SET = """
import sys
from labkit._jit import job_units
from labkit.toolpath.build import LayerSettings
from labkit.toolpath.job import vector_job
from labkit.vector import read_svg
tol = float(sys.argv[1])
for f in job_units(sys.argv[2:]):          # the batch declared: the rule projects from file 1
    d = read_svg(f, tol_mm=tol, arcs=True, warn=False)
    vector_job(d.paths, default=LayerSettings(feed_mm_min=300, s_word=1000), tol_mm=tol).gcode()
"""


CLOCK = ["wall"]                    # --clock: "wall" or "cpu" (see _process.process_time)
#: a command shorter than this runs again until its runs add up to it (best of up to ten):
#: the 20 % rule of labkit/_jit.py cannot be read from one run of a 0.2 s command
SETTLE_S = 2.0


def timed(argv, repeat, mode=None):
    """Best time of ``argv`` as a fresh process, with ``LABKIT_JIT=mode`` when given."""
    return timed_each({"": (argv, mode)}, repeat)[""]


def timed_each(runs, repeat):
    """Best times of commands compared in one row, run in turns (``_process.process_times``):
    name → ``(argv, LABKIT_JIT mode or None)``."""
    return process_times({name: (argv, {"LABKIT_JIT": None if mode in (None, "auto") else mode})
                          for name, (argv, mode) in runs.items()}, repeat, CLOCK[0], settle_s=SETTLE_S)


def labkit_row(name, size_label, argv, peer_t, peer_name, repeat, speedup=False):
    """Time ``labkit argv`` in the three modes and print one row of the ladder."""
    t = timed_each({m: ([PY, "-m", "labkit", *argv], m) for m in MODES}, repeat)
    better = min(t["python"], t["compiled"])
    ratio = peer_t / t["auto"] if speedup else t["auto"] / peer_t
    print(f"{name:18s} {size_label:>16s} {t['auto']:7.2f} s  {peer_name:14s} {peer_t:7.2f} s  "
          f"{ratio:6.2f}{'×' if speedup else ' '}  python {t['python']:6.2f}  compiled "
          f"{t['compiled']:6.2f}  default/better {t['auto'] / better:4.2f}", flush=True)
    return t


def gcode_rungs(tmp: Path):
    """Four G-code jobs: 30 lines of a real job, the real 2,418- and 40,299-line jobs, and
    the 40,299-line job repeated three times (made here)."""
    small = tmp / "jsdc-head30.gcode"
    small.write_text("".join((GCODE / "jsdc-laser.gcode").open().readlines()[:30]))
    big = (GCODE / "tball-pocket-laser.gcode").read_text()
    huge = tmp / "tball-pocket-x3.gcode"
    huge.write_text(big * 3)
    return [small, GCODE / "jsdc-laser.gcode", GCODE / "tball-pocket-laser.gcode", huge]


def lines_of(p: Path) -> str:
    count = p.read_bytes().count(b"\n")
    return f"{count:,} lines"


def ladder_gcode(tmp, repeat, only):
    t_numpy = timed([PY, "-c", "import numpy"], repeat)
    for f in gcode_rungs(tmp):
        peer = timed([PY, "-c", GCODEPARSER, str(f)], repeat)
        for cmd, extra, peer_t, peer_name in (
                ("check", [], peer, "gcodeparser"), ("info", [], peer, "gcodeparser"),
                ("plan", [], t_numpy, "import numpy"),
                ("preview", ["-o", str(tmp / "p.png")], t_numpy, "import numpy"),
                ("stream", ["--no-record"], t_numpy, "import numpy")):   # no record beside data/'s jobs
            if not only or cmd in only:
                labkit_row(cmd, lines_of(f), [cmd, str(f), *extra], peer_t, peer_name, repeat)
        if not only or "plan" in only:
            # the stall prediction (issue 30 §2) against plan without it: target ≤ 1.5×
            t_no_link = timed([PY, "-m", "labkit", "plan", str(f), "--no-link"], repeat)
            labkit_row("plan: link", lines_of(f), ["plan", str(f)], t_no_link, "plan --no-link", repeat)


def ladder_between(tmp, repeat):
    """The rungs between the G-code ladder's 2,418 and 40,299 lines, where the rule of
    labkit/_jit.py switches (the parse compiles near 35,000 lines, plan far earlier): the
    first 5,000 / 10,000 / 20,000 / 30,000 lines of the real 40,299-line job. Four rungs
    passed the rule while `info` of 10,000 lines ran 3× the better path between them.
    The stream to the virtual machine switches near 1,000 lines: its rungs between are the
    first 1,000 / 5,000 / 10,000 lines."""
    lines = (GCODE / "tball-pocket-laser.gcode").read_text().splitlines(keepends=True)
    t_numpy = timed([PY, "-c", "import numpy"], repeat)       # the stream's peer
    for n in (1_000, 5_000, 10_000, 20_000, 30_000):
        f = tmp / f"tball-first{n}.gcode"
        f.write_text("".join(lines[:n]))
        if n >= 5_000:
            peer = timed([PY, "-c", GCODEPARSER, str(f)], repeat)
            for cmd, extra, peer_name in (("check", [], "gcodeparser"), ("info", [], "gcodeparser"),
                                          ("plan", [], "gcodeparser"),
                                          ("preview", ["-o", str(tmp / "p.png")], "gcodeparser")):
                labkit_row(cmd, lines_of(f), [cmd, str(f), *extra], peer, peer_name, repeat)
        if n <= 10_000:
            labkit_row("stream", lines_of(f), ["stream", str(f), "--no-record"], t_numpy,
                       "import numpy", repeat)


def svg_rungs(tmp: Path):
    """jsdc.svg (4 shapes, real) and drawings of 45, 450 and 1,800 paths (made here)."""
    out = [(ROOT / "data" / "svg" / "cncjs" / "jsdc.svg", "4 shapes")]
    for n in (45, 450, 1800):
        folder = tmp / f"svg{n}"
        folder.mkdir()
        out.append((write_set(folder, files=1, elements=n)[0], f"{n} paths"))
    return out


def ladder_svg(tmp, repeat):
    for f, label in svg_rungs(tmp):
        peer = timed([PY, "-c", SVG_TO_GCODE, "0.01", str(f)], repeat)
        labkit_row("svg2gcode", label, ["svg2gcode", str(f), "--arcs", "-o", str(tmp / "s.gcode")],
                   peer, "svg-to-gcode", repeat, speedup=True)


def ladder_dxf(tmp, repeat):
    """dxf2gcode on drawings of 1, 10, 100 and 400 parts (about 13 entities each, made by
    ``_dxfset.py``: vpype-dxf fails on most real files of data/dxf with today's ezdxf) against
    vpype reading the same file with vpype-dxf, sorting its lines and writing G-code with
    vpype-gcode, as a process. vpype's ``-q 0.1mm`` (its default) is a chord length: its chords
    then sag at most 0.1² / 8r, within labkit's 0.01 mm for radii above 0.125 mm."""
    sys.path.insert(0, str(Path(__file__).parent))
    from _dxfset import write_dxf

    t_numpy = timed([PY, "-c", "import numpy"], repeat)
    print(f"(dxf2gcode: python -c 'import numpy' {t_numpy:.2f} s)")
    for parts in (1, 10, 100, 400):
        f = write_dxf(tmp / f"parts{parts}.dxf", parts, seed=parts)
        peer = timed([PY, "-c", VPYPE_DXF, "dread", "-q", "0.1mm", str(f), "linesort", "pagesize",
                      "4000mmx4000mm", "gwrite", "-p", "gcode", str(tmp / "v.gcode")], repeat)
        labkit_row("dxf2gcode", f"{parts} parts", ["dxf2gcode", str(f), "--arcs", "--force",
                   "-o", str(tmp / "d.gcode")], peer, "vpype", repeat, speedup=True)


def ladder_img(tmp, repeat):
    from PIL import Image

    sys.path.insert(0, str(Path(__file__).parent))
    from bench_raster import PY_ROW_SCAN, compact_mask

    # gray and dither write a move per pixel: their rungs stop at 512² (1024² takes over a
    # minute as one run on the shared machine); zigzag goes to issue 29's 4096². Gray and
    # dither run on two images of each size: the compact mask (long runs of one S, ten
    # times cheaper a pixel) and a photograph (a new S nearly every pixel): the rule of
    # labkit/_jit.py must land within 20 % of the better path on both.
    photo = Image.open(ROOT / "data" / "images" / "photo_500x450_72dpi.jpg").convert("L")
    for size in (32, 128, 256, 512, 1024, 4096):
        png = tmp / f"mask{size}.png"
        Image.fromarray(np.where(compact_mask(size), 0, 255).astype(np.uint8)).save(png, dpi=(254, 254))
        peer = timed([PY, "-c", PY_ROW_SCAN, str(png), str(tmp / "r.gcode")], repeat)
        modes = [m for m, sizes in (("zigzag", (32, 256, 1024, 4096)), ("gray", (32, 128, 256, 512)),
                                    ("dither", (32, 128, 256, 512))) if size in sizes]
        for mode in modes:
            labkit_row(f"img2gcode {mode}", f"{size}² px", ["img2gcode", str(png), "-o", str(tmp / "i.gcode"),
                       "--mode", mode, "--beam", "0.1", "--preview", "none", "--force"],
                       peer, "py row scan", repeat, speedup=True)
        if size <= 512:
            # the photograph of data/images resized (bicubic, made here) to size × size
            shot = tmp / f"photo{size}.png"
            photo.resize((size, size), Image.BICUBIC).save(shot, dpi=(254, 254))
            shot_peer = timed([PY, "-c", PY_ROW_SCAN, str(shot), str(tmp / "r.gcode")], repeat)
            for mode in ("gray", "dither"):
                t = labkit_row(f"{mode} photo", f"{size}² px", ["img2gcode", str(shot), "-o", str(tmp / "i.gcode"),
                               "--mode", mode, "--beam", "0.1", "--preview", "none", "--force"],
                               shot_peer, "py row scan", repeat, speedup=True)
                if size == 512 and mode == "gray":
                    # issue 29: the default preview of a 200,000-move job adds ≤ 0.3 s (205,000 here)
                    moves = _moves_of(tmp / "i.gcode")
                    with_preview = labkit_row("gray photo + prev", f"{size}² px", ["img2gcode", str(shot), "-o",
                                              str(tmp / "i.gcode"), "--mode", "gray", "--beam", "0.1", "--force"],
                                              shot_peer, "py row scan", repeat, speedup=True)
                    print(f"  the default preview of this {moves:,}-move job adds "
                          f"{with_preview['auto'] - t['auto']:5.2f} s (target ≤ 0.3 s)", flush=True)
        if size == 4096:                 # issue 29's target holds with the default preview too
            labkit_row("zigzag + preview", f"{size}² px", ["img2gcode", str(png), "-o", str(tmp / "i.gcode"),
                       "--mode", "zigzag", "--beam", "0.1", "--force"], peer, "py row scan", repeat,
                       speedup=True)


def _moves_of(gcode: Path) -> int:
    """Moves of a program labkit wrote one move a line: the lines with an X or Y word."""
    return sum(1 for line in gcode.read_text().splitlines()
               if not line.startswith(";") and ("X" in line or "Y" in line))


def svg_targets(tmp, repeat):
    """The svg2gcode targets of issue 29 §3 on the ten raw SVGs with transforms."""
    folder = tmp / "set"
    folder.mkdir()
    files = [str(f) for f in write_set(folder, files=10, elements=45)]
    print(f"\nsvg2gcode targets: {len(files)} raw SVGs with transforms, 450 paths (made by _svgset.py)")
    # issue 29's measure, "converted in one process": both converters imported in one process,
    # the set converted again and again (bench_vector.py's Part 1b, CPU time in that process)
    done = subprocess.run([PY, str(ROOT / "benchmarks" / "bench_vector.py"), "set"], cwd=ROOT,
                          capture_output=True, text=True, check=True)
    print("\n".join("  in " + line.strip() for line in done.stdout.splitlines()[2:]), flush=True)
    print("  fresh processes (start-up, imports and numba's load included):")
    undeclared = LABKIT_SVG_SET.replace("job_units(sys.argv[2:])", "sys.argv[2:]")
    for tol in ("0.1", "0.01"):
        peer = timed([PY, "-c", SVG_TO_GCODE, tol, *files], repeat)
        t = timed_each({**{m: ([PY, "-c", LABKIT_SVG_SET, tol, *files], m) for m in MODES},
                        "undeclared": ([PY, "-c", undeclared, tol, *files], None)}, repeat)
        t_undeclared = t["undeclared"]
        print(f"  one process, tol {tol:>4s} mm: labkit {t['auto']:6.2f} s (python {t['python']:6.2f}, "
              f"compiled {t['compiled']:6.2f}, batch not declared {t_undeclared:6.2f})  svg-to-gcode "
              f"{peer:6.2f} s  -> {peer / t['auto']:5.1f}× (the ≥ 20× target is the in-process measure); default/better "
              f"{t['auto'] / min(t['python'], t['compiled']):4.2f}", flush=True)
    per_lab = per_peer = 0.0
    for f in files[:3]:
        t = timed_each({"labkit": ([PY, "-m", "labkit", "svg2gcode", f, "--arcs", "-o", str(tmp / "o.gcode")], None),
                        "peer": ([PY, "-c", SVG_TO_GCODE, "0.01", f], None)}, repeat)
        per_lab, per_peer = per_lab + t["labkit"], per_peer + t["peer"]
    print(f"  one command per file (3 files, 0.01 mm): labkit {per_lab:6.2f} s  svg-to-gcode "
          f"{per_peer:6.2f} s  -> {per_peer / per_lab:5.2f}× (target ≥ 3×)")
    small = ROOT / "data" / "svg" / "cncjs" / "jsdc.svg"
    t = timed_each({"labkit": ([PY, "-m", "labkit", "svg2gcode", str(small), "-o", str(tmp / "j.gcode")], None),
                    "numpy": ([PY, "-c", "import numpy"], None)}, repeat)
    t_small, t_numpy = t["labkit"], t["numpy"]
    print(f"  small drawing jsdc.svg: labkit {t_small:5.2f} s, python -c 'import numpy' {t_numpy:5.2f} s "
          f"-> {t_small / t_numpy:4.2f}× the numpy floor (target ≤ 2.5×)")


def elsewhere():
    """Issue 29's "no regression elsewhere", in the ladder's run: the parse of 1 M lines against
    gcodeparser (≥ 10×), the edge detectors on 4096² against scikit-image (≤ 0.15× its time),
    the planners on a 1 M-move raster job (≥ 2 M blocks/s) — each benchmark's own measure."""
    print("\nno regression elsewhere (bench_gcode.py, bench_raster.py edges, bench_motion.py planning):")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    env.pop("LABKIT_JIT", None)
    for argv in (["bench_gcode.py"], ["bench_raster.py", "edges"], ["bench_motion.py", "--lines", "10000"]):
        done = subprocess.run([PY, str(ROOT / "benchmarks" / argv[0]), *argv[1:]], cwd=ROOT, env=env,
                              capture_output=True, text=True)
        print("\n".join("  " + line for line in done.stdout.splitlines() if line.strip()), flush=True)
        if done.returncode not in (0, 1):          # 1: bench_gcode's "targets not met", printed
            raise SystemExit(f"{argv[0]} failed:\n{done.stderr}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--clock", choices=("wall", "cpu"), default="wall",
                    help="time each process by the wall clock or by its CPU time (user + system; "
                         "steadier on a loaded machine)")
    ap.add_argument("--only", nargs="*", default=[],
                    help="parts to run: gcode (or check, info, plan, preview, stream), between, svg, dxf, "
                         "img, targets, elsewhere")
    args = ap.parse_args()
    only = set(args.only)
    CLOCK[0] = args.clock
    start = time.perf_counter()
    print(f"load average at start: {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores; "
          f"{args.clock} time of each process")
    print(f"{'command':18s} {'input':>16s} {'labkit':>9s}  {'peer':14s} {'time':>9s}  {'ratio':>7s}")
    with tempfile.TemporaryDirectory() as name:
        tmp = Path(name)
        gcode_parts = only & {"check", "info", "plan", "preview", "stream"}
        if not only or "gcode" in only or gcode_parts:
            ladder_gcode(tmp, args.repeat, gcode_parts)
        if not only or "between" in only:
            ladder_between(tmp, args.repeat)
        if not only or "svg" in only:
            ladder_svg(tmp, args.repeat)
        if not only or "dxf" in only:
            ladder_dxf(tmp, args.repeat)
        if not only or "img" in only:
            ladder_img(tmp, args.repeat)
        if not only or "targets" in only:
            svg_targets(tmp, args.repeat)
        if not only or "elsewhere" in only:
            elsewhere()
    print(f"load average at end: {os.getloadavg()[0]:.1f}; {time.perf_counter() - start:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
