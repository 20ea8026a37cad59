"""Compiled once for every user: the environment's kernel cache, read-only for the users, and
``make lab``'s warm-up of every kernel the chapters and commands call (issue 29, point 4).

Each check runs fresh processes: what a process compiled or loaded is read from numba's own
counters (``dispatcher.stats``: a cache hit loads machine code, a miss compiles).
"""

from __future__ import annotations

import json
import os
import shutil
import stat
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest


ROOT = Path(__file__).resolve().parents[1]
TABLE = ROOT / "labkit" / "_warm_kernels.json"

# Two small kernels; prints what the process did with each and which folders it chose.
PROBE = """
import json, sys
import labkit._jit as j
if sys.argv[1] == "pretend-read-only":     # when no read-only folder can be made (see below)
    j._writable = lambda folder: False
from labkit.geometry._quadratic import stable_quadratic_roots
from labkit.geometry.measure import _seg_dist
out = {}
for name in sys.argv[2:]:
    if name == "quadratic":
        k = stable_quadratic_roots; k(1.0, -3.0, 2.0)
    else:
        k = _seg_dist; k(0.0, 1.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    s = k.dispatcher.stats
    out[name] = {"loaded": sum(s.cache_hits.values()), "compiled": sum(s.cache_misses.values())}
shared, writable, user = j.cache_folders()
out["folders"] = [str(shared), writable, str(user)]
print(json.dumps(out))
"""


