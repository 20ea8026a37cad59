"""The Path model: one chain of line and circular-arc segments in millimetres.

A :class:`Path` holds numpy columns, one row per segment:

===========  =============  ==================================================
column       shape          meaning
===========  =============  ==================================================
vertices     (n + 1, 2)     segment end points in order, mm (segment i runs
                            from ``vertices[i]`` to ``vertices[i + 1]``)
centres      (n, 2)         arc centre in mm; NaN for straight segments
sweeps       (n,)           signed arc sweep, rad (CCW > 0, CW < 0); 0 for lines
===========  =============  ==================================================

A closed path ends where it starts. An arc never sweeps a full turn (a circle
is two arcs), so an arc's end differs from its start. Everything that came
from a curve carries ``deviation_mm``: the largest distance, measured by the
converter, between this path and the curve it stands for.

The attributes ``layer``, ``stroke``, ``fill`` and ``fill_rule`` travel with
the geometry so that per-layer power and speed ([DobotLaser]'s settings per
operation) and fill rules survive import, ordering and offsetting.
"""

from __future__ import annotations

import math
from typing import Iterable, Sequence

import numpy as np

from labkit.errors import GeometryError
from labkit.geometry.circle import chord_segments
from labkit.geometry import transform as _tf

__all__ = ["Path", "total_length", "paths_bounds", "bounds_each", "sample_each", "count_segments", "max_deviation", "check_paths"]

_META = ("layer", "stroke", "fill", "fill_rule", "source")


