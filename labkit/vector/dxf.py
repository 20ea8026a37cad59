"""DXF drawings → Paths in millimetres, through ezdxf ([MicroCAM] §6.1.1), cut as the CAD
program that wrote them draws them (checked against ezdxf's drawing add-on in the tests).

Entities read from model space, in the order a renderer draws them (the SORTENTSTABLE, else
ascending handles), and from block references (INSERT and MINSERT, with their transforms,
nested): LINE, ARC, CIRCLE, ELLIPSE, LWPOLYLINE and POLYLINE (2-D with bulges, and 3-D),
SPLINE, and the boundary loops of HATCH as closed outlines (cut, or filled by labkit's
hatching when asked; a loop an associative hatch shares with entities of the drawing is
cut once, by those). One rule for every entity's plane: the plan view — world x and y,
z dropped. A 3-D LINE, POLYLINE or SPLINE is its points' x, y; an entity drawn in its own
plane (OCS: arcs, circles, polylines, hatches) is mapped exactly for extrusion +Z or −Z
(mirrored blocks), by an orthographic projection within the tolerance for a tilted plane
(a circle becomes an ellipse), and as a line for a plane seen edge-on. A WIPEOUT hides what
was drawn before it: those entities are cut only outside its polygon, named in a warning.
Units come from ``$INSUNITS`` (inches, feet, mm, cm, m, µm) or the ``units`` argument; a
drawing without units is taken as mm with a warning. The entity's layer becomes the Path's
layer. Anything else (TEXT, DIMENSION, POINT, 3DFACE, meshes…) is counted by kind and
reported once.

Files ezdxf's strict reader refuses but its recover mode reads (OpenSCAD's R12, for one)
are read with a warning; a file neither reads — whatever ezdxf raises — is "not a readable
DXF file". Before any geometry is made, the reader refuses the drawing with the entity's
handle and layer for numbers that are not finite, a SPLINE whose degree, control points
and knots do not fit together, block references that form a cycle, and more entities after
expanding every block reference than the ``elements`` budget. One entity that cannot be
cut does not refuse the drawing: a circle of radius 0, an ellipse of ratio 0, a block
inserted at x or y scale 0 (collapsed to a line), an entity ezdxf cannot evaluate — each is
skipped with a warning that names it and says why. As AutoCAD and ezdxf draw them, a
negative radius is its absolute value, an ELLIPSE ratio above 1 makes the minor axis the
longer one, and a flat INSERT's z scale (LibreCAD writes 0) moves nothing in x or y.

Geometry: a polyline vertex's bulge b = tan(θ/4) gives the arc to the next vertex —
sweep θ = 4·atan(b), centre on the chord's perpendicular bisector at
(chord/2)·(1 − b²)/(2b) to the left. ELLIPSE has a major-axis vector and a ratio;
its parametric arc goes through :func:`labkit.geometry.ellipse_arc_to_arcs`. SPLINE
(NURBS) is evaluated with :class:`scipy.interpolate.BSpline` on homogeneous
coordinates over its valid knot range [t_p, t_n] only (closed splines from QCAD carry
knots outside it), flattened by subdivision within a share of the tolerance, then
refitted with arcs.
"""

from __future__ import annotations

import math
import warnings
from collections import Counter

import numpy as np

from labkit._files import check_input_file
from labkit._jit import job_units
from labkit.budget import check_budget
from labkit.errors import GeometryError, LabkitError, name_list
from labkit.geometry import transform as tf
from labkit.geometry.arcfit import coordinate_limit_mm, fit_arcs, sampling_share, tolerance_budget
from labkit.geometry.ellipse import ellipse_arc_to_arcs
from labkit.geometry.path import Path
from labkit.vector.svg import Drawing

__all__ = ["read_dxf", "bulge_arc", "spline_points", "INSUNITS_MM", "UNIT_NAMES"]

#: $INSUNITS code → millimetres per drawing unit (0 = unitless, taken as mm).
INSUNITS_MM = {0: 1.0, 1: 25.4, 2: 304.8, 4: 1.0, 5: 10.0, 6: 1000.0, 8: 25.4e-6, 9: 25.4e-3,
               10: 914.4, 13: 1e-3, 14: 100.0}

#: Unit names accepted by ``read_dxf(units=…)`` and ``--units`` → millimetres per unit.
UNIT_NAMES = {"mm": 1.0, "cm": 10.0, "m": 1000.0, "um": 1e-3, "inch": 25.4, "in": 25.4,
              "ft": 304.8, "mil": 25.4e-3}

#: Block references nested deeper than this are refused (CAD programs nest a few levels).
MAX_BLOCK_DEPTH = 64
#: Highest SPLINE degree accepted (CAD programs write 2–5; de Boor costs grow with the square).
MAX_SPLINE_DEGREE = 25


def _where(e) -> str:
    return f"{e.dxftype()} #{e.dxf.handle} on layer {e.dxf.get('layer', '0')!r}"


