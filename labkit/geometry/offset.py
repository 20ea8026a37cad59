"""Contour offsets for kerf compensation ([MicroCAM] §6.1.3.1, fig. 6-11/6-12).

A beam of width w removes w/2 on each side of its path. To cut a part to
size, its outline's path moves w/2 outwards and its holes' paths w/2 inwards
— both are one offset of the *filled region* by +w/2. [MicroCAM] offsets each
entity and repairs the joins case by case (trim at an intersection, or fill
a gap with an arc). Here the region is offset by shapely (GEOS), which also
resolves the self-intersections and vanishing features that case-by-case
repair misses, and the result is turned back into lines and arcs.

Arcs in, arcs out: the input arcs are sampled within a small share of the
tolerance, GEOS offsets the polygon with round joins (a round join around a
convex corner is exactly the set of points at distance d from it), and
:func:`labkit.geometry.arcfit.fit_arcs` recovers concentric arcs and join
arcs from the result — so an offset circle is again an arc of radius r ± d,
not hundreds of lines. ``join="miter"`` keeps sharp corners (within
``miter_limit``), as many laser operators prefer for outlines of squares.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from labkit.budget import check_budget
from labkit.errors import GeometryError
from labkit.geometry.arcfit import fit_arcs
from labkit.geometry.path import Path

__all__ = ["offset_paths", "region", "region_paths"]

_JOINS = {"round": "round", "miter": "mitre", "mitre": "mitre", "bevel": "bevel"}


def region(paths: Sequence[Path], *, tol_mm=0.001, fill_rule=None):
    """The filled region of closed paths as a shapely geometry.

    ``evenodd``: the symmetric difference of the rings (a ring inside another
    is a hole). ``nonzero``: rings are nested by containment and each face
    gets the winding number of its enclosing rings (+1 for a ring running the
    same way as the outermost, −1 the other way); faces with a non-zero
    number are filled — so a hole drawn the opposite way stays a hole, one
    drawn the same way does not. Rings that cross each other are treated by
    their nesting only. By default the first path's ``fill_rule``.
    """
    import shapely

    closed = [p for p in paths if p.closed]
    if not closed:
        return shapely.Polygon()
    rule = fill_rule or closed[0].fill_rule
    if rule not in ("evenodd", "nonzero"):
        raise GeometryError(f"fill_rule must be 'evenodd' or 'nonzero', got {rule!r}")
    rings = [p.sample(tol_mm) for p in closed]
    polys = [shapely.make_valid(shapely.Polygon(r)) for r in rings]
    if rule == "evenodd":
        out = polys[0]
        for poly in polys[1:]:
            out = shapely.symmetric_difference(out, poly)
        return out
    sign = np.sign([_signed_area(r) for r in rings])
    areas = np.array([poly.area for poly in polys])
    order = np.argsort(-areas)                      # containers before what they contain
    winding = np.zeros(len(rings))
    parent = np.full(len(rings), -1)
    for k, i in enumerate(order):
        probe = shapely.Point(rings[i][0])
        for j in order[:k][::-1]:                   # smallest container first
            if areas[j] > areas[i] and polys[j].covers(probe):
                parent[i] = j
                break
        winding[i] = (winding[parent[i]] if parent[i] >= 0 else 0) + sign[i]
    faces = []
    for i in range(len(rings)):
        if winding[i] == 0:
            continue
        face = polys[i]
        for c in np.flatnonzero(parent == i):
            face = shapely.difference(face, polys[c])
        faces.append(face)
    return shapely.union_all(faces) if faces else shapely.Polygon()


def offset_paths(paths: Sequence[Path], distance_mm: float, *, join="round", tol_mm=0.01,
                 arcs=True, miter_limit=4.0) -> list[Path]:
    """Offset the region enclosed by closed paths by ``distance_mm``.

    Parameters
    ----------
    paths : sequence of Path
        Closed paths of one part or drawing; open paths are refused.
    distance_mm : float
        Positive grows the region (outlines move out, holes shrink): kerf
        compensation for parts uses +kerf/2. Negative shrinks it.
    join : {"round", "miter", "bevel"}
        Corner style on the outside of corners.
    tol_mm : float
        Largest deviation of the result from the exact offset, mm.
    arcs : bool
        Give arcs back (True) or straight segments only.
    miter_limit : float
        Longest miter, as a multiple of ``|distance_mm|``.

    Returns
    -------
    list of Path
        Outer rings counter-clockwise, holes clockwise; layer and colours of
        the first path. A region that vanishes gives an empty list.

    Examples
    --------
    >>> ring = offset_paths([Path.circle((0, 0), 10)], 2.0)
    >>> len(ring), ring[0].n_segments, round(float(ring[0].radii_mm().max()), 3)
    (1, 2, 12.0)
    >>> sq = offset_paths([Path.rectangle(0, 0, 10, 10)], 1.0, join="miter")
    >>> sq[0].bounds().round(6).tolist(), sq[0].n_segments
    ([[-1.0, -1.0], [11.0, 11.0]], 4)
    """
    import shapely

    paths = list(paths)
    if not paths:
        return []
    opened = [p.source or repr(p) for p in paths if not p.closed]
    if opened:
        raise GeometryError(f"offset needs closed paths; open: {', '.join(map(str, opened[:3]))}")
    if join not in _JOINS:
        raise GeometryError(f"join must be one of {sorted(_JOINS)}, got {join!r}")
    if not tol_mm > 0:
        raise GeometryError(f"tol_mm must be > 0 mm, got {tol_mm!r}")
    if not math.isfinite(distance_mm):
        raise GeometryError(f"distance_mm must be a finite number of mm, got {distance_mm!r}")
    sample_tol = 0.2 * tol_mm
    reg = region(paths, tol_mm=sample_tol)
    d = float(distance_mm)
    if d != 0:
        step = 2.0 * math.acos(max(-1.0, 1.0 - sample_tol / abs(d))) if abs(d) > sample_tol else math.pi / 2
        quad_segs = max(1, math.ceil((math.pi / 2) / step)) if step > 0 else math.inf
        check_budget("segments", 4 * quad_segs, cause=f"rounding corners of an offset of {d:g} mm "
                     f"at {tol_mm:g} mm", option="--kerf")
        reg = shapely.buffer(reg, d, quad_segs=quad_segs, join_style=_JOINS[join],
                             mitre_limit=miter_limit)
    first = paths[0]
    meta = dict(layer=first.layer, stroke=first.stroke, fill=first.fill, fill_rule=first.fill_rule,
                source=first.source)
    return region_paths(reg, tol_mm, sample_tol_mm=sample_tol, arcs=arcs, **meta)


def region_paths(reg, tol_mm, *, sample_tol_mm=0.0, arcs=True, **meta) -> list[Path]:
    """The boundary rings of a shapely region as closed Paths of lines and arcs.

    Parameters
    ----------
    reg : shapely geometry
        Polygons (other parts are ignored), e.g. from :func:`region`.
    tol_mm : float
        Largest deviation of the output from the true boundary, mm.
    sample_tol_mm : float
        Deviation already in the region's vertices (how finely its curves were
        sampled), mm; the arc fit gets the rest of ``tol_mm``.
    arcs : bool
        Recover circular arcs (True) or give straight segments only.
    **meta
        Layer, colours, fill rule and source of the Paths.

    Returns
    -------
    list of Path
        Outer rings counter-clockwise, holes clockwise, so either fill rule
        fills the region.
    """
    import shapely

    reg = shapely.orient_polygons(reg) if hasattr(shapely, "orient_polygons") else reg
    out: list[Path] = []
    for poly in getattr(reg, "geoms", [reg]):
        if poly.is_empty or poly.geom_type != "Polygon":
            continue
        rings = [(np.asarray(poly.exterior.coords), True)] + [
            (np.asarray(r.coords), False) for r in poly.interiors]
        for pts, outer in rings:
            ccw = _signed_area(pts) > 0
            if ccw != outer:
                pts = pts[::-1]
            ring = fit_arcs(pts, tol_mm - sample_tol_mm, arcs=arcs, closed=True,
                            base_deviation_mm=sample_tol_mm, **meta)
            if ring.length_mm > 0:          # a sliver the fit closed to a point: nothing to cut
                out.append(ring)
    return out


def _signed_area(pts: np.ndarray) -> float:
    x, y = pts[:, 0], pts[:, 1]
    return 0.5 * float(np.sum(x[:-1] * y[1:] - x[1:] * y[:-1]))
