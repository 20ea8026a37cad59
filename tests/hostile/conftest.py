"""The hostile-input runner: ``python -m labkit ARGS`` in a subprocess under hard ceilings.

Every area's ``tests/hostile/test_<area>_*.py`` uses the ``run_labkit`` fixture. A case
states its outcome (exit status, the error and its place) and the runner enforces what
no input may cost: wall time (the child is killed at ``time_s``) and address space
(``resource.setrlimit(RLIMIT_AS)``, so memory that grows with a hostile input ends in a
MemoryError rather than a swapping machine). A traceback on stderr is always a failure.
"""

from __future__ import annotations

import os
import resource
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

#: Address space a labkit command needs before any input (Python, numpy, numba, llvmlite
#: map large virtual regions: ~800 MB measured with cached kernels, more while compiling);
#: a case's ``memory_mb`` is added on top of it. Too tight a limit can leave numba
#: compiling for minutes instead of failing, so keep this base generous.
BASE_ADDRESS_SPACE_MB = 1200


@dataclass(frozen=True)
class Result:
    """What a ``labkit`` run returned."""

    code: int
    stdout: str
    stderr: str
    seconds: float


def run(args, *, time_s: float = 60.0, memory_mb: float = 500.0, stdin: bytes | None = None,
        cwd=None, env: dict | None = None) -> Result:
    """Run ``python -m labkit *args`` within ``time_s`` seconds and ``memory_mb`` MB of
    address space above :data:`BASE_ADDRESS_SPACE_MB`; fail the test when either is exceeded
    or stderr holds a traceback."""
    limit = int((BASE_ADDRESS_SPACE_MB + memory_mb) * 2**20)

    def limits():
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))

    child_env = dict(os.environ)
    child_env["PYTHONPATH"] = os.pathsep.join(
        [str(ROOT)] + [p for p in child_env.get("PYTHONPATH", "").split(os.pathsep) if p])
    child_env.update(env or {})
    t0 = time.perf_counter()
    try:
        proc = subprocess.run([sys.executable, "-m", "labkit", *map(str, args)], input=stdin,
                              capture_output=True, timeout=time_s, preexec_fn=limits, cwd=cwd,
                              env=child_env)
    except subprocess.TimeoutExpired:
        pytest.fail(f"labkit {' '.join(map(str, args))[:200]} ran past its ceiling of {time_s} s")
    seconds = time.perf_counter() - t0
    out = proc.stdout.decode("utf-8", "replace")
    err = proc.stderr.decode("utf-8", "replace")
    if "MemoryError" in err:
        pytest.fail(f"labkit {' '.join(map(str, args))[:200]} exceeded its memory ceiling of "
                    f"{memory_mb} MB:\n{err[-2000:]}")
    if "Traceback (most recent call last)" in err:
        pytest.fail(f"labkit {' '.join(map(str, args))[:200]} gave a traceback:\n{err[-2000:]}")
    return Result(proc.returncode, out, err, seconds)


@pytest.fixture
def run_labkit():
    """The :func:`run` function (``run_labkit(["check", path], time_s=…, memory_mb=…)``)."""
    return run
