"""Timing a command as a user runs it: a fresh process, best of several after a warm-up."""

from __future__ import annotations

import os
import resource
import subprocess
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def process_time(argv: list[str], repeat: int, clock: str = "wall", settle_s: float = 0.0) -> float:
    """Best wall time (s) of ``argv`` as a fresh process, after one warm-up run; with
    ``clock="cpu"`` its CPU time instead (user + system, the process and its children):
    on a machine shared with other work, wall times stretch with the load of the moment,
    CPU times much less.

    The warm-up fills the caches a user's second run finds: numba's compiled kernels and
    Python's bytecode. An environment that forbids bytecode (``PYTHONDONTWRITEBYTECODE``,
    set on some CI images) would otherwise time compiling labkit's sources on every run,
    so it is dropped here. A failing command stops the benchmark with its stderr.

    ``settle_s``: after the ``repeat`` runs, a short command runs again until its measured
    runs add up to this many seconds (at most ten runs in all): one run of a 0.2 s command
    moves by a third with what else the machine does, the best of ten does not.
    """
    return process_times({"": (argv, {})}, repeat, clock, settle_s)[""]


def process_times(runs: dict, repeat: int, clock: str = "wall", settle_s: float = 0.0) -> dict:
    """:func:`process_time` of several commands compared with each other, run in turns
    (each once a round, after one warm-up round): what else the machine does in a minute
    then weighs on all of them alike, where one command timed after the other met another
    load (the same command, timed twice a minute apart, moved by a quarter).

    Parameters
    ----------
    runs : dict
        name → ``(argv, environment variables set for it)``; a variable set to None is removed.
    repeat, clock, settle_s
        As :func:`process_time`: a command takes its turn in every round until its own runs
        add up to ``settle_s`` (at most ten measured runs, at least ``repeat``).

    Returns
    -------
    dict
        name → its best time, s.
    """
    # the checkout first; a PYTHONPATH already set (peers installed with pip --target) after it
    base = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
    base.pop("PYTHONDONTWRITEBYTECODE", None)
    envs = {}
    for name, (_, extra) in runs.items():
        env = dict(base)
        for key, value in extra.items():
            if value is None:
                env.pop(key, None)
            else:
                env[key] = value
        envs[name] = env
    best = dict.fromkeys(runs, float("inf"))
    total = dict.fromkeys(runs, 0.0)
    k = 0
    while True:
        due = [name for name in runs if k <= repeat or (total[name] < settle_s and k <= max(repeat, 10))]
        if not due:
            break
        for name in due:
            argv = runs[name][0]
            t, used = time.perf_counter(), _children_cpu()
            done = subprocess.run(argv, env=envs[name], cwd=ROOT, capture_output=True, text=True)
            elapsed = time.perf_counter() - t if clock == "wall" else _children_cpu() - used
            if done.returncode != 0:
                raise SystemExit(f"{' '.join(argv)} failed:\n{done.stderr}")
            if k:
                best[name], total[name] = min(best[name], elapsed), total[name] + elapsed
        k += 1
    return best


def _children_cpu() -> float:
    """CPU seconds (user + system) of this process's finished children so far."""
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime
