"""SVG artwork → Paths in millimetres, through svgelements.

svgelements parses the file (paths with every command, shapes, ``use``,
nested transforms, viewBox, CSS units); labkit does the geometry. Each shape
is read *untransformed* (``reify=False``): its segments in its own frame plus
the full matrix that maps that frame to the page. The matrix then goes
through :mod:`labkit.geometry` exactly:

* lines and Bezier control points map exactly (Beziers are affine-invariant);
* an elliptical arc's image is an ellipse whose radii and rotation come from
  the SVD of the matrix's 2×2 part times the arc's own axes
  (:func:`labkit.geometry.transform.ellipse_image`), then circular arcs within
  the tolerance. svgelements' own ``reify()`` bakes arcs wrongly under skew or
  non-uniform scale with rotation (errors of millimetres) — it is not used.

Units: svgelements resolves lengths to user units (px at 96 per inch) and
folds the viewBox into each shape's matrix; labkit scales px → mm
(25.4/96; svgelements itself takes 1 mm as 3.7795296 px, 0.55 ppm more) and by default flips y so the drawing is upright on a machine
whose y axis points away from the operator (``flip_y``).

Only what a renderer draws is cut (checked against resvg in the tests):
``defs``, ``clipPath``, and, moved out of the way before svgelements sees them,
``symbol``/``marker``/``mask``/``pattern`` outside a reference, ``metadata`` and
Inkscape's ``flowRoot`` text frames; ``display:none`` and ``visibility:hidden``
(with CSS and inheritance, as svgelements resolves them); shapes with neither fill
nor stroke, or opacity 0; every ``switch`` child but the first. ``clip-path`` is applied
(:mod:`labkit.geometry.clip`): a shape is cut only inside its clip region, built from
the clipPath's shapes (and the outlines of the text it holds) in the referencing element's
user space or bounding box. A ``mask`` of opaque white shapes shows exactly their union and is
applied as that clip region; any other mask (black or grey content, strokes, opacity, its
own region) is not: every shape under one (its own or a group's) is named in a warning,
cut whole.

Text is cut as its glyph outlines, as a renderer draws it (:mod:`labkit.vector.text`: runs,
tspans, positions, anchors and the font named), each run on the layer of its own colour.
Bitmaps (``<image>``), flowed text frames and text on a path are not cut; they are named
once in a warning (``labkit job`` engraves the bitmaps: :mod:`labkit.vector.images`).
"""

from __future__ import annotations

import math
import os
import warnings
from dataclasses import dataclass, field

import numpy as np

from labkit._files import check_input_file
from labkit._jit import job_units
from labkit.errors import GeometryError, name_list
from labkit.geometry import transform as tf
from labkit.budget import budget, check_budget
from labkit.geometry.arcfit import (chain_fits, coordinate_limit_mm, cubics_to_arcs, sampling_share,
                                   tolerance_budget)
from labkit.geometry.bezier import cubic_samples, flatten_cubics, quad_to_cubic
from labkit.geometry.clip import clip_paths
from labkit.geometry.measure import path_distance
from labkit.geometry.offset import region
from labkit.geometry.ellipse import ellipse_arc_arrays
from labkit.geometry.path import Path
from labkit.vector._svg_scan import render_only, scan_svg

__all__ = ["Drawing", "read_svg", "svg_reference_samples", "PX_PER_INCH", "MM_PER_PX"]

PX_PER_INCH = 96.0
MM_PER_PX = 25.4 / PX_PER_INCH


@dataclass
class Drawing:
    """Paths read from a vector file.

    Attributes
    ----------
    paths : list of Path
        In document order, in mm.
    width_mm, height_mm : float
        Page size (NaN when the file gives none).
    skipped : list of str
        Elements that are not cut (bitmaps, flowed text frames, text on a path), named.
    invisible : list of str
        Shapes a renderer paints nothing for (no fill and no stroke, opacity 0, a fill
        of zero area), named; never cut.
    clipped : list of str
        Shapes cut only in part (or not at all) because a ``clip-path`` or the page
        clip hides the rest, named.
    source : str
        File name or ``"<string>"``.
    """

    paths: list[Path]
    width_mm: float = math.nan
    height_mm: float = math.nan
    skipped: list[str] = field(default_factory=list)
    source: str = "<string>"
    invisible: list[str] = field(default_factory=list)
    clipped: list[str] = field(default_factory=list)

    @property
    def layers(self) -> list[str]:
        """Layer names in first-seen order."""
        return list(dict.fromkeys(p.layer for p in self.paths))


def _load(source):
    import io

    import svgelements as se

    if isinstance(source, (bytes, bytearray)):
        data, name = bytes(source), "<bytes>"
    elif str(source).lstrip().startswith("<"):
        data, name = str(source).encode("utf-8"), "<string>"
    else:
        name = os.fspath(source)
        data = check_input_file(name, what="SVG file").read_bytes()
    scan = scan_svg(data, name)     # structure, cycles, depth, fan-out, non-finite numbers
    dropped: list[str] = []
    if scan.unrendered:             # svgelements draws symbols, markers, masks, text frames
        data, dropped = render_only(data)
    try:
        return se.SVG.parse(io.BytesIO(data), reify=False, ppi=PX_PER_INCH), name, dropped, scan
    except (ValueError, SyntaxError) as exc:       # svgelements: unresolvable units, bad XML
        raise GeometryError(f"{name}: cannot read this SVG ({exc})") from None
    except ArithmeticError as exc:                 # svgelements on degenerate numbers (an arc
        raise GeometryError(f"{name}: cannot read this SVG: a shape's numbers are degenerate "
                            f"({type(exc).__name__}: {exc})") from None   # radius that underflows)