class Path:
    """A chain of lines and circular arcs in mm (see the module docstring).

    Parameters
    ----------
    vertices : array_like, shape (n + 1, 2)
        Segment end points, mm.
    centres : array_like, shape (n, 2), optional
        Arc centres (NaN rows are lines). Default: all lines.
    sweeps : array_like, shape (n,), optional
        Signed arc sweeps in rad (0 for lines). Required where a centre is given.
    closed : bool
        The path is a loop. If the last vertex differs from the first, a
        closing line is added.
    layer : str
        Layer name (an SVG colour such as ``"#ff0000"`` or a DXF layer).
    stroke, fill : str or None
        Colours as ``#rrggbb`` (None = none).
    fill_rule : {"evenodd", "nonzero"}
        How :func:`labkit.geometry.hatch` decides the inside.
    source : str
        Where the path came from (element id, DXF handle…), for messages.
    deviation_mm : float
        Largest measured distance from the curve this path approximates.

    Examples
    --------
    >>> p = Path.rectangle(0, 0, 20, 10)
    >>> p.closed, p.n_segments, p.length_mm
    (True, 4, 60.0)
    >>> c = Path.circle((0, 0), 5)
    >>> c.n_segments, round(c.length_mm, 6), c.bounds().tolist()
    (2, 31.415927, [[-5.0, -5.0], [5.0, 5.0]])
    """

    __slots__ = ("vertices", "centres", "sweeps", "closed", "deviation_mm") + _META

    def __init__(self, vertices, centres=None, sweeps=None, *, closed=False, layer="0",
                 stroke=None, fill=None, fill_rule="evenodd", source="", deviation_mm=0.0):
        v = np.array(vertices, dtype=float).reshape(-1, 2)
        if len(v) < 2:
            raise GeometryError(f"a path needs at least 2 vertices, got {len(v)} (source {source!r})")
        n = len(v) - 1
        if centres is None:
            c = np.full((n, 2), np.nan)
            s = np.zeros(n)
        else:
            c = np.array(centres, dtype=float).reshape(-1, 2)
            s = np.zeros(n) if sweeps is None else np.array(sweeps, dtype=float).reshape(-1)
            if c.shape != (n, 2) or s.shape != (n,):
                raise GeometryError(f"centres must be ({n}, 2) and sweeps ({n},) for {n + 1} vertices, "
                                    f"got {c.shape} and {s.shape}")
        line = np.isnan(c[:, 0]) | (s == 0)
        c[line] = np.nan
        s[line] = 0.0
        if np.any(np.abs(s) >= 2 * math.pi - 1e-12):
            raise GeometryError("an arc segment must sweep less than a full turn; split circles in two")
        if closed and not (abs(v[0, 0] - v[-1, 0]) <= 1e-9 and abs(v[0, 1] - v[-1, 1]) <= 1e-9):
            v = np.vstack([v, v[:1]])
            c = np.vstack([c, [[np.nan, np.nan]]])
            s = np.append(s, 0.0)
        if fill_rule not in ("evenodd", "nonzero"):
            raise GeometryError(f"fill_rule must be 'evenodd' or 'nonzero', got {fill_rule!r}")
        self.vertices, self.centres, self.sweeps = v, c, s
        self.closed = bool(closed)
        self.layer, self.stroke, self.fill, self.fill_rule, self.source = (
            str(layer), stroke, fill, fill_rule, source)
        self.deviation_mm = float(deviation_mm)

    # -- construction -----------------------------------------------------------------

    @classmethod
    def polyline(cls, points, *, closed=False, **meta) -> "Path":
        """Straight segments through ``points`` (mm)."""
        return cls(points, closed=closed, **meta)

    @classmethod
    def rectangle(cls, x, y, width, height, **meta) -> "Path":
        """Closed axis-aligned rectangle with a corner at (x, y), mm."""
        pts = [(x, y), (x + width, y), (x + width, y + height), (x, y + height), (x, y)]
        return cls(pts, closed=True, **meta)

    @classmethod
    def arc(cls, centre, radius, start_rad, sweep_rad, **meta) -> "Path":
        """One arc (split in two when it sweeps a full turn or more)."""
        if not radius > 0:
            raise GeometryError(f"arc radius must be > 0 mm, got {radius!r}")
        if sweep_rad == 0:
            raise GeometryError("arc sweep must be non-zero")
        k = 1 if abs(sweep_rad) < 2 * math.pi - 1e-12 else 2
        ang = start_rad + sweep_rad * np.linspace(0, 1, k + 1)
        c = np.asarray(centre, dtype=float)
        v = c + radius * np.stack([np.cos(ang), np.sin(ang)], axis=1)
        closed = abs(abs(sweep_rad) - 2 * math.pi) < 1e-12
        if closed:
            v[-1] = v[0]
        return cls(v, np.tile(c, (k, 1)), np.full(k, sweep_rad / k), closed=closed, **meta)

    @classmethod
    def circle(cls, centre, radius, *, ccw=True, **meta) -> "Path":
        """Closed circle as two half-circle arcs, starting at angle 0."""
        return cls.arc(centre, radius, 0.0, 2 * math.pi if ccw else -2 * math.pi, **meta)

    def _meta(self) -> dict:
        return {k: getattr(self, k) for k in _META}

    def with_geometry(self, vertices, centres=None, sweeps=None, *, closed=None,
                      deviation_mm=None) -> "Path":
        """A new path with other geometry and the same layer, colours and source."""
        return Path(vertices, centres, sweeps, closed=self.closed if closed is None else closed,
                    deviation_mm=self.deviation_mm if deviation_mm is None else deviation_mm,
                    **self._meta())

    def copy(self) -> "Path":
        return self.with_geometry(self.vertices.copy(), self.centres.copy(), self.sweeps.copy())

    # -- queries ----------------------------------------------------------------------

    @property
    def n_segments(self) -> int:
        return len(self.sweeps)

    @property
    def is_arc(self) -> np.ndarray:
        """Mask of arc segments."""
        return self.sweeps != 0

    @property
    def start(self) -> np.ndarray:
        return self.vertices[0]

    @property
    def end(self) -> np.ndarray:
        return self.vertices[-1]

    def radii_mm(self) -> np.ndarray:
        """Arc radius per segment in mm (NaN for lines)."""
        return np.hypot(*(self.vertices[:-1] - self.centres).T)

    def lengths_mm(self) -> np.ndarray:
        """Length of each segment, mm (arcs along the arc)."""
        chord = np.hypot(*np.diff(self.vertices, axis=0).T)
        arc = self.is_arc
        chord[arc] = np.abs(self.sweeps[arc]) * self.radii_mm()[arc]
        return chord

    @property
    def length_mm(self) -> float:
        """Total length in mm."""
        return float(self.lengths_mm().sum())

    def bounds(self) -> np.ndarray:
        """``[[xmin, ymin], [xmax, ymax]]`` in mm, arcs included exactly (the vertices and every
        axis crossing an arc sweeps: :func:`labkit.geometry.circle.arc_bounds`' numbers)."""
        v = self.vertices
        arc = np.flatnonzero(self.sweeps != 0)
        if len(arc):
            v = np.vstack([v, _axis_crossings(v[arc], self.centres[arc], self.sweeps[arc])[0]])
        return np.array([v.min(axis=0), v.max(axis=0)])

    def signed_area_mm2(self) -> float:
        """Signed area of a closed path, mm² (CCW > 0), arcs' circular segments included."""
        v = self.vertices
        area = 0.5 * float(np.sum(v[:-1, 0] * v[1:, 1] - v[1:, 0] * v[:-1, 1]))
        arc = self.is_arc
        if arc.any():
            r = self.radii_mm()[arc]
            s = self.sweeps[arc]
            area += float(np.sum(0.5 * r * r * (s - np.sin(s))))
        return area

    def sample(self, tol_mm=0.01) -> np.ndarray:
        """A polyline (k, 2) through the path whose chords stay within ``tol_mm`` of the arcs."""
        if not tol_mm > 0:
            raise GeometryError(f"tol_mm must be > 0 mm, got {tol_mm!r}")
        v, sw = self.vertices, self.sweeps
        arc = sw != 0
        if not arc.any():
            return v.copy()
        # chords per segment (1 for a line), then every sample in one vectorised pass
        counts = np.ones(len(sw), np.int64)
        r = np.hypot(*(v[:-1][arc] - self.centres[arc]).T)
        counts[arc] = chord_segments(r, sw[arc], tol_mm)
        seg = np.repeat(np.arange(len(sw)), counts)
        first = np.cumsum(counts) - counts
        k = np.arange(len(seg)) - first[seg] + 1            # 1 … n within each segment
        frac = k / counts[seg]
        out = v[seg + 1].copy()                               # segment ends (lines: exact)
        inner = arc[seg] & (k < counts[seg])
        if inner.any():
            i = seg[inner]
            c = self.centres[i]
            p0 = v[i] - c
            rad = np.hypot(*p0.T)
            a = np.arctan2(p0[:, 1], p0[:, 0]) + sw[i] * frac[inner]
            out[inner] = c + rad[:, None] * np.stack([np.cos(a), np.sin(a)], axis=1)
        return np.vstack([v[:1], out])

    # -- operations -------------------------------------------------------------------

    def reversed(self) -> "Path":
        """The same path run backwards (arcs change direction)."""
        return self.with_geometry(self.vertices[::-1], self.centres[::-1], -self.sweeps[::-1])

    def rolled(self, index: int) -> "Path":
        """A closed path started at vertex ``index`` instead of vertex 0."""
        if not self.closed:
            raise GeometryError("only a closed path can start at another vertex")
        n = self.n_segments
        index %= n
        if index == 0:
            return self
        seg = np.concatenate((np.arange(index, n), np.arange(index)))
        v = np.vstack([self.vertices[seg], self.vertices[index:index + 1]])
        # the same segments in another order: nothing for the constructor to check or
        # normalise again (ordering rolls hundreds of closed paths of a drawing)
        out = object.__new__(Path)
        for k in Path.__slots__:
            setattr(out, k, getattr(self, k))
        out.vertices, out.centres, out.sweeps = v, self.centres[seg], self.sweeps[seg]
        return out

    def transformed(self, m, *, tol_mm=0.01) -> "Path":
        """Apply an affine transform (3×3). Arcs stay arcs under a similarity.

        Under any other transform an arc's image is an elliptical arc; it is
        replaced by circular arcs from :func:`labkit.geometry.ellipse_to_arcs`
        within ``tol_mm`` (never by a wrong circle).

        Examples
        --------
        >>> from labkit.geometry import transform as tf
        >>> c = Path.circle((0, 0), 10).transformed(tf.scale(2, 1), tol_mm=0.01)
        >>> c.bounds().round(6).tolist(), c.deviation_mm <= 0.01, c.n_segments > 2
        ([[-20.0, -10.0], [20.0, 10.0]], True, True)
        """
        m = np.asarray(m, dtype=float)
        v = _tf.apply(m, self.vertices)
        if not self.is_arc.any():
            return self.with_geometry(v)
        mirror = np.linalg.det(m[:2, :2]) < 0
        if _tf.is_similarity(m):
            c = _tf.apply(m, self.centres)
            return self.with_geometry(v, c, -self.sweeps if mirror else self.sweeps)
        from labkit.geometry.ellipse import ellipse_arc_to_arcs

        a = m[:2, :2]
        pieces_v, pieces_c, pieces_s = [v[:1]], [], []
        dev = self.deviation_mm
        for i in range(self.n_segments):
            if self.sweeps[i] == 0:
                pieces_v.append(v[i + 1:i + 2])
                pieces_c.append([[np.nan, np.nan]])
                pieces_s.append([0.0])
                continue
            c0 = self.centres[i]
            p0 = self.vertices[i] - c0
            r = math.hypot(*p0)
            t0 = math.atan2(p0[1], p0[0])
            sub = ellipse_arc_to_arcs(_tf.apply(m, c0), a * r, t0, self.sweeps[i], tol_mm=tol_mm)
            sub_v = sub.vertices.copy()
            sub_v[0], sub_v[-1] = v[i], v[i + 1]
            pieces_v.append(sub_v[1:])
            pieces_c.append(sub.centres)
            pieces_s.append(sub.sweeps)
            dev = max(dev, self.deviation_mm + sub.deviation_mm)
        return self.with_geometry(np.vstack(pieces_v), np.vstack(pieces_c), np.concatenate(pieces_s),
                                  deviation_mm=dev)

    def __repr__(self) -> str:
        kind = "closed" if self.closed else "open"
        return (f"<Path {kind} n={self.n_segments} arcs={int(self.is_arc.sum())} "
                f"length={self.length_mm:.3f} mm layer={self.layer!r}>")


