"""Planar sections of a 3-D model as a laser job ([MicroCAM] §6.1.3.6, planar section toolpath).

[MicroCAM]'s PlanarSectionToolPath takes a triangle mesh, a step down (ZOffset), the
beam radius R, a maximum angle between segments (MaxDeg) and a direction (top-down or
bottom-up); it sections the model at each level, pockets each section by offsets of the
beam radius and joins the levels into one toolpath. Here:

1. :func:`read_mesh` reads STL (ASCII or binary) and the other formats trimesh reads;
2. :func:`section_loops` cuts the mesh with the plane z = h: every triangle whose
   vertices lie on both sides gives one segment between two *mesh edges*; the two
   triangles that share an edge share its crossing point exactly, so the segments are
   chained into closed loops by the mesh's own topology (no distance tolerance), each
   oriented by its triangle's normal: outer boundaries counter-clockwise, holes
   clockwise. A vertex exactly on the plane counts as above it (a symbolic
   perturbation), so touching vertices never make a segment of zero length;
3. :func:`simplify_loop` removes the vertices where the contour turns by less than
   MaxDeg, as long as the contour stays within ``tol_mm`` of the section;
4. :func:`section_toolpath` pockets each section — the contour offset inwards by the
   beam radius, then by a beam diameter more at a time until nothing is left
   (:func:`labkit.geometry.offset.offset_paths`, inner rings first by
   :func:`labkit.geometry.order.order_paths`) — and joins the levels, top-down or
   bottom-up, into one :class:`~labkit.toolpath.Moves` with the beam off between them
   (:func:`labkit.toolpath.build.build_moves`).

trimesh (mature, MIT, pure Python on numpy) reads the files and is the peer the sections
are checked against (``trimesh.intersections.mesh_plane``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from labkit.errors import GeometryError, InputError
from labkit.geometry.path import Path
from labkit.toolpath.moves import LaserMode, MoveKind, Moves

__all__ = ["Mesh", "read_mesh", "revolved_mesh", "section_loops", "section_levels", "simplify_loop",
           "section_toolpath", "loop_area_mm2"]


#: Section steps shorter than this are dropped (a vertex within rounding of the plane), mm.
MIN_STEP_MM = 1e-9


@dataclass(frozen=True)
class Mesh:
    """A triangle mesh: ``vertices`` (n, 3) in mm and ``faces`` (m, 3) vertex indices,
    wound counter-clockwise seen from outside (outward normals)."""

    vertices: np.ndarray
    faces: np.ndarray

    @property
    def bounds(self) -> np.ndarray:
        """``[[xmin, ymin, zmin], [xmax, ymax, zmax]]``, mm."""
        return np.array([self.vertices.min(axis=0), self.vertices.max(axis=0)])


def read_mesh(path) -> Mesh:
    """Read a triangle mesh (STL, OBJ, PLY, OFF …) with trimesh; coordinates in mm.

    Raises
    ------
    InputError
        The file is missing, not a mesh, has no triangles, or is not closed (a section
        of an open surface has no inside to pocket).
    """
    import trimesh

    from labkit._files import check_input_file

    p = check_input_file(path, what="mesh file (STL)")
    try:
        loaded = trimesh.load(str(p), force="mesh")
    except Exception as exc:             # trimesh raises many kinds for a bad file
        raise InputError(f"{p}: not a mesh file trimesh can read ({type(exc).__name__}: {exc}); "
                         "expected STL (ASCII or binary), OBJ, PLY or OFF") from None
    faces = np.asarray(getattr(loaded, "faces", np.zeros((0, 3))), np.int64)
    if len(faces) == 0:
        raise InputError(f"{p}: no triangles; expected a closed triangle mesh")
    if not loaded.is_watertight:
        raise InputError(f"{p}: the mesh is not closed (watertight): {len(faces)} triangles with "
                         "open edges; expected a solid whose sections are closed loops")
    return Mesh(np.asarray(loaded.vertices, float), faces)


def _as_mesh(mesh) -> Mesh:
    if isinstance(mesh, Mesh):
        return mesh
    if hasattr(mesh, "vertices") and hasattr(mesh, "faces"):          # a trimesh.Trimesh
        return Mesh(np.asarray(mesh.vertices, float), np.asarray(mesh.faces, np.int64))
    raise GeometryError(f"expected a Mesh or a trimesh.Trimesh, got {type(mesh).__name__}")


def section_loops(mesh, z_mm: float) -> list[np.ndarray]:
    """The closed contours of the section of a closed mesh with the plane z = ``z_mm``.

    Parameters
    ----------
    mesh : Mesh or trimesh.Trimesh
        A closed (watertight), consistently wound triangle mesh, mm.
    z_mm : float
        Height of the cutting plane, mm.

    Returns
    -------
    list of ndarray, shape (k + 1, 2)
        Each loop's XY vertices, first = last; outer boundaries counter-clockwise,
        holes clockwise (seen from +Z). Empty above or below the model.

    Raises
    ------
    GeometryError
        The crossing segments do not close into loops (an open or non-manifold mesh).

    Examples
    --------
    A unit cube cut half-way up gives its square, counter-clockwise:

    >>> import trimesh
    >>> loops = section_loops(trimesh.creation.box(extents=(2, 2, 2)), 0.25)
    >>> len(loops), round(loop_area_mm2(loops[0]), 12)
    (1, 4.0)
    """
    m = _as_mesh(mesh)
    v, f = m.vertices, m.faces
    d = v[:, 2] - float(z_mm)
    above = d >= 0                                   # on the plane counts as above
    fa = above[f]
    cross = fa.any(axis=1) & ~fa.all(axis=1)
    if not cross.any():
        return []
    tri = f[cross]
    ta = fa[cross]
    # walking each triangle in its winding order (outward normal), one edge goes from above
    # to below the plane and one from below to above; with the solid on the left seen from
    # +Z, the segment runs from the first crossing to the second (topology, not geometry,
    # decides the direction, so near-zero segments are oriented as reliably as long ones)
    e = np.stack([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]], axis=1)      # (t, 3, 2)
    ea = np.stack([ta[:, [0, 1]], ta[:, [1, 2]], ta[:, [2, 0]]], axis=1)
    down = ea[..., 0] & ~ea[..., 1]
    up = ~ea[..., 0] & ea[..., 1]
    rows = np.arange(len(tri))
    e_down = np.sort(e[rows, np.argmax(down, axis=1)], axis=1)
    e_up = np.sort(e[rows, np.argmax(up, axis=1)], axis=1)
    uniq, inv = np.unique(np.vstack([e_down, e_up]), axis=0, return_inverse=True)
    inv = inv.reshape(-1)
    start, end = inv[:len(tri)], inv[len(tri):]
    # exact crossing point of each unique edge (computed once: shared by both triangles)
    a, b = uniq[:, 0], uniq[:, 1]
    t = d[a] / (d[a] - d[b])
    pts = v[a, :2] + t[:, None] * (v[b, :2] - v[a, :2])
    pts[d[b] == 0] = v[b[d[b] == 0], :2]           # a vertex on the plane is its own crossing
    # each edge point starts one segment and ends one; follow them
    n_pts = len(uniq)
    if (np.bincount(start, minlength=n_pts) != 1).any() or (np.bincount(end, minlength=n_pts) != 1).any():
        raise GeometryError(f"the section at z = {z_mm:g} mm does not close into loops: the mesh is "
                            "open or not manifold; expected a closed solid")
    next_seg = np.empty(len(start), np.int64)
    by_start = np.empty(n_pts, np.int64)
    by_start[start] = np.arange(len(start))
    next_seg[:] = by_start[end]
    seen = np.zeros(len(start), bool)
    loops = []
    for s0 in range(len(start)):
        if seen[s0]:
            continue
        chain = []
        s = s0
        while not seen[s]:
            seen[s] = True
            chain.append(start[s])
            s = next_seg[s]
        ring = pts[np.array(chain)]
        # a vertex on (or within rounding of) the plane is the crossing point of all its
        # crossed edges: drop the steps shorter than MIN_STEP_MM this makes
        ring = ring[np.hypot(*(ring - np.roll(ring, 1, axis=0)).T) > MIN_STEP_MM]
        if len(ring) >= 3:
            loops.append(np.vstack([ring, ring[:1]]))
    return loops


def loop_area_mm2(loop: np.ndarray) -> float:
    """Signed area of a closed polyline (shoelace), mm²; positive counter-clockwise.

    >>> loop_area_mm2(np.array([[0, 0], [2, 0], [2, 1], [0, 1], [0, 0]], float))
    2.0
    """
    x, y = loop[:, 0], loop[:, 1]
    return 0.5 * float(np.sum(x[:-1] * y[1:] - x[1:] * y[:-1]))


def _point_segment_distance(p, a, b):
    ab = b - a
    den = float(ab @ ab)
    t = 0.0 if den == 0 else min(1.0, max(0.0, float((p - a) @ ab) / den))
    return float(np.hypot(*(p - a - t * ab)))


def simplify_loop(loop: np.ndarray, max_deg: float = 5.0, tol_mm: float = 0.01) -> np.ndarray:
    """Drop the vertices of a closed contour where it turns by less than ``max_deg``.

    [MicroCAM]'s planar sections take MaxDeg, "the maximum allowed angle between two
    segments": a vertex where the direction changes by less is not worth a G-code
    block. So that a slow curve made of many small turns is not flattened away, a
    vertex is dropped only while every vertex dropped since the last kept one stays
    within ``tol_mm`` of the new segment.

    Parameters
    ----------
    loop : ndarray, shape (k + 1, 2)
        Closed polyline, first = last, mm.
    max_deg : float
        Turning angles below this are merged, degrees (0…180).
    tol_mm : float
        Largest distance of a dropped vertex from the simplified contour, mm.

    Returns
    -------
    ndarray, shape (j + 1, 2)
        The kept vertices, first = last (at least a triangle).

    Examples
    --------
    A square sampled with 4 points per side keeps only its corners:

    >>> t = np.linspace(0, 1, 5)[:-1]
    >>> sq = np.vstack([np.c_[t, 0 * t], np.c_[1 + 0 * t, t], np.c_[1 - t, 1 + 0 * t],
    ...                 np.c_[0 * t, 1 - t], [[0, 0]]])
    >>> simplify_loop(sq, 5, 0.001).tolist()
    [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [0.0, 0.0]]
    """
    if not (0 <= max_deg <= 180):
        raise GeometryError(f"max_deg must be in [0, 180] degrees, got {max_deg!r}")
    if not tol_mm >= 0:
        raise GeometryError(f"tol_mm must be >= 0 mm, got {tol_mm!r}")
    pts = np.asarray(loop, float)[:-1]
    n = len(pts)
    if n <= 3:
        return np.asarray(loop, float)
    # start at the sharpest corner so the seam sits where a vertex is kept anyway
    din = pts - np.roll(pts, 1, axis=0)
    dout = np.roll(pts, -1, axis=0) - pts
    turn = np.abs(np.arctan2(din[:, 0] * dout[:, 1] - din[:, 1] * dout[:, 0],
                             np.einsum("ij,ij->i", din, dout)))
    pts = np.roll(pts, -int(np.argmax(turn)), axis=0)
    limit = math.radians(max_deg)
    kept = [pts[0]]
    dropped = []
    for i in range(1, n):
        a, p, b = kept[-1], pts[i], pts[(i + 1) % n]
        u, w = p - a, b - p
        ang = abs(math.atan2(u[0] * w[1] - u[1] * w[0], float(u @ w)))
        if ang < limit and all(_point_segment_distance(q, a, b) <= tol_mm for q in dropped + [p]):
            dropped.append(p)
            continue
        kept.append(p)
        dropped = []
    if len(kept) < 3:
        return np.asarray(loop, float)
    return np.vstack(kept + [kept[0]])


def section_levels(z_min: float, z_max: float, step_mm: float, *, top_down: bool = True) -> np.ndarray:
    """The section heights: the middle of each slab of thickness ``step_mm``.

    Slab k spans [z_min + k·step, z_min + (k+1)·step] (the last one may be thinner and
    is cut at its own middle); top-down lists them from the top (machining material
    away), bottom-up from the bottom (building).

    >>> section_levels(0, 1, 0.25).tolist()
    [0.875, 0.625, 0.375, 0.125]
    >>> section_levels(0, 1, 0.4, top_down=False).tolist()
    [0.2, 0.6, 0.9]
    """
    if not (math.isfinite(step_mm) and step_mm > 0):
        raise GeometryError(f"step_mm must be a finite number > 0 mm, got {step_mm!r}")
    if not z_max > z_min:
        raise GeometryError(f"the model has no height (z from {z_min:g} to {z_max:g} mm)")
    n = math.ceil((z_max - z_min) / step_mm - 1e-9)
    lo = z_min + step_mm * np.arange(n)
    hi = np.minimum(lo + step_mm, z_max)
    z = (lo + hi) / 2
    return z[::-1] if top_down else z


def _pocket(loops, beam_mm, tol_mm):
    """Inward offsets of one section: −R, −3R, −5R … until the region vanishes."""
    from labkit.geometry.offset import offset_paths
    from labkit.geometry.order import order_paths

    outline = [Path.polyline(lp, closed=True) for lp in loops]
    rings = []
    d = beam_mm / 2
    while True:
        ring = offset_paths(outline, -d, tol_mm=tol_mm)
        if not ring:
            break
        rings.extend(ring)
        d += beam_mm
    return order_paths(rings)


def section_toolpath(mesh, step_mm: float, beam_mm: float, *, top_down: bool = True,
                     max_deg: float = 5.0, tol_mm: float = 0.005, z_top_mm: float | None = None,
                     feed_mm_min: float = 600.0, s_word: float = 1000.0,
                     laser=LaserMode.CONSTANT) -> tuple[Moves, list[dict]]:
    """A planar-section job: each section of the model pocketed, level by level.

    Parameters
    ----------
    mesh : Mesh or trimesh.Trimesh
        The closed model, mm.
    step_mm : float
        Step down (ZOffset) between sections, mm, > 0.
    beam_mm : float
        Beam diameter: the first offset is half of it (the cut edge lies on the
        section), the next ones a whole diameter each, mm, > 0.
    top_down : bool
        Levels from the top down (material removal) or bottom up (building).
    max_deg : float
        MaxDeg: contour vertices turning less than this are dropped
        (:func:`simplify_loop`), degrees.
    tol_mm : float
        Tolerance of the simplification and of the offsets, mm.
    z_top_mm : float, optional
        Z of the machine at the model's top (default: the model's own Z): each level
        is cut at its own Z, shifted so the top of the model is at ``z_top_mm``.
    feed_mm_min, s_word, laser
        Cutting feed (mm/min), power S and laser mode.

    Returns
    -------
    moves : Moves
        Every level's rings in order (inner first), the beam off on the rapids between
        rings and between levels.
    levels : list of dict
        Per level: ``z_mm`` (model), ``loops`` (the simplified contours),
        ``area_mm2`` (section area), ``rings`` (number of offset rings).

    Examples
    --------
    A 4 × 4 × 1 mm box in steps of 0.5 mm with a 1 mm beam: two levels, each pocketed
    by two square rings (offsets 0.5 and 1.5 mm):

    >>> import trimesh
    >>> moves, levels = section_toolpath(trimesh.creation.box(extents=(4, 4, 1)), 0.5, 1.0)
    >>> [(lv["z_mm"], lv["area_mm2"], lv["rings"]) for lv in levels]
    [(0.25, 16.0, 2), (-0.25, 16.0, 2)]
    >>> sorted(set(np.round(moves.end[moves.laser_on, 2], 9).tolist()))
    [-0.25, 0.25]
    """
    from labkit.toolpath.build import LayerSettings, build_moves

    m = _as_mesh(mesh)
    if not (math.isfinite(beam_mm) and beam_mm > 0):
        raise GeometryError(f"beam_mm must be a finite number > 0 mm, got {beam_mm!r}")
    lo, hi = m.bounds
    z_levels = section_levels(float(lo[2]), float(hi[2]), step_mm, top_down=top_down)
    shift = 0.0 if z_top_mm is None else float(z_top_mm) - float(hi[2])
    settings = LayerSettings(feed_mm_min=feed_mm_min, s_word=s_word, laser=laser)
    parts, info = [], []
    head = np.zeros(3)
    for z in z_levels:
        loops = [simplify_loop(lp, max_deg, tol_mm) for lp in section_loops(m, z)]
        rings = _pocket(loops, beam_mm, tol_mm) if loops else []
        info.append(dict(z_mm=float(z), loops=loops, rings=len(rings),
                         area_mm2=float(sum(loop_area_mm2(lp) for lp in loops))))
        if not rings:
            continue
        level = build_moves(rings, settings, origin=(head[0], head[1], z + shift))
        if level.kind[0] == MoveKind.RAPID:
            level.start[0] = head                 # the rapid also changes Z, from the last level
        else:
            level = Moves.concat([Moves(kind=[MoveKind.RAPID], start=[head], end=[level.start[0]],
                                        feed_mm_min=feed_mm_min, s_word=s_word, laser=int(laser)),
                                  level])
        head = level.end[-1].copy()
        parts.append(level)
    if not parts:
        raise GeometryError("no section is wider than the beam: nothing to cut (lower beam_mm or "
                            "step_mm)")
    return Moves.concat(parts), info


def revolved_mesh(profile, sides: int = 64, *, phase_rad: float = 0.0) -> Mesh:
    """A closed mesh of revolution: a profile (r, z) turned about the Z axis as ``sides``-gons.

    With ``sides=4`` (and ``phase_rad=π/4``) a stepped profile gives a stepped pyramid;
    with many sides a quarter circle gives a dome. Each ring is a regular polygon of
    circumradius r, so the section at any height between two profile points is again
    a regular polygon, of circumradius interpolated linearly — a closed form the
    sections are tested against.

    Parameters
    ----------
    profile : array_like, shape (m + 1, 2)
        (r, z) from the bottom centre (r = 0) to the top centre (r = 0), mm; inner
        points r > 0.
    sides : int
        Polygon sides per ring (≥ 3).
    phase_rad : float
        Angle of each ring's first vertex, rad.

    Returns
    -------
    Mesh
        Outward-facing triangles.

    Examples
    --------
    >>> m = revolved_mesh([(0, 0), (1, 0), (1, 2), (0, 2)], 4, phase_rad=math.pi / 4)
    >>> len(m.vertices), len(m.faces), round(loop_area_mm2(section_loops(m, 1.0)[0]), 12)
    (10, 16, 2.0)
    """
    prof = np.asarray(profile, float)
    if prof.ndim != 2 or prof.shape[1] != 2 or len(prof) < 3:
        raise GeometryError(f"profile must be (r, z) rows, at least 3, got shape {prof.shape}")
    if prof[0, 0] != 0 or prof[-1, 0] != 0 or not np.all(prof[1:-1, 0] > 0):
        raise GeometryError("profile must start and end on the axis (r = 0) with r > 0 between")
    if int(sides) != sides or sides < 3:
        raise GeometryError(f"sides must be an integer >= 3, got {sides!r}")
    n = int(sides)
    ang = phase_rad + 2 * math.pi * np.arange(n) / n
    rings = prof[1:-1]
    verts = [np.array([[0.0, 0.0, prof[0, 1]]])]
    for r, z in rings:
        verts.append(np.c_[r * np.cos(ang), r * np.sin(ang), np.full(n, z)])
    verts.append(np.array([[0.0, 0.0, prof[-1, 1]]]))
    v = np.vstack(verts)
    top = len(v) - 1
    j = np.arange(n)
    jn = (j + 1) % n
    faces = [np.c_[np.zeros(n, np.int64), 1 + jn, 1 + j]]                 # bottom, facing down
    for i in range(len(rings) - 1):
        a, b = 1 + i * n + j, 1 + i * n + jn
        c, d = 1 + (i + 1) * n + jn, 1 + (i + 1) * n + j
        faces += [np.c_[a, b, c], np.c_[a, c, d]]
    last = 1 + (len(rings) - 1) * n
    faces.append(np.c_[np.full(n, top), last + j, last + jn])              # top, facing up
    return Mesh(v, np.vstack(faces).astype(np.int64))