def _finite(e, what: str, values, limit: float = math.inf) -> None:
    """Refuse values that are not finite, or (coordinates) beyond ``limit`` drawing units."""
    parts = [np.ravel(np.asarray(v, dtype=float)) for v in values]
    arr = np.concatenate(parts) if parts else np.zeros(0)
    if not np.isfinite(arr).all():
        bad = arr[~np.isfinite(arr)].ravel()[0]
        raise GeometryError(f"{_where(e)}: {what} holds {float(bad)!r}, not a finite number")
    if len(arr) and np.abs(arr).max() > limit:
        raise GeometryError(f"{_where(e)}: {what} reaches {np.abs(arr).max():.6g} drawing units, "
                            f"beyond {limit:.3g}, where double precision no longer resolves "
                            f"the tolerance")


def bulge_arc(p0, p1, bulge):
    """Centre and signed sweep (rad) of a polyline bulge from p0 to p1.

    >>> c, s = bulge_arc((0, 0), (2, 0), 1.0)       # b = 1: a half circle, CCW
    >>> c.round(12).tolist(), round(s, 12)
    ([1.0, 0.0], 3.141592653590)
    """
    p0 = np.asarray(p0, float)
    p1 = np.asarray(p1, float)
    d = p1 - p0
    chord = math.hypot(*d)
    if bulge == 0 or chord == 0:
        return np.array([np.nan, np.nan]), 0.0
    h = 0.5 * chord * (1 - bulge * bulge) / (2 * bulge)
    left = np.array([-d[1], d[0]]) / chord
    return 0.5 * (p0 + p1) + h * left, 4.0 * math.atan(bulge)


def _poly(points, bulges, closed, meta, k) -> Path | None:
    pts = np.asarray(points, float)[:, :2] * k
    bul = np.asarray(bulges, float)
    if closed:
        pts = np.vstack([pts, pts[:1]])
    else:
        bul = bul[:-1]
    keep = np.r_[True, np.any(np.diff(pts, axis=0) != 0, axis=1)]
    seg_keep = keep[1:]
    pts, bul = pts[keep], bul[seg_keep]
    if len(pts) < 2:
        return None
    cents, sweeps = [], []
    for a, b, g in zip(pts[:-1], pts[1:], bul):
        c, s = bulge_arc(a, b, g)
        cents.append(c)
        sweeps.append(s)
    return Path(pts, np.array(cents).reshape(-1, 2), np.array(sweeps), closed=closed, **meta)


def _de_boor(t, c, p, u) -> np.ndarray:
    """The B-spline of degree ``p``, knots ``t`` and control points ``c`` (n, d) at the
    parameters ``u`` (within t[p]..t[n]): de Boor's algorithm, all parameters at once. Written
    here rather than scipy's BSpline, whose import costs a small drawing ~0.3 s."""
    n = len(c)
    k = np.clip(np.searchsorted(t, u, side="right") - 1, p, n - 1)      # each parameter's knot span
    d = c[k[:, None] - p + np.arange(p + 1)]                              # (m, p + 1, d)
    for r in range(1, p + 1):
        for j in range(p, r - 1, -1):
            lo, hi = t[j + k - p], t[j + 1 + k - r]
            span = hi - lo
            a = np.where(span > 0, (u - lo) / np.where(span > 0, span, 1.0), 0.0)[:, None]
            d[:, j] = (1.0 - a) * d[:, j - 1] + a * d[:, j]
    return d[:, p]


