"""No half-written file (issue 25 §4): a full disk, Ctrl-C or an exception while a command writes
leaves the old file or no file — never a truncated program — and no temporary file behind.

A full disk is injected in the one place every writer goes through: the file object
:func:`labkit._files.atomic_output` creates for its temporary file is replaced by one whose
raw writes stop with ``ENOSPC`` after a given number of bytes (a short write first, as a
real full disk gives). Ctrl-C is a real SIGINT sent to a real ``labkit img2gcode`` process while
it writes a large program.
"""

from __future__ import annotations

import errno
import io
import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

import labkit._files as files
from labkit._files import atomic_output, write_figure
from labkit.cli import main
from labkit.errors import InputError

ROOT = Path(__file__).resolve().parents[1]
SVG = ROOT / "data" / "svg" / "labkit" / "arc_flags.svg"
GCODE = ROOT / "data" / "gcode" / "cncjs" / "jsdc-laser.gcode"
OLD = "; the previous program, complete\nM5\n"


class _DiskFull(io.FileIO):
    """A file on a disk with ``room`` bytes free: a short write, then ENOSPC."""

    room = 0

    def write(self, data):
        data = memoryview(data).cast("B")
        if self.room <= 0:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        n = super().write(data[:self.room])
        self.room -= n
        return n


def _create_on_full_disk(room, only):
    """Stands in for the writer's ``_create_temporary``: the same new file, on a full disk."""
    def create(path, mode, *, encoding=None, newline=None, errors=None):
        raw = _DiskFull(path, "x")
        raw.room = room if only is None or path.name.startswith(f".{only}.") else 1 << 62
        buffered = io.BufferedWriter(raw)
        if "b" in mode:
            return buffered
        return io.TextIOWrapper(buffered, encoding=encoding or "utf-8", newline=newline, errors=errors)
    return create


@pytest.fixture
def full_disk(monkeypatch):
    """``full_disk(room, only=None)``: from now on the writer's temporary files (those for the
    file named ``only``, if given) hold at most ``room`` bytes."""
    def fill(room, only=None):
        monkeypatch.setattr(files, "_create_temporary", _create_on_full_disk(room, only))
    return fill


def _leftovers(folder):
    return sorted(p.name for p in Path(folder).iterdir() if p.name.endswith(".part"))


def _refused(capsys, argv):
    """The command's one-line refusal (exit 1). A warning another process's compile cache may
    print on a shared machine can precede it; the refusal is one line, and the last."""
    code = main([str(a) for a in argv])
    err = capsys.readouterr().err
    assert code == 1, err
    said = [line for line in err.splitlines() if line.startswith(f"labkit {argv[0]}: ")]
    assert "Traceback" not in err and len(said) == 1 and err.splitlines()[-1] == said[0], err
    return said[0]


def test_atomic_output_keeps_the_old_file_on_a_full_disk(tmp_path, full_disk):
    out = tmp_path / "job.gcode"
    out.write_text(OLD)
    out.chmod(0o640)
    full_disk(10)
    with pytest.raises(InputError, match=r"job.gcode: cannot be written \(the disk is full\); "
                                         "the previous file is left as it was"):
        with atomic_output(out) as fh:
            fh.write("G1 X10 S1000\n" * 10_000)
    assert out.read_text() == OLD and _leftovers(tmp_path) == []
    new = tmp_path / "new.gcode"
    with pytest.raises(InputError, match="no file was written"):
        with atomic_output(new) as fh:
            fh.write("G1 X10 S1000\n" * 10_000)
    assert not new.exists() and _leftovers(tmp_path) == []


def test_atomic_output_replaces_complete_keeps_permissions_and_never_writes_through_a_link(tmp_path):
    out = tmp_path / "job.gcode"
    out.write_text(OLD)
    out.chmod(0o640)
    with atomic_output(out) as fh:
        fh.write("G0 X0\n")
    assert out.read_text() == "G0 X0\n" and (out.stat().st_mode & 0o777) == 0o640
    # a new file gets what open() would give it: 0o666 less the umask
    mask = os.umask(0o022)
    try:
        with atomic_output(tmp_path / "fresh.gcode") as fh:
            fh.write("M5\n")
    finally:
        os.umask(mask)
    assert ((tmp_path / "fresh.gcode").stat().st_mode & 0o777) == 0o644
    # a link at the output name is replaced; the file it pointed to is not touched
    precious = tmp_path / "artwork.svg"
    precious.write_text("<svg/>")
    link = tmp_path / "link.gcode"
    link.symlink_to(precious)
    with atomic_output(link) as fh:
        fh.write("M5\n")
    assert precious.read_text() == "<svg/>" and not link.is_symlink() and link.read_text() == "M5\n"
    # an exception of any kind in the block: the old file, and no temporary
    with pytest.raises(RuntimeError):
        with atomic_output(out) as fh:
            fh.write("G1 X5 S1000\n")
            raise RuntimeError("mid-write")
    assert out.read_text() == "G0 X0\n" and _leftovers(tmp_path) == []


