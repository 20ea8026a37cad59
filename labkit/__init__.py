"""labkit — a research and teaching toolkit for laser CNC machines.

The subpackages own one topic each and are imported on first use, so
``import labkit`` stays fast and headless:

gcode     G-code text → Moves (parse), Moves → text (emit), arcs, simulation
geometry  Paths of lines and circular arcs in mm: curves, transforms, offsets, order
vector    SVG and DXF import into Paths
raster    images → engraving Moves
toolpath  the Moves model and the generators that build it
motion    Bresenham, speed profiles, look-ahead, laser power, step timing
viz       matplotlib plots and ipywidgets (imported lazily)
"""

import importlib

__version__ = "0.1.0"

__all__ = [
    "__version__",
    "gcode",
    "geometry",
    "vector",
    "raster",
    "toolpath",
    "motion",
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
