"""Compiled kernels on demand: numba is imported, and a module's kernels compiled or
loaded from the cache, only when a kernel of that module first needs the speed.

Every kernel is written once, as plain Python over numpy arrays, and decorated with
:func:`jit` instead of ``numba.njit``. The decorator returns a :class:`Kernel`:

- Until a kernel runs compiled, nothing of numba is imported. Importing numba and
  loading a module's cached machine code costs :data:`LOAD_COST_S` of CPU time, which
  dominates a command on a small file (``labkit check`` on a 2,400-line job parses in
  3 ms once compiled).
- **The rule (one for every kernel and command):** kernels run as plain Python (their
  ``py_func``, the same function numba compiles) while the CPU time this process has
  spent running kernels as Python, plus what the work at hand is projected to spend,
  stays below :data:`LOAD_COST_S`; once it would reach it, numba is loaded and every
  later call runs compiled — except inputs below :data:`PYTHON_ALWAYS_BELOW` elements
  (and below the kernel's ``python_below``), which still run as Python until that kernel
  has spent :data:`MODULE_LOAD_COST_S` on them, what loading one more module's cached
  code costs. The projection is the job's when one is open
  (:func:`job_units`: the Python time per unit of the units done so far, times the units
  left; with jobs inside jobs — files of a batch, shapes of a file — the largest), and at
  least the call's own: ``n / python_below`` loads for ``n`` array elements
  (``python_below`` is set where the kernel is declared, from its measured cost per
  element; 0 means always compiled). The tally carries across jobs, so a process that
  converts many small files pays for numba once its Python time would have paid for it.
  A job switched late has paid for what it ran as Python before: the projection starts
  once :data:`JOB_SAMPLE` of its units are done or it has spent that share of
  :data:`LOAD_COST_S`, so a job near the crossover pays about a tenth of a load extra.
  One-dimensional ``uint8`` arguments are handed to Python as ``memoryview``
  objects: indexing them gives Python ints, which is both faster than numpy scalars and
  keeps numba's integer arithmetic (numpy 2 keeps ``uint8 - 48`` a wrapping ``uint8``,
  numba widens it to ``int64``). A kernel declared with ``views=True`` (one that only
  indexes its array arguments element by element, ``p[i, 0]``, and reads ``.shape``) gets
  every C-contiguous array argument as a ``memoryview``: its arithmetic then runs on Python
  floats, about twice as fast as on numpy scalars and bit for bit the same.
- Otherwise the first call makes the numba dispatcher, which compiles (or loads from
  numba's cache) on that call. Kernels name each other as usual: numba is taught that a
  :class:`Kernel` it meets in compiled code is its dispatcher, so callees compile (or
  come with the caller's cached code) exactly as with ``numba.njit``.

``LABKIT_JIT=python`` runs every kernel as Python (stepping through with a debugger),
``LABKIT_JIT=compiled`` compiles every kernel on first use (what the tests of the
compiled path set), ``NUMBA_DISABLE_JIT=1`` is honoured as numba defines it.
"""

from __future__ import annotations

import contextlib
import functools
import os
import sys
import threading
import time
import types

__all__ = ["Kernel", "jit", "compile_all", "mode", "forced", "job_units", "LOAD_COST_S"]

# Depth of kernels running as Python. Shared by threads on purpose (a plain list is the
# cheapest check on the hot path of nested calls): a thread that starts a kernel while
# another runs one as Python runs as Python too — the same results, only slower.
_python_depth = [0]
_lock = threading.RLock()
_registry: dict[str, list["Kernel"]] = {}
_numba_loaded = [False]             # a kernel of this process went compiled
#: Below this many elements a ``python_below`` kernel runs as Python even when numba is
#: loaded already (a few ms as Python against ~15 ms to load its cached machine code).
PYTHON_ALWAYS_BELOW = 4096
#: CPU seconds that importing numba and loading a job's cached kernels cost (measured on
#: the 2-core reference machine: numba's import 0.25 s, the first module's kernels 0.45 s;
#: svg2gcode's five modules 0.9–1.0 s, its CPU time compiled less its time as Python with
#: the kernels' own share taken out). CPU time, not wall time, on both sides of the rule:
#: a loaded machine stretches both alike.
LOAD_COST_S = 1.0
#: A job projects its Python time once this share of its units is done, or once it has
#: spent this share of LOAD_COST_S as Python: a late switch costs at most about that much.
JOB_SAMPLE = 0.1
#: CPU seconds to load one more module's cached kernels once numba is loaded: a kernel runs
#: tiny inputs as Python after the load until they have cost it this much.
MODULE_LOAD_COST_S = 0.03
_spent = [0.0]                      # CPU s this process has spent in kernels run as Python
_jobs: list["_Job"] = []            # the open jobs, innermost last
_cpu_clock = time.process_time      # the clock of the tally (tests set their own)
_hooks_installed = False


#: The mode when ``LABKIT_JIT`` is not set (the test suite sets ``"compiled"``, so the
#: kernels it exercises in-process are the compiled ones, as users' big jobs run them).
DEFAULT_MODE = "auto"
_forced: list = [None]              # set by forced(): overrides everything