def test_a_folder_that_cannot_be_written_is_one_sentence(tmp_path):
    with pytest.raises(InputError, match=r"missing/job.gcode: cannot be written \(No such file or directory\); "
                                         "no file was written"):
        with atomic_output(tmp_path / "missing" / "job.gcode") as fh:
            fh.write("M5\n")
    with pytest.raises(InputError, match="is a directory"):
        with atomic_output(tmp_path) as fh:
            fh.write("M5\n")


def test_write_figure_takes_the_format_from_the_name(tmp_path):
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])
    try:
        write_figure(fig, tmp_path / "a.svg")
        write_figure(fig, tmp_path / "a.png", dpi=50)
        with pytest.raises(InputError, match=r"a.gcode: cannot draw a '.gcode' file; expected one of .*\.png"):
            write_figure(fig, tmp_path / "a.gcode")
    finally:
        plt.close(fig)
    assert (tmp_path / "a.svg").read_text().lstrip().startswith("<?xml")
    assert (tmp_path / "a.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not (tmp_path / "a.gcode").exists() and _leftovers(tmp_path) == []


@pytest.fixture(scope="module")
def image(tmp_path_factory):
    """A 60 × 40 px gradient with a dark disc, at 254 dpi (6 × 4 mm)."""
    y, x = np.mgrid[0:40, 0:60]
    g = (x * 4).astype(np.uint8)
    g[(x - 30) ** 2 + (y - 20) ** 2 < 150] = 0
    path = tmp_path_factory.mktemp("img") / "disc.png"
    Image.fromarray(g).save(path, dpi=(254, 254))
    return path


@pytest.fixture(scope="module")
def widths_csv(tmp_path_factory):
    path = tmp_path_factory.mktemp("fit") / "w.csv"
    path.write_text((ROOT / "data" / "cutwidth" / "synthetic_paperboard.csv").read_text())
    return path


# one writer of each kind a command writes: G-code (vector, raster, patterns), previews, layouts,
# fits, traces, step files, split parts and scans (the probe's simulated scan, the cut-width CSV)
CASES = {
    "svg2gcode": lambda d, e: (["svg2gcode", SVG, "-o", d / "out.gcode"], ["out.gcode"]),
    "img2gcode": lambda d, e: (["img2gcode", e["image"], "-o", d / "out.gcode", "--preview", "none"],
                               ["out.gcode"]),
    "img2gcode preview": lambda d, e: (["img2gcode", e["image"], "-o", d / "out.gcode", "--preview",
                                        d / "out.png"], ["out.png"]),
    "preview": lambda d, e: (["preview", GCODE, "-o", d / "out.png"], ["out.png"]),
    "pattern": lambda d, e: (["pattern", "helix", "-o", d / "out.gcode"], ["out.gcode"]),
    "cutwidth pattern": lambda d, e: (["cutwidth", "pattern", "--powers", "500:1500:3", "--speeds", "300:900:3",
                                       "-o", d / "out.gcode"], ["out.gcode", "out.json"]),
    "cutwidth fit": lambda d, e: (["cutwidth", "fit", e["widths"], "-o", d / "out.json"], ["out.json"]),
    "plan --trace": lambda d, e: (["plan", e["small"], "--trace", d / "out.csv"], ["out.csv"]),
    "steps": lambda d, e: (["steps", e["small"], "-o", d / "out.csv"], ["out.csv"]),
    "split": lambda d, e: (["split", e["program"], "--max-lines", "1500", "-o", d],
                           ["prog.part001.gcode", "prog.part002.gcode"]),
    "probe scan": lambda d, e: (["probe", "scan", "--step", "0.5", "--csv", d / "out.csv"], ["out.csv"]),
}


#: cases where the disk fills only for one file: the G-code is written, its preview is not
FULL_ONLY = {"img2gcode preview": "out.png"}


@pytest.mark.parametrize("case", list(CASES))
def test_a_full_disk_leaves_the_old_file_or_none(case, tmp_path, image, widths_csv, full_disk, capsys):
    program = tmp_path / "prog.gcode"
    program.write_text(GCODE.read_text())
    small = tmp_path / "small.gcode"
    small.write_text("G21 G90\nG0 X0 Y0\nM4 S500\nG1 X5 Y3 F600\nG1 X0 Y5\nM5\n")
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    argv, outputs = CASES[case](out_dir, dict(image=image, widths=widths_csv, program=program,
                                                         small=small))
    # the command works on a disk with room (and writes more than the full disk will take)
    assert main([str(a) for a in argv]) == 0, capsys.readouterr().err
    capsys.readouterr()
    assert all((out_dir / name).stat().st_size > 200 for name in outputs)
    # the old files, then a full disk after 100 bytes of the new ones
    for name in outputs:
        (out_dir / name).write_text(OLD)
    full_disk(100, only=FULL_ONLY.get(case))
    err = _refused(capsys, argv)
    assert "cannot be written (the disk is full); the previous file is left as it was" in err
    assert all((out_dir / name).read_text() == OLD for name in outputs)
    assert _leftovers(out_dir) == []
    # and with no old file: no file
    for name in outputs:
        (out_dir / name).unlink()
    err = _refused(capsys, argv)
    assert "cannot be written (the disk is full); no file was written" in err
    assert not any((out_dir / name).exists() for name in outputs) and _leftovers(out_dir) == []


def test_the_layout_is_never_left_beside_a_program_it_does_not_describe(tmp_path, full_disk, capsys):
    """cutwidth pattern writes two files: a full disk on either leaves the old pair."""
    argv = ["cutwidth", "pattern", "--powers", "500:1500:3", "--speeds", "300:900:3", "-o", tmp_path / "g.gcode"]
    assert main([str(a) for a in argv]) == 0
    old = {n: (tmp_path / n).read_text() for n in ("g.gcode", "g.json")}
    # the layout is written whole, the program not: the layout must not be replaced either
    full_disk(100, only="g.gcode")
    argv[3] = "600:1600:3"
    _refused(capsys, argv)
    assert {n: (tmp_path / n).read_text() for n in old} == old and _leftovers(tmp_path) == []


def test_cutwidth_measure_on_a_full_disk(tmp_path, full_disk, capsys):
    from labkit.laser.measure import render_scan
    from labkit.laser.models import dose_width

    assert main(["cutwidth", "pattern", "--powers", "1000:2500:2", "--speeds", "300:600:2",
                 "-o", str(tmp_path / "g.gcode")]) == 0
    layout = json.loads((tmp_path / "g.json").read_text())
    truth = dose_width([d["power_mw"] for d in layout["lines"]], [d["speed_mm_min"] for d in layout["lines"]],
                       0.12, 200.0)
    Image.fromarray((render_scan(layout, truth, dpi=300) * 255).round().astype(np.uint8)).save(
        tmp_path / "scan.png", dpi=(300, 300))
    (tmp_path / "w.csv").write_text(OLD)
    full_disk(100)
    err = _refused(capsys, ["cutwidth", "measure", tmp_path / "scan.png", "--layout", tmp_path / "g.json",
                            "-o", tmp_path / "w.csv"])
    assert "w.csv: cannot be written (the disk is full)" in err
    assert (tmp_path / "w.csv").read_text() == OLD and not (tmp_path / "w.png").exists()
    assert _leftovers(tmp_path) == []


_SLOW_DISK = """
import io, sys, time
import labkit._files as files

class Slow(io.FileIO):
    def write(self, data):
        n = super().write(memoryview(data).cast("B")[:16384])
        time.sleep(0.01)
        return n

def create(path, mode, *, encoding=None, newline=None, errors=None):
    buffered = io.BufferedWriter(Slow(path, "x"))
    return buffered if "b" in mode else io.TextIOWrapper(buffered, encoding=encoding or "utf-8",
                                                         newline=newline, errors=errors)

files._create_temporary = create
from labkit.cli import main
sys.exit(main(sys.argv[1:]))
"""


@pytest.mark.parametrize("old", [True, False], ids=["old file", "no file"])
def test_ctrl_c_while_img2gcode_writes_leaves_the_old_program(tmp_path, old):
    """SIGINT to a real ``labkit img2gcode`` subprocess while it writes a multi-megabyte program.

    The disk is made slow (16 KB per 10 ms, in the child only) so that the signal lands
    while the temporary file is being written — the window a fast disk makes too short
    to hit reliably."""
    rng = np.random.default_rng(25)
    Image.fromarray((rng.random((400, 400)) * 255).astype(np.uint8)).save(tmp_path / "noise.png",
                                                                          dpi=(254, 254))
    out = tmp_path / "job.gcode"
    if old:
        out.write_text(OLD)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    child = subprocess.Popen([sys.executable, "-c", _SLOW_DISK, "img2gcode", str(tmp_path / "noise.png"),
                              "-o", str(out), "--preview", "none", "--mode", "dither"],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env, cwd=tmp_path)
    deadline = time.monotonic() + 240
    part = []
    while time.monotonic() < deadline and child.poll() is None:
        part = [p for p in tmp_path.iterdir() if p.name.endswith(".part") and p.stat().st_size > 50_000]
        if part:
            break
        time.sleep(0.02)
    assert part, f"the program was never seen being written: {child.communicate()[1].decode()}"
    child.send_signal(signal.SIGINT)
    _, err = child.communicate(timeout=60)
    err = err.decode()
    assert child.returncode == 130 and "labkit img2gcode: interrupted" in err and "Traceback" not in err
    assert (out.read_text() == OLD) if old else not out.exists()
    assert _leftovers(tmp_path) == []


def test_ctrl_c_to_a_plain_img2gcode_on_a_big_image(tmp_path):
    """The same with nothing slowed down: a 1200 × 1200 px dithered image is a 9 MB program,
    whose temporary file lives about 0.1 s; SIGINT is sent as soon as it appears. Python
    delivers the signal when the write call returns, before the rename: the old program stays.
    Should a loaded machine deliver it only after the rename, the new program must be whole."""
    rng = np.random.default_rng(1)
    Image.fromarray((rng.random((1200, 1200)) * 255).astype(np.uint8)).save(tmp_path / "big.png", dpi=(254, 254))
    out = tmp_path / "big.gcode"
    out.write_text(OLD)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    child = subprocess.Popen([sys.executable, "-m", "labkit", "img2gcode", str(tmp_path / "big.png"), "-o", str(out),
                              "--preview", "none", "--mode", "dither"],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env, cwd=tmp_path)
    deadline = time.monotonic() + 300
    seen = False
    while time.monotonic() < deadline and child.poll() is None:
        if any(p.name.endswith(".part") for p in tmp_path.iterdir()):
            child.send_signal(signal.SIGINT)
            seen = True
            break
        time.sleep(0.001)
    stdout, err = child.communicate(timeout=120)
    assert seen, f"the temporary file was never seen: {err.decode()}"
    assert "Traceback" not in err.decode() and _leftovers(tmp_path) == [], err.decode()
    assert child.returncode in (0, 130), err.decode()
    if child.returncode == 130:
        assert out.read_text() == OLD
    else:
        assert child.returncode == 0
        text = out.read_text()
        lines = int(re.search(r"G-code lines\s+(\d+)", stdout.decode()).group(1))
        assert text.count("\n") == lines and text.rstrip().endswith("M2")


def test_a_picture_name_matplotlib_cannot_write_is_refused_before_any_work(tmp_path, image, capsys):
    """--annotated, --preview and -o of the drawing commands: refused before the program or the
    widths CSV beside them is (re)written."""
    out = tmp_path / "out.gcode"
    out.write_text(OLD)
    err = _refused(capsys, ["img2gcode", image, "-o", out, "--preview", tmp_path / "p.gcode"])
    assert "p.gcode: cannot draw a '.gcode' file; expected one of" in err and ".png" in err
    assert out.read_text() == OLD
    err = _refused(capsys, ["preview", GCODE, "-o", tmp_path / "p.txt"])
    assert "p.txt: cannot draw a '.txt' file" in err and not (tmp_path / "p.txt").exists()