def _page_matrix(doc, flip_y):
    h = float(doc.height) if doc.height is not None else 0.0
    if flip_y:
        return tf.matrix(MM_PER_PX, 0, 0, -MM_PER_PX, 0, h * MM_PER_PX)
    return tf.scale(MM_PER_PX)


def _element_matrix(el, page):
    m = el.transform
    return page @ tf.matrix(m.a, m.b, m.c, m.d, m.e, m.f)


def _colour(value):
    if value is None:
        return None
    try:
        if value.value is None or value.alpha == 0:
            return None
        return value.hex[:7]
    except AttributeError:
        return None


def _paints_area(p: Path, tol_mm: float) -> bool:
    """Whether a fill-only subpath covers any area: False when all of it lies within
    ``tol_mm`` of one straight line (a renderer fills nothing there)."""
    return _spans_area(p.sample(tol_mm), tol_mm)


def _spans_area(pts: np.ndarray, tol_mm: float) -> bool:
    centred = pts - pts.mean(axis=0)
    if len(pts) < 3 or not centred.any():
        return False
    minor = np.linalg.svd(centred, full_matrices=False)[2][-1]      # normal of the best line
    return float(np.abs(centred @ minor).max()) > tol_mm


def _closed(p: Path) -> Path:
    """``p`` with the straight closing side a renderer fills to."""
    return p.with_geometry(np.vstack([p.vertices, p.vertices[:1]]),
                           np.vstack([p.centres, [[np.nan, np.nan]]]), np.r_[p.sweeps, 0.0], closed=True)


def _opacity(el) -> float:
    try:
        return float(el.values.get("opacity", 1.0))
    except (TypeError, ValueError):
        return 1.0


def _name(el, index):
    ident = getattr(el, "id", None)
    return f"{type(el).__name__.lower()}#{ident}" if ident else f"{type(el).__name__.lower()}[{index}]"


class _Chain:
    """A curve chain waiting for the greedy fit: a :class:`_FitBatch` fits a drawing's chains
    together; until then it stands in the builder's lists for the lines and arcs it becomes
    (``fit``: vertices, centres, sweeps and deviation, :func:`chain_fits`)."""

    __slots__ = ("ctrl", "fit")

    def __init__(self, ctrl):
        self.ctrl, self.fit = ctrl, None

    @property
    def end(self):
        return self.ctrl[-1, 3]


class _FitBatch:
    """The curve chains of one drawing, fitted in one go (:func:`chain_fits`: one flattening
    and one fitting call for hundreds of chains) when the drawing has been read."""

    def __init__(self, tol_mm):
        self.tol, self.chains = tol_mm, []

    def add(self, ctrl) -> _Chain:
        chain = _Chain(ctrl)
        self.chains.append(chain)
        return chain

    def resolve(self):
        if self.chains:
            for chain, fit in zip(self.chains, chain_fits([c.ctrl for c in self.chains], self.tol)):
                chain.fit = fit
            self.chains = []


class _Subpath:
    """A subpath read with its chains still to fit: :meth:`path` after the batch is resolved."""

    __slots__ = ("v", "c", "s", "closed", "dev", "meta")

    def __init__(self, v, c, s, closed, dev, meta):
        self.v, self.c, self.s, self.closed, self.dev, self.meta = v, c, s, closed, dev, meta

    def path(self) -> Path | None:
        # a chain's fit joins as whole arrays (chains are most of a subpath), not row by row
        dev = max([self.dev] + [x.fit[3] for x in self.v if isinstance(x, _Chain)])
        v = np.concatenate([x.fit[0][1:] if isinstance(x, _Chain) else np.reshape(np.asarray(x, float), (1, 2))
                            for x in self.v])
        c = np.concatenate([x.fit[1] if isinstance(x, _Chain) else np.reshape(np.asarray(x, float), (1, 2))
                            for x in self.c])
        s = np.concatenate([x.fit[2] if isinstance(x, _Chain) else np.asarray([x], float) for x in self.s])
        return _subpath(v, c, s, self.closed, dev, self.meta)


def _subpath(v, c, s, closed, dev, meta) -> Path | None:
    """A subpath's vertices, centres and sweeps (lists or arrays) as a Path, closed if asked;
    None when it is a point or, closed, a line there and back."""
    if len(v) < 2:
        return None
    v = np.array(v)
    c, s = np.array(c, float).reshape(-1, 2), np.array(s, float).reshape(-1)
    if closed and not (abs(v[0, 0] - v[-1, 0]) <= 1e-9 and abs(v[0, 1] - v[-1, 1]) <= 1e-9):
        v = np.vstack([v, v[:1]])
        c = np.vstack([c, [[np.nan, np.nan]]])
        s = np.append(s, 0.0)
    elif closed:
        v[-1] = v[0]
    if len(v) == 2 and closed:
        return None
    return Path(v, c, s, closed=closed, deviation_mm=dev, **meta)


