"""DXF drawings → Paths in millimetres, through ezdxf (seed 001 §6.1.1).

Entities read from model space (and from block references, which ezdxf
expands with their transforms): LINE, ARC, CIRCLE, ELLIPSE,
LWPOLYLINE and 2-D POLYLINE (with bulges), SPLINE. Units come from the
header variable ``$INSUNITS`` (inches, feet, mm, cm, m, µm; unitless is
taken as mm). The entity's layer becomes the Path's layer, so layers can be
given their own power and speed. Anything else (TEXT, HATCH, DIMENSION, 3-D
entities…) is skipped with a warning naming it.

Geometry: a polyline vertex's bulge b = tan(θ/4) gives the arc to the next
vertex — sweep θ = 4·atan(b), centre on the chord's perpendicular bisector
at (chord/2)·(1 − b²)/(2b) to the left. ELLIPSE has a major-axis vector and a
ratio; its parametric arc goes through
:func:`labkit.geometry.ellipse_arc_to_arcs`. SPLINE is flattened by ezdxf
within a share of the tolerance and refitted with arcs.
"""

from __future__ import annotations

import math
import os
import warnings

import numpy as np

from labkit.errors import GeometryError
from labkit.geometry.arcfit import FLATTEN_SHARE, fit_arcs
from labkit.geometry.ellipse import ellipse_arc_to_arcs
from labkit.geometry.path import Path
from labkit.vector.svg import Drawing

__all__ = ["read_dxf", "bulge_arc", "INSUNITS_MM"]

#: $INSUNITS code → millimetres per drawing unit (0 = unitless, taken as mm).
INSUNITS_MM = {0: 1.0, 1: 25.4, 2: 304.8, 4: 1.0, 5: 10.0, 6: 1000.0, 8: 25.4e-6, 9: 25.4e-3,
               10: 914.4, 13: 1e-3, 14: 100.0}


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


def _entity_paths(e, k, tol_mm, meta, skipped):
    kind = e.dxftype()
    if kind == "LINE":
        a, b = np.array(e.dxf.start)[:2] * k, np.array(e.dxf.end)[:2] * k
        return [Path([a, b], **meta)] if np.any(a != b) else []
    if kind == "CIRCLE":
        return [Path.circle(np.array(e.dxf.center)[:2] * k, e.dxf.radius * k, **meta)]
    if kind == "ARC":
        a0 = math.radians(e.dxf.start_angle)
        sweep = math.radians((e.dxf.end_angle - e.dxf.start_angle) % 360.0) or 2 * math.pi
        return [Path.arc(np.array(e.dxf.center)[:2] * k, e.dxf.radius * k, a0, sweep, **meta)]
    if kind == "ELLIPSE":
        major = np.array(e.dxf.major_axis)[:2] * k
        minor = e.dxf.ratio * np.array([-major[1], major[0]])
        if e.dxf.extrusion[2] < 0:         # seen from below: mirrored in x
            major, minor = major * [-1, 1], minor * [-1, 1]
        jac = np.column_stack([major, minor])
        t0, t1 = e.dxf.start_param, e.dxf.end_param
        dt = (t1 - t0) % (2 * math.pi) or 2 * math.pi
        centre = np.array(e.dxf.center)[:2] * k
        if e.dxf.extrusion[2] < 0:
            centre = centre * [-1, 1]
        return [ellipse_arc_to_arcs(centre, jac, t0, dt, tol_mm=tol_mm, **meta)]
    if kind == "LWPOLYLINE":
        pts = list(e.get_points("xyb"))
        if len(pts) < 2:
            return []
        arr = np.array(pts, float)
        p = _poly(arr[:, :2], arr[:, 2], bool(e.closed), meta, k)
        return [p] if p else []
    if kind == "POLYLINE":
        if e.is_3d_polyline or e.is_poly_face_mesh or e.is_polygon_mesh:
            skipped.append(f"{kind}(3D)#{e.dxf.handle}")
            return []
        verts = list(e.vertices)
        if len(verts) < 2:
            return []
        pts = np.array([v.dxf.location for v in verts], float)[:, :2]
        bul = np.array([v.dxf.bulge for v in verts], float)
        p = _poly(pts, bul, bool(e.is_closed), meta, k)
        return [p] if p else []
    if kind == "SPLINE":
        flat = FLATTEN_SHARE * tol_mm
        pts = np.array(list(e.construction_tool().flattening(flat / k)), float)[:, :2] * k
        closed = bool(e.closed) or (len(pts) > 2 and np.allclose(pts[0], pts[-1], atol=1e-9))
        return [fit_arcs(pts, tol_mm - flat, closed=closed, base_deviation_mm=flat, **meta)]
    if kind == "INSERT":
        out = []
        for sub in e.virtual_entities():
            sub_meta = dict(meta, layer=meta["layer"] if sub.dxf.layer == "0" else sub.dxf.layer)
            out += _entity_paths(sub, k, tol_mm, sub_meta, skipped)
        return out
    skipped.append(f"{kind}#{e.dxf.handle}")
    return []


def read_dxf(source, *, tol_mm=0.01, warn=True) -> Drawing:
    """Read a DXF file into Paths in mm (see the module docstring for entities and units).

    Parameters
    ----------
    source : str or path
        DXF file name.
    tol_mm : float
        Largest deviation of ellipses and splines from their arcs, mm.
    warn : bool
        Warn about skipped entities, naming each (type and handle).

    Returns
    -------
    Drawing
        One Path per entity, layer = DXF layer. Join them into chains with
        :func:`labkit.geometry.join_chains`.
    """
    import ezdxf

    if not tol_mm > 0:
        raise GeometryError(f"tol_mm must be > 0 mm, got {tol_mm!r}")
    name = os.fspath(source)
    if not os.path.exists(name):
        raise FileNotFoundError(f"DXF file not found: {name}")
    try:
        doc = ezdxf.readfile(name)
    except (ezdxf.DXFStructureError, OSError) as exc:
        raise GeometryError(f"{name}: not a readable DXF file ({exc})") from None
    code = int(doc.header.get("$INSUNITS", 0))
    if code not in INSUNITS_MM:
        raise GeometryError(f"{name}: $INSUNITS = {code} is not a length unit labkit knows "
                            f"(expected one of {sorted(INSUNITS_MM)})")
    k = INSUNITS_MM[code]
    paths: list[Path] = []
    skipped: list[str] = []
    for e in doc.modelspace():
        meta = dict(layer=e.dxf.layer, source=f"{e.dxftype()}#{e.dxf.handle}", fill_rule="evenodd")
        paths += _entity_paths(e, k, tol_mm, meta, skipped)
    if skipped and warn:
        warnings.warn(f"{name}: skipped {len(skipped)} DXF entities labkit does not cut: "
                      f"{', '.join(skipped)}", stacklevel=2)
    return Drawing(paths, math.nan, math.nan, skipped, name)