def _probe(tmp: Path, home: str, *kernels: str, read_only: str = "no") -> dict:
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "LABKIT_JIT")}
    env.update(LABKIT_JIT="compiled", LABKIT_SHARED_KERNELS=str(tmp / "shared"),
               XDG_CACHE_HOME=str(tmp / home), PYTHONPATH=str(ROOT))
    argv = [sys.executable, "-c", PROBE, "pretend-read-only" if read_only == "pretend" else "-",
            *kernels]
    if read_only == "mount":                 # root ignores mode bits: a read-only bind mount
        script = (f"mount --bind {tmp}/shared {tmp}/shared && "
                  f"mount -o remount,ro,bind {tmp}/shared && exec \"$@\"")
        argv = ["unshare", "-m", "sh", "-c", script, "sh", *argv]
    done = subprocess.run(argv, env=env, cwd=tmp, capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def _read_only_way(tmp: Path) -> str:
    """How this machine can make the shared folder read-only for a process."""
    if os.geteuid() != 0:
        return "mode"
    probe = tmp / "ro-probe"
    probe.mkdir()
    ok = subprocess.run(["unshare", "-m", "sh", "-c",
                         f"mount --bind {probe} {probe} && mount -o remount,ro,bind {probe} "
                         f"&& ! touch {probe}/x"], capture_output=True) if shutil.which("unshare") else None
    return "mount" if ok is not None and ok.returncode == 0 else "pretend"


def _files(folder: Path) -> dict[str, int]:
    return {str(p.relative_to(folder)): p.stat().st_mtime_ns for p in folder.rglob("*") if p.is_file()}


def test_a_read_only_shared_cache_serves_every_user_and_new_kernels_go_to_the_users_cache():
    with tempfile.TemporaryDirectory() as name:
        tmp = Path(name)
        # The teacher: the environment's folder is writable, so the kernel is compiled there
        # and nothing goes to the teacher's own cache.
        teacher = _probe(tmp, "teacher", "quadratic")
        assert teacher["quadratic"] == {"loaded": 0, "compiled": 1}
        assert teacher["folders"][1] is True and teacher["folders"][2] == "None"
        shared_files = _files(tmp / "shared")
        assert any(f.endswith(".nbi") and "stable_quadratic_roots" in f for f in shared_files)
        assert not (tmp / "teacher").exists() or not any((tmp / "teacher").rglob("*.nbc"))

        # A student: the folder is read-only to them (mode bits, a read-only mount, or, where
        # neither can be made, labkit told so). The kernel the teacher compiled is loaded,
        # not compiled; a kernel the teacher did not compile is compiled into the student's
        # cache; the shared folder is left exactly as it was.
        way = _read_only_way(tmp)
        if way == "mode":
            for p in [tmp / "shared", *(tmp / "shared").rglob("*")]:
                p.chmod(p.stat().st_mode & ~(stat.S_IWUSR | stat.S_IWGRP | stat.S_IWOTH))
        student = _probe(tmp, "student", "quadratic", "segment", read_only=way)
        assert student["folders"][1] is False
        assert student["quadratic"] == {"loaded": 1, "compiled": 0}
        assert student["segment"] == {"loaded": 0, "compiled": 1}
        assert _files(tmp / "shared") == shared_files
        saved = [p.name for p in (tmp / "student").rglob("*.nbc") if not p.is_symlink()]
        assert any("_seg_dist" in n for n in saved) and not any("quadratic" in n for n in saved)

        # The same student again: both kernels now load (one through the link to the shared
        # folder, one from their own cache).
        again = _probe(tmp, "student", "quadratic", "segment", read_only=way)
        assert again["quadratic"] == again["segment"] == {"loaded": 1, "compiled": 0}
        if way == "mode":
            for p in [tmp / "shared", *(tmp / "shared").rglob("*")]:
                p.chmod(p.stat().st_mode | stat.S_IWUSR)


def test_the_warm_list_holds_every_chapter_and_command():
    """The list ``make lab`` compiles was recorded from every chapter on disk and every command
    of tests/_chapter_kernels.py, and names kernels that exist (a kernel renamed or inlined
    since: record again the sources named)."""
    from labkit._jit import kernel_named

    sys.path.insert(0, str(ROOT / "tests"))
    try:
        import _chapter_kernels
    finally:
        sys.path.remove(str(ROOT / "tests"))
    table = json.loads(TABLE.read_text())
    chapters = {f"notebooks/{p.name}" for p in (ROOT / "notebooks").glob("[0-9][0-9]-*.ipynb")}
    recorded = set(table["by_source"])
    assert chapters <= recorded, f"chapters never recorded: {sorted(chapters - recorded)}"
    commands = {s for s in recorded if s.startswith("labkit ")}
    assert len(commands) == len(_chapter_kernels.COMMANDS)
    for source, kernels in table["by_source"].items():
        for name, signatures in kernels.items():
            assert set(signatures) <= set(table["signatures"][name]), (source, name)
    for name in table["signatures"]:
        try:
            kernel_named(name)
        except LookupError:
            users = [s for s, kernels in table["by_source"].items() if name in kernels]
            pytest.fail(f"{name} is no kernel now: run tests/_chapter_kernels.py {' '.join(users)}")
    # chapter 03 (de Casteljau, flattening) is the one the issue names: its kernels are there
    assert table["by_source"]["notebooks/03-bezier-de-casteljau.ipynb"]


# A fresh process after the warm-up: every signature a chapter or command uses loads from the
# cache; none compiles.
CHECK_WARM = """
import base64, json, pickle, sys
from labkit._jit import kernel_named
table = json.load(open(sys.argv[1]))
names = sorted({(k, s) for kernels in table["by_source"].values() for k, sigs in kernels.items()
                for s in sigs})
missed = []
for name, text in names:
    d = kernel_named(name).compiled()
    sig = pickle.loads(base64.b64decode(table["signatures"][name][text]))
    before = sum(d.stats.cache_misses.values())
    d.compile(sig)
    if sum(d.stats.cache_misses.values()) != before:
        missed.append(name + text[:60])
print(json.dumps({"checked": len(names), "compiled": missed}))
"""


def test_make_labs_warm_up_leaves_every_chapter_and_command_kernel_compiled():
    """What ``make lab`` runs (``python -m labkit._jit warm``), then a fresh process: every
    kernel signature the chapters and commands were recorded calling loads, none compiles.
    Uses this install's own cache (a second run only loads: seconds)."""
    makefile = (ROOT / "Makefile").read_text()
    lab = makefile[makefile.index("\nlab:"):].split("\n\n")[0]
    assert "-m labkit._jit warm" in lab
    env = {k: v for k, v in os.environ.items() if k not in ("LABKIT_JIT",)}
    env["PYTHONPATH"] = str(ROOT)
    done = subprocess.run([sys.executable, "-m", "labkit._jit", "warm"], env=env, cwd=ROOT,
                          capture_output=True, text=True, timeout=3600)
    assert done.returncode == 0, done.stderr[-2000:]
    check = subprocess.run([sys.executable, "-c", CHECK_WARM, str(TABLE)], env=env, cwd=ROOT,
                           capture_output=True, text=True, timeout=3600)
    assert check.returncode == 0, check.stderr[-2000:]
    found = json.loads(check.stdout.strip().splitlines()[-1])
    assert found["checked"] > 20 and found["compiled"] == []