def _singular_values(jac) -> tuple[float, float]:
    """The 2 × 2 matrix's singular values (largest first) in closed form: half the sum and
    difference of the norms of its conformal and anticonformal parts (numpy's SVD costs
    ~25 µs a call, and a drawing has one call per elliptical arc)."""
    (a, b), (c, d) = jac.tolist()
    q, r = math.hypot(a + d, c - b), math.hypot(a - d, b + c)
    return 0.5 * (q + r), 0.5 * abs(q - r)


class _Builder:
    """Accumulates one subpath's segments as lines and arcs; with a ``batch``, its greedy fits
    wait there (:class:`_FitBatch`) and :meth:`finish` may give a :class:`_Subpath`."""

    def __init__(self, start, tol_mm, arcs, fit, meta, batch=None):
        self.v = [np.asarray(start, float)]
        self.c: list = []
        self.s: list = []
        self.cubics: list = []          # the pending curve chain: arrays (k, 4, 2)
        self.rows: list = []            # and its newest cubics as 8-float tuples (no numpy per segment)
        self.tol, self.arcs, self.fit, self.meta = tol_mm, arcs, fit, meta
        # the greedy fit takes straight lines and ellipse samples into the curve chain, so
        # collinear runs merge and gentle polylines become arcs
        self.chain_all = arcs and fit == "greedy"
        self.batch = batch if self.chain_all else None
        self.waiting = False            # a chain in v waits for the batch
        self.dev = 0.0

    def _last(self):
        """The last vertex (the end of a waiting chain)."""
        x = self.v[-1]
        return x.end if isinstance(x, _Chain) else x

    @property
    def here(self):
        if self.rows:
            return self.rows[-1][6:]
        return self.cubics[-1][-1, 3] if self.cubics else self._last()

    def _commit(self):
        if self.rows:
            self.cubics.append(np.array(self.rows).reshape(-1, 4, 2))
            self.rows = []

    def _flush(self):
        self._commit()
        if not self.cubics:
            return
        ctrl = np.concatenate(self.cubics)
        self.cubics = []
        start = self._last()
        if self.batch is not None:
            ctrl[0, 0] = start
            chain = self.batch.add(ctrl)
            self.v.append(chain)
            self.c.append(chain)
            self.s.append(chain)
            self.waiting = True
        elif self.arcs:
            p = cubics_to_arcs(ctrl, self.tol, start=start, method=self.fit)
            self._append(p)
        else:
            pts, counts = flatten_cubics(ctrl, self.tol)
            pts[-1] = ctrl[-1, 3]
            chords = Path(np.vstack([start[None], pts]))
            # measured, not assumed: eight samples per chord against the polyline
            dev = float(path_distance(chords, cubic_samples(ctrl, 8 * counts + 1)).max())
            for q in pts:
                self.line(q)
            self.dev = max(self.dev, dev)

    def _append(self, p: Path):
        self.v.extend(p.vertices[1:])
        self.c.extend(p.centres)
        self.s.extend(p.sweeps)
        self.dev = max(self.dev, p.deviation_mm)

    def _chords(self, pts):
        """Straight chords from here through ``pts[1:]`` (k + 1, 2; row 0 is overwritten with
        here), as cubics of the chain. Written out with few numpy calls: a drawing makes one
        call per elliptical arc, hundreds of calls of a few dozen points."""
        pts[0] = self.here
        self._commit()
        a = pts[:-1]
        d = pts[1:] - a
        keep = d.any(axis=1)
        if not keep.all():
            if not keep.any():
                return
            a, d = a[keep], d[keep]
        c = np.empty((len(a), 4, 2))
        c[:, 0] = a
        c[:, 1] = a + d / 3.0
        c[:, 2] = a + 2.0 * d / 3.0
        c[:, 3] = a + d
        self.cubics.append(c)

    def line(self, end):
        if self.chain_all:
            hx, hy = self.here
            ex, ey = float(end[0]), float(end[1])
            if ex != hx or ey != hy:
                dx, dy = ex - hx, ey - hy
                self.rows.append((hx, hy, hx + dx / 3.0, hy + dy / 3.0, hx + 2.0 * dx / 3.0,
                                  hy + 2.0 * dy / 3.0, ex, ey))
            return
        end = np.asarray(end, float)
        self._flush()
        if np.array_equal(end, self._last()):
            return
        self.v.append(end)
        self.c.append((np.nan, np.nan))
        self.s.append(0.0)

    def cubic(self, ctrl):
        (x0, y0), (x1, y1), (x2, y2), (x3, y3) = ctrl
        if x0 == x1 == x2 == x3 and y0 == y1 == y2 == y3:
            return
        if not self.rows and not self.cubics:
            x0, y0 = self._last()
        self.rows.append((float(x0), float(y0), float(x1), float(y1), float(x2), float(y2),
                          float(x3), float(y3)))

    def ellipse_arc(self, centre, jac, t0, dt, end):
        if dt == 0:
            return self.line(end)
        s0, s1 = _singular_values(jac)
        if self.chain_all and s1 < (1.0 - 1e-9) * s0:
            # a true ellipse joins the chain as samples whose chords stay within the
            # flattening share (a chord of the unit circle over dt/n misses it by
            # 1 − cos(dt/2n); the map stretches that by at most its largest singular value)
            flat, _ = sampling_share(self.tol)
            step = 2.0 * math.acos(max(1.0 - flat / s0, -1.0))
            n = max(2, math.ceil(abs(dt) / step)) if step > 0 else math.inf
            if not n <= budget("segments"):        # (the message only when it is needed)
                check_budget("segments", n, cause=f"an elliptical arc {s0:.3g} mm across at "
                             f"tolerance {self.tol:g} mm ({self.meta['source']})", option="--tol")
            t = t0 + dt * np.arange(1, n) / n
            ring = np.empty((n - 1, 2))
            ring[:, 0], ring[:, 1] = np.cos(t), np.sin(t)
            pts = np.empty((n + 1, 2))            # row 0: here, filled by _chords
            np.add(centre, ring @ jac.T, out=pts[1:n])
            pts[n] = end
            self._chords(pts)
            return
        self._flush()
        share = tolerance_budget(self.tol, arcs=self.arcs)
        v, c, sweep, dev, _ = ellipse_arc_arrays(centre, jac, t0, dt, None, share.read_mm, "midpoint")
        v[0], v[-1] = self._last(), end
        if not self.arcs:
            for q in Path(v, c, sweep).sample(share.chords_mm)[1:]:
                self.line(q)
            self.dev = max(self.dev, dev + share.chords_mm)
            return
        self.v.extend(v[1:])
        self.c.extend(c)
        self.s.extend(sweep)
        self.dev = max(self.dev, dev)

    def finish(self, closed) -> Path | _Subpath | None:
        if closed and self.chain_all and (self.cubics or self.rows):
            self.line(self.v[0])                   # the closing side joins the chain too
        self._flush()
        if self.waiting:
            return _Subpath(self.v, self.c, self.s, closed, self.dev, self.meta)
        return _subpath(self.v, self.c, self.s, closed, self.dev, self.meta)