def check_paths(value, *, name: str = "paths") -> list[Path]:
    """Return ``value`` as a list if it is a sequence of :class:`Path`, else name what it is.

    The entry check of the functions that take a drawing (``build_moves``,
    ``prepare_paths``): SVG text, a dict, a single Path or a list holding
    something else is refused with labkit's own error, not an AttributeError.

    Parameters
    ----------
    value : object
        What the caller was given.
    name : str
        The argument's name, for the message.

    Returns
    -------
    list of Path

    Raises
    ------
    GeometryError
        Naming the argument and, for a list, the first item that is not a Path.

    Examples
    --------
    >>> check_paths("M 0 0 L 10 0")
    Traceback (most recent call last):
    ...
    labkit.errors.GeometryError: paths must be a list of labkit.geometry.Path, got str; SVG text becomes Paths with labkit.vector.read_svg(text).paths
    """
    hint = {str: "; SVG text becomes Paths with labkit.vector.read_svg(text).paths",
            Path: "; put a single path in a list: [path]"}.get(type(value), "")
    if isinstance(value, (str, bytes, dict, Path)) or not isinstance(value, Iterable):
        raise GeometryError(f"{name} must be a list of labkit.geometry.Path, got {type(value).__name__}{hint}")
    items = list(value)
    for i, p in enumerate(items):
        if not isinstance(p, Path):
            raise GeometryError(f"{name}[{i}] must be a labkit.geometry.Path, got {type(p).__name__}")
    return items


