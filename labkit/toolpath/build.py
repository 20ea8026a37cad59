"""Paths → Moves: the vector job ([DobotLaser]'s operation settings, [MicroCAM]'s contour toolpath).

:func:`prepare_paths` runs the geometry pipeline on imported artwork — join
loose pieces into chains, compensate the kerf, hatch filled shapes, order
everything for little travel with holes before parts — and
:func:`build_moves` turns the ordered paths into a machine program: per
layer its own feed, power and number of passes ([DobotLaser] asks for speed,
passes and pass depth), an optional Z step down after each pass, the beam
off on every travel move (rapids; GRBL's laser mode also keeps the beam off
on G0), arcs as G2/G3.

Fill goes before the contour of the same layer, so the outline is cut last
and leaves clean edges over the ends of the hatch lines.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np

from labkit.errors import GeometryError
from labkit.geometry.chains import join_chains
from labkit.geometry.hatching import hatch
from labkit.geometry.offset import offset_paths
from labkit.geometry.order import order_paths
from labkit.geometry.path import Path, check_paths, sample_each
from labkit.toolpath.moves import LaserMode, MoveKind, Moves

__all__ = ["LayerSettings", "build_moves", "prepare_paths"]


@dataclass(frozen=True)
class LayerSettings:
    """How one layer is cut.

    Attributes
    ----------
    feed_mm_min : float
        Cutting feed, mm/min.
    s_word : float
        Laser power word S (0…``s_max``).
    passes : int
        How many times the layer is cut.
    z_step_mm : float
        Z lowered after each pass, mm ([DobotLaser]'s pass depth; 0 for none).
    laser : LaserMode
        M3 (constant) or M4 (dynamic: power follows speed).
    """

    feed_mm_min: float = 1000.0
    s_word: float = 1000.0
    passes: int = 1
    z_step_mm: float = 0.0
    laser: LaserMode = LaserMode.CONSTANT

    def __post_init__(self):
        if not self.feed_mm_min > 0:
            raise GeometryError(f"feed_mm_min must be > 0 mm/min, got {self.feed_mm_min!r}")
        if not self.s_word >= 0:
            raise GeometryError(f"s_word must be >= 0, got {self.s_word!r}")
        if int(self.passes) != self.passes or self.passes < 1:
            raise GeometryError(f"passes must be an integer >= 1, got {self.passes!r}")
        if not math.isfinite(self.z_step_mm) or self.z_step_mm < 0:
            raise GeometryError(f"z_step_mm must be >= 0 mm, got {self.z_step_mm!r}")


def _layer_settings(layer, settings, default) -> LayerSettings:
    if isinstance(settings, LayerSettings):
        return settings
    return settings.get(layer, default)


#: Arcs whose centres and radii agree this closely (mm) are one circle.
SAME_CIRCLE_MM = 1e-6


def _merged_circles(p: Path):
    """The path's segments with neighbouring arcs of one circle (same centre, radius and
    direction) merged into one move, and a closed path that is a single circle into one
    full-circle move (G2/G3 back to its start: one block instead of two to four).

    Returns (vertices (k+1, 2), centres (k, 2), sweeps (k,))."""
    v, c, s = p.vertices, p.centres, p.sweeps
    if len(s) < 2:
        return v, c, s
    r = np.hypot(*(v[:-1] - c).T)
    same = ((s[1:] * s[:-1] > 0) & (np.hypot(*(c[1:] - c[:-1]).T) <= SAME_CIRCLE_MM)
            & (np.abs(r[1:] - r[:-1]) <= SAME_CIRCLE_MM))
    if not same.any():
        return v, c, s
    if same.all() and p.closed and abs(abs(s.sum()) - 2 * math.pi) < 1e-9:
        return v[[0, -1]], c[:1], np.array([s.sum()])
    keep = [0]
    sweeps = [s[0]]
    for i in range(1, len(s)):
        if same[i - 1] and abs(sweeps[-1] + s[i]) < 2 * math.pi - 1e-9:
            sweeps[-1] += s[i]
        else:
            keep.append(i)
            sweeps.append(s[i])
    return np.vstack([v[keep], v[-1:]]), c[keep], np.array(sweeps)


def build_moves(paths: Sequence[Path], settings: LayerSettings | Mapping[str, LayerSettings] = LayerSettings(),
                *, default: LayerSettings = LayerSettings(), origin=(0.0, 0.0, 0.0), s_max=1000.0,
                rapid_tol_mm=1e-6) -> Moves:
    """A machine program cutting ``paths`` in the order given.

    Parameters
    ----------
    paths : sequence of Path
        Already ordered (see :func:`prepare_paths`).
    settings : LayerSettings or mapping layer → LayerSettings
        One setting for everything, or per layer (missing layers use ``default``).
    default : LayerSettings
        For layers not in ``settings``.
    origin : (x, y, z)
        Head position before the first move, mm.
    s_max : float
        S of full power.
    rapid_tol_mm : float
        A travel move is added only where the next path starts farther away.

    Returns
    -------
    Moves
        Layers in the order their first path appears; each layer's passes one
        after the other (pass k at Z = origin_z − k·z_step_mm); within a pass
        the paths in the given order, joined by rapids. Neighbouring arcs of
        one circle become one move, and a closed circle one full-turn arc.

    Examples
    --------
    >>> sq = Path.rectangle(0, 0, 10, 10)
    >>> m = build_moves([sq, Path.circle((30, 5), 5)], LayerSettings(feed_mm_min=600, s_word=800))
    >>> [MoveKind(k).name for k in m.kind]            # the circle: one full-turn G3
    ['LINE', 'LINE', 'LINE', 'LINE', 'RAPID', 'ARC_CCW']
    >>> round(float(m.lengths_mm()[m.laser_on].sum()), 4), bool(m.laser_on[4])
    (71.4159, False)
    """
    layers: dict[str, list[Path]] = {}
    for p in check_paths(paths):
        layers.setdefault(p.layer, []).append(p)
    pos = np.asarray(origin, dtype=float).copy()
    if pos.shape != (3,):
        raise GeometryError(f"origin must be (x, y, z) in mm, got {origin!r}")
    chunks = []
    for layer, group in layers.items():
        ls = _layer_settings(layer, settings, default)
        merged = [_merged_circles(p) for p in group]
        counts = np.array([len(s) for _, _, s in merged])
        verts = [v for v, _, _ in merged]
        # a pass's segments as whole arrays (a drawing has hundreds of small paths), its
        # rapids put in before the paths that start away from where the head is
        v0 = np.concatenate([v[:-1] for v in verts])
        v1 = np.concatenate([v[1:] for v in verts])
        centres = np.concatenate([c for _, c, _ in merged])
        sweeps = np.concatenate([s for _, _, s in merged])
        ends = np.array([v[-1] for v in verts])
        starts = np.array([v[0] for v in verts])
        first = np.r_[0, np.cumsum(counts)[:-1]]
        kind = np.where(sweeps > 0, MoveKind.ARC_CCW, np.where(sweeps < 0, MoveKind.ARC_CW, MoveKind.LINE))
        for k in range(int(ls.passes)):
            z = float(origin[2]) - k * ls.z_step_mm
            zc = np.full((len(sweeps), 1), z)
            centre = np.hstack([centres, zc])
            centre[sweeps == 0] = np.nan
            start = np.hstack([starts, np.full((len(group), 1), z)])
            before = np.vstack([pos[None], np.hstack([ends[:-1], np.full((len(group) - 1, 1), z)])])
            rapid = np.flatnonzero(np.linalg.norm(start - before, axis=1) > rapid_tol_mm)
            seg_start, seg_end = np.hstack([v0, zc]), np.hstack([v1, zc])
            if len(rapid):
                at = first[rapid]
                kind_k = np.insert(kind, at, MoveKind.RAPID)
                seg_start = np.insert(seg_start, at, before[rapid], axis=0)
                seg_end = np.insert(seg_end, at, start[rapid], axis=0)
                centre = np.insert(centre, at, np.nan, axis=0)
            else:
                kind_k = kind
            n = len(kind_k)
            chunks.append(dict(kind=kind_k, start=seg_start, end=seg_end, centre=centre,
                               feed=np.full(n, ls.feed_mm_min), power=np.full(n, ls.s_word),
                               laser=np.full(n, int(ls.laser))))
            pos = np.array([ends[-1][0], ends[-1][1], z])
    if not chunks:
        return Moves.empty(s_max=s_max)
    cat = {k: np.concatenate([c[k] for c in chunks]) for k in chunks[0]}
    return Moves(kind=cat["kind"].astype(np.int8), start=cat["start"], end=cat["end"],
                 centre=cat["centre"], feed_mm_min=cat["feed"], s_word=cat["power"],
                 laser=cat["laser"].astype(np.int8), s_max=s_max)


def prepare_paths(paths: Sequence[Path], *, join_tol_mm=0.01, kerf_mm=0.0, tol_mm=0.01, arcs=True,
                  fill=False, fill_spacing_mm=0.1, fill_angle_rad=0.0, fill_rule=None,
                  order=True, improve=True, origin=(0.0, 0.0)) -> list[Path]:
    """The geometry pipeline of a vector job: chains → kerf → fill → order.

    Parameters
    ----------
    paths : sequence of Path
        Imported artwork (any order).
    join_tol_mm : float
        Ends closer than this are joined into chains ([MicroCAM] §6.1.2).
    kerf_mm : float
        Beam kerf width; closed shapes are offset by kerf/2 outwards (holes
        inwards, nesting judged over all layers) so parts come out to size.
        Where offsetting the region would lose a drawn line, each shape is offset
        on its own: one inside an odd number of others is a hole, whichever
        element or fill rule drew it; none is merged or lost.
        0: no offset.
    tol_mm : float
        Tolerance of the offset geometry, mm.
    arcs : bool
        Offsets give arcs back (False: lines only).
    fill : bool
        Hatch the closed shapes of each layer before cutting their contours.
    fill_spacing_mm, fill_angle_rad, fill_rule
        Hatch line spacing (the beam width), direction and fill rule
        (default: each shape's own rule from the SVG).
    order : bool
        Reorder for short travel (greedy nearest neighbour), holes first.
    improve : bool
        2-opt after the greedy ordering.
    origin : (x, y)
        Head position before the job, mm.

    Returns
    -------
    list of Path
        Per layer: fill lines, then contours. Layers run in first-seen order,
        except that a layer with work inside another layer's closed paths
        runs before it.

    Examples
    --------
    >>> part, hole = Path.rectangle(0, 0, 40, 40), Path.circle((20, 20), 5)
    >>> out = prepare_paths([part, hole], kerf_mm=0.2)
    >>> [(p.closed, round(abs(p.signed_area_mm2()), 2)) for p in out]
    [(True, 75.4), (True, 1616.04)]
    """
    paths = check_paths(paths)
    if kerf_mm < 0 or not math.isfinite(kerf_mm):
        raise GeometryError(f"kerf_mm must be >= 0 mm, got {kerf_mm!r}")
    chains = _lines_unless_area(join_chains(paths, join_tol_mm), tol_mm)
    layers: dict[str, list[Path]] = {}
    for p in chains:
        layers.setdefault(p.layer, []).append(p)
    closed_all = [p for p in chains if p.closed]
    if kerf_mm > 0 and closed_all:
        # One offset over every layer's closed paths: a hole drawn on its own layer (a CAD habit)
        # is still a hole of the part around it, so its path moves inwards, not outwards.
        offsets = _offset_by_source(closed_all, kerf_mm / 2, tol_mm=tol_mm, arcs=arcs)
        for name, group in layers.items():
            layers[name] = offsets.get(name, []) + [p for p in group if not p.closed]
    out: list[Path] = []
    pos = tuple(origin)
    for name in _inner_layers_first(layers, tol_mm):
        group = layers[name]
        closed = [p for p in group if p.closed]
        opened = [p for p in group if not p.closed]
        fill_lines = hatch(closed, fill_spacing_mm, angle_rad=fill_angle_rad, fill_rule=fill_rule,
                           tol_mm=tol_mm) if fill else []
        contours = closed + opened
        if order:
            if fill_lines:
                fill_lines = order_paths(fill_lines, origin=pos, improve=improve, inner_first=False)
                pos = tuple(fill_lines[-1].end)
            contours = order_paths(contours, origin=pos, improve=improve, inner_first=True)
        out += fill_lines + contours
        if out:
            pos = tuple(out[-1].end)
    return out


def _offset_by_source(closed: list[Path], distance_mm: float, *, tol_mm: float, arcs: bool
                      ) -> dict[str, list[Path]]:
    """Kerf compensation of every closed path; each result ring goes back to its source's layer.

    Where the region of all closed paths has every drawn ring on its boundary, that region is
    offset as one (a ring lies ``|distance_mm|`` from the ring it was offset from, so the
    nearest source ring is its source; rings merged from several sources take the nearest
    one's layer and colours). Where it does not — a hole drawn as its own shape the same way
    round as its outline under the nonzero rule, overlapping shapes, parts sharing an edge —
    offsetting the region would lose a drawn line, so each ring is offset on its own instead
    (:func:`_offset_each`), as LightBurn and LaserGRBL offset nested shapes.
    """
    import shapely

    from labkit.geometry.offset import region

    sample_tol = 0.2 * tol_mm                    # as offset_paths samples the region
    rings = [p.sample(sample_tol) for p in closed]
    edge = region(closed, tol_mm=sample_tol).boundary.buffer(tol_mm)
    shapely.prepare(edge)
    lost = not all(edge.covers(shapely.LineString(r)) for r in rings)
    if lost:
        return _offset_each(closed, distance_mm, tol_mm=tol_mm, arcs=arcs)
    sources = [shapely.LinearRing(r) for r in rings]
    by_layer: dict[str, list[Path]] = {}
    for ring in offset_paths(closed, distance_mm, tol_mm=tol_mm, arcs=arcs):
        probe = shapely.Point(ring.start[:2])
        k = int(np.argmin([src.distance(probe) for src in sources]))
        p = closed[k].with_geometry(ring.vertices, ring.centres, ring.sweeps, closed=True,
                                    deviation_mm=ring.deviation_mm)
        by_layer.setdefault(p.layer, []).append(p)
    return by_layer


def _offset_each(closed: list[Path], distance_mm: float, *, tol_mm: float, arcs: bool
                 ) -> dict[str, list[Path]]:
    """Kerf compensation ring by ring; each result keeps its own source's layer.

    Every closed path moves ``distance_mm`` to its waste side: outwards when it lies inside an
    even number of the other closed paths (an outline, an island in a hole), inwards when odd (a
    hole) — whichever element, layer or fill rule drew it. No path is merged into another or
    lost, and a hole the kerf closes keeps its drawn line (the beam is as wide as the hole),
    with a warning.
    """
    import warnings

    import shapely

    rings = [p.sample(tol_mm) for p in closed]
    polys = [shapely.make_valid(shapely.Polygon(r)) for r in rings]
    areas = np.array([q.area for q in polys])
    tree = shapely.STRtree(polys)
    by_layer: dict[str, list[Path]] = {}
    for i, p in enumerate(closed):
        probe = shapely.Point(rings[i][0])
        depth = sum(1 for j in tree.query(probe) if j != i and areas[j] > areas[i] and polys[j].covers(probe))
        hole = depth % 2 == 1
        out = offset_paths([p], -distance_mm if hole else distance_mm, tol_mm=tol_mm, arcs=arcs)
        if not out:
            warnings.warn(f"{p.source or 'a hole'}: a hole narrower than the kerf ({2 * distance_mm:g} mm) "
                          f"is cut on its drawn line, uncompensated", stacklevel=4)
            out = [p]
        for ring in out:
            if hole and ring is not p:
                ring = ring.reversed()            # holes run clockwise, as a region's holes do
            q = p.with_geometry(ring.vertices, ring.centres, ring.sweeps, closed=True,
                                deviation_mm=ring.deviation_mm)
            by_layer.setdefault(q.layer, []).append(q)
    return by_layer


def _lines_unless_area(chains: Sequence[Path], tol_mm: float) -> list[Path]:
    """The chains to cut: one of no length is nothing to cut (dropped); a closed chain that
    encloses no area — a line drawn there and back, or a piece shorter than the join tolerance
    snapped shut (a CAD floor plan's stray sub-micron LINE) — is cut as the open line it is
    (its samples all on the line through its start and its farthest sample). Only closed
    chains with an area are outlines: offsets, hatching and nesting need a polygon. All
    chains at once: a drawing of hundreds of shapes made hundreds of small numpy passes."""
    chains = list(chains)
    if not chains:
        return []
    # length > 0: some segment longer than 0 and none NaN (lengths are never negative)
    seg = np.array([p.n_segments for p in chains])
    owner = np.repeat(np.arange(len(chains)), seg)
    lengths = np.concatenate([p.lengths_mm() for p in chains])
    positive = np.zeros(len(chains), bool)
    positive[owner[lengths > 0]] = True
    positive[owner[np.isnan(lengths)]] = False
    chains = [p for p, ok in zip(chains, positive) if ok]
    closed = [k for k, p in enumerate(chains) if p.closed]
    flat = np.zeros(len(chains), bool)                  # closed, but no area: cut as a line
    if closed:
        pts = sample_each([chains[k] for k in closed], tol_mm)
        size = np.array([len(q) for q in pts])
        ring = np.repeat(np.arange(len(closed)), size)
        d = np.concatenate(pts) - np.array([chains[k].vertices[0] for k in closed])[ring]
        far_d = np.hypot(d[:, 0], d[:, 1])
        begin = np.cumsum(size) - size
        top = np.maximum.reduceat(far_d, begin)
        hit = np.flatnonzero(far_d == top[ring])          # the first farthest sample (argmax)
        first_hit = hit[np.unique(ring[hit], return_index=True)[1]]
        far = d[first_hit]
        bent = (d[:, 0] * far[ring, 1] - d[:, 1] * far[ring, 0]) != 0
        flat[closed] = ~np.logical_or.reduceat(bent, begin)
    return [p.with_geometry(p.vertices, p.centres, p.sweeps, closed=False) if f else p
            for p, f in zip(chains, flat)]


def _inner_layers_first(layers: Mapping[str, list[Path]], tol_mm: float) -> list[str]:
    """Layer names in first-seen order, except that a layer with work inside another layer's
    closed paths runs before it: whatever lies inside a part (holes, engraving) must be done
    before the part's outline frees it from the sheet. Mutual nesting keeps first-seen order."""
    import shapely

    names = list(layers)
    if len(names) < 2:
        return names                                  # nothing to put before anything
    polys = {n: [shapely.Polygon(r) for r in sample_each([p for p in layers[n] if p.closed], tol_mm)]
             for n in names}
    inside: dict[str, set[str]] = {n: set() for n in names}        # n has work inside these layers
    for n in names:
        for m in names:
            if m == n or not polys[m]:
                continue
            outer = shapely.union_all([shapely.make_valid(q) for q in polys[m]])
            if any(outer.contains(shapely.Point(p.start[:2])) for p in layers[n]):
                inside[n].add(m)
    order: list[str] = []
    pending = names[:]
    while pending:
        # the first pending layer that no other pending layer must precede
        ready = [n for n in pending if not any(n in inside[m] and m not in inside[n]
                                               for m in pending if m != n)]
        pick = ready[0] if ready else pending[0]
        order.append(pick)
        pending.remove(pick)
    return order