def _shape_paths(el, m, tol_mm, arcs, fit, meta, batch=None) -> list[Path | _Subpath]:
    import svgelements as se

    out: list[Path] = []
    b: _Builder | None = None
    start = None
    a2 = m[:2, :2]
    (ma, mc, me), (mb, md, mf) = (float(q) for q in m[0]), (float(q) for q in m[1])

    lim = coordinate_limit_mm(tol_mm)

    def P(pt):                          # the element's matrix on one point (hot path: no numpy calls)
        x, y = pt.x, pt.y
        x, y = ma * x + mc * y + me, mb * x + md * y + mf
        if not (-lim < x < lim and -lim < y < lim):         # NaN fails too
            raise GeometryError(f"{meta['source']}: a point at ({x:.6g}, {y:.6g}) mm lies beyond "
                                f"{lim:.3g} mm, where double precision no longer resolves the "
                                f"tolerance of {tol_mm:g} mm")
        return (x, y)

    for seg in el.segments(transformed=False):
        if isinstance(seg, se.Move):
            if b is not None:
                p = b.finish(False)
                if p is not None:
                    out.append(p)
            start = P(seg.end)
            b = _Builder(start, tol_mm, arcs, fit, meta, batch)
            continue
        if b is None:             # a path that does not start with M (svgelements allows it)
            start = P(seg.start)
            b = _Builder(start, tol_mm, arcs, fit, meta, batch)
        if isinstance(seg, se.Close):
            p = b.finish(True)
            if p is not None:
                out.append(p)
            b = _Builder(start, tol_mm, arcs, fit, meta, batch)
        elif isinstance(seg, se.Line):
            b.line(P(seg.end))
        elif isinstance(seg, se.CubicBezier):
            b.cubic((P(seg.start), P(seg.control1), P(seg.control2), P(seg.end)))
        elif isinstance(seg, se.QuadraticBezier):
            # quad_to_cubic's degree elevation in floats (the same operations, no arrays per segment)
            (sx, sy), (qx, qy), (ex, ey) = P(seg.start), P(seg.control), P(seg.end)
            b.cubic(((sx, sy), ((sx + 2 * qx) / 3, (sy + 2 * qy) / 3),
                     ((ex + 2 * qx) / 3, (ey + 2 * qy) / 3), (ex, ey)))
        elif isinstance(seg, se.Arc):
            rx, ry = seg.rx, seg.ry           # (svgelements measures them from points on each read)
            if rx == 0 or ry == 0:
                b.line(P(seg.end))
                continue
            rot = seg.get_rotation()
            rot = float(rot.as_radians) if hasattr(rot, "as_radians") else float(rot)
            cr, sr = math.cos(rot), math.sin(rot)
            jac = a2 @ np.array([[cr, -sr], [sr, cr]]) @ np.array([[rx, 0.0], [0.0, ry]])
            b.ellipse_arc(np.array(P(seg.center)), jac, float(seg.get_start_t()), float(seg.sweep), P(seg.end))
        else:  # pragma: no cover - svgelements has no other segment kinds
            raise GeometryError(f"unknown SVG segment {type(seg).__name__} in {meta['source']}")
    if b is not None:
        p = b.finish(False)
        if p is not None:
            out.append(p)
    return out


