"""Dry-run a program: envelope check, lengths with the beam on and off, time at constant feed.

This is [LaserApp]'s simulation step (§3.2) — validate every line, track the
modal state, flag moves that leave the machine, report lengths and an
estimated time — on a parsed :class:`~labkit.toolpath.Moves`. The time here
assumes every move runs at its programmed feed (infinite acceleration), the
figure laser software usually quotes; :mod:`labkit.motion` plans real
acceleration and look-ahead.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field

import numpy as np

from labkit.errors import BoundsError, InputError
from labkit.toolpath.moves import MoveKind, Moves, check_moves

__all__ = ["Envelope", "JobSummary", "summarize", "check_bounds", "DEFAULT_RAPID_MM_MIN"]

#: Rapid rate assumed when none is given: GRBL's default max rate ($110) 500 mm/min is
#: far too slow for lasers; 6000 mm/min (100 mm/s) is typical of diode laser gantries.
DEFAULT_RAPID_MM_MIN = 6000.0


@dataclass(frozen=True)
class Envelope:
    """The reachable box of a machine, mm (machine coordinates).

    Examples
    --------
    >>> Envelope.from_size(400, 300).hi
    (400.0, 300.0, inf)
    """

    lo: tuple[float, float, float] = (0.0, 0.0, -math.inf)
    hi: tuple[float, float, float] = (math.inf, math.inf, math.inf)

    @classmethod
    def from_size(cls, x_mm: float, y_mm: float, z_mm: float | None = None) -> "Envelope":
        """A work area from the origin: 0…x, 0…y (and 0…z when given; Z free otherwise)."""
        for name, v in (("x_mm", x_mm), ("y_mm", y_mm), ("z_mm", z_mm)):
            if v is not None and not v > 0:
                raise ValueError(f"{name} must be > 0 mm, got {v!r}")
        zlo, zhi = (0.0, float(z_mm)) if z_mm is not None else (-math.inf, math.inf)
        return cls((0.0, 0.0, zlo), (float(x_mm), float(y_mm), zhi))


def check_bounds(moves: Moves, envelope: Envelope, *, tol_mm: float = 1e-6) -> None:
    """Raise :class:`~labkit.errors.BoundsError` at the first move that leaves ``envelope``.

    Arcs are checked along the arc (their extreme points), not only at
    their ends. The error names the source line of the offending move, and
    quotes it when the moves came from a file.

    Examples
    --------
    >>> from labkit.gcode import parse
    >>> m = parse("G0 X10 Y10\\nG2 X30 Y10 I10 J0 F600")     # the arc's top reaches Y20
    >>> check_bounds(m, Envelope.from_size(100, 15))
    Traceback (most recent call last):
    ...
    labkit.errors.BoundsError: <string>:2:1: error 102: move leaves the machine envelope: Y reaches 20 mm, the limit is 15 mm (expected 0 <= X <= 100, 0 <= Y <= 15)
    """
    check_moves(moves)
    if not isinstance(envelope, Envelope):
        raise InputError(f"envelope must be a labkit.gcode.simulate.Envelope (Envelope.from_size(x_mm, y_mm)), "
                         f"got {type(envelope).__name__}")
    lo, hi = moves.extents()
    motion = moves.is_motion[:, None]
    elo = np.asarray(envelope.lo, dtype=float)
    ehi = np.asarray(envelope.hi, dtype=float)
    bad_lo = (lo < elo - tol_mm) & motion
    bad_hi = (hi > ehi + tol_mm) & motion
    bad = (bad_lo | bad_hi).any(axis=1)
    if not bad.any():
        return
    i = int(np.flatnonzero(bad)[0])
    axis = int(np.flatnonzero(bad_lo[i] | bad_hi[i])[0])
    name = "XYZ"[axis]
    if bad_hi[i, axis]:
        what = f"{name} reaches {hi[i, axis]:.6g} mm, the limit is {ehi[axis]:.6g} mm"
    else:
        what = f"{name} reaches {lo[i, axis]:.6g} mm, the limit is {elo[axis]:.6g} mm"
    limits = ", ".join(f"{elo[a]:.6g} <= {'XYZ'[a]} <= {ehi[a]:.6g}" for a in range(3)
                       if math.isfinite(elo[a]) or math.isfinite(ehi[a]))
    raise BoundsError(f"move leaves the machine envelope: {what}", filename=moves.source,
                      line=int(moves.line[i]), column=1, text=_source_text(moves, i),
                      expected=limits)


def _source_text(moves: Moves, i: int) -> str:
    if moves.source is None or moves.line[i] <= 0:
        return ""
    try:
        with open(moves.source, "rb") as fh:
            for k, raw in enumerate(fh, start=1):
                if k == moves.line[i]:
                    return raw.decode("utf-8", "replace").strip()
    except OSError:
        return ""
    return ""


@dataclass
class JobSummary:
    """What a program does, in numbers (lengths mm, times s, feeds mm/min).

    Attributes
    ----------
    moves : int
        Rows of the program.
    counts : dict
        Rows by kind (``rapid``, ``line``, ``arc_cw``, ``arc_ccw``, ``dwell``).
    bounds : list
        ``[[xmin, ymin, zmin], [xmax, ymax, zmax]]`` of all motion, mm.
    cut_bounds : list
        The same for moves with the beam on.
    cut_length_mm, travel_length_mm : float
        Path length with the beam on, and of every other motion.
    laser_on_time_s : float
        Σ cut length / feed.
    dwell_time_s : float
        Σ G4 dwells.
    estimated_time_s : float
        Cut and non-burning feed moves at their feed, rapids at ``rapid_mm_min``,
        plus dwells (no acceleration).
    rapid_mm_min : float
        Rapid rate used for the estimate.
    source_lines : int or None
        Lines in the source text, when known.
    records : int
        Non-motion records kept (``$`` lines, stops, …).
    diagnostics : int
        Errors found in lenient parsing.
    cut_moves : int
        Rows with the beam on.
    idle_feed_length_mm : float
        Length of feed moves (G1/G2/G3) with the beam off, mm (part of the travel length).

    The one job summary of labkit: :func:`summarize` makes it for any program, and
    :func:`labkit.raster.engrave.summarize` for raster jobs.
    """

    moves: int
    counts: dict
    bounds: list
    cut_bounds: list
    cut_length_mm: float
    travel_length_mm: float
    laser_on_time_s: float
    dwell_time_s: float
    estimated_time_s: float
    rapid_mm_min: float
    source_lines: int | None = None
    records: int = 0
    diagnostics: int = 0
    cut_moves: int = 0
    idle_feed_length_mm: float = 0.0
    extra: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        """Plain types only, every non-finite number (NaN bounds of an empty program, an
        unknown time) as None, ready for strict ``json.dumps``."""
        return _finite_or_none(asdict(self))

    def to_json(self) -> str:
        """Strict JSON (RFC 8259: no ``NaN`` or ``Infinity``; unknown numbers are ``null``).

        >>> import json; json.loads(summarize(Moves.empty()).to_json())["bounds"]
        [[None, None, None], [None, None, None]]
        """
        return json.dumps(self.to_dict(), indent=2, allow_nan=False)

    def format(self) -> str:
        """A short human-readable report."""
        def box(b):
            if b[0][0] is None or not math.isfinite(b[0][0]):
                return "none"
            return (f"X {b[0][0]:.3f}…{b[1][0]:.3f}  Y {b[0][1]:.3f}…{b[1][1]:.3f}  "
                    f"Z {b[0][2]:.3f}…{b[1][2]:.3f} mm")
        counts = ", ".join(f"{k} {v}" for k, v in self.counts.items() if v)
        lines = []
        if self.source_lines is not None:
            lines.append(f"lines           {self.source_lines}")
        lines += [
            f"moves           {self.moves} ({counts or 'none'})",
            f"bounds          {box(self.bounds)}",
            f"cut bounds      {box(self.cut_bounds)}",
            f"cut length      {self.cut_length_mm:.3f} mm",
            f"travel length   {self.travel_length_mm:.3f} mm",
            f"laser-on time   {_hms(self.laser_on_time_s)}",
            f"dwell time      {_hms(self.dwell_time_s)}",
            f"estimated time  {_hms(self.estimated_time_s)} (constant feed; rapids at "
            f"{self.rapid_mm_min:g} mm/min)",
        ]
        if self.records:
            lines.append(f"records         {self.records}")
        if self.diagnostics:
            lines.append(f"diagnostics     {self.diagnostics}")
        lines += [f"{k:<15} {v}" for k, v in self.extra.items()]
        return "\n".join(lines)


def _finite_or_none(value):
    if isinstance(value, dict):
        return {k: _finite_or_none(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite_or_none(v) for v in value]
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, np.integer):
        return int(value)
    return value


def _hms(seconds: float) -> str:
    if not math.isfinite(seconds):
        return "unknown"
    m, s = divmod(seconds, 60.0)
    h, m = divmod(int(m), 60)
    return f"{h:d}:{m:02d}:{s:06.3f} ({seconds:.3f} s)"


#: Rows :func:`summarize` takes at once (a few MB of temporaries each time).
SUMMARY_ROWS = 1 << 18


def summarize(moves: Moves, *, rapid_mm_min: float = DEFAULT_RAPID_MM_MIN,
              source_lines: int | None = None) -> JobSummary:
    """Lengths, bounds and a constant-feed time estimate of a program.

    Parameters
    ----------
    moves : Moves
    rapid_mm_min : float
        Speed assumed for G0, mm/min.
    source_lines : int, optional
        Number of lines of the source text, reported as is.

    Examples
    --------
    >>> from labkit.gcode import parse
    >>> s = summarize(parse("G0 X10\\nM3 S1000\\nG1 X20 F600\\nG4 P1\\nM5"), rapid_mm_min=600)
    >>> s.cut_length_mm, s.travel_length_mm, s.laser_on_time_s, s.estimated_time_s
    (10.0, 10.0, 1.0, 3.0)
    """
    check_moves(moves)
    if not rapid_mm_min > 0:
        raise ValueError(f"rapid_mm_min must be > 0 mm/min, got {rapid_mm_min!r}")
    # In blocks of rows (views, not copies): a photo's millions of moves never need a
    # dozen temporaries of their full length at once (138 MB for 2.26 M moves).
    cut_length = travel_length = idle_length = laser_time = feed_time = rapid_time = 0.0
    cut_box = np.full((2, 3), np.nan)
    for lo in range(0, len(moves), SUMMARY_ROWS):
        part = moves[lo:lo + SUMMARY_ROWS]
        length = part.lengths_mm()
        cut = part.laser_on
        feed_rows = part.is_feed
        with np.errstate(divide="ignore", invalid="ignore"):
            t_feed = np.where(feed_rows, length / part.feed_mm_min * 60.0, 0.0)
        cut_length += float(length[cut].sum())
        travel_length += float(length[part.is_motion & ~cut].sum())
        idle_length += float(length[feed_rows & ~cut].sum())
        laser_time += float(t_feed[cut].sum())
        feed_time += float(t_feed.sum())
        rapid_time += float(length[part.kind == MoveKind.RAPID].sum()) / rapid_mm_min * 60.0
        box = part.bounds(cut)
        cut_box = np.array([np.fmin(cut_box[0], box[0]), np.fmax(cut_box[1], box[1])])
    dwell = float(moves.dwell_s[moves.kind == MoveKind.DWELL].sum())
    kinds, counts = np.unique(moves.kind, return_counts=True)
    count_map = {k.name.lower(): 0 for k in MoveKind}
    for k, c in zip(kinds, counts):
        count_map[MoveKind(int(k)).name.lower()] = int(c)
    return JobSummary(
        moves=len(moves),
        counts=count_map,
        bounds=moves.bounds().tolist(),
        cut_bounds=cut_box.tolist(),
        cut_length_mm=cut_length,
        travel_length_mm=travel_length,
        laser_on_time_s=laser_time,
        dwell_time_s=dwell,
        estimated_time_s=feed_time + rapid_time + dwell,
        rapid_mm_min=float(rapid_mm_min),
        source_lines=source_lines,
        records=len(moves.records),
        diagnostics=len(moves.diagnostics) + moves.dropped_diagnostics,
        cut_moves=int(moves.laser_on.sum()),
        idle_feed_length_mm=idle_length,
    )
