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
import sys
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


def _numba_cache_dir(root: Path | None = None, base: Path | None = None) -> Path:
    """Where compiled kernels are cached: one folder per state of labkit's sources.

    numba's own cache is keyed by the file of each compiled function, so it keeps
    serving a kernel after a kernel it calls in another module has changed. Keying
    the whole cache by every source file's size and modification time makes any
    edit start from a fresh cache. Older folders beyond the last few are removed.
    """
    import hashlib
    import shutil

    root = root or Path(__file__).resolve().parent
    digest = hashlib.sha1()
    for path in sorted(root.rglob("*.py")):
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


def _configure_numba_cache() -> None:
    if os.environ.get("NUMBA_CACHE_DIR"):
        return                                   # the user chose a cache folder
    try:
        folder = str(_numba_cache_dir())
    except OSError:
        return                                   # no writable cache folder: numba's default
    os.environ["NUMBA_CACHE_DIR"] = folder
    if "numba" in sys.modules:                   # numba read its settings already
        sys.modules["numba"].config.CACHE_DIR = folder


_configure_numba_cache()