def spline_points(degree, control_points, knots, weights=None, *, tol_mm) -> np.ndarray:
    """Points of a (rational) B-spline over its valid knot range, within ``tol_mm`` of it.

    Parameters
    ----------
    degree : int
        p ≥ 1.
    control_points : array_like, shape (n, 2 or 3)
        n ≥ p + 1 control points, mm (z is ignored).
    knots : array_like, shape (n + p + 1,)
        Non-decreasing knot vector.
    weights : array_like, shape (n,), optional
        Positive weights (a NURBS); all 1 when omitted.
    tol_mm : float
        Largest distance of the chord polyline from the curve, checked at a quarter,
        half and three quarters of every chord's parameter interval, mm.

    Returns
    -------
    ndarray, shape (m, 2)
        Points from C(t_p) to C(t_n); the parts of the knot vector outside that
        range (periodic and "closed" splines carry them) are never evaluated.

    Examples
    --------
    A quadratic Bézier as a clamped B-spline: C(½) = (1, 1) for control points (0, 0), (1, 2), (2, 0).

    >>> pts = spline_points(2, [[0, 0], [1, 2], [2, 0]], [0, 0, 0, 1, 1, 1], tol_mm=1e-3)
    >>> pts[0].tolist(), pts[-1].tolist(), bool(np.isclose(pts[:, 1].max(), 1.0, atol=1e-3))
    ([0.0, 0.0], [2.0, 0.0], True)
    """
    p = int(degree)
    c = np.asarray(control_points, float)[:, :2]
    n = len(c)
    t = np.asarray(knots, float)
    w = np.ones(n) if weights is None or len(weights) == 0 else np.asarray(weights, float)
    homogeneous = np.column_stack([c * w[:, None], w])

    def at(u):
        h = _de_boor(t, homogeneous, p, u)
        return h[:, :2] / h[:, 2:3]

    lo, hi = t[p], t[n]
    breaks = np.unique(t[(t >= lo) & (t <= hi)])
    u = np.unique(np.concatenate([np.linspace(a, b, 2 * p + 3) for a, b in zip(breaks[:-1], breaks[1:])]))
    pts = at(u)
    for _ in range(60):                    # each pass halves the parameter steps still too coarse
        du = np.diff(u)
        a, b = pts[:-1], pts[1:]
        ab = b - a
        ll = np.einsum("ij,ij->i", ab, ab)
        err = np.zeros(len(du))
        # the chord's largest sag need not sit at the midpoint: a quarter, half and three
        # quarters of each step, evaluated in one call
        quarter, pm, three = np.split(at(np.concatenate([u[:-1] + f * du for f in (0.25, 0.5, 0.75)])), 3)
        for q in (quarter, pm, three):
            s = np.clip(np.einsum("ij,ij->i", q - a, ab) / np.where(ll > 0, ll, 1.0), 0.0, 1.0)
            err = np.maximum(err, np.hypot(*(q - a - s[:, None] * ab).T))
        bad = err > tol_mm
        if not bad.any():
            break
        check_budget("segments", len(u) + int(bad.sum()),
                     cause=f"a spline flattened to {tol_mm:g} mm", option="--tol")
        mid = u[:-1] + 0.5 * du
        order = np.argsort(np.concatenate([u, mid[bad]]), kind="stable")
        u = np.concatenate([u, mid[bad]])[order]
        pts = np.concatenate([pts, pm[bad]])[order]
    return pts


def _spline(e, k, tol_mm, meta) -> list[Path]:
    p = int(e.dxf.degree)
    if len(e.control_points) == 0:                  # defined by fit points only: ezdxf interpolates
        if len(e.fit_points) < 2:
            raise GeometryError(f"{_where(e)}: neither control points nor two fit points")
        _finite(e, "a fit point", e.fit_points, coordinate_limit_mm(tol_mm) / k)
        tool = e.construction_tool()
        return _bspline(e, tool.degree, np.asarray(tool.control_points, float), tool.knots(),
                        tool.weights(), bool(e.closed), k, tol_mm, meta)
    return _bspline(e, p, np.asarray(e.control_points, float), list(e.knots), list(e.weights),
                    bool(e.closed), k, tol_mm, meta)


def _bspline(e, p, ctrl, knots, weights, closed, k, tol_mm, meta) -> list[Path]:
    """A SPLINE entity's or a HATCH spline edge's curve, its numbers checked first."""
    if not 1 <= p <= MAX_SPLINE_DEGREE:
        raise GeometryError(f"{_where(e)}: degree {p} is outside 1…{MAX_SPLINE_DEGREE}")
    _finite(e, "a control point", ctrl, coordinate_limit_mm(tol_mm) / k)
    _finite(e, "a knot", knots)
    _finite(e, "a weight", weights)
    n = len(ctrl)
    if n < p + 1:
        raise GeometryError(f"{_where(e)}: {n} control points cannot carry degree {p} "
                            f"(at least {p + 1} needed)")
    if len(knots) == 0:                              # no knots: clamped and uniform, as ezdxf does
        knots = np.r_[np.zeros(p), np.linspace(0.0, 1.0, n - p + 1), np.ones(p)]
    knots = np.asarray(knots, float)
    if len(knots) != n + p + 1:
        raise GeometryError(f"{_where(e)}: {len(knots)} knots for {n} control points of degree "
                            f"{p} (expected {n + p + 1})")
    if np.any(np.diff(knots) < 0) or not knots[n] > knots[p]:
        raise GeometryError(f"{_where(e)}: the knot vector decreases or has an empty valid range")
    if len(weights) not in (0, n) or (len(weights) and not np.all(np.asarray(weights) > 0)):
        raise GeometryError(f"{_where(e)}: weights must be {n} positive numbers")
    flat, fit = sampling_share(tol_mm)
    pts = spline_points(p, np.asarray(ctrl, float)[:, :2] * k, knots, weights, tol_mm=flat)
    if len(pts) < 2 or not np.any(pts != pts[0]):
        return []
    closed = closed or (len(pts) > 2 and np.allclose(pts[0], pts[-1], atol=1e-9))
    return [fit_arcs(pts, fit, closed=closed, base_deviation_mm=flat, **meta)]


class _Unusable(Exception):
    """An entity that cannot be cut (a point, a line-thin ellipse, a collapsed block): it is
    skipped with a warning that says why, and the rest of the drawing is read."""