def _glyph_paths(verts, codes, tol_mm, arcs, fit, meta) -> list[Path]:
    """Closed Paths of placed glyph outlines (matplotlib path vertices and codes, mm), through
    the builder every SVG curve goes through (lines, arcs fitted to the glyphs' Beziers)."""
    from matplotlib.path import Path as MplPath

    lim = coordinate_limit_mm(tol_mm)
    if not (np.isfinite(verts).all() and np.abs(verts).max() < lim):
        raise GeometryError(f"{meta['source']}: text placed beyond {lim:.3g} mm, where double precision "
                            f"no longer resolves the tolerance of {tol_mm:g} mm")
    out: list[Path] = []
    b, i = None, 0
    while i < len(codes):
        c = codes[i]
        if c == MplPath.MOVETO:
            if b is not None:
                p = b.finish(True)
                if p is not None:
                    out.append(p)
            b, i = _Builder(verts[i], tol_mm, arcs, fit, meta), i + 1
        elif c == MplPath.LINETO:
            b.line(verts[i])
            i += 1
        elif c == MplPath.CURVE3:
            b.cubic(quad_to_cubic(b.here, verts[i], verts[i + 1]))
            i += 2
        elif c == MplPath.CURVE4:
            b.cubic(np.array([b.here, verts[i], verts[i + 1], verts[i + 2]]))
            i += 3
        else:                                  # CLOSEPOLY (its vertex is ignored)
            if b is not None:
                p = b.finish(True)
                if p is not None:
                    out.append(p)
            b, i = None, i + 1
    if b is not None:
        p = b.finish(True)
        if p is not None:
            out.append(p)
    return out


def _text_paths(runs, matrix_of, tol_mm, arcs, fit, source, label, meta_of) -> list[tuple[object, list[Path]]]:
    """Per run of one ``<text>``: its glyphs as closed Paths (see :mod:`labkit.vector.text`)."""
    from labkit.vector.text import glyph_outlines

    return [(run, _glyph_paths(v, c, tol_mm, arcs, fit, meta_of(run)))
            for run, v, c in glyph_outlines(runs, matrix_of, source=source, label=label)]


def _clip_id(el) -> str | None:
    """The id a ``clip-path="url(#id)"`` names (clip-path is not inherited), else None."""
    value = el.values.get("clip-path")
    if not value or value == "none":
        return None
    value = str(value).strip()
    if value.startswith("url(") and value.endswith(")"):
        value = value[4:-1].strip().strip("'\"")
    return value[1:] if value.startswith("#") else value


class _Clips:
    """Clip regions (shapely, page mm) of every shape under a ``clip-path``.

    A ``clipPath``'s contents are drawn in the user space of the element that references
    it (``clipPathUnits="userSpaceOnUse"``, that element's transform included) or in its
    bounding box (``objectBoundingBox``), through the clipPath's own transform — not in
    the frame where it is defined. svgelements folds the definition's context into the
    clip contents' matrices; the scan's record of each clipPath's own transform takes it
    back out. Nested clips (a clipped shape in a clipped group) intersect.
    """

    def __init__(self, doc, scan, page, tol_mm, fit, name="<string>"):
        import svgelements as se

        self.doc, self.own, self.page, self.fit = doc, scan.clip_transforms or {}, page, fit
        self.doc_name = name
        self.sample_tol = 0.2 * tol_mm
        self.chains: dict[int, tuple] = {}
        self.cache: dict[tuple, object] = {}
        self.unsupported: list[str] = []
        if not self.own and not any(_clip_id(el) for el in doc.elements()):
            return
        stack = [(iter(doc), ())]
        while stack:                                  # iterative: nesting may be deep
            children, chain = stack[-1]
            el = next(children, None)
            if el is None:
                stack.pop()
                continue
            ident = _clip_id(el)
            own = chain + ((el, ident),) if ident else chain
            if own:
                self.chains[id(el)] = own
            if isinstance(el, (se.Group, se.Use)):
                stack.append((iter(el), own))

    def region(self, el, label):
        """The region that clips ``el``, or None when nothing clips it."""
        import shapely

        chain = self.chains.get(id(el))
        if not chain:
            return None
        out = None
        for ref, ident in chain:
            key = (id(ref), ident)
            if key not in self.cache:
                self.cache[key] = self._build(ref, ident, label)
            reg = self.cache[key]
            if reg is not None:
                out = reg if out is None else shapely.intersection(out, reg)
        return out

    def _matrix(self, text):
        import svgelements as se

        m = se.Matrix(text) if text else se.Matrix()
        return tf.matrix(m.a, m.b, m.c, m.d, m.e, m.f)

    def _build(self, ref, ident, label):
        import shapely
        import svgelements as se

        clip = self.doc.get_element_by_id(ident)
        if not isinstance(clip, se.ClipPath):
            self.unsupported.append(f"{label} (clip-path #{ident} is not a clipPath)")
            return None
        acc = self._matrix(clip.values.get("transform", ""))       # context @ own
        user = _element_matrix(ref, self.page) @ self._matrix(self.own.get(ident, "")) @ np.linalg.inv(acc)
        if clip.values.get("clipPathUnits") == "objectBoundingBox":
            box = _own_bbox(ref)
            if box is None:
                return shapely.Polygon()              # no box: nothing is drawn
            (x0, y0), (x1, y1) = box
            user = (_element_matrix(ref, self.page) @ tf.matrix(x1 - x0, 0, 0, y1 - y0, x0, y0)
                    @ self._matrix(self.own.get(ident, "")) @ np.linalg.inv(acc))
        parts = []
        texts: dict[str, list] = {}
        stack = [iter(clip)]
        while stack:
            child = next(stack[-1], None)
            if child is None:
                stack.pop()
                continue
            if isinstance(child, (se.Group, se.Use)):
                stack.append(iter(child))
                continue
            if (child.values.get("display") == "none"
                    or child.values.get("visibility") in ("hidden", "collapse")):
                continue
            if isinstance(child, (se.SVGText, se.Text)):        # a text's runs, its own last
                from labkit.vector.text import run_key

                key, _, is_text = run_key(child)
                texts.setdefault(key, []).append(child)
                if is_text:
                    meta = dict(layer="clip", fill_rule="nonzero", source=f"clipPath#{ident}")
                    runs = _text_paths(texts.pop(key), lambda r: user @ _element_matrix(r, np.eye(3)),
                                       self.sample_tol, False, self.fit, self.doc_name, f"text in clipPath#{ident}",
                                       lambda r: meta)
                    rings = [p for _, ps in runs for p in ps if len(p.vertices) > 2]
                    if rings:
                        parts.append(region(rings, tol_mm=self.sample_tol, fill_rule="nonzero"))
                continue
            if not isinstance(child, se.Shape):
                self.unsupported.append(f"{label} (clip-path #{ident} holds {type(child).__name__.lower()})")
                continue
            rule = "evenodd" if str(child.values.get("clip-rule", "nonzero")).strip() == "evenodd" \
                else "nonzero"
            meta = dict(layer="clip", fill_rule=rule, source=f"clipPath#{ident}")
            m = user @ _element_matrix(child, np.eye(3))
            subpaths = _shape_paths(child, m, self.sample_tol, False, self.fit, meta)
            rings = [p if p.closed else _closed(p) for p in subpaths if len(p.vertices) > 2]
            if rings:
                parts.append(region(rings, tol_mm=self.sample_tol, fill_rule=rule))
        return shapely.union_all(parts) if parts else shapely.Polygon()


