"""2-D geometry in millimetres: circles and arcs, curves, transforms, chains, offsets, order.

The :class:`Path` model (lines and circular arcs, numpy columns) is what
vector import produces and toolpath building consumes. Curves become Paths at
a stated tolerance: Beziers by De Casteljau (:mod:`~labkit.geometry.bezier`),
ellipses by curvature-weighted arcs (:mod:`~labkit.geometry.ellipse`), any
dense curve by arc fitting (:mod:`~labkit.geometry.arcfit`).
"""

from labkit.geometry import transform
from labkit.geometry.arcfit import cubics_to_arcs, fit_arcs
from labkit.geometry.bezier import (
    cubic_point,
    flatness,
    flatten_adaptive_t,
    flatten_cubic,
    flatten_cubics,
    quad_to_cubic,
    split_cubic,
)
from labkit.geometry.chains import join_chains
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
from labkit.geometry.ellipse import (
    curvature_weighted_points,
    default_arcs_per_quadrant,
    ellipse_arc_to_arcs,
    ellipse_point,
    ellipse_to_arcs,
)
from labkit.geometry.hatch import hatch, hatch_lines
from labkit.geometry.measure import hausdorff, path_distance
from labkit.geometry.offset import offset_paths
from labkit.geometry.order import Ordering, order_paths, order_segments, travel_length
from labkit.geometry.path import Path, count_segments, max_deviation, paths_bounds, total_length

__all__ = [
    "Path",
    "Ordering",
    "arc_bounds",
    "arc_length",
    "arc_points",
    "chord_segments",
    "circumcentre",
    "count_segments",
    "cubic_point",
    "cubics_to_arcs",
    "curvature_weighted_points",
    "default_arcs_per_quadrant",
    "ellipse_arc_to_arcs",
    "ellipse_point",
    "ellipse_to_arcs",
    "fit_arcs",
    "flatness",
    "flatten_adaptive_t",
    "flatten_cubic",
    "flatten_cubics",
    "grbl_segments",
    "hatch",
    "hatch_lines",
    "hausdorff",
    "join_chains",
    "max_deviation",
    "mid_arc_point",
    "offset_paths",
    "order_paths",
    "order_segments",
    "orientation",
    "path_distance",
    "paths_bounds",
    "quad_to_cubic",
    "split_cubic",
    "sweep_angle",
    "total_length",
    "transform",
    "travel_length",
]