def _plan_matrix(e, elevation, k) -> np.ndarray:
    """The affine map (3 × 3, mm) from an entity's plane — its OCS at ``elevation`` drawing
    units, coordinates already in mm — to the plan view: world coordinates with z dropped,
    the rule a 3-D LINE follows. The identity for extrusion +Z, a mirror of x for −Z, an
    orthographic projection for any other plane."""
    from ezdxf.math import OCS

    ex = e.dxf.get("extrusion", (0.0, 0.0, 1.0))
    _finite(e, "extrusion", [ex, elevation])
    if not math.hypot(*ex) > 0:
        raise _Unusable("its extrusion vector has length 0")
    ocs = OCS(ex)
    ux, uy, uz = ocs.ux, ocs.uy, ocs.uz
    return np.array([[ux.x, uy.x, uz.x * elevation * k],
                     [ux.y, uy.y, uz.y * elevation * k],
                     [0.0, 0.0, 1.0]])


def _to_plan(paths: list[Path], m: np.ndarray, tol_mm: float) -> list[Path]:
    """Paths drawn in an entity's plane, mapped by its plan matrix ``m`` (:func:`_plan_matrix`):
    exactly for the XY plane and its mirror, through ellipse arcs within ``tol_mm`` for a
    tilted plane, and as the polyline of samples within ``tol_mm`` for a plane seen edge-on
    (a projection never lengthens a chord's sag), where a circle is drawn as a line."""
    if np.array_equal(m, np.eye(3)):
        return paths
    if abs(np.linalg.det(m[:2, :2])) > 1e-9:
        return [p.transformed(m, tol_mm=tol_mm) for p in paths]
    out = []
    for p in paths:
        pts = tf.apply(m, p.sample(tol_mm))
        keep = np.r_[True, np.any(np.diff(pts, axis=0) != 0, axis=1)]
        if keep.sum() >= 2:
            out.append(p.with_geometry(pts[keep], closed=False, deviation_mm=p.deviation_mm + tol_mm))
    return out


def _ellipse(e, centre, major, extrusion, ratio, t0, t1, k, tol_mm, meta) -> list[Path]:
    """An elliptical arc c + cos t·major + sin t·minor (world coordinates, minor = ratio ·
    N × major as DXF defines it; a ratio above 1 makes the minor axis the longer one, as
    ezdxf and AutoCAD draw it) seen from above."""
    centre, major = np.array(tuple(centre), float), np.array(tuple(major), float)
    _finite(e, "the centre, axis, ratio or parameters", [*centre, *major, ratio, t0, t1],
            coordinate_limit_mm(tol_mm) / k)
    n = np.array(tuple(extrusion), float)
    if not np.linalg.norm(n) > 0:
        raise _Unusable("its extrusion vector has length 0")
    if not ratio > 0:
        raise _Unusable(f"axis ratio {ratio:g}: the ellipse has no width")
    if not np.any(major != 0):
        raise _Unusable("its major axis has length 0")
    minor = ratio * np.cross(n / np.linalg.norm(n), major)
    jac = np.column_stack([major[:2], minor[:2]]) * k
    dt = (t1 - t0) % (2 * math.pi) or 2 * math.pi
    c = centre[:2] * k
    if abs(np.linalg.det(jac)) > 1e-9 * max(1.0, float(np.abs(jac).max()) ** 2):
        return [ellipse_arc_to_arcs(c, jac, t0, dt, tol_mm=tol_mm, **meta)]
    # seen edge-on: a line; a chord of the unit circle over step s sags 1 − cos(s/2)
    big = max(float(np.linalg.norm(major)), float(np.linalg.norm(minor))) * k
    step = 2.0 * math.acos(max(1.0 - tol_mm / big, -1.0))
    count = max(2, math.ceil(dt / step))
    check_budget("segments", count, cause=f"{_where(e)} at tolerance {tol_mm:g} mm", option="--tol")
    t = t0 + dt * np.linspace(0.0, 1.0, count + 1)
    pts = c + np.stack([np.cos(t), np.sin(t)], axis=1) @ jac.T
    keep = np.r_[True, np.any(np.diff(pts, axis=0) != 0, axis=1)]
    return [Path(pts[keep], deviation_mm=tol_mm, **meta)] if keep.sum() >= 2 else []


