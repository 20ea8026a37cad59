"""Tool paths over the marked pixels of a mask ([LaserApp] §2.5.1–2.5.2, §3.4.1).

Coordinates
-----------
Paths live on the *half-pixel grid*: integer units of half a pixel, x to the
right and y **up**, origin at the bottom-left corner of the image (where the
seed's segment connection starts). Pixel (row r, column c) of an image with
``H`` rows has its centre at (2c + 1, 2(H − r) − 1). Integers keep the
greedy ordering exact: equal distances are really equal.

Every polyline runs through pixel centres. With ``ends="edge"`` (default)
its two ends are pushed half a pixel outwards along the path, to the pixel
edges, so that the beam sweeps the whole first and last pixel and a lone
pixel still gets a one-pixel burn; ``ends="centre"`` keeps the seed's
centre-to-centre lines (a lone pixel is then a zero-length cut). Either way
the pixels whose centres lie on a path are exactly the ones it burns.

Zig-zag makes one segment per run of marked pixels in a row or column;
spiral makes one segment per sub-path of the corner walk. Segments are then
put in order by :func:`connect`: greedy nearest-first from the origin.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from labkit.errors import RasterError
from labkit.geometry.order import Ordering
from labkit.raster import _walk
from labkit.raster._border import check_mask

__all__ = ["Segments", "Connection", "zigzag_segments", "spiral_segments", "connect", "scan_order",
           "choose_axis"]

_ENDS = ("edge", "centre")


@dataclass(frozen=True)
class Segments:
    """Open polylines on the half-pixel grid (see the module docstring).

    Attributes
    ----------
    points : ndarray of int64, shape (m, 2)
        Vertices (x, y) in half-pixel units, all segments one after another.
    offsets : ndarray of int64, shape (n + 1,)
        Segment k is ``points[offsets[k]:offsets[k + 1]]`` (at least 2 points).
    shape : tuple of int
        (rows, columns) of the image the segments came from.
    reversible : bool
        Whether a segment may be run backwards (bidirectional zig-zag).
    """

    points: np.ndarray
    offsets: np.ndarray
    shape: tuple[int, int]
    reversible: bool = False

    def __len__(self) -> int:
        return len(self.offsets) - 1

    @property
    def starts(self) -> np.ndarray:
        """First vertex of each segment, (n, 2)."""
        return self.points[self.offsets[:-1]]

    @property
    def ends(self) -> np.ndarray:
        """Last vertex of each segment, (n, 2)."""
        return self.points[self.offsets[1:] - 1]

    @property
    def vertex_count(self) -> int:
        """Number of vertices (corners included)."""
        return len(self.points)

    def cut_count(self) -> int:
        """Number of straight cuts (vertex pairs) — the seed's "ToolLines" with the tool on."""
        return len(self.points) - len(self)

    def polyline(self, k: int) -> np.ndarray:
        """Vertices of segment ``k``, (j, 2) half-pixel units."""
        return self.points[self.offsets[k]:self.offsets[k + 1]]

    def reordered(self, connection: "Connection") -> "Segments":
        """The segments in the connection's order, reversed where it says so."""
        order = np.asarray(connection.order, dtype=np.int64)
        flip = np.asarray(connection.flipped, dtype=bool)
        lengths = np.diff(self.offsets)[order]
        new_offsets = np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64)
        seg_of = np.repeat(np.arange(len(order)), lengths)
        rank = np.arange(len(seg_of)) - new_offsets[seg_of]
        src_start = self.offsets[order][seg_of]
        src_last = self.offsets[order + 1][seg_of] - 1
        idx = np.where(flip[seg_of], src_last - rank, src_start + rank)
        return Segments(self.points[idx], new_offsets, self.shape, self.reversible)

    def cuts(self) -> tuple[np.ndarray, np.ndarray]:
        """(starts, ends) of every straight cut in order, each (k, 2) half-pixel units."""
        inner = np.ones(len(self.points), dtype=bool)
        inner[self.offsets[1:] - 1] = False  # a segment's last vertex starts no cut
        idx = np.flatnonzero(inner)
        return self.points[idx], self.points[idx + 1]

    def to_mm(self, pixel_mm: float) -> np.ndarray:
        """All vertices in mm, (m, 2)."""
        return self.points * (0.5 * float(pixel_mm))


#: The order in which segments are cut: labkit's one ordering result
#: (:class:`labkit.geometry.order.Ordering`). Here ``flipped`` (``reversed``) runs a segment
#: backwards; ``examined`` counts distances computed to candidate entry points (one per
#: segment, two when reversible), the work the seed's eq. 10 counts, (n² − n)/2 for its
#: scan; ``method`` is ``"reference"``, ``"indexed"`` or ``"scan"``; travel is not in mm
#: here (NaN).
Connection = Ordering


