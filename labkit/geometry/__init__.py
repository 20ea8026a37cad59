"""2-D geometry in millimetres: circles and arcs, curves, transforms, chains, offsets, order.

The :class:`Path` model (lines and circular arcs, numpy columns) is what
vector import produces and toolpath building consumes. Curves become Paths at
a stated tolerance: Beziers by De Casteljau (:mod:`~labkit.geometry.bezier`),
ellipses by curvature-weighted arcs (:mod:`~labkit.geometry.ellipse`), any
dense curve by arc fitting (:mod:`~labkit.geometry.arcfit`).

Submodules load on first use (``labkit.geometry.offset_paths`` imports shapely
only then), so ``import labkit.gcode`` — which needs only
:mod:`~labkit.geometry.circle` — stays light.
"""

from labkit._lazy import lazy_names

# public name → submodule that defines it (None: the name is the submodule)
_WHERE = {
    "arc_bounds": 'circle',
    "arc_length": 'circle',
    "arc_points": 'circle',
    "chord_segments": 'circle',
    "circumcentre": 'circle',
    "count_segments": 'path',
    "cubic_chains_to_arcs": 'arcfit',
    "cubic_point": 'bezier',
    "cubics_to_arcs": 'arcfit',
    "curvature_weighted_points": 'ellipse',
    "default_arcs_per_quadrant": 'ellipse',
    "ellipse_arc_to_arcs": 'ellipse',
    "ellipse_point": 'ellipse',
    "ellipse_to_arcs": 'ellipse',
    "fit_arcs": 'arcfit',
    "flatness": 'bezier',
    "flatten_adaptive_t": 'bezier',
    "flatten_cubic": 'bezier',
    "flatten_cubics": 'bezier',
    "grbl_segments": 'circle',
    "hatch": 'hatching',
    "hatch_lines": 'hatching',
    "hausdorff": 'measure',
    "join_chains": 'chains',
    "max_deviation": 'path',
    "mid_arc_point": 'circle',
    "offset_paths": 'offset',
    "order_paths": 'order',
    "order_segments": 'order',
    "Ordering": 'order',
    "orientation": 'circle',
    "Path": 'path',
    "path_distance": 'measure',
    "paths_bounds": 'path',
    "quad_to_cubic": 'bezier',
    "split_cubic": 'bezier',
    "sweep_angle": 'circle',
    "total_length": 'path',
    "transform": None,
    "travel_length": 'order',
}

__all__ = sorted(_WHERE, key=str.lower)


__getattr__, __dir__ = lazy_names(__name__, _WHERE, __all__)