def _hatch(e, k, tol_mm, meta, sink) -> list[Path]:
    """A HATCH's boundary loops as closed outlines (cut, or filled by labkit's hatching when
    asked), in the hatch's plane seen from above. A loop that follows entities of the
    drawing (an associative hatch's source objects) is cut once, by those entities."""
    from ezdxf.entities.boundary_paths import ArcEdge, EdgePath, EllipseEdge, LineEdge, SplineEdge
    from ezdxf.math import fit_points_to_cad_cv

    from labkit.geometry.chains import join_chains

    elevation = float(e.dxf.get("elevation", (0.0, 0.0, 0.0))[2])
    m = _plan_matrix(e, elevation, k)
    lim = coordinate_limit_mm(tol_mm) / k
    out: list[Path] = []
    for loop in e.paths:
        handles = list(getattr(loop, "source_boundary_objects", []) or [])
        if e.dxf.get("associative", 0) and handles and all(sink.is_cut(h) for h in handles):
            continue
        if not isinstance(loop, EdgePath):           # a polyline loop: vertices with bulges
            pts = np.array([tuple(v)[:3] for v in loop.vertices], float).reshape(-1, 3)
            _finite(e, "a boundary vertex or bulge", pts, lim)
            p = _poly(pts[:, :2], pts[:, 2], True, meta, k) if len(pts) >= 2 else None
            out += _to_plan([p], m, tol_mm) if p else []
            continue
        pieces: list[Path] = []
        for edge in loop.edges:
            if isinstance(edge, LineEdge):
                a, b = np.array(edge.start, float)[:2], np.array(edge.end, float)[:2]
                _finite(e, "a boundary line", [a, b], lim)
                if np.any(a != b):
                    pieces.append(Path([a * k, b * k], **meta))
            elif isinstance(edge, ArcEdge):          # ezdxf holds every arc edge counter-clockwise
                c, r = np.array(edge.center, float)[:2], abs(float(edge.radius))
                _finite(e, "a boundary arc", [c, r, edge.start_angle, edge.end_angle], lim)
                sweep = math.radians((edge.end_angle - edge.start_angle) % 360.0) or 2 * math.pi
                if r > 0:
                    pieces.append(Path.arc(c * k, r * k, math.radians(edge.start_angle), sweep, **meta))
            elif isinstance(edge, EllipseEdge):
                el = edge.construction_tool()
                pieces += _ellipse(e, el.center, el.major_axis, (0.0, 0.0, 1.0), el.ratio,
                                   el.start_param, el.end_param, k, tol_mm, meta)
            elif isinstance(edge, SplineEdge):
                if len(edge.control_points):
                    pieces += _bspline(e, int(edge.degree), np.asarray(edge.control_points, float),
                                       list(edge.knot_values), list(edge.weights or []), False,
                                       k, tol_mm, meta)
                elif len(edge.fit_points) >= 2:
                    _finite(e, "a boundary fit point", np.asarray(edge.fit_points, float), lim)
                    tool = fit_points_to_cad_cv([(x, y, 0.0) for x, y, *_ in edge.fit_points])
                    pieces += _bspline(e, tool.degree, np.asarray(tool.control_points, float),
                                       tool.knots(), tool.weights(), False, k, tol_mm, meta)
        for chain in join_chains(pieces, tol_mm, by_layer=False):   # a renderer closes gaps
            closed = chain if chain.closed else chain.with_geometry(
                np.vstack([chain.vertices, chain.vertices[:1]]),
                np.vstack([chain.centres, [[np.nan, np.nan]]]), np.r_[chain.sweeps, 0.0], closed=True)
            out += _to_plan([closed], m, tol_mm)
    return out


class _Sink:
    """The cut paths in draw order. A WIPEOUT hides what was drawn before it: those paths
    keep only their parts outside its polygon, as ezdxf's drawing add-on paints it."""

    def __init__(self, doc, tol_mm):
        self.doc, self.tol_mm = doc, tol_mm
        self.paths: list[Path] = []
        self.skipped: list[str] = []          # kinds labkit does not cut (text, images, …)
        self.unusable: list[str] = []         # entities that cannot be cut, with the reason
        self.wiped: list[str] = []            # entities cut only in part (under a WIPEOUT)

    def is_cut(self, handle) -> bool:
        """Whether the entity of this handle is one labkit cuts on its own."""
        ent = self.doc.entitydb.get(handle)
        return ent is not None and ent.is_alive and ent.dxftype() in CUT_KINDS

    def wipe(self, e, k) -> None:
        import shapely

        from labkit.geometry.clip import clip_paths

        pts = np.array([(v.x, v.y) for v in e.boundary_path_wcs()], float).reshape(-1, 2) * k
        _finite(e, "a boundary vertex", pts)
        if len(pts) < 3:
            return
        hole = shapely.make_valid(shapely.Polygon(pts))
        if not hole.area > 0:
            return
        x0, y0, x1, y1 = hole.bounds
        for i, p in enumerate(list(self.paths)):
            (a0, b0), (a1, b1) = p.bounds()
            if a1 < x0 or a0 > x1 or b1 < y0 or b0 > y1:
                continue
            outside = shapely.box(min(a0, x0) - 1, min(b0, y0) - 1, max(a1, x1) + 1,
                                  max(b1, y1) + 1).difference(hole)
            cut = clip_paths([p], outside, tol_mm=self.tol_mm, fill_regions=False)
            if cut.clipped:
                self.paths[i] = cut.paths        # replaced in place: the draw order is kept
                self.wiped.append(p.source)
        self.paths = [q for item in self.paths for q in (item if isinstance(item, list) else [item])]


#: Entity kinds labkit cuts.
CUT_KINDS = frozenset(("LINE", "ARC", "CIRCLE", "ELLIPSE", "LWPOLYLINE", "POLYLINE", "SPLINE",
                       "HATCH"))