def total_length(paths: Iterable[Path]) -> float:
    """Sum of path lengths, mm."""
    return float(sum(p.length_mm for p in paths))


def count_segments(paths: Iterable[Path]) -> tuple[int, int]:
    """(line segments, arc segments) over all paths."""
    lines = arcs = 0
    for p in paths:
        a = int(p.is_arc.sum())
        arcs += a
        lines += p.n_segments - a
    return lines, arcs


def max_deviation(paths: Iterable[Path]) -> float:
    """Largest ``deviation_mm`` over the paths (0 for none)."""
    return max((p.deviation_mm for p in paths), default=0.0)


def _axis_crossings(starts, centres, sweeps):
    """Where arcs (their start points, centres and non-zero sweeps) cross the axis directions
    through their centres — the extreme points :func:`labkit.geometry.circle.arc_bounds` adds to
    an arc's ends, with its arithmetic (numpy's atan2 is the same libm function as math's; the
    radius is math.hypot's). Returns the points (k, 2) and the arc each belongs to (k,)."""
    c = centres
    a0 = np.arctan2(starts[:, 1] - c[:, 1], starts[:, 0] - c[:, 0])
    ccw = sweeps >= 0
    lo = np.where(ccw, a0, a0 + sweeps)
    hi = np.where(ccw, a0 + sweeps, a0) + 1e-15
    quarter = math.pi / 2
    # a sweep under a full turn crosses at most four axes: k0 … k0 + 3 quarters on
    k = np.ceil(lo / quarter)[:, None] + np.arange(4.0)
    which, step = np.nonzero(k * quarter <= hi[:, None])
    if not len(which):
        return np.empty((0, 2)), which
    d = starts[which] - c[which]
    r = np.array([math.hypot(x, y) for x, y in d.tolist()])
    unit = _AXES[(k[which, step] % 4).astype(np.int64)]
    return c[which] + r[:, None] * unit, which


