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
  (:func:`job_units`, or :func:`job` for units that end outside a loop, such as a stream's
  lines as they are answered: the Python time per unit of the units done so far, times the
  units left; with jobs inside jobs — files of a batch, shapes of a file — the largest), and at
  least the call's own: ``n / python_below`` loads for ``n`` array elements (or the call's
  ``work``, for a kernel whose cost an element depends on an argument)
  (``python_below`` is set where the kernel is declared, from its measured cost per
  element; 0 means always compiled). The tally carries across jobs, so a process that
  converts many small files pays for numba once its Python time would have paid for it.
  A job switched late has paid for what it ran as Python before: the projection starts
  once :data:`JOB_SAMPLE` of its units are done or it has spent that share of
  :data:`LOAD_COST_S`, so a job near the crossover pays about a tenth of a load extra.
  Work a job knows it will do later in kernels it has not called yet (a dithered image's
  moves, written once the dots are made) is declared with :func:`expecting` and added to
  every projection until those kernels run, so the first kernel of the job decides for
  the whole of it (``later=True``: until the block ends, for work that begins after it in
  a kernel the block calls for other work, as a stream's file is read before the virtual
  machine reads each line again). The tally's clock is the CPU time of the thread that
  runs the kernel, so another thread's work (a sender polling) is not charged to it.
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

**Where compiled kernels are kept** (:func:`cache_folders`): in the environment labkit is
installed in (``<sys.prefix>/var/cache/labkit/numba``) when this process may write there, so
that one ``make lab`` (:func:`warm`) compiles them for every user of the install; otherwise in
the user's cache (``~/.cache/labkit/numba``), which then starts as links to the kernels the
environment holds: numba refuses a cache folder it cannot write to, so a read-only shared
cache is read through these links, and a kernel missing from it is compiled and saved in the
user's folder (a save replaces the link, never writes through it). Both are keyed by the
state of the kernels' sources (:func:`labkit._numba_cache_dir`). ``NUMBA_CACHE_DIR``, when
set, is numba's own and wins; ``LABKIT_SHARED_KERNELS`` names another shared folder.

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
from pathlib import Path