def _entity_paths(e, k, tol_mm, meta, sink, depth=0) -> None:
    """Add the paths of entity ``e`` to ``sink`` (an INSERT: its block's, in block order)."""
    import ezdxf

    kind = e.dxftype()
    try:
        new = _paths(e, kind, k, tol_mm, meta, sink, depth)     # a WIPEOUT replaces sink.paths
        sink.paths += new
    except _Unusable as why:
        sink.unusable.append(f"{kind}#{e.dxf.handle} ({why})")
    except LabkitError:
        raise
    except (AttributeError, TypeError, KeyError, IndexError, ValueError, ArithmeticError,
            ezdxf.DXFError) as exc:          # ezdxf on entities it cannot make sense of
        sink.unusable.append(f"{kind}#{e.dxf.handle} (ezdxf cannot read it: "
                             f"{type(exc).__name__}: {exc})")


def _paths(e, kind, k, tol_mm, meta, sink, depth) -> list[Path]:
    import ezdxf

    lim = coordinate_limit_mm(tol_mm) / k
    if kind == "LINE":                           # world coordinates: z dropped
        a, b = np.array(e.dxf.start)[:2], np.array(e.dxf.end)[:2]
        _finite(e, "an end point", [a, b], lim)
        return [Path([a * k, b * k], **meta)] if np.any(a != b) else []
    if kind in ("CIRCLE", "ARC"):                # in the entity's plane (OCS), seen from above
        centre, r = np.array(e.dxf.center), e.dxf.radius
        _finite(e, "the centre or radius", [*centre, r], lim)
        r = abs(r)                               # AutoCAD and ezdxf draw a negative radius as |r|
        if not r > 0:
            raise _Unusable("radius 0: a point")
        m = _plan_matrix(e, centre[2], k)
        if kind == "CIRCLE":
            return _to_plan([Path.circle(centre[:2] * k, r * k, **meta)], m, tol_mm)
        _finite(e, "an angle", [e.dxf.start_angle, e.dxf.end_angle])
        sweep = math.radians((e.dxf.end_angle - e.dxf.start_angle) % 360.0) or 2 * math.pi
        arc = Path.arc(centre[:2] * k, r * k, math.radians(e.dxf.start_angle), sweep, **meta)
        return _to_plan([arc], m, tol_mm)
    if kind == "ELLIPSE":
        return _ellipse(e, np.array(e.dxf.center), np.array(e.dxf.major_axis),
                        e.dxf.get("extrusion", (0.0, 0.0, 1.0)), e.dxf.ratio, e.dxf.start_param,
                        e.dxf.end_param, k, tol_mm, meta)
    if kind == "LWPOLYLINE":
        pts = np.array(list(e.get_points("xyb")), float).reshape(-1, 3)
        _finite(e, "a vertex or bulge", pts, lim)
        p = _poly(pts[:, :2], pts[:, 2], bool(e.closed), meta, k) if len(pts) >= 2 else None
        return _to_plan([p], _plan_matrix(e, e.dxf.get("elevation", 0.0), k), tol_mm) if p else []
    if kind == "POLYLINE":
        if e.is_poly_face_mesh or e.is_polygon_mesh:
            raise _Unusable("a 3-D mesh")
        verts = list(e.vertices)
        pts = np.array([v.dxf.location for v in verts], float).reshape(-1, 3)
        bul = np.array([v.dxf.get("bulge", 0.0) for v in verts], float)
        _finite(e, "a vertex or bulge", [pts.ravel(), bul] if len(pts) else [], lim)
        if len(pts) < 2:
            return []
        if e.is_3d_polyline:                     # world coordinates: z dropped, straight sides
            p = _poly(pts[:, :2], np.zeros(len(pts)), bool(e.is_closed), meta, k)
            return [p] if p else []
        p = _poly(pts[:, :2], bul, bool(e.is_closed), meta, k)
        m = _plan_matrix(e, float(e.dxf.get("elevation", (0.0, 0.0, 0.0))[2]), k)
        return _to_plan([p], m, tol_mm) if p else []
    if kind == "SPLINE":                         # world coordinates: z dropped
        return _spline(e, k, tol_mm, meta)
    if kind == "HATCH":
        return _hatch(e, k, tol_mm, meta, sink)
    if kind == "WIPEOUT":
        sink.wipe(e, k)
        return []
    if kind == "INSERT":
        scale = [e.dxf.get("xscale", 1.0), e.dxf.get("yscale", 1.0), e.dxf.get("zscale", 1.0)]
        _finite(e, "the insertion point, scale or rotation",
                [*e.dxf.get("insert", (0, 0, 0)), *scale, e.dxf.get("rotation", 0.0)], lim)
        if scale[0] == 0 or scale[1] == 0:
            raise _Unusable(f"block {e.dxf.name!r} inserted at scale {scale[0]:g} × {scale[1]:g} "
                            f"collapses to a line")
        if scale[2] == 0:                        # a flat insert's z scale does not move x or y
            ex = e.dxf.get("extrusion", (0.0, 0.0, 1.0))
            if abs(ex[0]) > 1e-12 or abs(ex[1]) > 1e-12:
                raise _Unusable(f"block {e.dxf.name!r} inserted at z scale 0 in a tilted plane")
            e.dxf.zscale = 1.0
        if depth >= MAX_BLOCK_DEPTH:
            raise GeometryError(f"{_where(e)}: block references nested more than "
                                f"{MAX_BLOCK_DEPTH} deep")
        copies = e.multi_insert() if e.mcount > 1 else [e]
        for ins in copies:
            try:
                subs = list(ins.virtual_entities())
            except (ValueError, ZeroDivisionError, ezdxf.DXFError) as exc:
                raise _Unusable(f"block {e.dxf.name!r} cannot be placed ({exc})") from None
            for sub in subs:
                sub_meta = dict(meta, layer=meta["layer"] if sub.dxf.layer == "0" else sub.dxf.layer)
                _entity_paths(sub, k, tol_mm, sub_meta, sink, depth + 1)
        return []
    sink.skipped.append(f"{kind}#{e.dxf.handle}")
    return []


