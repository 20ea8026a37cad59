"""Shared test settings: deterministic hypothesis runs, headless matplotlib."""

import os

import matplotlib
from hypothesis import HealthCheck, settings

matplotlib.use("Agg")

# In-process tests exercise the compiled kernels, as big jobs run them; small inputs run
# as Python only in commands started as subprocesses (fast to start) and in the tests
# that compare the two paths (tests/test_jit.py).
from labkit import _jit  # noqa: E402

_jit.DEFAULT_MODE = "compiled"

# Seeded, repeatable property tests: the same examples on every machine and every run.
settings.register_profile(
    "labkit",
    derandomize=True,
    deadline=None,
    max_examples=int(os.environ.get("LABKIT_HYPOTHESIS_EXAMPLES", "150")),
    suppress_health_check=[HealthCheck.too_slow],
)
settings.load_profile("labkit")


def pytest_configure(config):
    # With parallel workers (pytest -n, see the Makefile), compile the kernels once in
    # the controller before the workers start, instead of once per worker
    # (tests/_warm_kernels.py). Without xdist, or on a worker, nothing to do.
    if hasattr(config, "workerinput") or not getattr(config.option, "numprocesses", None):
        return
    from tests._warm_kernels import warm_once

    for note in warm_once():
        print(f"note: kernel warm-up: {note}")



def _serialise_kernel_starts():
    """Parallel workers (make test: pytest -n) start one Jupyter kernel per notebook. Two kernels
    starting at the same moment can pick the same free TCP ports, and one dies ("Kernel died
    before replying to kernel_info"), failing a notebook at random. Starts are serialised across
    workers by a file lock; each kernel is running, with its ports bound, when the lock opens."""
    import fcntl
    import functools
    import tempfile
    from pathlib import Path

    try:
        from nbval import kernel as nbval_kernel
    except ImportError:
        return
    start = nbval_kernel.RunningKernel.__init__
    if getattr(start, "_labkit_serialised", False):
        return
    lock_path = Path(tempfile.gettempdir()) / "labkit-nbval-kernel-start.lock"

    @functools.wraps(start)
    def serialised(self, *args, **kwargs):
        with open(lock_path, "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            try:
                start(self, *args, **kwargs)
            finally:
                fcntl.flock(lock, fcntl.LOCK_UN)

    serialised._labkit_serialised = True
    nbval_kernel.RunningKernel.__init__ = serialised


_serialise_kernel_starts()
