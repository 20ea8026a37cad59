"""2-D geometry in millimetres: circles and arcs, curves, transforms, chains, offsets, order."""

from labkit.geometry.circle import (
    arc_bounds,
    arc_length,
    arc_points,
    chord_segments,
    circumcentre,
    grbl_segments,
    mid_arc_point,
    orientation,
    sweep_angle,
)

__all__ = [
    "arc_bounds",
    "arc_length",
    "arc_points",
    "chord_segments",
    "circumcentre",
    "grbl_segments",
    "mid_arc_point",
    "orientation",
    "sweep_angle",
]