__all__ = ["Kernel", "jit", "compile_all", "mode", "forced", "job", "job_units", "expecting", "LOAD_COST_S",
           "cache_folders", "warm", "rule_state"]

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
_ahead: list[dict] = []             # work declared by open expecting() blocks: Kernel → elements
_after: list[dict] = []             # the same, declared to begin after the block (later=True)
# The tally's clock is the calling thread's CPU time: a stream's virtual machine runs its
# kernels in the reader thread while the sender polls in the main one, and the process's
# clock charged the sender's time to the kernels (tests set their own clock).
_cpu_clock = time.thread_time
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
    work : callable or None
        The size of a call for the rule, from its arguments (:func:`jit`); None: its array
        elements.
    """

    def __init__(self, func, options: dict, python_below: int, python=None, views=False, work=None):
        self.py_func = func
        self.work = work
        self.views = bool(views)
        self.options = options
        self.python_below = int(python_below)
        self.python_impl = python
        self.dispatcher = None
        self.spent_since_load = 0.0     # CPU s run as Python after numba was loaded
        functools.update_wrapper(self, func)

    @property
    def targetoptions(self) -> dict:
        """The decorator's options under numba's name for them: numba's inliner looks for
        ``inline`` there, so a kernel declared ``inline="always"`` is inlined into its
        compiled callers (without this, numba met a :class:`Kernel`, saw no options and
        compiled a call)."""
        return self.options

    @property
    def name(self) -> str:
        """``module.qualname`` of the kernel's function."""
        return f"{self.py_func.__module__}.{self.py_func.__qualname__}"

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
        for declared in _ahead:                    # from now on its calls count themselves
            declared.pop(self, None)
        n = self.work(*args) if self.work is not None else _elements(args)
        if how == "auto" and runs_as_python(n, self.python_below,
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
                        _install_cache_locator()
                        _install_numba_hooks()
                        _hooks_installed = True
                    import numba

                    self.dispatcher = numba.njit(**self.options)(self.py_func)
                    _numba_loaded[0] = True
        return self.dispatcher


def rule_state() -> tuple:
    """What the rule has settled in this process so far: whether numba is loaded, the
    kernels that run compiled, and the CPU seconds spent running kernels as Python. Equal
    before and after some work, that work neither loaded code nor ran a kernel as Python:
    the process has paid its one-time costs for such work (benchmarks time it from then on).

    Returns
    -------
    tuple
        ``(numba loaded, names of compiled kernels, CPU s spent as Python)``.
    """
    compiled = tuple(sorted(k.name for kernels in _registry.values() for k in kernels
                            if k.dispatcher is not None))
    return _numba_loaded[0], compiled, _spent[0]


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
    for declared in _ahead + _after:               # kernels the job will call later
        for kernel, elements in declared.items():
            projected += (elements / kernel.python_below * LOAD_COST_S if kernel.python_below
                          else LOAD_COST_S)        # always compiled: numba will be loaded
    return _spent[0] + projected < LOAD_COST_S


class _Job:
    """A job of ``units`` like units of work (shapes of a drawing): what it spent as Python
    per unit done so far projects what the rest will spend."""

    def __init__(self, units: int):
        self.units, self.done, self.spent_at_start = units, 0, _spent[0]
        self.spent_at_done = _spent[0]          # the tally when the last unit ended

    def projected_rest(self, inner: "_Job | None" = None) -> float:
        """CPU s the units left will spend as Python; ``inner``, the job running inside the
        current unit, tells how much of that unit is done (a batch projects from part of
        its first file). Without one, the units done give the cost of a unit, and what the
        unit under way has spent already is taken off its share: a file's kernels after
        its shapes (ordering, G-code) ran with the file counted as not begun, and a batch
        of ten files at 0.1 mm projected twice its Python time and loaded numba for 0.5 s
        more than it ran as Python."""
        spent = _spent[0] - self.spent_at_start
        done = self.done + (inner.done / inner.units if inner is not None and inner.units else 0.0)
        if done == 0 or (done < JOB_SAMPLE * self.units and spent < JOB_SAMPLE * LOAD_COST_S):
            return 0.0                   # too few units yet to tell (one shape may be unlike the rest)
        if done != self.done:
            return spent / done * (self.units - done)
        per_unit = (self.spent_at_done - self.spent_at_start) / done
        left = self.units - done                # the unit under way is one of them
        return max(per_unit * left - (_spent[0] - self.spent_at_done), per_unit * (left - 1), 0.0)

    def advance(self, count: int = 1) -> None:
        """``count`` more units are done."""
        self.done += count
        self.spent_at_done = _spent[0]


@contextlib.contextmanager
def job(units: int):
    """Declare a job of ``units`` like units of work, done as :meth:`_Job.advance` says, so
    that the rule of the module docstring projects the job's Python time from the units
    done so far. For work whose units end outside a loop over them: a stream's lines end
    when the controller acknowledges them, and the virtual machine runs their kernels in
    another thread.

    Parameters
    ----------
    units : int
        The job's size: lines, shapes, files.

    Yields
    ------
    _Job
        Call its ``advance(count=1)`` as units end.

    Examples
    --------
    >>> with job(3) as lines:
    ...     for _ in range(3):
    ...         lines.advance()
    """
    current = _Job(int(units))
    _jobs.append(current)
    try:
        yield current
    finally:
        _jobs.remove(current)


def job_units(items):
    """Iterate over ``items``, the units of one job (:func:`job`), each done when the loop
    asks for the next one.

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
    with job(len(items)) as current:
        for item in items:
            yield item
            current.advance()


@contextlib.contextmanager
def expecting(work, later: bool = False):
    """Declare work the job will do after the block, in kernels it has not called yet.

    Inside the block the rule of the module docstring adds each declared kernel's
    ``elements / python_below`` loads to every projection, so a job whose later work would
    pay for numba runs compiled from its first kernel on, instead of running that kernel
    as Python and loading numba for the next one anyway. A declaration ends when its
    kernel is called (its calls then count themselves) or when the block ends.

    Parameters
    ----------
    work : dict
        ``{kernel: array elements}``, the elements as the kernel will be called with them
        (in all, when it is called in parts); e.g.
        :func:`labkit.gcode.writer.emit_work` for the program the job will write.
    later : bool
        The declared work begins after the block, so a call of its kernel inside the block
        is other work and the declaration stands until the block ends: a stream's reading
        of the file, before the virtual machine reads each line again
        (:func:`labkit.machine.virtual.stream_work`).

    Examples
    --------
    >>> @jit(python_below=1000, cache=False)
    ... def later(a):
    ...     return a.sum()
    >>> with expecting({later: 10_000}):     # ten loads' worth of later work
    ...     pass                                # a kernel called here would run compiled
    """
    declared = {kernel: int(n) for kernel, n in dict(work).items() if n > 0}
    if not declared:                   # nothing ahead: every projection stays as it is
        yield
        return
    where = _after if later else _ahead
    where.append(declared)
    try:
        yield
    finally:
        where.remove(declared)


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


def jit(func=None, *, python_below: int = 0, python=None, views: bool = False, work=None, **options):
    """Declare a kernel: ``@jit`` or ``@jit(python_below=N, **numba_options)``.

    ``python`` gives a plain-Python twin that runs instead of the kernel's own code when it
    runs as Python — for the rare kernel whose numba-friendly form is slow in Python
    (element-by-element writes into a record array); it must compute the same (tests compare
    the two paths).

    ``views=True`` hands the array arguments to Python as ``memoryview`` objects (see the
    module docstring): only for a kernel that indexes them element by element.

    ``work`` gives a call's size for the rule instead of its arguments' array elements: a
    function of the call's arguments returning elements at the kernel's ordinary cost, for a
    kernel whose cost per element depends on an argument (a parse that records the modal state
    of every line costs six times a plain parse as Python).

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
        kernel = Kernel(f, options, python_below, python, views, work)
        _registry.setdefault(f.__module__, []).append(kernel)
        return kernel

    return wrap if func is None else wrap(func)


def _shared_base() -> Path:
    """The folder under which an environment keeps the kernels its users share."""
    chosen = os.environ.get("LABKIT_SHARED_KERNELS")
    return Path(chosen) if chosen else Path(sys.prefix) / "var" / "cache" / "labkit" / "numba"


def _writable(folder) -> bool:
    # A file made and removed, not os.access: root passes os.access on any mode bits.
    import tempfile

    try:
        tempfile.TemporaryFile(dir=folder).close()
        return True
    except OSError:
        return False


_folders: list = []                 # (shared folder or None, it is writable, user folder or None)


def cache_folders(refresh: bool = False) -> tuple:
    """Where this process keeps compiled kernels (see the module docstring).

    Returns
    -------
    tuple
        ``(shared, shared_writable, user)``: the environment's folder for this state of the
        kernels' sources (``None`` when it does not exist and cannot be made), whether this
        process may write there, and the user's folder (``None`` when the shared one is
        writable, the only one then used, or when no user folder can be made).
    """
    if _folders and not refresh:
        return _folders[0]
    import hashlib

    from labkit import _numba_cache_dir

    root = Path(__file__).resolve().parent
    checkout = hashlib.sha1(str(root).encode()).hexdigest()[:8]
    try:
        shared = _numba_cache_dir(root, _shared_base() / checkout)
    except OSError:
        shared = None
    writable = shared is not None and _writable(shared)
    user = None
    if not writable:
        try:
            user = _numba_cache_dir(root)
        except OSError:
            user = None
    _folders[:] = [(shared, writable, user)]
    return _folders[0]


def _link_shared(shared_sub: Path, user_sub: Path) -> None:
    """Link every file of a shared cache folder into the user's, where the user has none."""
    try:
        names = os.listdir(shared_sub)
    except OSError:
        return
    user_sub.mkdir(parents=True, exist_ok=True)
    for name in names:
        target = user_sub / name
        if not os.path.lexists(target) and ".tmp." not in name:
            with contextlib.suppress(OSError):   # another process linked it first
                os.symlink(shared_sub / name, target)


_locator: list = []


def _locator_class():
    """numba's cache locator for labkit's kernels (made once: it subclasses numba's classes)."""
    if _locator:
        return _locator[0]
    from numba.core import caching

    here = os.path.dirname(os.path.abspath(__file__)) + os.sep
    linked: set = set()

    class LabkitCacheLocator(caching._SourceFileBackedLocatorMixin, caching._CacheLocator):
        """The environment's folder when writable, else the user's seeded with links to it."""

        def __init__(self, py_func, py_file, folder):
            self._py_file = py_file
            self._lineno = py_func.__code__.co_firstlineno
            self._cache_path = os.path.join(str(folder), self.get_suitable_cache_subpath(py_file))

        def get_cache_path(self):
            return self._cache_path

        @classmethod
        def from_function(cls, py_func, py_file):
            from numba.core import config

            if config.CACHE_DIR or not os.path.abspath(py_file).startswith(here):
                return None                  # numba's own choice, or not one of labkit's kernels
            shared, writable, user = cache_folders()
            folder = shared if writable else user
            if folder is None:
                return None                  # numba's default locators decide
            self = cls(py_func, py_file, folder)
            if not writable and shared is not None and self._cache_path not in linked:
                sub = self.get_suitable_cache_subpath(py_file)
                _link_shared(Path(shared) / sub, Path(self._cache_path))
                linked.add(self._cache_path)
            try:
                self.ensure_cache_path()
            except OSError:
                return None
            return self

    _locator.append(LabkitCacheLocator)
    return LabkitCacheLocator


def _install_cache_locator() -> None:
    """Put labkit's locator first in numba's list (for labkit's files only; others pass on)."""
    from numba.core import caching

    impl = caching.CompileResultCacheImpl
    cls = _locator_class()
    if cls not in impl._locator_classes:
        impl._locator_classes = [cls, *impl._locator_classes]


def kernel_named(name: str) -> Kernel:
    """The kernel whose function is ``module.qualname`` (:attr:`Kernel.name`); its module is
    imported. Raises LookupError when that module declares no such kernel."""
    import importlib

    module, _, qualname = name.rpartition(".")
    importlib.import_module(module)
    for k in _registry.get(module, []):
        if k.py_func.__qualname__ == qualname:
            return k
    raise LookupError(f"{name} is not a kernel (renamed or removed since the list was recorded)")


def warm(table_path=None, report=None) -> list[str]:
    """Compile every kernel any chapter or command uses, for the argument types each uses, into
    the cache (the environment's when writable: ``make lab`` compiles once for every user).

    Parameters
    ----------
    table_path : path-like, optional
        The kernels and signatures to compile (default ``labkit/_warm_kernels.json``, written
        by ``tests/_chapter_kernels.py`` from running every chapter and command).
    report : callable, optional
        Called with one line per kernel as it is done.

    Returns
    -------
    list of str
        The signatures that could not be compiled, one line each (empty when all were).
    """
    import base64
    import json
    import pickle

    path = Path(table_path) if table_path else Path(__file__).with_name("_warm_kernels.json")
    try:
        table = json.loads(path.read_text(encoding="utf-8"))["signatures"]
    except (OSError, ValueError, KeyError) as exc:
        return [f"{path}: no list of kernels to compile ({type(exc).__name__}: {exc})"]
    problems = []
    with forced("compiled"):
        for name, signatures in table.items():
            try:
                dispatcher = kernel_named(name).compiled()
            except Exception as exc:              # noqa: BLE001 (listed, the rest still warm)
                problems.append(f"{name}: {type(exc).__name__}: {exc}")
                continue
            for text, blob in signatures.items():
                try:
                    dispatcher.compile(pickle.loads(base64.b64decode(blob)))
                except Exception as exc:          # noqa: BLE001
                    problems.append(f"{name}{text[:80]}: {type(exc).__name__}: {str(exc)[:200]}")
            if report is not None:
                report(f"{name}: {len(signatures)} signature(s)")
    return problems


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


def compiled_signatures() -> dict[str, dict[str, str]]:
    """The kernels this process holds machine code for (compiled or loaded from the cache).

    Returns
    -------
    dict
        ``module.name`` of each kernel → its numba signatures: the argument types' ``repr``
        → the same types pickled (base64), which :func:`warm` compiles again.
    """
    import base64
    import pickle

    found = {}
    for kernels in _registry.values():
        for k in kernels:
            if k.dispatcher is not None and k.dispatcher.signatures:
                found[k.name] = {repr(tuple(s)): base64.b64encode(pickle.dumps(tuple(s))).decode()
                                 for s in k.dispatcher.signatures}
    return found


if __name__ == "__main__":
    # ``python -m labkit._jit warm``: what ``make lab`` runs. The module's own names are taken
    # from the imported module, not this __main__ copy, whose registry is empty.
    from labkit._jit import cache_folders as _folders_of, warm as _warm

    if sys.argv[1:] != ["warm"]:
        sys.exit("usage: python -m labkit._jit warm")
    failed = _warm()
    shared, writable, user = _folders_of()
    print(f"labkit: kernels cached in {shared if writable else user}"
          + ("" if writable else f" (the environment's {shared or 'folder'} is not writable here)"))
    for line in failed:
        print(f"note: not compiled now, will compile when first used: {line}", file=sys.stderr)
    sys.exit(1 if failed else 0)