def _own_bbox(el):
    """Bounding box of ``el`` in its own user space ((x0, y0), (x1, y1)), or None."""
    import svgelements as se

    if isinstance(el, se.Shape):
        box = el.bbox(transformed=False)
        return None if box is None else ((box[0], box[1]), (box[2], box[3]))
    inv = np.linalg.inv(_element_matrix(el, np.eye(3)))
    corners = []
    for sub in el.select():
        if isinstance(sub, se.Shape) and sub is not el:
            box = sub.bbox(transformed=True)
            if box is not None:
                corners += [(box[0], box[1]), (box[2], box[1]), (box[0], box[3]), (box[2], box[3])]
    if not corners:
        return None
    pts = tf.apply(inv, np.array(corners, float))
    return tuple(pts.min(axis=0)), tuple(pts.max(axis=0))


def _iter_shapes(doc):
    import svgelements as se

    for index, el in enumerate(doc.elements()):
        if isinstance(el, (se.SVGText, se.Text)):
            yield index, el, "text"
        elif isinstance(el, (se.SVGImage, se.Image)):
            yield index, el, "image"
        elif isinstance(el, se.Shape):
            if el.values.get("visibility") in ("hidden", "collapse") or el.values.get("display") == "none":
                continue
            yield index, el, "shape"