_AXES = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]])      # cos, sin of k quarters


def sample_each(paths: Sequence[Path], tol_mm=0.01) -> list[np.ndarray]:
    """Each path's :meth:`Path.sample` (the same points), all paths in one vectorised pass.

    >>> a, b = sample_each([Path.circle((0, 0), 1), Path.rectangle(0, 0, 2, 1)], 0.1)
    >>> len(a), b.tolist()
    (9, [[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0], [0.0, 0.0]])
    """
    if not tol_mm > 0:
        raise GeometryError(f"tol_mm must be > 0 mm, got {tol_mm!r}")
    if not len(paths):
        return []
    n_seg = np.array([p.n_segments for p in paths])
    v = np.concatenate([p.vertices for p in paths])
    sw = np.concatenate([p.sweeps for p in paths])
    first_vertex = np.cumsum(n_seg + 1) - (n_seg + 1)
    row = np.arange(len(sw)) + np.repeat(np.arange(len(paths)), n_seg)    # each segment's start
    arc = sw != 0
    counts = np.ones(len(sw), np.int64)
    if arc.any():
        centres = np.concatenate([p.centres for p in paths])
        r = np.hypot(*(v[row[arc]] - centres[arc]).T)
        counts[arc] = chord_segments(r, sw[arc], tol_mm)
    seg = np.repeat(np.arange(len(sw)), counts)
    first = np.cumsum(counts) - counts
    k = np.arange(len(seg)) - first[seg] + 1
    out = v[row[seg] + 1]                                 # segment ends (lines: exact)
    inner = arc[seg] & (k < counts[seg])
    if inner.any():
        i = seg[inner]
        c = centres[i]
        p0 = v[row[i]] - c
        rad = np.hypot(*p0.T)
        a = np.arctan2(p0[:, 1], p0[:, 0]) + sw[i] * (k / counts[seg])[inner]
        out[inner] = c + rad[:, None] * np.stack([np.cos(a), np.sin(a)], axis=1)
    # each path: its first vertex, then its segments' points
    per_path = np.add.reduceat(counts, np.cumsum(n_seg) - n_seg) if len(sw) else np.zeros(len(paths), np.int64)
    per_path = np.where(n_seg > 0, per_path, 0)
    size = per_path + 1
    start = np.cumsum(size) - size
    pts = np.empty((int(size.sum()), 2))
    body = np.ones(len(pts), bool)
    body[start] = False
    pts[start] = v[first_vertex]
    pts[body] = out
    return np.split(pts, start[1:])


def bounds_each(paths: Sequence[Path]) -> np.ndarray:
    """Each path's :meth:`Path.bounds` (the same numbers), all paths at once: shape (n, 2, 2).

    >>> bounds_each([Path.circle((0, 0), 1), Path.rectangle(2, 2, 1, 3)]).tolist()
    [[[-1.0, -1.0], [1.0, 1.0]], [[2.0, 2.0], [3.0, 5.0]]]
    """
    if not len(paths):
        return np.zeros((0, 2, 2))
    sizes = np.array([len(p.vertices) for p in paths])
    v = np.concatenate([p.vertices for p in paths])
    sw = np.concatenate([p.sweeps for p in paths])
    owner = np.repeat(np.arange(len(paths)), sizes)
    seg = np.ones(len(v), bool)                          # row k starts segment k of its path
    seg[np.cumsum(sizes) - 1] = False
    arc = np.flatnonzero(seg)[sw != 0]
    if len(arc):
        centres = np.concatenate([p.centres for p in paths])[sw != 0]
        pts, which = _axis_crossings(v[arc], centres, sw[sw != 0])
        v, owner = np.vstack([v, pts]), np.concatenate([owner, owner[arc][which]])
    order = np.argsort(owner, kind="stable")
    v, first = v[order], np.searchsorted(owner[order], np.arange(len(paths)))
    return np.stack([np.minimum.reduceat(v, first), np.maximum.reduceat(v, first)], axis=1)


def paths_bounds(paths: Sequence[Path]) -> np.ndarray:
    """Box around all paths, ``[[xmin, ymin], [xmax, ymax]]`` mm (NaN when empty)."""
    if not len(paths):
        return np.full((2, 2), np.nan)
    boxes = bounds_each(paths)
    return np.array([boxes[:, 0].min(axis=0), boxes[:, 1].max(axis=0)])
