"""Clipping paths to a region: SVG ``clip-path`` and the page.

A renderer paints only the part of a shape inside its clip region; the laser must
cut only that part too. A stroked path (a cut) keeps the pieces of its centre line
inside the region; a fill-only shape (an engraved area) becomes the boundary of
its filled region intersected with the clip region. Both go through shapely
(GEOS) on samples taken within a small share of the tolerance, and the arc fit
(:func:`labkit.geometry.arcfit.fit_arcs`) turns the pieces back into lines and
arcs — a path wholly inside the region is kept exactly as it was, one wholly
outside is dropped.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from labkit.errors import GeometryError
from labkit.geometry.arcfit import fit_arcs
from labkit.geometry.offset import region, region_paths
from labkit.geometry.path import Path

__all__ = ["clip_paths", "ClipResult", "rectangle_region"]

#: Share of the tolerance spent sampling curves before clipping; the arc fit gets the rest.
SAMPLE_SHARE = 0.2


@dataclass
class ClipResult:
    """Paths after clipping, and what was removed.

    Attributes
    ----------
    paths : list of Path
        The parts inside the region.
    removed_mm : float
        Path length removed (outside the region), mm.
    clipped : list of str
        Sources of the paths that lost some or all of their length.
    """

    paths: list[Path]
    removed_mm: float
    clipped: list[str]


def rectangle_region(x0, y0, x1, y1):
    """An axis-aligned rectangle as a shapely polygon (mm).

    >>> rectangle_region(0, 0, 210, 297).area
    62370.0
    """
    import shapely

    return shapely.box(min(x0, x1), min(y0, y1), max(x0, x1), max(y0, y1))


def _meta(p: Path) -> dict:
    return dict(layer=p.layer, stroke=p.stroke, fill=p.fill, fill_rule=p.fill_rule, source=p.source)


def clip_paths(paths: Sequence[Path], clip, *, tol_mm=0.01, arcs=True, fill_regions=True) -> ClipResult:
    """Keep the parts of ``paths`` that lie inside the region ``clip``.

    Parameters
    ----------
    paths : sequence of Path
        In mm. Paths with a fill and no stroke are engraved areas: with
        ``fill_regions`` the closed ones of one source are clipped as one filled
        region (their fill rule), so the result is the outline of what a renderer
        paints. All others are cut lines: their centre lines are clipped.
    clip : shapely geometry
        The region, mm (a polygon or several).
    tol_mm : float
        Largest deviation of a clipped piece from the original path, mm.
    arcs : bool
        Recover arcs in clipped pieces (False: straight segments only).
    fill_regions : bool
        Treat fill-only closed paths as areas (see above).

    Returns
    -------
    ClipResult
        The clipped paths in input order, the length removed, and the sources
        of the paths that changed.

    Examples
    --------
    A 20 mm line half inside a 10 mm square keeps its inside half:

    >>> r = clip_paths([Path([[-5, 5], [15, 5]], source="line#a")], rectangle_region(0, 0, 10, 10))
    >>> r.paths[0].vertices.round(9).tolist(), round(r.removed_mm, 9), r.clipped
    ([[0.0, 5.0], [10.0, 5.0]], 10.0, ['line#a'])

    A circle of radius 5 clipped to its upper half stays one arc:

    >>> r = clip_paths([Path.circle((0, 0), 5)], rectangle_region(-10, 0, 10, 10))
    >>> [(p.n_segments, int(p.is_arc.sum())) for p in r.paths], round(r.removed_mm, 6)
    ([(1, 1)], 15.707963)
    """
    import shapely

    if not tol_mm > 0:
        raise GeometryError(f"tol_mm must be > 0 mm, got {tol_mm!r}")
    clip = shapely.make_valid(clip)
    shapely.prepare(clip)
    sample_tol = SAMPLE_SHARE * tol_mm
    out: list[Path] = []
    removed = 0.0
    changed: list[str] = []
    areas: dict[str, list[int]] = {}
    if fill_regions:
        for i, p in enumerate(paths):
            if p.closed and p.stroke is None and p.fill is not None:
                areas.setdefault(p.source, []).append(i)
    done: set[int] = set()
    for i, p in enumerate(paths):
        if i in done:
            continue
        group = areas.get(p.source) if i in areas.get(p.source, ()) else None
        if group is not None:
            members = [paths[k] for k in group]
            done.update(group)
            pieces, lost = _clip_area(members, clip, tol_mm, sample_tol, arcs)
        else:
            pieces, lost = _clip_line(p, clip, tol_mm, sample_tol, arcs)
        out += pieces
        removed += lost
        if lost > 0 or not pieces:
            changed.append(p.source)
    return ClipResult(out, removed, list(dict.fromkeys(changed)))


def _clip_line(p: Path, clip, tol_mm, sample_tol, arcs):
    import shapely

    pts = p.sample(sample_tol)
    line = shapely.LineString(pts)
    if clip.covers(line):
        return [p], 0.0
    if not clip.intersects(line):
        return [], p.length_mm
    inside = shapely.line_merge(shapely.intersection(line, clip))
    out = []
    for piece in getattr(inside, "geoms", [inside]):
        if piece.geom_type != "LineString" or piece.length <= 0:
            continue
        coords = np.asarray(piece.coords)
        ring = p.closed and len(coords) > 2 and np.array_equal(coords[0], coords[-1])
        q = fit_arcs(coords, tol_mm - sample_tol, arcs=arcs, closed=ring,
                     base_deviation_mm=sample_tol + p.deviation_mm, **_meta(p))
        out.append(q)
    return out, max(0.0, p.length_mm - sum(q.length_mm for q in out))


def _clip_area(members: list[Path], clip, tol_mm, sample_tol, arcs):
    import shapely

    filled = region(members, tol_mm=sample_tol)
    if clip.covers(filled):
        return members, 0.0
    inside = shapely.intersection(filled, clip)
    meta = _meta(members[0])
    meta["fill_rule"] = "evenodd"          # outer rings CCW, holes CW: both rules agree
    pieces = region_paths(inside, tol_mm, sample_tol_mm=sample_tol, arcs=arcs, **meta)
    # the original outline outside the clip (the clip's edge adds outline of its own)
    outline = shapely.union_all([shapely.LineString(p.sample(sample_tol)) for p in members])
    return pieces, max(float(shapely.difference(outline, clip).length), 1e-12)