def read_svg(source, *, tol_mm=0.01, arcs=True, fit="greedy", flip_y=True, warn=True,
             clip_to_page=False) -> Drawing:
    """Read an SVG file (or SVG text) into Paths in mm.

    Parameters
    ----------
    source : str, path or bytes
        File name, or the SVG document itself (text starting with ``<``).
    tol_mm : float
        Largest distance of any output path from the true curve, mm.
    arcs : bool
        Keep circular arcs (G2/G3) and fit arcs to Beziers; False gives
        straight segments only (for controllers without arcs).
    fit : {"greedy", "biarc"}
        How curves become arcs (:mod:`labkit.geometry.arcfit`): ``"greedy"``
        (fewest blocks; straight runs and true ellipses join the curve so
        collinear lines merge) or ``"biarc"`` (tangent-continuous). Circles
        and circular arcs stay exact either way.
    flip_y : bool
        Mirror y so the drawing's top is at +y (SVG's y points down).
    warn : bool
        Issue a :class:`UserWarning` naming skipped bitmaps and text frames, shapes a
        clip-path could not be applied to, and shapes that reach outside the page.
    clip_to_page : bool
        Cut only what lies on the page (the document's width × height), as a
        renderer shows it. Otherwise shapes beyond the page are kept whole and
        named in a warning that says how far and how much lies outside.

    Returns
    -------
    Drawing
        Paths in document order; each keeps its stroke and fill colour, its
        layer (the stroke colour, else the fill colour), its fill rule and
        its source element (``path#id`` or ``rect[12]``).

    Examples
    --------
    >>> svg = '''<svg xmlns="http://www.w3.org/2000/svg" width="40mm" height="20mm"
    ...   viewBox="0 0 40 20"><circle cx="10" cy="10" r="5" stroke="red" fill="none"/>
    ...   <rect x="20" y="5" width="10" height="10" stroke="#0000ff" fill="none"/></svg>'''
    >>> d = read_svg(svg)
    >>> [(p.layer, p.closed, p.n_segments, int(p.is_arc.sum())) for p in d.paths]
    [('#ff0000', True, 4, 4), ('#0000ff', True, 4, 0)]
    >>> d.paths[0].bounds().round(9).tolist(), round(d.height_mm, 9)
    ([[5.0, 5.0], [15.0, 15.0]], 20.0)
    """
    if not tol_mm > 0:
        raise GeometryError(f"tol_mm must be > 0 mm, got {tol_mm!r}")
    doc, name, dropped, scan = _load(source)
    page = _page_matrix(doc, flip_y)
    clips = _Clips(doc, scan, page, tol_mm, fit, name)
    paths: list[Path] = []
    skipped: list[str] = list(dropped)
    invisible: list[str] = []
    clipped: list[str] = []
    masked: list[str] = []
    texts: dict[str, list] = {}            # a text's runs until the text itself (the last) arrives

    def meta_of(el, label):
        stroke, fill = _colour(el.stroke), _colour(el.fill)
        rule = str(el.values.get("fill-rule", "nonzero")).strip().lower()
        return dict(layer=stroke or fill or "none", stroke=stroke, fill=fill,
                    fill_rule="evenodd" if rule == "evenodd" else "nonzero", source=label)

    def add(el, label, new):
        """A shape's (or a text run's) paths as a renderer paints them: visible, clipped."""
        if _colour(el.stroke) is None:  # fill only: a zero-area subpath paints nothing, and
            kept = [p for p in new if _paints_area(p, tol_mm)]   # the outline of what it paints
            if len(kept) < len(new) and label not in invisible:   # is closed (SVG fills an open
                invisible.append(label)                           # subpath as if closed)
            new = [p if p.closed else _closed(p) for p in kept]
        for p in new:
            if not (np.isfinite(p.vertices).all() and np.isfinite(p.sweeps).all()):
                raise GeometryError(f"{name}: {label} maps to coordinates that are not finite "
                                    f"numbers (a transform or size beyond double range)")
        if new and str(el.values.get("mask") or "none").strip() != "none":   # svgelements
            masked.append(label)                          # hands a group's mask to its shapes
        reg = clips.region(el, label)
        if reg is not None and new:
            cut = clip_paths(new, reg, tol_mm=tol_mm, arcs=arcs)
            if cut.clipped and label not in clipped:
                clipped.append(label)
            new = cut.paths
        paths.extend(new)

    def visible(el, label) -> bool:
        if (_colour(el.stroke) is None and _colour(el.fill) is None) or _opacity(el) == 0:
            steps.append((None, label, None))         # a renderer paints nothing here
            return False
        return True

    # The greedy fits of every shape wait in one batch (one flattening and one fitting call
    # for the whole drawing); what is done with each shape's paths is kept in order until then.
    batch = _FitBatch(tol_mm) if arcs and fit == "greedy" else None
    steps: list[tuple] = []                   # (element, label, paths), or (None, label, None): invisible
    for index, el, kind in job_units(list(_iter_shapes(doc))):   # Python or compiled: _jit's rule
        label = _name(el, index)
        if kind == "image":
            skipped.append(label)
            continue
        if kind == "text":
            from labkit.vector.text import run_key

            key, _, is_text = run_key(el)
            texts.setdefault(key, []).append(el)
            if not is_text:
                continue
            runs = texts.pop(key)
            try:
                drawn = _text_paths(runs, lambda r: _element_matrix(r, page), tol_mm, arcs, fit, name, label,
                                    lambda r: meta_of(r, label))
            except ArithmeticError as exc:
                raise GeometryError(f"{name}: {label} has degenerate numbers "
                                    f"({type(exc).__name__}: {exc})") from None
            for run, new in drawn:             # a hidden run still takes its place on the line
                if run.values.get("visibility") not in ("hidden", "collapse") and visible(run, label):
                    steps.append((run, label, new))
            continue
        if not visible(el, label):
            continue
        m = _element_matrix(el, page)
        try:
            new = _shape_paths(el, m, tol_mm, arcs, fit, meta_of(el, label), batch)
        except GeometryError:
            raise
        except ValueError as exc:                  # svgelements resolves some units lazily
            raise GeometryError(f"{name}: cannot read this SVG ({exc}) at {label}") from None
        except ArithmeticError as exc:
            raise GeometryError(f"{name}: {label} has degenerate numbers "
                                f"({type(exc).__name__}: {exc})") from None
        steps.append((el, label, new))
    if batch is not None:
        batch.resolve()
    for el, label, new in steps:
        if el is None:
            if label not in invisible:
                invisible.append(label)
            continue
        made = [p.path() if isinstance(p, _Subpath) else p for p in new]
        add(el, label, [p for p in made if p is not None])
    notes = [  # (the shapes a note is about, what it says of them): each said once when there are any
        (skipped, f"not cut: {len(skipped)} element(s) that are not vector shapes: {', '.join(skipped)} — "
                  f"engrave bitmaps with svg2gcode --images MODE or labkit job (a layer with operation \"image\" "
                  f"on this SVG); convert flowed text and text on a path to paths in the drawing program "
                  f"(Inkscape: Path › Object to Path)"),
        (invisible, f"skipped {len(invisible)} shape(s) a renderer paints nothing for (no fill and no stroke, "
                    f"opacity 0, or a fill of zero area): {name_list(invisible)}"),
        (clips.unsupported, f"clip-path is not applied where its clipPath holds what is neither a shape nor "
                            f"text, or is missing; {len(clips.unsupported)} shape(s) are cut whole where a "
                            f"renderer shows only their clipped part: {name_list(clips.unsupported)} — clip "
                            f"them in the drawing program (Inkscape: Path › Intersection)"),
        (masked, f"mask is not applied; {len(masked)} shape(s) under a mask are cut whole where a renderer "
                 f"shows only what the mask lets through: {name_list(masked)} — apply the mask in the "
                 f"drawing program (Inkscape: Object › Mask › Release, then Path › Intersection)")]
    for shapes, said in notes if warn else ():
        if shapes:
            warnings.warn(f"{name}: {said}", stacklevel=2)
    width = float(doc.width) * MM_PER_PX if doc.width is not None else math.nan
    height = float(doc.height) * MM_PER_PX if doc.height is not None else math.nan
    if paths and width > 0 and height > 0:
        paths = _page_check(paths, width, height, name, tol_mm, arcs, clip_to_page, warn, clipped)
    return Drawing(paths, width, height, skipped, name, invisible, clipped)


