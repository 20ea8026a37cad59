"""The Moves model: a machine program as numpy columns.

One row per motion (rapid, line, arc) or dwell, in program order. G-code text
parses into Moves (:func:`labkit.gcode.parse`), generators build Moves
(vector, raster, patterns), Moves emit to G-code (:func:`labkit.gcode.emit`),
and the motion planner plans Moves. Columns, units and dtypes:

==============  ===========  =====================================================
column          dtype        meaning
==============  ===========  =====================================================
kind            int8         :class:`MoveKind` (rapid, line, arc CW, arc CCW, dwell)
start, end      float64 n×3  X Y Z in mm (machine coordinates, absolute)
centre          float64 n×3  arc centre in mm (NaN for non-arcs)
plane           int8         17, 18 or 19 (G17 XY, G18 ZX, G19 YZ) of an arc
feed_mm_min     float64      feed in effect, mm/min (NaN if never set)
s_word          float32      laser power word S in effect (0…``s_max``)
laser           int8         :class:`LaserMode` in effect: 0 off, 3 M3, 4 M4
dwell_s         float64      dwell time in s (DWELL rows only, else 0)
line            int32        1-based source line (0 for generated moves)
work_offset     float64 n×3  work origin in machine mm for this move (G54-G59 + G92
                             + G43.1): work coordinates = machine − work_offset
==============  ===========  =====================================================

This table is the one list of the columns (``_COLUMNS`` below holds the same): the
constructor, :class:`MovesBuilder`, :meth:`Moves.from_rows` and the record type
:data:`MOVE_ROW` (one row of every column, which the compiled parser fills) all derive
from it, so adding a column is one edit there.

The beam burns only on feed moves (lines and arcs) with the laser mode on
and S > 0 — GRBL's laser mode keeps it off on rapids; see :attr:`Moves.laser_on`.
Around 100 bytes per move (see :attr:`Moves.nbytes`).
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass
from typing import Any, Iterable, Sequence

import numpy as np

from labkit.geometry.circle import sweep_angle

__all__ = ["MoveKind", "LaserMode", "Record", "Moves", "MovesBuilder", "PLANE_AXES", "MOVE_ROW",
           "BLANK_ROW", "check_moves"]


class MoveKind(enum.IntEnum):
    """What one row of :class:`Moves` does."""

    RAPID = 0     #: G0, laser off
    LINE = 1      #: G1
    ARC_CW = 2    #: G2
    ARC_CCW = 3   #: G3
    DWELL = 4     #: G4 (no motion)


class LaserMode(enum.IntEnum):
    """Laser state in effect for a move (the M word that set it)."""

    OFF = 0        #: M5
    CONSTANT = 3   #: M3: power S whatever the speed
    DYNAMIC = 4    #: M4: power scaled by actual / programmed speed (GRBL laser mode)


#: For each plane (G17/G18/G19): first arc axis, second arc axis, linear (helix) axis.
#: GRBL's convention: G18 is the ZX plane (Z first), G19 the YZ plane.
PLANE_AXES = {17: (0, 1, 2), 18: (2, 0, 1), 19: (1, 2, 0)}


@dataclass(frozen=True)
class Record:
    """A non-motion line kept from the source: ``$`` system lines, stops, settings.

    Attributes
    ----------
    line : int
        1-based source line.
    index : int
        Number of moves before it (its position in the program).
    kind : str
        ``"system"`` ($ line), ``"pause"`` (M0), ``"end"`` (M2/M30),
        ``"lookahead"`` (G5 P…), ``"comment"`` is never recorded.
    text : str
        The line as written (system lines) or the word that made it.
    value : float
        Numeric argument (G5's buffer size), NaN when none.
    """

    line: int
    index: int
    kind: str
    text: str
    value: float = math.nan


_COLUMNS = {
    # name: (dtype, trailing shape, fill value for new rows)
    "kind": (np.int8, (), 0),
    "start": (np.float64, (3,), 0.0),
    "end": (np.float64, (3,), 0.0),
    "centre": (np.float64, (3,), np.nan),
    "plane": (np.int8, (), 17),
    "feed_mm_min": (np.float64, (), np.nan),
    "s_word": (np.float32, (), 0.0),
    "laser": (np.int8, (), 0),
    "dwell_s": (np.float64, (), 0.0),
    "line": (np.int32, (), 0),
    "work_offset": (np.float64, (3,), 0.0),
}

#: One move as a record: every column of ``_COLUMNS`` by name, dtype and shape (the row
#: type of the compiled parser's output; :meth:`Moves.from_rows` turns it into columns).
# np.record as the scalar type: a row reads and writes its fields as attributes (row.kind = k) in
# plain Python too, as it does in compiled code, so one kernel source runs both ways (labkit._jit).
MOVE_ROW = np.dtype((np.record, [(name, dtype, shape) for name, (dtype, shape, _) in _COLUMNS.items()]))

#: A one-element array of :data:`MOVE_ROW` holding every column's fill value (a new row
#: starts as a copy of it, so a column nobody writes keeps its default).
BLANK_ROW = np.zeros(1, MOVE_ROW)
for _name, (_dtype, _shape, _fill) in _COLUMNS.items():
    BLANK_ROW[_name] = _fill
del _name, _dtype, _shape, _fill


class Moves:
    """A machine program as column arrays (see the module docstring for the columns).

    Parameters
    ----------
    kind, start, end, centre, plane, feed_mm_min, s_word, laser, dwell_s, line, work_offset
        Column arrays of equal length; missing columns take their defaults
        (``centre`` NaN, ``plane`` 17, ``feed_mm_min`` NaN, others 0).
    source : str, optional
        File the moves came from (for messages).
    s_max : float
        S value meaning full power (dialect setting; GRBL default 1000).
    records : sequence of Record
        Non-motion lines kept from the source.
    diagnostics : sequence of GcodeError
        Problems found in lenient parsing (empty when strict).
    dropped_diagnostics : int
        Further problems counted but not kept (beyond the ``diagnostics`` budget).

    Examples
    --------
    >>> m = Moves(kind=[MoveKind.RAPID, MoveKind.LINE],
    ...           start=[[0, 0, 0], [10, 0, 0]], end=[[10, 0, 0], [10, 5, 0]],
    ...           feed_mm_min=[np.nan, 600], s_word=[0, 500], laser=[3, 3])
    >>> len(m), m.lengths_mm().tolist(), m.laser_on.tolist()
    (2, [10.0, 5.0], [False, True])
    """

    __slots__ = tuple(_COLUMNS) + ("source", "s_max", "records", "diagnostics",
                                   "dropped_diagnostics")

    def __init__(self, *, source: str | None = None, s_max: float = 1000.0,
                 records: Sequence[Record] = (), diagnostics: Sequence[Any] = (),
                 dropped_diagnostics: int = 0, **columns):
        unknown = set(columns) - set(_COLUMNS)
        if unknown:
            raise TypeError(f"unknown Moves column(s) {sorted(unknown)}; columns are {list(_COLUMNS)}")
        if "kind" not in columns:
            raise TypeError("Moves needs at least the 'kind' column")
        n = len(np.atleast_1d(columns["kind"]))
        for name, (dtype, shape, fill) in _COLUMNS.items():
            if name in columns:
                arr = np.asarray(columns[name], dtype=dtype)
                if arr.ndim == 0:
                    arr = np.full((n,) + shape, arr, dtype=dtype)
            elif fill == 0:      # calloc'd: a column nobody writes takes no memory until written
                arr = np.zeros((n,) + shape, dtype=dtype)
            else:
                arr = np.full((n,) + shape, fill, dtype=dtype)
            if arr.shape != (n,) + shape:
                raise ValueError(f"Moves column {name!r} has shape {arr.shape}, expected {(n,) + shape}")
            object.__setattr__(self, name, arr)
        self.source = source
        self.s_max = float(s_max)
        self.records = tuple(records)
        self.diagnostics = tuple(diagnostics)
        self.dropped_diagnostics = int(dropped_diagnostics)

    @staticmethod
    def column_names() -> tuple[str, ...]:
        """The column names, in the one order of the table above."""
        return tuple(_COLUMNS)

    # -- construction -----------------------------------------------------------------

    @classmethod
    def from_rows(cls, rows: np.ndarray, **kw) -> "Moves":
        """Moves from an array of :data:`MOVE_ROW` records (each column copied contiguous).

        >>> rows = np.repeat(BLANK_ROW, 2)
        >>> rows["kind"] = MoveKind.LINE; rows["end"][1] = [3.0, 4.0, 0.0]
        >>> Moves.from_rows(rows).lengths_mm().tolist()
        [0.0, 5.0]
        """
        if rows.dtype != MOVE_ROW:
            raise TypeError(f"rows must have dtype MOVE_ROW, got {rows.dtype}")
        return cls(**{name: np.ascontiguousarray(rows[name]) for name in _COLUMNS}, **kw)

    @classmethod
    def empty(cls, **kw) -> "Moves":
        """A program with no moves."""
        return cls(kind=np.zeros(0, np.int8), **kw)

    @classmethod
    def concat(cls, parts: Iterable["Moves"]) -> "Moves":
        """Join programs end to end (records are re-indexed; the first part's settings win)."""
        parts = list(parts)
        if not parts:
            return cls.empty()
        cols = {name: np.concatenate([getattr(p, name) for p in parts]) for name in _COLUMNS}
        records, offset = [], 0
        for p in parts:
            records += [Record(r.line, r.index + offset, r.kind, r.text, r.value) for r in p.records]
            offset += len(p)
        return cls(source=parts[0].source, s_max=parts[0].s_max, records=records,
                   diagnostics=[d for p in parts for d in p.diagnostics], **cols)

    @classmethod
    def from_cuts(cls, starts, ends, *, feed_mm_min, s_word, laser=LaserMode.CONSTANT,
                  origin=(0.0, 0.0, 0.0), s_max=1000.0, rapid_tol_mm=1e-9) -> "Moves":
        """Straight cuts in the given order, joined by rapids where they do not touch.

        Parameters
        ----------
        starts, ends : array_like, shape (n, 2) or (n, 3)
            Start and end of each cut in mm (Z = 0 when 2-D).
        feed_mm_min : float or array_like
            Cutting feed per cut, mm/min.
        s_word : float or array_like
            Laser power word per cut (0…``s_max``).
        laser : LaserMode
            M3 (constant) or M4 (dynamic) for the cuts.
        origin : sequence of 3 floats
            Where the head is before the first move, mm.
        rapid_tol_mm : float
            A rapid is inserted only where the gap is larger than this, mm.

        Returns
        -------
        Moves

        Examples
        --------
        >>> m = Moves.from_cuts([[0, 0], [5, 0]], [[2, 0], [9, 0]], feed_mm_min=1200, s_word=800)
        >>> [MoveKind(k).name for k in m.kind]
        ['LINE', 'RAPID', 'LINE']
        """
        starts = _as_xyz(starts)
        ends = _as_xyz(ends)
        n = len(starts)
        if ends.shape != starts.shape:
            raise ValueError(f"starts and ends differ in shape: {starts.shape} vs {ends.shape}")
        prev_end = np.vstack([np.asarray(origin, dtype=float)[None, :], ends[:-1]]) if n else ends
        gap = np.linalg.norm(starts - prev_end, axis=1) > rapid_tol_mm
        feed = np.broadcast_to(np.asarray(feed_mm_min, dtype=float), (n,))
        power = np.broadcast_to(np.asarray(s_word, dtype=np.float32), (n,))
        # Row layout: every cut takes one row, plus one rapid row before it when there is a gap.
        rows_per_cut = 1 + gap.astype(np.int64)
        cut_row = np.cumsum(rows_per_cut) - 1
        total = int(rows_per_cut.sum())
        kind = np.full(total, MoveKind.RAPID, np.int8)
        start = np.empty((total, 3))
        end = np.empty((total, 3))
        kind[cut_row] = MoveKind.LINE
        start[cut_row] = starts
        end[cut_row] = ends
        rapid_row = cut_row[gap] - 1
        start[rapid_row] = prev_end[gap]
        end[rapid_row] = starts[gap]
        feed_col = np.full(total, np.nan)
        feed_col[cut_row] = feed
        feed_col[rapid_row] = feed[gap]
        power_col = np.zeros(total, np.float32)
        power_col[cut_row] = power
        power_col[rapid_row] = power[gap]
        return cls(kind=kind, start=start, end=end, feed_mm_min=feed_col, s_word=power_col,
                   laser=np.full(total, int(laser), np.int8), s_max=s_max)

    # -- container protocol -----------------------------------------------------------

    def __len__(self) -> int:
        return len(self.kind)

    def __getitem__(self, index) -> "Moves":
        """Rows by slice, mask or index array (always a Moves; records are dropped
        unless the selection is a plain slice from the start)."""
        if isinstance(index, (int, np.integer)):
            index = slice(index, index + 1 if index != -1 else None)
        cols = {name: getattr(self, name)[index] for name in _COLUMNS}
        return Moves(source=self.source, s_max=self.s_max, **cols)

    def copy(self) -> "Moves":
        """A deep copy (columns copied)."""
        cols = {name: getattr(self, name).copy() for name in _COLUMNS}
        return Moves(source=self.source, s_max=self.s_max, records=self.records,
                     diagnostics=self.diagnostics, **cols)

    def columns(self) -> dict[str, np.ndarray]:
        """The column arrays by name (views, not copies)."""
        return {name: getattr(self, name) for name in _COLUMNS}

    def __repr__(self) -> str:
        counts = ", ".join(f"{MoveKind(k).name.lower()}={c}"
                           for k, c in zip(*np.unique(self.kind, return_counts=True)))
        src = f" from {self.source!r}" if self.source else ""
        return f"<Moves n={len(self)}{src}: {counts or 'empty'}>"

    def __eq__(self, other):
        if not isinstance(other, Moves):
            return NotImplemented
        return len(self) == len(other) and all(
            np.array_equal(getattr(self, n), getattr(other, n), equal_nan=True) for n in _COLUMNS)

    __hash__ = None

    @property
    def nbytes(self) -> int:
        """Memory held by the columns, bytes."""
        return sum(getattr(self, n).nbytes for n in _COLUMNS)

    # -- derived quantities -----------------------------------------------------------

    @property
    def motion_lines(self) -> int:
        """G-code lines that move the head (G0–G3 and their modal continuations).

        Parsed Moves count the distinct source lines holding a motion; built Moves one
        line per motion row, as :func:`labkit.gcode.emit` writes them.

        >>> from labkit.gcode import parse
        >>> parse("G21\\nG0 X1 Y1\\nG1 X2 F100\\nX3\\nM5\\nG4 P1\\n").motion_lines
        3
        """
        motion = self.kind <= MoveKind.ARC_CCW
        lines = self.line[motion]
        if len(lines) and (lines > 0).all():
            return int(len(np.unique(lines)))
        return int(np.count_nonzero(motion))

    @property
    def work_start(self) -> np.ndarray:
        """Start points in work coordinates (what the program's X Y Z words mean), mm."""
        return self.start - self.work_offset

    @property
    def work_end(self) -> np.ndarray:
        """End points in work coordinates, mm.

        >>> from labkit.gcode import parse
        >>> m = parse("G0 X10\\nG92 X0\\nG0 X5")
        >>> m.end[:, 0].tolist(), m.work_end[:, 0].tolist()
        ([10.0, 15.0], [10.0, 5.0])
        """
        return self.end - self.work_offset

    @property
    def work_centre(self) -> np.ndarray:
        """Arc centres in work coordinates, mm (NaN for non-arcs)."""
        return self.centre - self.work_offset

    def in_work_coordinates(self) -> "Moves":
        """The same program with positions in work coordinates (offset column 0): for
        drawing what the user wrote. Without offsets, the program itself (no copy)."""
        if not self.work_offset.any():
            return self
        out = self.copy()
        out.start[:] = self.work_start
        out.end[:] = self.work_end
        out.centre[:] = self.work_centre
        out.work_offset[:] = 0.0
        return out

    @property
    def is_arc(self) -> np.ndarray:
        """Rows that are G2/G3 arcs."""
        return (self.kind == MoveKind.ARC_CW) | (self.kind == MoveKind.ARC_CCW)

    @property
    def is_motion(self) -> np.ndarray:
        """Rows that move the head (everything but dwells)."""
        return self.kind != MoveKind.DWELL

    @property
    def is_feed(self) -> np.ndarray:
        """Rows that move at the programmed feed (G1, G2, G3)."""
        return (self.kind >= MoveKind.LINE) & (self.kind <= MoveKind.ARC_CCW)

    @property
    def laser_on(self) -> np.ndarray:
        """Rows during which the beam burns: feed moves with M3/M4 and S > 0."""
        return self.is_feed & (self.laser != LaserMode.OFF) & (self.s_word > 0)

    def power_fraction(self) -> np.ndarray:
        """Programmed power as a fraction 0…1 of full power (0 when the beam is off)."""
        return np.where(self.laser_on, np.clip(self.s_word / self.s_max, 0.0, 1.0), 0.0)

    def power_mw(self, max_power_mw: float) -> np.ndarray:
        """Programmed optical power per move, mW (linear in S; 0 when off); ``max_power_mw``
        is the machine's power at full duty (its description's ``laser_max_power_mw``)."""
        from labkit.units import s_to_mw

        return np.where(self.laser_on, s_to_mw(self.s_word, s_max=self.s_max,
                                               max_power_mw=max_power_mw), 0.0)

    def plane_coords(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Split 3-D points into (in-plane 2-D coords, linear coord) per row's plane."""
        idx = np.array([PLANE_AXES[17], PLANE_AXES[18], PLANE_AXES[19]])[self.plane.astype(int) - 17]
        rows = np.arange(len(self))[:, None]
        return points[rows, idx[:, :2]], points[np.arange(len(self)), idx[:, 2]]

    def radius_mm(self) -> np.ndarray:
        """Arc radius in mm (distance start–centre in the arc plane); NaN for non-arcs."""
        p0, _ = self.plane_coords(self.start)
        c, _ = self.plane_coords(np.nan_to_num(self.centre, nan=0.0))
        r = np.hypot(*(p0 - c).T)
        return np.where(self.is_arc, r, np.nan)

    def sweep_rad(self) -> np.ndarray:
        """Signed arc sweep in rad (CCW positive; ±2π for full circles); 0 for non-arcs."""
        out = np.zeros(len(self))
        arc = self.is_arc
        if arc.any():
            sub = self[arc]
            p0, _ = sub.plane_coords(sub.start)
            p1, _ = sub.plane_coords(sub.end)
            c, _ = sub.plane_coords(sub.centre)
            out[arc] = sweep_angle(p0, p1, c, sub.kind == MoveKind.ARC_CW)
        return out

    def lengths_mm(self) -> np.ndarray:
        """Path length of each move in mm (arcs along the arc, helices included; dwell 0)."""
        length = np.linalg.norm(self.end - self.start, axis=1)
        arc = self.is_arc
        if arc.any():
            sub = self[arc]
            _, z0 = sub.plane_coords(sub.start)
            _, z1 = sub.plane_coords(sub.end)
            length[arc] = np.hypot(np.abs(self.sweep_rad()[arc]) * self.radius_mm()[arc], z1 - z0)
        length[self.kind == MoveKind.DWELL] = 0.0
        return length

    def extents(self) -> tuple[np.ndarray, np.ndarray]:
        """Per-row axis-aligned box: (lo, hi), each (n, 3) mm, arcs exact.

        An arc reaches beyond its end points wherever it crosses one of the
        four axis directions through its centre; those extreme points are
        included. Dwell rows give their position.
        """
        lo = np.minimum(self.start, self.end)
        hi = np.maximum(self.start, self.end)
        arc = np.flatnonzero(self.is_arc)
        if len(arc) == 0:
            return lo, hi
        sub = self[arc]
        p0, _ = sub.plane_coords(sub.start)
        c, _ = sub.plane_coords(sub.centre)
        r = np.hypot(*(p0 - c).T)
        a0 = np.arctan2(p0[:, 1] - c[:, 1], p0[:, 0] - c[:, 0])
        sweep = self.sweep_rad()[arc]
        ang_lo = np.minimum(a0, a0 + sweep)
        ang_hi = np.maximum(a0, a0 + sweep)
        axes = np.array([PLANE_AXES[17], PLANE_AXES[18], PLANE_AXES[19]])[sub.plane.astype(int) - 17]
        for k, (dx, dy) in enumerate(((1, 0), (0, 1), (-1, 0), (0, -1))):
            direction = k * math.pi / 2
            m = np.ceil((ang_lo - direction) / (2 * math.pi) - 1e-12)
            crossed = direction + 2 * math.pi * m <= ang_hi + 1e-12
            for axis_pos, comp in ((0, dx), (1, dy)):
                if comp == 0:
                    continue
                value = c[:, axis_pos] + comp * r
                col = axes[:, axis_pos]
                rows = arc[crossed]
                cols = col[crossed]
                vals = value[crossed]
                lo[rows, cols] = np.minimum(lo[rows, cols], vals)
                hi[rows, cols] = np.maximum(hi[rows, cols], vals)
        return lo, hi

    def bounds(self, mask: np.ndarray | None = None) -> np.ndarray:
        """Axis-aligned box of the path, arcs included exactly.

        Parameters
        ----------
        mask : array of bool, optional
            Only these rows (e.g. ``moves.laser_on``).

        Returns
        -------
        ndarray, shape (2, 3)
            ``[[xmin, ymin, zmin], [xmax, ymax, zmax]]`` in mm; NaN when empty.

        Examples
        --------
        >>> b = MovesBuilder(feed_mm_min=600)
        >>> b.rapid(x=10); b.arc_ccw(x=-10, i=-10)         # upper half circle, r = 10
        >>> b.build().bounds().tolist()
        [[-10.0, 0.0, 0.0], [10.0, 10.0, 0.0]]
        """
        keep = self.is_motion if mask is None else (np.asarray(mask, dtype=bool) & self.is_motion)
        if not keep.any():
            return np.full((2, 3), np.nan)
        if not (keep & self.is_arc).any():      # lines only: the end points' box, no copy of every column
            every = keep.all()
            box = np.empty((2, 3))
            for a in range(3):                    # column by column: 10x faster than .min(axis=0)
                s, e = (p[:, a] if every else p[:, a][keep] for p in (self.start, self.end))
                box[0, a] = np.minimum(s.min(), e.min())
                box[1, a] = np.maximum(s.max(), e.max())
            return box
        lo, hi = self[keep].extents()
        return np.array([lo.min(axis=0), hi.max(axis=0)])

    def to_dataframe(self):
        """The columns as a pandas DataFrame (one row per move, XYZ split into columns)."""
        import pandas as pd

        data = {"kind": [MoveKind(k).name for k in self.kind], "line": self.line}
        for name in ("start", "end", "centre"):
            for i, ax in enumerate("xyz"):
                data[f"{name}_{ax}"] = getattr(self, name)[:, i]
        for i, ax in enumerate("xyz"):
            data[f"work_offset_{ax}"] = self.work_offset[:, i]
        for name in ("plane", "feed_mm_min", "s_word", "laser", "dwell_s"):
            data[name] = getattr(self, name)
        data["laser_on"] = self.laser_on
        data["length_mm"] = self.lengths_mm()
        return pd.DataFrame(data)


_NOT_MOVES_HINT = {str: "; G-code text becomes Moves with labkit.gcode.parse",
                   dict: "; a program is built with labkit.toolpath.MovesBuilder"}


def check_moves(value, *, name: str = "moves", finite: bool = True, error: type | None = None) -> Moves:
    """Return ``value`` if it is a :class:`Moves` program, else raise labkit's error naming ``name``.

    The entry check of the public functions that take a program (``emit``,
    ``summarize``, ``plan``, ``simulate_burn``, the Dobot's reach check, …): text, a
    dict or an array is not a program, and a position, arc centre, power or dwell
    that is not finite would be planned, drawn or sent as nonsense.

    Parameters
    ----------
    value, name
        What the caller was given and the argument's name, as for
        :func:`labkit.geometry.path.check_paths`.
    finite : bool
        Also require finite positions on motion rows, finite arc centres, finite
        powers on motion rows and finite dwells on dwell rows.
    error : type, optional
        The :class:`labkit.errors.LabkitError` kind to raise (default ``InputError``).

    Returns
    -------
    Moves

    Examples
    --------
    >>> check_moves("G1 X10")
    Traceback (most recent call last):
    ...
    labkit.errors.InputError: moves must be a labkit.toolpath.Moves, got str; G-code text becomes Moves with labkit.gcode.parse
    >>> m = Moves(kind=[MoveKind.LINE], start=[[0, 0, 0]], end=[[np.nan, 0, 0]], feed_mm_min=[600])
    >>> check_moves(m, name="job")
    Traceback (most recent call last):
    ...
    labkit.errors.InputError: job: <moves>: move 0 has a position that is not finite (end X = nan); expected finite coordinates in mm
    """
    from labkit.errors import InputError

    error = InputError if error is None else error
    if not isinstance(value, Moves):
        hint = next((h for t, h in _NOT_MOVES_HINT.items() if isinstance(value, t)), "")
        raise error(f"{name} must be a labkit.toolpath.Moves, got {type(value).__name__}{hint}")
    if not finite or not len(value):
        return value
    arc = value.is_arc
    checks = [("start", value.start, "motion", "a position", "finite coordinates in mm"),
              ("end", value.end, "motion", "a position", "finite coordinates in mm"),
              ("centre", value.centre, "arc", "an arc centre", "finite coordinates in mm"),
              ("s_word", value.s_word[:, None], "motion", "a power", "a finite S"),
              ("dwell_s", value.dwell_s[:, None], "dwell", "a dwell", "a finite dwell in s")]
    for column, data, rows, what, expected in checks:
        # a sum is NaN or inf when any term is: one pass and no temporaries for a sound program
        # (2.3 M moves: ~20 ms); only a suspect column is searched row by row
        quick = data[arc] if rows == "arc" else data      # centres are NaN off the arcs by design
        if math.isfinite(float(np.sum(quick, dtype=np.float64))):
            continue
        rows = {"motion": value.is_motion, "arc": arc, "dwell": value.kind == MoveKind.DWELL}[rows]
        bad = rows[:, None] & ~np.isfinite(np.asarray(data, float))
        if bad.any():
            i, a = map(int, np.argwhere(bad)[0])
            line = int(value.line[i])
            axis = f" {'XYZ'[a]}" if data.shape[1] == 3 else ""
            raise error(f"{name}: {value.source or '<moves>'}: move {i}{f' (line {line})' if line else ''} "
                        f"has {what} that is not finite ({column}{axis} = {data[i, a]}); expected {expected}")
    return value


def _as_xyz(points) -> np.ndarray:
    pts = np.asarray(points, dtype=float)
    if pts.ndim != 2 or pts.shape[1] not in (2, 3):
        raise ValueError(f"points must have shape (n, 2) or (n, 3), got {pts.shape}")
    if pts.shape[1] == 2:
        pts = np.hstack([pts, np.zeros((len(pts), 1))])
    return pts


class MovesBuilder:
    """Build a program move by move with modal state, like writing G-code by hand.

    Convenient for generators that emit moves one at a time; vectorised
    generators should build the columns directly instead.

    Examples
    --------
    >>> b = MovesBuilder(feed_mm_min=1200, s_word=300, laser=LaserMode.CONSTANT)
    >>> b.rapid(x=5, y=5)
    >>> b.line(x=15)
    >>> b.arc_cw(x=15, y=-5, i=0, j=-5)
    >>> m = b.build()
    >>> [MoveKind(k).name for k in m.kind], round(float(m.lengths_mm()[2]), 4)
    (['RAPID', 'LINE', 'ARC_CW'], 15.708)
    """

    def __init__(self, *, origin=(0.0, 0.0, 0.0), feed_mm_min=math.nan, s_word=0.0,
                 laser=LaserMode.OFF, plane=17, s_max=1000.0, source=None):
        self.position = np.asarray(origin, dtype=float).copy()
        self.feed_mm_min = float(feed_mm_min)
        self.s_word = float(s_word)
        self.laser = LaserMode(laser)
        self.plane = int(plane)
        self.s_max = s_max
        self.source = source
        self._rows: list[np.ndarray] = []     # one-element MOVE_ROW arrays
        self.records: list[Record] = []

    def _target(self, x, y, z):
        t = self.position.copy()
        for i, v in enumerate((x, y, z)):
            if v is not None:
                t[i] = v
        return t

    def _add(self, kind, end, centre=(math.nan,) * 3, dwell_s=0.0, line=0):
        row = BLANK_ROW.copy()       # columns not set here (e.g. work_offset) keep their fill
        row["kind"] = int(kind)
        row["start"] = self.position
        row["end"] = end
        row["centre"] = centre
        row["plane"] = self.plane
        row["feed_mm_min"] = self.feed_mm_min
        row["s_word"] = self.s_word
        row["laser"] = int(self.laser)
        row["dwell_s"] = dwell_s
        row["line"] = line
        self._rows.append(row)
        self.position = np.asarray(end, float).copy()

    def set(self, *, feed_mm_min=None, s_word=None, laser=None, plane=None):
        """Change modal settings for the following moves."""
        if feed_mm_min is not None:
            self.feed_mm_min = float(feed_mm_min)
        if s_word is not None:
            self.s_word = float(s_word)
        if laser is not None:
            self.laser = LaserMode(laser)
        if plane is not None:
            if plane not in PLANE_AXES:
                raise ValueError(f"plane must be 17, 18 or 19, got {plane!r}")
            self.plane = int(plane)

    def rapid(self, x=None, y=None, z=None, *, line=0):
        """G0 to the given absolute coordinates (mm); omitted axes stay."""
        self._add(MoveKind.RAPID, self._target(x, y, z), line=line)

    def line(self, x=None, y=None, z=None, *, line=0, **modal):
        """G1 to the given absolute coordinates (mm) at the feed in effect."""
        if modal:
            self.set(**modal)
        self._add(MoveKind.LINE, self._target(x, y, z), line=line)

    def _arc(self, kind, x, y, z, i, j, k, line, modal):
        if modal:
            self.set(**modal)
        offset = np.array([i or 0.0, j or 0.0, k or 0.0])
        centre = self.position + offset
        self._add(kind, self._target(x, y, z), centre=centre, line=line)

    def arc_cw(self, x=None, y=None, z=None, *, i=None, j=None, k=None, line=0, **modal):
        """G2 with centre offsets I J K (mm, incremental from the start)."""
        self._arc(MoveKind.ARC_CW, x, y, z, i, j, k, line, modal)

    def arc_ccw(self, x=None, y=None, z=None, *, i=None, j=None, k=None, line=0, **modal):
        """G3 with centre offsets I J K (mm, incremental from the start)."""
        self._arc(MoveKind.ARC_CCW, x, y, z, i, j, k, line, modal)

    def dwell(self, seconds, *, line=0):
        """G4: wait ``seconds`` s in place."""
        if seconds < 0:
            raise ValueError(f"dwell must be >= 0 s, got {seconds!r}")
        self._add(MoveKind.DWELL, self.position.copy(), dwell_s=float(seconds), line=line)

    def record(self, kind, text, value=math.nan, *, line=0):
        """Keep a non-motion record (e.g. an M0 pause) at the current position."""
        self.records.append(Record(line, len(self._rows), kind, text, value))

    def build(self) -> Moves:
        """The moves so far as a :class:`Moves`."""
        if not self._rows:
            return Moves.empty(s_max=self.s_max, source=self.source, records=self.records)
        return Moves.from_rows(np.concatenate(self._rows), source=self.source, s_max=self.s_max,
                               records=self.records)
