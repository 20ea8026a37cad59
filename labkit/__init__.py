"""labkit — a research and teaching toolkit for laser CNC machines.

The subpackages own one topic each and are imported on first use, so
``import labkit`` stays fast and headless:

gcode     G-code text → Moves (parse), Moves → text (emit), arcs, simulation
geometry  Paths of lines and circular arcs in mm: curves, transforms, offsets, order
vector    SVG and DXF import into Paths
raster    images → engraving Moves
toolpath  the Moves model and the generators that build it
motion    Bresenham, speed profiles, look-ahead, laser power, step timing
machine   driving GRBL, the labkit firmware and the Dobot over pyserial; the virtual machine
viz       matplotlib plots and ipywidgets (imported lazily)
"""

import importlib
import os
import re
from pathlib import Path

__version__ = "0.1.0"

__all__ = [
    "__version__",
    "gcode",
    "geometry",
    "vector",
    "raster",
    "toolpath",
    "motion",
    "machine",
    "viz",
    "errors",
    "units",
]

_SUBMODULES = frozenset(__all__) - {"__version__"}


def __getattr__(name):
    # Lazy subpackages: `labkit.motion` costs nothing until someone touches it.
    if name in _SUBMODULES:
        return importlib.import_module(f"labkit.{name}")
    raise AttributeError(f"module 'labkit' has no attribute {name!r}")


def __dir__():
    return sorted(__all__)


_IMPORT = re.compile(r"^\s*(?:from\s+(\.*)([\w.]*)\s+import\s+([\w\s,()*]+)|import\s+([\w.]+))", re.M)


_DECLARES_KERNEL = re.compile(r"^\s*@jit\b|\bjit\(", re.M)


def _kernel_sources(root: Path) -> list[Path]:
    """The source files compiled kernels depend on: every module that declares a kernel
    (``@jit``), and every module of the package those import, transitively.

    numba compiles a module's globals into its kernels and inlines the kernels they
    call, so these files — and only these — decide what a cached kernel contains.

    Examples
    --------
    >>> here = Path(__file__).resolve().parent
    >>> names = {p.relative_to(here).as_posix() for p in _kernel_sources(here)}
    >>> "_jit.py" in names and "gcode/_kernel.py" in names, "viz/gcode.py" in names
    (True, False)
    """
    package = root.name

    def module_file(dotted: str) -> Path | None:
        parts = dotted.split(".")
        if parts[0] != package:
            return None
        base = root.joinpath(*parts[1:])
        for candidate in (base.with_suffix(".py"), base / "__init__.py"):
            if candidate.is_file():
                return candidate
        return None

    def imported(path: Path) -> set[Path]:
        text = path.read_text(encoding="utf-8", errors="replace")
        here = [package, *path.relative_to(root).with_suffix("").parts]
        if here[-1] == "__init__":
            here = here[:-1]
        else:
            here = here[:-1]                 # the package the module is in
        found = set()
        for dots, name, names, plain in _IMPORT.findall(text):
            if plain:
                targets = [plain]
            else:
                base = here[:len(here) - (len(dots) - 1)] if dots else []
                mod = ".".join(base + ([name] if name else [])) if dots else name
                words = [w for w in re.split(r"[\s,()]+", names) if w and w != "*"]
                targets = [mod] + [f"{mod}.{w}" for w in words if w != "as"]
            for target in targets:
                f = module_file(target)
                if f is not None:
                    found.add(f)
        return found

    todo = [p for p in root.rglob("*.py")
            if _DECLARES_KERNEL.search(p.read_text(encoding="utf-8", errors="replace"))]
    seen: set[Path] = set()
    while todo:
        path = todo.pop()
        if path not in seen:
            seen.add(path)
            todo.extend(imported(path) - seen)
    return sorted(seen)


def _numba_cache_dir(root: Path | None = None, base: Path | None = None) -> Path:
    """Where compiled kernels are cached: one folder per state of the kernels' sources.

    numba's own cache is keyed by the file of each compiled function, so it keeps
    serving a kernel after a kernel or a constant it uses in another module has changed.
    Keying the cache by the size and modification time of every file a kernel depends
    on (:func:`_kernel_sources`) makes such an edit start from a fresh cache, while an
    edit anywhere else (a command, a plot, a docstring outside the kernels' modules)
    keeps every compiled kernel. Older folders beyond the last few are removed.
    """
    import hashlib
    import shutil

    root = root or Path(__file__).resolve().parent
    digest = hashlib.sha1()
    for path in _kernel_sources(root):
        st = path.stat()
        digest.update(f"{path.relative_to(root)}:{st.st_size}:{st.st_mtime_ns};".encode())
    if base is None:
        # One folder per checkout, so that two checkouts (a clone and a worktree) do
        # not prune each other's kernels.
        base = (Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "labkit"
                / "numba" / hashlib.sha1(str(root).encode()).hexdigest()[:8])
    here = base / digest.hexdigest()[:16]
    here.mkdir(parents=True, exist_ok=True)
    others = sorted((p for p in base.iterdir() if p.is_dir() and p != here),
                    key=lambda p: p.stat().st_mtime)
    for old in others[:-3]:
        shutil.rmtree(old, ignore_errors=True)
    return here