def _page_check(paths, width, height, name, tol_mm, arcs, clip_to_page, warn, clipped):
    """Shapes reaching beyond the page (a renderer does not show that part): clipped to
    it, or named in a warning with how far and how much lies outside."""
    from labkit.geometry.clip import rectangle_region
    from labkit.geometry.path import bounds_each

    if not (warn or clip_to_page):     # the paths come back as they are: nothing to find
        return paths
    lo, hi = np.array([0.0, 0.0]), np.array([width, height])
    boxes = bounds_each(paths)
    beyond = np.maximum(np.maximum((lo - boxes[:, 0]).max(axis=1), (boxes[:, 1] - hi).max(axis=1)), 0.0)
    out = np.flatnonzero(beyond > tol_mm)
    if not len(out):
        return paths
    page = rectangle_region(0.0, 0.0, width, height)
    pieces = {i: clip_paths([paths[i]], page, tol_mm=tol_mm, arcs=arcs) for i in out}
    names = list(dict.fromkeys(s for r in pieces.values() for s in r.clipped))
    if not names:                       # the bounds of an arc reach out, the arc does not
        return paths
    if clip_to_page:
        clipped.extend(s for s in names if s not in clipped)
        return [q for i, p in enumerate(paths) for q in (pieces[i].paths if i in pieces else [p])]
    removed = sum(r.removed_mm for r in pieces.values())
    if warn:
        warnings.warn(f"{name}: {len(names)} shape(s) reach outside the {width:g} × {height:g} mm "
                      f"page, up to {beyond.max():.3g} mm beyond its edge ({removed:.1f} mm of "
                      f"path outside, which a renderer does not show): {name_list(names)}"
                      f" — they are cut whole; clip_to_page=True "
                      f"(--clip-to-page) cuts only what lies on the page", stacklevel=3)
    return paths


def svg_reference_samples(source, *, per_segment=2000, flip_y=True,
                          tol_mm=0.01) -> dict[str, list[np.ndarray]]:
    """Dense true samples of every shape, for checking conversions.

    Each segment is sampled by svgelements (``npoint``) in the element's own
    frame and mapped to mm by the element's exact matrix (a fill-only subpath is
    closed, as a renderer fills it, and one within ``tol_mm`` of a straight line — zero
    area, as :func:`read_svg` judges it at the same tolerance — left out) — the independent
    reference the tests and the benchmark measure Hausdorff distances against.

    Returns
    -------
    dict
        Element label (as in ``Path.source``) → list of polylines (k, 2) in mm,
        one per subpath.
    """
    import svgelements as se

    doc, _, _, _ = _load(source)
    page = _page_matrix(doc, flip_y)
    out: dict[str, list[np.ndarray]] = {}
    t = np.linspace(0.0, 1.0, per_segment)
    for index, el, kind in _iter_shapes(doc):
        if kind != "shape":
            continue
        m = _element_matrix(el, page)
        polys, cur = [], []
        for seg in el.segments(transformed=False):
            if isinstance(seg, se.Move):
                if len(cur) > 1:
                    polys.append(np.vstack(cur))
                cur = [tf.apply(m, [[seg.end.x, seg.end.y]])]
                continue
            if seg.start is None or seg.end is None:
                continue
            if isinstance(seg, se.Close):
                pts = np.array([[seg.start.x, seg.start.y], [seg.end.x, seg.end.y]])
            elif isinstance(seg, se.Line):
                pts = np.array([[seg.start.x, seg.start.y], [seg.end.x, seg.end.y]])
            else:
                pts = np.asarray(seg.npoint(t), dtype=float)
            cur.append(tf.apply(m, pts))
        if len(cur) > 1:
            polys.append(np.vstack(cur))
        if _colour(el.stroke) is None and _colour(el.fill) is not None:   # filled as if closed;
            polys = [q if np.array_equal(q[0], q[-1]) else np.vstack([q, q[:1]])  # zero area:
                     for q in polys if _spans_area(q, tol_mm)]                     # nothing drawn
        if polys:
            out[_name(el, index)] = polys
    return out