def mode() -> str:
    """``"auto"``, ``"python"`` or ``"compiled"``: :func:`forced`, ``LABKIT_JIT``, then
    :data:`DEFAULT_MODE`."""
    if _forced[0] is not None:
        return _forced[0]
    if os.environ.get("NUMBA_DISABLE_JIT", "0") not in ("", "0"):
        return "python"
    value = os.environ.get("LABKIT_JIT", "").strip().lower() or DEFAULT_MODE
    if value not in ("auto", "python", "compiled"):
        raise ValueError(f"LABKIT_JIT={value!r}: expected auto, python or compiled")
    return value


def _elements(args) -> int:
    total = 0
    for a in args:
        if isinstance(a, tuple):                   # a record of arrays (a NamedTuple of columns)
            total += _elements(a)
            continue
        size = getattr(a, "size", None)
        if isinstance(size, int):
            total += size
        elif isinstance(a, (bytes, bytearray, memoryview)):
            total += len(a)
    return total


def _as_python(a):
    # One-dimensional uint8 arrays (text, masks): Python ints on indexing; see above.
    if isinstance(a, tuple) and hasattr(a, "_fields"):     # a NamedTuple of columns
        return type(a)(*(_as_python(x) for x in a))
    if getattr(a, "ndim", None) == 1 and getattr(a, "dtype", None) is not None \
            and a.dtype.char == "B" and a.flags.c_contiguous:
        return memoryview(a)
    return a


def _as_view(a):
    # views=True: every C-contiguous array indexes to Python scalars; see above.
    if isinstance(a, tuple) and hasattr(a, "_fields"):
        return type(a)(*(_as_view(x) for x in a))
    flags = getattr(a, "flags", None)
    if flags is not None and getattr(a, "ndim", 0) >= 1 and flags.c_contiguous and a.size:
        return memoryview(a)
    return a


class Kernel:
    """A numba kernel compiled on first need; see the module docstring.

    Attributes
    ----------
    py_func : callable
        The plain Python function (as on a numba dispatcher).
    python_below : int
        Below this many array elements in all, an uncompiled module runs ``py_func``.
    """

    def __init__(self, func, options: dict, python_below: int, python=None, views=False):
        self.py_func = func
        self.views = bool(views)
        self.options = options
        self.python_below = int(python_below)
        self.python_impl = python
        self.dispatcher = None
        self.spent_since_load = 0.0     # CPU s run as Python after numba was loaded
        functools.update_wrapper(self, func)

    def __repr__(self):
        state = "compiled" if self.dispatcher is not None else "not compiled"
        return f"<labkit kernel {self.py_func.__module__}.{self.py_func.__qualname__} ({state})>"

    def __get__(self, obj, objtype=None):      # behave as a plain function in classes
        return self if obj is None else types.MethodType(self, obj)

    def __call__(self, *args):
        if _python_depth[0]:                       # called from a kernel running as Python
            return self.py_func(*args)
        dispatcher = self.dispatcher
        if dispatcher is not None and _forced[0] is None:
            return dispatcher(*args)
        how = mode()
        if how == "python":
            return self.run_python(*args)
        if how == "auto" and runs_as_python(_elements(args), self.python_below,
                                            self.spent_since_load):
            return self.run_python(*args, tally=True)
        return self.compiled()(*args)

    def run_python(self, *args, tally=False):
        """Run as plain Python (kernels it calls too), whatever the size; ``tally`` counts
        its CPU time towards the rule's tally."""
        _python_depth[0] += 1
        start = _cpu_clock() if tally else 0.0
        loaded = _numba_loaded[0]
        try:
            convert = _as_view if self.views else _as_python
            return self.python_twin()(*(convert(a) for a in args))
        finally:
            _python_depth[0] -= 1
            if tally:
                took = _cpu_clock() - start
                _spent[0] += took
                if loaded:
                    self.spent_since_load += took

    def python_twin(self):
        """``py_func`` with the kernels it names bound to their own twins: a kernel running as
        Python calls the kernels below it as plain functions, without passing through
        :meth:`__call__` for each call (a parse makes tens of thousands of such calls)."""
        twin = self.__dict__.get("_twin")
        if twin is None:
            f = self.python_impl or self.py_func
            names = dict(f.__globals__)
            twin = types.FunctionType(f.__code__, names, f.__name__, f.__defaults__, f.__closure__)
            twin.__kwdefaults__ = f.__kwdefaults__
            self._twin = twin                    # before the callees: kernels may call each other
            for name in f.__code__.co_names:
                value = names.get(name)
                if isinstance(value, Kernel):
                    names[name] = value.python_twin()
        return twin

    def compiled(self):
        """The numba dispatcher (it compiles, or loads from numba's cache, on first call)."""
        if self.dispatcher is None:
            with _lock:
                if self.dispatcher is None:
                    global _hooks_installed
                    if not _hooks_installed:
                        from labkit import _configure_numba_cache

                        _configure_numba_cache()     # before numba reads its settings
                        _install_numba_hooks()
                        _hooks_installed = True
                    import numba

                    self.dispatcher = numba.njit(**self.options)(self.py_func)
                    _numba_loaded[0] = True
        return self.dispatcher


