"""Machine programs: the Moves model and the generators that build it."""

from labkit.toolpath.moves import PLANE_AXES, LaserMode, Moves, MovesBuilder, MoveKind, Record

__all__ = ["Moves", "MovesBuilder", "MoveKind", "LaserMode", "Record", "PLANE_AXES"]
