"""DXF drawings → Paths in millimetres, through ezdxf ([MicroCAM] §6.1.1).

Entities read from model space and from block references (INSERT and MINSERT, with
their transforms, nested): LINE, ARC, CIRCLE, ELLIPSE, LWPOLYLINE and 2-D POLYLINE
(with bulges), SPLINE. Entities whose extrusion is −Z (mirrored blocks, some CAD
programs' arcs) are mapped to the XY plane; entities in other planes are skipped.
Units come from ``$INSUNITS`` (inches, feet, mm, cm, m, µm) or the ``units``
argument; a drawing without units is taken as mm with a warning. The entity's layer
becomes the Path's layer. Anything else (TEXT, HATCH, DIMENSION, POINT, 3-D entities…)
is counted by kind and reported once.

Files ezdxf's strict reader refuses but its recover mode reads (OpenSCAD's R12, for
one) are read with a warning. Before any geometry is made, the reader refuses with
the entity's handle and layer: numbers that are not finite, a zero or non-finite
INSERT scale (AutoCAD refuses scale 0; ezdxf draws it at scale 1), an ELLIPSE ratio
outside (0, 1], a SPLINE whose degree, control points and knots do not fit together,
block references that form a cycle, and more entities after expanding every block
reference than the ``elements`` budget.

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
from labkit.budget import check_budget
from labkit.errors import GeometryError
from labkit.geometry.arcfit import FLATTEN_SHARE, coordinate_limit_mm, fit_arcs, tolerance_budget
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


def _plane(e) -> float | None:
    """+1 for entities in the XY plane, −1 for extrusion −Z (x mirrored), None otherwise."""
    ex = e.dxf.get("extrusion", (0.0, 0.0, 1.0))
    _finite(e, "extrusion", ex)
    if abs(ex[0]) < 1e-9 and abs(ex[1]) < 1e-9 and ex[2] != 0:
        return 1.0 if ex[2] > 0 else -1.0
    return None


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
    from scipy.interpolate import BSpline

    p = int(degree)
    c = np.asarray(control_points, float)[:, :2]
    n = len(c)
    t = np.asarray(knots, float)
    w = np.ones(n) if weights is None or len(weights) == 0 else np.asarray(weights, float)
    spl = BSpline(t, np.column_stack([c * w[:, None], w]), p, extrapolate=False)

    def at(u):
        h = spl(u)
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
        for f in (0.25, 0.5, 0.75):        # the chord's largest sag need not sit at the midpoint
            q = at(u[:-1] + f * du)
            s = np.clip(np.einsum("ij,ij->i", q - a, ab) / np.where(ll > 0, ll, 1.0), 0.0, 1.0)
            err = np.maximum(err, np.hypot(*(q - a - s[:, None] * ab).T))
            if f == 0.5:
                pm = q
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
    if not 1 <= p <= MAX_SPLINE_DEGREE:
        raise GeometryError(f"{_where(e)}: degree {p} is outside 1…{MAX_SPLINE_DEGREE}")
    if len(e.control_points) == 0:                  # defined by fit points only: ezdxf interpolates
        if len(e.fit_points) < 2:
            raise GeometryError(f"{_where(e)}: neither control points nor two fit points")
        _finite(e, "a fit point", e.fit_points, coordinate_limit_mm(tol_mm) / k)
        tool = e.construction_tool()
        ctrl, knots, weights = np.asarray(tool.control_points, float), tool.knots(), tool.weights()
        p = tool.degree
    else:
        ctrl = np.asarray(e.control_points, float)
        knots, weights = list(e.knots), list(e.weights)
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
    flat = FLATTEN_SHARE * tol_mm
    pts = spline_points(p, ctrl * k, knots, weights, tol_mm=flat)
    if len(pts) < 2 or not np.any(pts != pts[0]):
        return []
    closed = bool(e.closed) or (len(pts) > 2 and np.allclose(pts[0], pts[-1], atol=1e-9))
    return [fit_arcs(pts, tol_mm - flat, closed=closed, base_deviation_mm=flat, **meta)]


def _entity_paths(e, k, tol_mm, meta, skipped, depth=0) -> list[Path]:
    import ezdxf

    kind = e.dxftype()
    lim = coordinate_limit_mm(tol_mm) / k
    if kind == "LINE":
        a, b = np.array(e.dxf.start)[:2], np.array(e.dxf.end)[:2]
        _finite(e, "an end point", [a, b], lim)
        return [Path([a * k, b * k], **meta)] if np.any(a != b) else []
    if kind in ("CIRCLE", "ARC", "LWPOLYLINE", "POLYLINE"):
        if kind == "POLYLINE" and (e.is_3d_polyline or e.is_poly_face_mesh or e.is_polygon_mesh):
            skipped.append(f"{kind}(3D)#{e.dxf.handle}")
            return []
        mirror = _plane(e)                       # these are given in the entity's plane (OCS)
        if mirror is None:
            skipped.append(f"{kind}(not in the XY plane)#{e.dxf.handle}")
            return []
    if kind in ("CIRCLE", "ARC"):
        centre, r = np.array(e.dxf.center)[:2], e.dxf.radius
        _finite(e, "the centre or radius", [*centre, r], lim)
        if not r > 0:
            raise GeometryError(f"{_where(e)}: radius {r!r} is not positive")
        centre = centre * [mirror, 1.0] * k
        if kind == "CIRCLE":
            return [Path.circle(centre, r * k, ccw=mirror > 0, **meta)]
        _finite(e, "an angle", [e.dxf.start_angle, e.dxf.end_angle])
        a0 = math.radians(e.dxf.start_angle)
        sweep = math.radians((e.dxf.end_angle - e.dxf.start_angle) % 360.0) or 2 * math.pi
        if mirror < 0:
            a0, sweep = math.pi - a0, -sweep
        return [Path.arc(centre, r * k, a0, sweep, **meta)]
    if kind == "ELLIPSE":
        centre, major = np.array(e.dxf.center)[:2], np.array(e.dxf.major_axis)[:2]
        ratio, t0, t1 = e.dxf.ratio, e.dxf.start_param, e.dxf.end_param
        _finite(e, "the centre, axis, ratio or parameters", [*centre, *major, ratio, t0, t1], lim)
        if not 0 < ratio <= 1 + 1e-9:
            raise GeometryError(f"{_where(e)}: axis ratio {ratio!r} is outside (0, 1]")
        if not np.any(major != 0):
            raise GeometryError(f"{_where(e)}: the major axis has length 0")
        mirror = _plane(e)
        if mirror is None:
            skipped.append(f"{kind}(not in the XY plane)#{e.dxf.handle}")
            return []
        # centre and major axis are in world coordinates; the minor axis is ratio · (N × major)
        minor = ratio * mirror * np.array([-major[1], major[0]])
        dt = (t1 - t0) % (2 * math.pi) or 2 * math.pi
        jac = np.column_stack([major, minor]) * k
        return [ellipse_arc_to_arcs(centre * k, jac, t0, dt, tol_mm=tol_mm, **meta)]
    if kind == "LWPOLYLINE":
        pts = np.array(list(e.get_points("xyb")), float).reshape(-1, 3)
        _finite(e, "a vertex or bulge", pts, lim)
        if len(pts) < 2:
            return []
        p = _poly(pts[:, :2] * [mirror, 1.0], pts[:, 2] * mirror, bool(e.closed), meta, k)
        return [p] if p else []
    if kind == "POLYLINE":
        verts = list(e.vertices)
        pts = np.array([v.dxf.location for v in verts], float).reshape(-1, 3)[:, :2]
        bul = np.array([v.dxf.get("bulge", 0.0) for v in verts], float)
        _finite(e, "a vertex or bulge", [pts.ravel(), bul] if len(pts) else [], lim)
        if len(pts) < 2:
            return []
        p = _poly(pts * [mirror, 1.0], bul * mirror, bool(e.is_closed), meta, k)
        return [p] if p else []
    if kind == "SPLINE":
        return _spline(e, k, tol_mm, meta)
    if kind == "INSERT":
        scale = [e.dxf.get("xscale", 1.0), e.dxf.get("yscale", 1.0), e.dxf.get("zscale", 1.0)]
        _finite(e, "the insertion point, scale or rotation",
                [*e.dxf.get("insert", (0, 0, 0)), *scale, e.dxf.get("rotation", 0.0)], lim)
        if any(v == 0 for v in scale):
            raise GeometryError(f"{_where(e)}: block {e.dxf.name!r} inserted at scale "
                                f"{scale[0]:g} × {scale[1]:g} × {scale[2]:g}; a zero scale "
                                f"collapses it (AutoCAD refuses it)")
        if depth >= MAX_BLOCK_DEPTH:
            raise GeometryError(f"{_where(e)}: block references nested more than "
                                f"{MAX_BLOCK_DEPTH} deep")
        out = []
        copies = e.multi_insert() if e.mcount > 1 else [e]
        for ins in copies:
            try:
                subs = list(ins.virtual_entities())
            except (ValueError, ZeroDivisionError, ezdxf.DXFError) as exc:
                raise GeometryError(f"{_where(e)}: block {e.dxf.name!r} cannot be placed "
                                    f"({exc})") from None
            for sub in subs:
                sub_meta = dict(meta, layer=meta["layer"] if sub.dxf.layer == "0" else sub.dxf.layer)
                out += _entity_paths(sub, k, tol_mm, sub_meta, skipped, depth + 1)
        return out
    skipped.append(f"{kind}#{e.dxf.handle}")
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
    import ezdxf
    from ezdxf import recover

    budget = tolerance_budget(tol_mm, arcs=arcs)
    tol_mm = budget.read_mm
    path = check_input_file(source, what="DXF file")
    name = str(path)
    import logging

    logging.getLogger("ezdxf").setLevel(logging.ERROR)    # its notes on handles go to stderr
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            doc = ezdxf.readfile(name)
        recovered = False
    except (ezdxf.DXFError, UnicodeDecodeError, ValueError, OSError):
        try:
            doc, auditor = recover.readfile(name)
        except (ezdxf.DXFError, OSError, UnicodeDecodeError, ValueError) as exc:
            raise GeometryError(f"{name}: not a readable DXF file ({exc})") from None
        if auditor.has_errors or len(doc.modelspace()) == 0:
            raise GeometryError(f"{name}: not a readable DXF file (ezdxf's recover mode found "
                                f"{len(auditor.errors)} unrecoverable error(s))")
        recovered = True
    if recovered and warn:
        warnings.warn(f"{name}: the file breaks the DXF structure; read with ezdxf's recover "
                      f"mode — check the result", stacklevel=2)
    with open(path, "rb") as f:                      # the header comes first; stop at entities
        head = f.read(1 << 20)
    head = head.split(b"ENTITIES", 1)[0]
    k = _unit_scale(doc, units, name, warn, written_units=b"$INSUNITS" in head)
    _expanded_count(doc, name)
    paths: list[Path] = []
    skipped: list[str] = []
    for e in doc.modelspace():
        meta = dict(layer=e.dxf.get("layer", "0"), source=f"{e.dxftype()}#{e.dxf.handle}",
                    fill_rule="evenodd")
        try:
            paths += _entity_paths(e, k, tol_mm, meta, skipped)
        except GeometryError as exc:
            raise GeometryError(f"{name}: {exc}") from None
    if skipped and warn:
        kinds = Counter(s.split("#")[0] for s in skipped)
        listed = ", ".join(f"{n} {kind}" for kind, n in kinds.most_common())
        warnings.warn(f"{name}: skipped {len(skipped)} entities labkit does not cut ({listed}): "
                      f"{', '.join(skipped[:10])}{' …' if len(skipped) > 10 else ''}", stacklevel=2)
    if units is None and paths and warn:
        _check_extents(paths, k, name)
    if not arcs:                # exact arcs read at read_mm become chords within chords_mm
        paths = [p if not p.is_arc.any() else
                 p.with_geometry(p.sample(budget.chords_mm), deviation_mm=p.deviation_mm + budget.chords_mm)
                 for p in paths]
    return Drawing(paths, math.nan, math.nan, skipped, name)


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