def _expanded_count(doc, name) -> int:
    """Entities after expanding every block reference; refuses cycles and the budget."""
    memo: dict[str, int] = {}

    def block(bname, chain, where):
        if bname in memo:
            return memo[bname]
        if bname in chain:
            ring = " → ".join([*chain[chain.index(bname):], bname])
            raise GeometryError(f"{name}: {where}: block references form a cycle ({ring})")
        if len(chain) >= MAX_BLOCK_DEPTH:
            raise GeometryError(f"{name}: {where}: block references nested more than "
                                f"{MAX_BLOCK_DEPTH} deep")
        layout = doc.blocks.get(bname)
        total = 0 if layout is None else sum(entity(e, [*chain, bname]) for e in layout)
        memo[bname] = total
        check_budget("elements", total, cause=f"copies inside block {bname!r} of {name}")
        return total

    def entity(e, chain):
        if e.dxftype() != "INSERT":
            return 1
        reps = max(1, int(e.dxf.get("row_count", 1))) * max(1, int(e.dxf.get("column_count", 1)))
        return 1 + reps * block(e.dxf.name, chain, _where(e))

    total = sum(entity(e, []) for e in doc.modelspace())
    check_budget("elements", total, cause=f"block references (INSERT) in {name}")
    return total


def _unit_scale(doc, units, name, warn, written_units=True) -> float:
    if units is not None:
        try:
            return UNIT_NAMES[str(units).lower()]
        except KeyError:
            raise GeometryError(f"units {units!r}: expected one of {', '.join(UNIT_NAMES)}") from None
    # ezdxf fills a header the file lacks from its template ($INSUNITS = 6, metres):
    # only a $INSUNITS written in the file itself says anything about its units.
    code = doc.header.get("$INSUNITS", 0) if written_units else 0
    try:
        code = int(code)
    except (TypeError, ValueError):
        code = -1
    if code not in INSUNITS_MM:
        raise GeometryError(f"{name}: $INSUNITS = {code} is not a length unit labkit knows "
                            f"(expected one of {sorted(INSUNITS_MM)}); give the units (--units)")
    if code == 0 and warn:
        imperial = doc.header.get("$MEASUREMENT", 1) == 0
        warnings.warn(f"{name}: the drawing does not say its units ($INSUNITS missing or 0"
                      f"{', $MEASUREMENT imperial' if imperial else ''}); taken as millimetres — "
                      f"give --units inch (or units='inch') if it was drawn in inches", stacklevel=3)
    return INSUNITS_MM[code]


def _load(name):
    """The document and whether ezdxf's recover mode was needed; any failure of either
    reader (ezdxf raises more than its own errors on malformed entities) is refused."""
    import ezdxf
    from ezdxf import recover

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return ezdxf.readfile(name), False
    except (MemoryError, RecursionError):
        raise
    except Exception:                                 # noqa: BLE001 — try recover mode next
        pass
    try:
        doc, auditor = recover.readfile(name)
    except (MemoryError, RecursionError):
        raise
    except Exception as exc:                          # noqa: BLE001 — ezdxf's loaders raise
        raise GeometryError(f"{name}: not a readable DXF file (ezdxf: {type(exc).__name__}: "
                            f"{exc})") from None      # AttributeError on malformed entities
    if auditor.has_errors or len(doc.modelspace()) == 0:
        raise GeometryError(f"{name}: not a readable DXF file (ezdxf's recover mode found "
                            f"{len(auditor.errors)} unrecoverable error(s))")
    return doc, True


def _draw_order(layout):
    """The layout's entities in the order a renderer draws them (its SORTENTSTABLE, else
    ascending handles — as ezdxf's drawing add-on does); a WIPEOUT hides only what came before."""
    from ezdxf import reorder

    mapping = list(layout.get_redraw_order())
    return reorder.ascending(layout, mapping) if mapping else iter(layout)