def runs_as_python(n: int, python_below: int, spent_since_load: float = 0.0) -> bool:
    """The rule of the module docstring: whether a call of ``n`` array elements to a kernel
    declared with ``python_below`` (that has spent ``spent_since_load`` CPU seconds as Python
    since numba was loaded) runs as Python in ``"auto"`` mode now."""
    if n >= python_below:
        return False                      # python_below=0: always compiled
    if _numba_loaded[0]:
        return n < PYTHON_ALWAYS_BELOW and spent_since_load < MODULE_LOAD_COST_S
    inner = _jobs[1:] + [None]
    projected = max([n / python_below * LOAD_COST_S]
                    + [j.projected_rest(k) for j, k in zip(_jobs, inner)])
    return _spent[0] + projected < LOAD_COST_S


class _Job:
    """A job of ``units`` like units of work (shapes of a drawing): what it spent as Python
    per unit done so far projects what the rest will spend."""

    def __init__(self, units: int):
        self.units, self.done, self.spent_at_start = units, 0, _spent[0]

    def projected_rest(self, inner: "_Job | None" = None) -> float:
        """CPU s the units left will spend as Python; ``inner``, the job running inside the
        current unit, tells how much of that unit is done (a batch projects from part of
        its first file)."""
        spent = _spent[0] - self.spent_at_start
        done = self.done + (inner.done / inner.units if inner is not None and inner.units else 0.0)
        if done == 0 or (done < JOB_SAMPLE * self.units and spent < JOB_SAMPLE * LOAD_COST_S):
            return 0.0                   # too few units yet to tell (one shape may be unlike the rest)
        return spent / done * (self.units - done)


def job_units(items):
    """Iterate over ``items``, the units of one job, so that the rule of the module
    docstring projects the job's Python time from the units done so far.

    Parameters
    ----------
    items : sequence
        The units (shapes of a drawing, entities of a DXF); its length is the job's size.

    Yields
    ------
    object
        Each item in turn; a unit counts as done when the loop asks for the next one.

    A program converting many files in one process declares them too (``for f in
    job_units(files): ...``): the first file's Python time then projects the batch's.

    Examples
    --------
    >>> [x * 2 for x in job_units([1, 2, 3])]
    [2, 4, 6]
    """
    current = _Job(len(items))
    _jobs.append(current)
    try:
        for item in items:
            yield item
            current.done += 1
    finally:
        _jobs.remove(current)


@contextlib.contextmanager
def forced(how: str):
    """Run every kernel called inside the block as ``"python"`` or ``"compiled"``.

    For tests that compare the two and for stepping through a kernel in a debugger.
    """
    if how not in ("python", "compiled"):
        raise ValueError(f"forced({how!r}): expected 'python' or 'compiled'")
    previous, _forced[0] = _forced[0], how
    try:
        yield
    finally:
        _forced[0] = previous


def jit(func=None, *, python_below: int = 0, python=None, views: bool = False, **options):
    """Declare a kernel: ``@jit`` or ``@jit(python_below=N, **numba_options)``.

    ``python`` gives a plain-Python twin that runs instead of the kernel's own code when it
    runs as Python — for the rare kernel whose numba-friendly form is slow in Python
    (element-by-element writes into a record array); it must compute the same (tests compare
    the two paths).

    ``views=True`` hands the array arguments to Python as ``memoryview`` objects (see the
    module docstring): only for a kernel that indexes them element by element.

    ``cache=True`` is the default (numba's cache folder is set by :mod:`labkit`).

    >>> @jit(python_below=1000, cache=False)   # cache=False: a doctest has no file
    ... def total(a):
    ...     s = 0.0
    ...     for v in a:
    ...         s += v
    ...     return s
    >>> import numpy as np
    >>> float(total(np.arange(4.0)))
    6.0
    >>> with forced("python"):
    ...     float(total(np.arange(10_000.0)))
    49995000.0
    """
    options.setdefault("cache", True)

    def wrap(f):
        kernel = Kernel(f, options, python_below, python, views)
        _registry.setdefault(f.__module__, []).append(kernel)
        return kernel

    return wrap if func is None else wrap(func)


def _install_numba_hooks() -> None:
    """Teach numba that a :class:`Kernel` named in compiled code is its dispatcher."""
    from numba.core import types
    from numba.core.typing.typeof import typeof_impl

    @typeof_impl.register(Kernel)
    def _typeof_kernel(value, context):
        return types.Dispatcher(value.compiled())


def compile_all(module: str | None = None) -> int:
    """Compile (or load from cache) every declared kernel, or those of ``module``.

    Returns how many kernels it compiled; used to warm numba's cache once before
    parallel test workers start.
    """
    count = 0
    for name, kernels in list(_registry.items()):
        if module is None or name == module:
            for k in kernels:
                k.compiled()
                count += 1
    return count