def choose_axis(shape) -> str:
    """The seed's choice of scan lines: rows if the image has fewer rows than columns, else columns.

    Lines then run along the longer side (fewer, longer lines).

    Examples
    --------
    >>> choose_axis((100, 300)), choose_axis((300, 100)), choose_axis((50, 50))
    ('rows', 'columns', 'columns')
    """
    return "rows" if shape[0] < shape[1] else "columns"


#: Pixels per band when runs are found: the mask is read a band of rows at a time, so the
#: working set stays a few bytes per band pixel (~20 MB) whatever the image's size.
_BAND_PIXELS = 1 << 22


def _changes(before: np.ndarray, after: np.ndarray):
    """(row, column, rising) of every pixel where ``after`` differs from ``before`` (two
    boolean views of one band, a pixel apart), row by row: one pass over the band."""
    k = np.flatnonzero(before != after)              # booleans: numpy's fast count and scan
    r, c = np.divmod(k, after.shape[1])
    return r, c, after[r, c]


def _runs(mask: np.ndarray, columns: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(line, first, stop) of every run of marked pixels, line by line, along the line.

    A run starts where a marked pixel follows an unmarked one (or the image's edge) and
    stops (exclusive) where an unmarked one follows a marked one: where the mask, padded
    with unmarked pixels, differs from itself shifted one pixel along the line (rising where
    the later pixel is marked). Whole-array numpy on booleans, a band of rows at a time; a
    compiled loop would be faster only once numba's ~0.4 s start is paid.
    """
    n_rows, n_cols = mask.shape
    band = max(1, _BAND_PIXELS // max(n_cols, 1))
    starts, stops = [], []
    for a in range(0, n_rows, band):
        b = min(a + band, n_rows)
        if columns:
            # the row above the band (or the edge) and, after the last band, the edge below
            block = np.zeros((b - a + 1 + (b == n_rows), n_cols), bool)
            if a:
                block[0] = mask[a - 1]
            block[1:b - a + 1] = mask[a:b]
            r, c, up = _changes(block[:-1], block[1:])
            starts.append((c[up], r[up] + a))
            stops.append((c[~up], r[~up] + a))
        else:
            block = np.zeros((b - a, n_cols + 2), bool)
            block[:, 1:-1] = mask[a:b]
            r, c, up = _changes(block[:, :-1], block[:, 1:])
            starts.append((r[up] + a, c[up]))
            stops.append((r[~up] + a, c[~up]))
    line, first = (np.concatenate(x).astype(np.int64) for x in zip(*starts))
    stop_line, stop = (np.concatenate(x).astype(np.int64) for x in zip(*stops))
    if columns:
        # found row by row: order by column, then down the column (runs alternate
        # start/stop within a column, so the two orders pair them up)
        order = np.lexsort((first, line))
        line, first = line[order], first[order]
        stop = stop[np.lexsort((stop, stop_line))]
    return line, first, stop


def zigzag_segments(mask, *, axis: str = "auto", direction: str = "bidirectional",
                    ends: str = "edge") -> Segments:
    """One straight segment per run of marked pixels along rows or columns.

    Parameters
    ----------
    mask : ndarray of bool, 2-D
        True = burn.
    axis : {"auto", "rows", "columns"}
        Scan lines; ``"auto"`` is the seed's rule (:func:`choose_axis`).
    direction : {"bidirectional", "unidirectional"}
        Unidirectional runs all go left → right (rows) or bottom → top
        (columns); bidirectional ones may be run either way (the connection
        picks the nearer end).
    ends : {"edge", "centre"}
        Where a run starts and stops (see the module docstring).

    Returns
    -------
    Segments
        In scan order: lines from the top row (left column) on, runs along the line.

    Notes
    -----
    [LaserApp] §3.4.1: each run is its own segment, so that the connection can
    jump to the nearest run rather than the next one on the same line.

    Examples
    --------
    >>> m = np.array([[1, 1, 0, 1],
    ...               [0, 1, 1, 0]], dtype=bool)
    >>> s = zigzag_segments(m, axis="rows")
    >>> len(s), s.points.tolist()
    (3, [[0, 3], [4, 3], [6, 3], [8, 3], [2, 1], [6, 1]])
    """
    m = check_mask(mask)
    if axis == "auto":
        axis = choose_axis(m.shape)
    if axis not in ("rows", "columns"):
        raise RasterError(f"axis must be 'auto', 'rows' or 'columns', got {axis!r}")
    if direction not in ("bidirectional", "unidirectional"):
        raise RasterError(f"direction must be 'bidirectional' or 'unidirectional', got {direction!r}")
    if ends not in _ENDS:
        raise RasterError(f"ends must be one of {_ENDS}, got {ends!r}")
    rows = m.shape[0]
    inset = 1 if ends == "centre" else 0
    if axis == "rows":
        line, first, stop = _runs(m, columns=False)
        y = 2 * (rows - line) - 1
        pts = np.stack([2 * first + inset, y, 2 * stop - inset, y], axis=1)
    else:
        line, first, stop = _runs(m, columns=True)   # line = column, first/stop = rows (top → bottom)
        x = 2 * line + 1
        pts = np.stack([x, 2 * (rows - stop) + inset, x, 2 * (rows - first) - inset], axis=1)
    n = len(line)
    return Segments(pts.reshape(2 * n, 2).astype(np.int64), np.arange(0, 2 * n + 1, 2, dtype=np.int64),
                    m.shape, direction == "bidirectional")


def spiral_segments(mask, *, ends: str = "edge") -> Segments:
    """Contour-parallel (spiral) paths by the seed's corner walk.

    Parameters
    ----------
    mask : ndarray of bool, 2-D
        True = burn.
    ends : {"edge", "centre"}
        Where a sub-path starts and stops (see the module docstring).

    Returns
    -------
    Segments
        One segment per sub-path, in the order the walk made them.

    Notes
    -----
    [LaserApp] §3.4.1, "Segment Pathing": start at the bottom-left pixel of the
    bottom row heading up; at each pixel try left, straight, right (relative
    to the heading), so the walk hugs the outline clockwise and then spirals
    inward; every pixel is consumed as it is passed, so none is pathed twice;
    a dead end closes the sub-path and the walk restarts at the next free
    pixel. Walks never leave their 4-connected island, so walking the whole
    image gives, island by island, the sub-paths the seed finds per island.
    The compiled walk visits each pixel once: O(pixels).

    Examples
    --------
    >>> m = np.ones((3, 3), dtype=bool)
    >>> s = spiral_segments(m, ends="centre")
    >>> len(s), (s.points // 2).tolist()   # pixel columns, rows from the bottom
    (1, [[0, 0], [0, 2], [2, 2], [2, 0], [1, 0], [1, 1]])
    """
    m = check_mask(mask)
    if ends not in _ENDS:
        raise RasterError(f"ends must be one of {_ENDS}, got {ends!r}")
    vr, vc, offsets = _walk.spiral_walk(m)
    rows = m.shape[0]
    pts = np.stack([2 * vc + 1, 2 * (rows - vr) - 1], axis=1)
    counts = np.diff(offsets)
    # A lone pixel (one vertex) becomes a two-point segment: across it (edge) or on its centre.
    lone = counts == 1
    reps = np.where(np.repeat(lone, counts), 2, 1)
    pts = np.repeat(pts, reps, axis=0)
    counts = counts + lone
    offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    if ends == "edge" and len(counts):
        first, last = offsets[:-1], offsets[1:] - 1
        lone_first = first[lone]
        pts[lone_first, 0] -= 1
        pts[lone_first + 1, 0] += 1
        long_first, long_last = first[~lone], last[~lone]
        pts[long_first] -= np.sign(pts[long_first + 1] - pts[long_first])
        pts[long_last] += np.sign(pts[long_last] - pts[long_last - 1])
    return Segments(pts.astype(np.int64), offsets, m.shape, False)


def _grid_cell(points: np.ndarray, n: int) -> int:
    span = points.max(axis=0) + 1
    return max(1, int(np.ceil(np.sqrt(2.0 * float(span[0]) * float(span[1]) / max(n, 1)))))


def connect(segments: Segments, *, method: str = "indexed", origin=(0, 0)) -> Connection:
    """Order segments greedily: nearest entry point first, from the origin.

    Parameters
    ----------
    segments : Segments
    method : {"indexed", "reference", "scan"}
        ``"reference"`` — [LaserApp]'s O(n²) scan of every remaining segment at
        every step; ``"indexed"`` — the same choices found through a uniform
        grid of entry points (about O(n log n) on images); ``"scan"`` — no
        search, the classic zig-zag order (:func:`scan_order`).
    origin : (int, int)
        Start position in half-pixel units (default the bottom-left corner).

    Returns
    -------
    Connection

    Notes
    -----
    Distances are squared Euclidean distances on the integer half-pixel grid
    from the current position (the end of the last segment) to a segment's
    start — or either end if the segments are reversible. Ties go to the
    lower segment index, then to the unreversed direction; both methods
    implement that same total order, so their results are identical.

    Examples
    --------
    >>> m = np.zeros((3, 5), bool); m[0, 3:] = m[1, :3] = m[2, 3:] = True
    >>> s = zigzag_segments(m, axis="rows")
    >>> c = connect(s, method="reference")
    >>> c.order.tolist(), c.flipped.tolist(), c.examined
    ([1, 0, 2], [False, False, True], 12)
    >>> c2 = connect(s)
    >>> c2.order.tolist() == c.order.tolist(), c2.flipped.tolist() == c.flipped.tolist()
    (True, True)
    """
    if method == "scan":
        return scan_order(segments)
    if method not in ("indexed", "reference"):
        raise RasterError(f"method must be 'indexed', 'reference' or 'scan', got {method!r}")
    ox, oy = (int(v) for v in origin)
    if ox < 0 or oy < 0:
        raise RasterError(f"origin must be in the image's quadrant (x, y >= 0 half-pixels), got {origin!r}")
    n = len(segments)
    if n == 0:
        return Ordering(np.zeros(0, np.int64), np.zeros(0, bool), examined=0, method=method)
    s, e = segments.starts, segments.ends
    args = (s[:, 0].copy(), s[:, 1].copy(), e[:, 0].copy(), e[:, 1].copy(), bool(segments.reversible),
            ox, oy)
    from labkit.raster import _connect   # compiled with numba: loaded only when connecting

    if method == "reference":
        order, flipped, examined = _connect.greedy_reference(*args)
        return Ordering(order, flipped, examined=int(examined), method=method)
    # the grid search every ordering in labkit uses; half-pixel coordinates are integers, so
    # squared distances are exact and the ties fall as in the reference scan
    from labkit.geometry.order import greedy_grid

    if segments.reversible:         # candidate 2i: run i forward, 2i + 1: backwards
        entry = np.stack([s, e], axis=1).reshape(-1, 2).astype(float)
        leave = np.stack([e, s], axis=1).reshape(-1, 2).astype(float)
    else:
        entry, leave = s.astype(float), e.astype(float)
    ends = 2 if segments.reversible else 1
    citem = np.repeat(np.arange(n, dtype=np.int64), ends)
    cell = float(_grid_cell(entry, len(entry)))
    hi = np.maximum(entry.max(axis=0), (ox, oy))
    nx, ny = (int(v // cell) + 1 for v in hi)
    none = np.full(n, -1, np.int64)
    x, y, lx, ly = (np.ascontiguousarray(a) for a in (entry[:, 0], entry[:, 1], leave[:, 0], leave[:, 1]))
    picked, _, examined, _ = greedy_grid(x, y, lx, ly, citem, n,
                                         np.zeros(n, np.int64), none, float(ox), float(oy), cell,
                                         0.0, 0.0, nx, ny)
    return Ordering(citem[picked], picked % ends == 1, examined=int(examined), method=method)


def scan_order(segments: Segments) -> Connection:
    """The plain zig-zag order, no search: line by line from the bottom (rows) or the left (columns).

    Along each line the runs follow one another; with reversible segments
    every other line runs backwards (the boustrophedon of [LaserApp] Fig. 2.15,
    left), otherwise all go the same way (Fig. 2.15, right).

    Examples
    --------
    >>> m = np.array([[1, 0, 1], [1, 1, 0]], dtype=bool)
    >>> c = scan_order(zigzag_segments(m, axis="rows"))
    >>> c.order.tolist(), c.flipped.tolist()
    ([2, 1, 0], [False, True, True])
    """
    n = len(segments)
    s, e = segments.starts, segments.ends
    horizontal = bool(n) and bool(np.all(s[:, 1] == e[:, 1])) and not np.all(s[:, 0] == e[:, 0])
    line_coord, along = (s[:, 1], s[:, 0]) if horizontal else (s[:, 0], s[:, 1])
    order = np.lexsort((along, line_coord)) if n else np.zeros(0, np.int64)
    flipped = np.zeros(n, dtype=bool)
    if segments.reversible and n:
        _, line_rank = np.unique(line_coord[order], return_inverse=True)
        flipped = line_rank % 2 == 1
        # reversed lines are also visited from their far end
        for_keys = np.where(flipped, -along[order], along[order])
        order = order[np.lexsort((for_keys, line_coord[order]))]
    return Ordering(order.astype(np.int64), flipped, method="scan")
