"""Machine programs: the Moves model and the generators that build it."""

from labkit.toolpath.moves import PLANE_AXES, LaserMode, Moves, MovesBuilder, MoveKind, Record

__all__ = ["Moves", "MovesBuilder", "MoveKind", "LaserMode", "Record", "PLANE_AXES", "patterns"]


def __getattr__(name):
    # labkit.toolpath.patterns loads on first use (it pulls in arc fitting and corner loops)
    if name == "patterns":
        import importlib
        return importlib.import_module("labkit.toolpath.patterns")
    raise AttributeError(f"module 'labkit.toolpath' has no attribute {name!r}")