def read_dxf(source, *, tol_mm=0.01, units=None, warn=True, arcs=True) -> Drawing:
    """Read a DXF file into Paths in mm (see the module docstring for entities and units).

    Parameters
    ----------
    source : str or path
        DXF file name.
    tol_mm : float
        Largest deviation of ellipses and splines from their arcs, mm.
    units : str, optional
        The drawing unit (``"mm"``, ``"cm"``, ``"m"``, ``"um"``, ``"inch"``, ``"ft"``,
        ``"mil"``), overriding ``$INSUNITS``.
    warn : bool
        Warn about recovery, missing units and skipped entities (counted by kind).
    arcs : bool
        Keep arcs (G2/G3). False gives straight segments only, the tolerance shared
        between reading and chording by :func:`labkit.geometry.arcfit.tolerance_budget`.

    Returns
    -------
    Drawing
        One Path per entity, layer = DXF layer. Join them into chains with
        :func:`labkit.geometry.join_chains`.
    """
    import logging

    budget = tolerance_budget(tol_mm, arcs=arcs)
    tol_mm = budget.read_mm
    path = check_input_file(source, what="DXF file")
    name = str(path)
    logging.getLogger("ezdxf").setLevel(logging.ERROR)    # its notes on handles go to stderr
    doc, recovered = _load(name)
    if recovered and warn:
        warnings.warn(f"{name}: the file breaks the DXF structure; read with ezdxf's recover "
                      f"mode — check the result", stacklevel=2)
    with open(path, "rb") as f:                      # the header comes first; stop at entities
        head = f.read(1 << 20)
    head = head.split(b"ENTITIES", 1)[0]
    k = _unit_scale(doc, units, name, warn, written_units=b"$INSUNITS" in head)
    _expanded_count(doc, name)
    sink = _Sink(doc, tol_mm)
    for e in job_units(list(_draw_order(doc.modelspace()))):   # Python or compiled: _jit's rule
        meta = dict(layer=e.dxf.get("layer", "0"), source=f"{e.dxftype()}#{e.dxf.handle}",
                    fill_rule="evenodd")
        try:
            _entity_paths(e, k, tol_mm, meta, sink)
        except GeometryError as exc:
            raise GeometryError(f"{name}: {exc}") from None
    paths, skipped = sink.paths, sink.skipped
    if skipped and warn:
        kinds = Counter(s.split("#")[0] for s in skipped)
        listed = ", ".join(f"{n} {kind}" for kind, n in kinds.most_common())
        warnings.warn(f"{name}: skipped {len(skipped)} entities labkit does not cut ({listed}): "
                      f"{name_list(skipped)}", stacklevel=2)
    if sink.unusable and warn:
        warnings.warn(f"{name}: skipped {len(sink.unusable)} entities that cannot be cut: "
                      f"{name_list(sink.unusable)}", stacklevel=2)
    wiped = list(dict.fromkeys(sink.wiped))
    if wiped and warn:
        warnings.warn(f"{name}: {len(wiped)} entities lie partly under a WIPEOUT drawn after "
                      f"them; only their visible parts are cut: {name_list(wiped)}", stacklevel=2)
    if units is None and paths and warn:
        _check_extents(paths, k, name)
    if not arcs:                # exact arcs read at read_mm become chords within chords_mm
        paths = [p if not p.is_arc.any() else
                 p.with_geometry(p.sample(budget.chords_mm), deviation_mm=p.deviation_mm + budget.chords_mm)
                 for p in paths]
    return Drawing(paths, math.nan, math.nan, skipped + sink.unusable, name, clipped=wiped)


#: Drawing sizes (largest side, mm) a laser job plausibly has; outside, the units are doubted.
PLAUSIBLE_SPAN_MM = (1.0, 3000.0)


def _check_extents(paths, mm_per_unit, name) -> None:
    """Warn when the drawing's size in mm is implausible for a laser job: the units in the
    file (or the mm assumed without them) are probably not the ones it was drawn in."""
    from labkit.geometry.path import paths_bounds

    lo, hi = paths_bounds(paths)
    span = float(np.max(hi - lo))
    low, high = PLAUSIBLE_SPAN_MM
    if not span > 0 or low <= span <= high:
        return
    assumed = next(u for u, v in UNIT_NAMES.items() if v == mm_per_unit) if mm_per_unit in \
        UNIT_NAMES.values() else f"{mm_per_unit:g} mm"
    drawn = span / mm_per_unit
    better = [u for u in ("mm", "inch", "cm", "m", "um") if low <= drawn * UNIT_NAMES[u] <= high
              and UNIT_NAMES[u] != mm_per_unit]
    hint = (f"if it was drawn in {better[0]}, give --units {better[0]} (units='{better[0]}')"
            if better else "check the drawing's units (--units)")
    warnings.warn(f"{name}: the drawing is {f'{span:,.0f}' if span >= 10 else f'{span:.3g}'} mm across with its units taken as {assumed}, "
                  f"implausibly {'small' if span < low else 'large'} for a laser job — {hint}",
                  stacklevel=3)
