"""Curves to circular arcs within a tolerance ([MicroCAM] §6.1.4).

Cutting a curve as many short lines makes many G-code blocks and short
segments, and [MicroCAM] measured that segments shorter than ~0.4 mm keep a
controller below the programmed feed. Replacing the curve by arcs (G2/G3)
that stay within a tolerance gives fewer, longer blocks. Two methods:

``method="greedy"`` (the default) flattens Béziers at ``FLATTEN_SHARE·tol``
(:func:`labkit.geometry.bezier.flatten_cubics`) and then, from the current
sample, takes the longest run of samples that one line or one arc fits
within the rest of the tolerance (exponential then binary search). The arc
for a run is chosen on the run's chord: of the arcs of up to a half turn
through the run's two end samples, the one in the middle of the range of
curvatures for which every sample lies within the tolerance (each sample
allows one interval, found in closed form — :mod:`labkit.geometry._greedyfit`); when
that range is empty, the circle through the first, middle and last samples
is tried. A candidate is accepted only if every sample is within the
tolerance radially and every chord between samples is too (its sagitta
under the arc plus the larger miss of its two ends), so the bound holds
between samples as well. The pieces end on samples of the curve, so joints
are exact; on a smooth curve they are not tangent-continuous (the kink at a
joint is bounded by the tolerance), while on polylines made of true lines and
arcs (offsets) they are, since the fit finds those exactly.

``method="biarc"`` (:mod:`labkit.geometry.biarc`) fits the cubics directly
and is tangent-continuous (G1) wherever the curve is, for controllers and
studies that need it; it uses more blocks. The curve is cut into pieces,
each replaced by a biarc — two circular arcs through the piece's end
points, leaving and arriving along the curve's own tangents and sharing a
tangent where they meet. Each piece is grown greedily as long as its biarc
stays within ``tol_mm`` of the curve, measured both ways on dense samples.
Pieces end at cusps and corners; next pieces share the curve's tangent at
their common point. Straight pieces come out as lines, arcs of one circle
are merged, and a cubic that is a circular arc comes back as that arc.

* Beziers (:func:`cubics_to_arcs`) are fitted directly: the tangents come from
  the control polygon of each piece (the first non-vanishing of C1 − S,
  C2 − S, E − S, which stays right at cusps and coincident control points),
  and the samples from the cubic itself — no flattening budget is spent.
* Dense polylines (:func:`fit_arcs`) take tangents from the circle through
  each vertex and its neighbours, follow a much longer neighbouring segment
  (a straight edge meeting a curve tangentially) and treat a vertex turning
  by more than :data:`CORNER_RAD` as a corner.

The biarc fit checks its error on samples, so it keeps ``1 - SAMPLE_SHARE``
of the tolerance for the curve between samples and for the written G-code's
rounding; where its samples may misjudge a curve it re-measures densely.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from labkit.errors import GeometryError
from labkit.geometry._greedyfit import fit_runs_many
from labkit.geometry.bezier import cubic_samples, flatten_cubics
from labkit.geometry.path import Path

__all__ = ["fit_arcs", "cubics_to_arcs", "cubic_chains_to_arcs", "chain_fits", "coordinate_limit_mm", "tolerance_budget", "ToleranceBudget",
           "sampling_share", "FLATTEN_SHARE", "CORNER_RAD", "KINK_RAD", "METHODS"]

#: Share of the tolerance spent on sampling a curve before a polyline fit (the rest fits).
#: Denser samples leave more to the fit and give longer arcs (0.15 → 0.1: 8 % fewer
#: blocks on the cncjs drawing at 0.1 mm, for 15 % more fitting time).
FLATTEN_SHARE = 0.1


def sampling_share(tol_mm: float) -> tuple[float, float]:
    """A reading tolerance shared between sampling a curve and fitting lines and arcs to
    the samples: the one place :data:`FLATTEN_SHARE` is applied.

    Parameters
    ----------
    tol_mm : float
        What reading the curve may deviate in all, mm.

    Returns
    -------
    sample_mm, fit_mm : float
        The samples stay within ``sample_mm`` of the curve (``FLATTEN_SHARE · tol_mm``) and
        the fit within ``fit_mm`` of the samples (the rest), mm.

    Examples
    --------
    >>> sampling_share(0.1)
    (0.010000000000000002, 0.09)
    """
    sample = FLATTEN_SHARE * tol_mm
    return sample, tol_mm - sample


@dataclass(frozen=True)
class ToleranceBudget:
    """How a job's tolerance is shared between the steps that approximate the drawing.

    Attributes
    ----------
    read_mm : float
        Reading the drawing: curves become lines and arcs within this, mm.
    chords_mm : float
        Arcs become chords within this when the controller gets no arcs (0 with arcs), mm.
    emit_mm : float
        Coordinate resolution of the written G-code (the writer rounds within it), mm.
    """

    read_mm: float
    chords_mm: float
    emit_mm: float


def tolerance_budget(tol_mm: float, *, arcs: bool = True) -> ToleranceBudget:
    """Share ``tol_mm`` between reading, chording and writing a vector job.

    The reader and the chords share the tolerance (half each without arcs, so a DXF arc
    read exactly and then chorded stays within it); the written resolution is a tenth of
    the tolerance, at most 1 µm (finer than any laser machine resolves), and goes on top.

    Parameters
    ----------
    tol_mm : float
        Largest deviation of the cut from the drawing, mm (> 0).
    arcs : bool
        Whether the G-code keeps arcs (G2/G3).

    Examples
    --------
    >>> tolerance_budget(0.01, arcs=False)
    ToleranceBudget(read_mm=0.005, chords_mm=0.005, emit_mm=0.001)
    >>> tolerance_budget(0.002)
    ToleranceBudget(read_mm=0.002, chords_mm=0.0, emit_mm=0.0002)
    """
    if not (isinstance(tol_mm, (int, float)) and 0 < tol_mm < math.inf):
        raise GeometryError(f"tol_mm must be a finite number > 0 mm, got {tol_mm!r}")
    tol = float(tol_mm)
    if arcs:
        return ToleranceBudget(tol, 0.0, min(tol / 10.0, 0.001))
    return ToleranceBudget(tol / 2.0, tol / 2.0, min(tol / 10.0, 0.001))


def coordinate_limit_mm(tol_mm: float) -> float:
    """Largest coordinate magnitude at which geometry can still be computed within ``tol_mm``.

    A double resolves |x| to |x|·2⁻⁵²; arc centres, chord sags and offsets lose a few
    more bits. Beyond ``tol_mm · 2⁴⁰`` (11,000 km at 0.01 mm) a drawing's numbers no
    longer carry its tolerance and flattening them only burns memory, so readers refuse
    them with the element's name.

    >>> round(coordinate_limit_mm(0.01) / 1e6)     # km
    10995
    """
    return float(tol_mm) * 2.0 ** 40


#: A polyline vertex turning by more than this (rad) is a corner for :func:`fit_arcs`.
CORNER_RAD = math.radians(50.0)
#: Joints between cubics whose tangents differ by more than this (rad) are corners;
#: a biarc piece may run across smoother joints.
KINK_RAD = math.radians(1.0)
#: Share of the tolerance the biarc fit may use on its samples (the rest covers the
#: curve between samples).
SAMPLE_SHARE = 0.85
#: Fits of a cubic chain tried at shrinking shares until the densely measured deviation
#: is within tolerance (:func:`_measured_deviation`).
VERIFY_ROUNDS = 4
METHODS = ("greedy", "biarc")
#: Largest kink the fit leaves between two of its own segments where the curve is smooth (rad).
G1_TOL_RAD = math.radians(1.0)
_NO_BREAKS = np.empty(0)
#: Samples per segment when fitting a polyline: its midpoint and its end vertex.
_POLYLINE_SAMPLES = 2


def _check_method(method):
    if method not in METHODS:
        raise GeometryError(f"method must be one of {METHODS}, got {method!r}")


def fit_arcs(points, tol_mm, *, arcs=True, closed=False, base_deviation_mm=0.0, method="greedy",
             **meta) -> Path:
    """Replace a dense polyline by fewer lines and circular arcs within ``tol_mm``.

    Parameters
    ----------
    points : array_like, shape (n, 2)
        Samples of a curve, mm, in order (n ≥ 2).
    tol_mm : float
        Largest distance of any sample from the primitive replacing it, mm.
    arcs : bool
        False allows straight lines only (a polyline simplification).
    closed : bool
        The points form a loop (first = last).
    base_deviation_mm : float
        Deviation already in the samples (added to the reported deviation).
    method : {"greedy", "biarc"}
        The greedy longest-run fit (default) or tangent-continuous biarcs on
        estimated vertex tangents (see the module docstring). ``arcs=False``
        always simplifies greedily.
    **meta
        Layer and colours of the :class:`Path`.

    Returns
    -------
    Path
        Its piece ends are a subset of ``points`` (a biarc adds its joint);
        ``deviation_mm`` is the largest distance measured between the
        polyline (vertices and chord midpoints) and the output, plus
        ``base_deviation_mm``.

    Examples
    --------
    Two hundred samples of a half circle become one arc:

    >>> import numpy as np
    >>> t = np.linspace(0, np.pi, 200)
    >>> p = fit_arcs(np.c_[10 * np.cos(t), 10 * np.sin(t)], 0.001)
    >>> p.n_segments, round(float(p.radii_mm()[0]), 6), round(float(p.sweeps[0]), 6)
    (1, 10.0, 3.141593)

    A square stays four lines (its corners are corners):

    >>> sq = fit_arcs([[0, 0], [10, 0], [10, 10], [0, 10], [0, 0]], 0.1, closed=True)
    >>> sq.n_segments, int(sq.is_arc.sum())
    (4, 0)
    """
    _check_method(method)
    p = np.ascontiguousarray(points, dtype=float).reshape(-1, 2)
    if len(p) < 2:
        raise GeometryError(f"fit_arcs needs at least 2 points, got {len(p)}")
    if not tol_mm > 0:
        raise GeometryError(f"tol_mm must be > 0 mm, got {tol_mm!r}")
    keep = np.concatenate(([True], np.any(np.diff(p, axis=0) != 0, axis=1)))
    p = p[keep]
    if len(p) < 2:
        raise GeometryError("fit_arcs: all points coincide")
    if arcs and method == "biarc":
        loop = bool(closed and len(p) >= 4)
        if closed and np.allclose(p[0], p[-1], rtol=0, atol=1e-9):
            p[-1] = p[0]
        elif closed:
            p = np.vstack([p, p[:1]])
        from labkit.geometry._biarcfit import hermite_chain      # the biarc fit's kernels load on use

        seg = np.hypot(*np.diff(p, axis=0).T)
        ctrl = hermite_chain(p, loop, CORNER_RAD, max(4.0 * float(tol_mm), 2.0 * float(np.median(seg))))
        half = np.array([float((len(p) - 1) // 2)]) if loop else _NO_BREAKS
        return _fit(ctrl, tol_mm, loop, half, shape=_straight_cubics(p), closed=closed,
                    base_deviation_mm=base_deviation_mm, **meta)
    if closed and len(p) >= 5:
        # fit the two halves of a loop apart, so that a circle becomes two half arcs
        # rather than one arc short of a full turn plus a sliver
        mid = len(p) // 2
        (v1, c1, s1, w1), (v2, c2, s2, w2) = _greedy_runs([p[:mid + 1], p[mid:]], float(tol_mm), arcs)
        verts, centres, sweeps = np.vstack([v1, v2[1:]]), np.vstack([c1, c2]), np.concatenate([s1, s2])
        worst = max(w1, w2)
    else:
        ((verts, centres, sweeps, worst),) = _greedy_runs([p], float(tol_mm), arcs)
    return Path(verts, centres, sweeps, closed=closed,
                deviation_mm=float(worst) + base_deviation_mm, **meta)


def _greedy_runs(polylines, tol_mm: float, arcs: bool) -> list[tuple]:
    """The greedy fit of many polylines (each (n, 2), n ≥ 2, no two neighbours equal) in one
    kernel call: per polyline its vertices (a subset of its points), centres, sweeps and
    largest miss."""
    sizes = np.array([len(q) for q in polylines], np.int64)
    starts = np.concatenate([[0], np.cumsum(sizes)])
    pts = np.ascontiguousarray(np.concatenate(polylines), dtype=float) if len(polylines) > 1 \
        else np.ascontiguousarray(polylines[0], dtype=float)
    ends, centres, sweeps, counts, worst = fit_runs_many(pts, starts, float(tol_mm), bool(arcs))
    first = np.concatenate([[0], np.cumsum(counts)])
    out = []
    for k in range(len(polylines)):
        a, b = first[k], first[k + 1]
        out.append((np.vstack([pts[starts[k]:starts[k] + 1], pts[ends[a:b]]]), centres[a:b],
                    sweeps[a:b], float(worst[k])))
    return out


def _straight_cubics(p: np.ndarray) -> np.ndarray:
    """The polyline ``p`` (n, 2) as n − 1 straight cubics (control points at the thirds),
    each of which traces its segment at uniform speed."""
    a, b = p[:-1], p[1:]
    return np.ascontiguousarray(np.stack([a, a + (b - a) / 3.0, b - (b - a) / 3.0, b], axis=1))


def _fit(ctrl, tol_mm, closed_loop, breaks, *, shape=None, base_deviation_mm=0.0, closed=False,
         **meta) -> Path:
    """Fit the cubic chain ``ctrl``; with ``shape`` (a polyline as straight cubics), fit that
    polyline, following the tangents ``ctrl`` estimates at its vertices. A polyline is measured
    at each vertex and segment midpoint; a curve by density, then re-measured where its
    samples may misjudge it."""
    from labkit.geometry._biarcfit import fit_cubic_chain

    ctrl = np.ascontiguousarray(ctrl)
    polyline = shape is not None
    shape = shape if polyline else ctrl
    per_cubic = _POLYLINE_SAMPLES if polyline else 0
    share = SAMPLE_SHARE
    for _ in range(VERIFY_ROUNDS):
        # the kernel turns tangents by up to its limit; 2 % headroom keeps the joints that
        # the written arcs actually make within G1_TOL_RAD
        v, cen, sw, worst, _ = fit_cubic_chain(ctrl, shape, share * float(tol_mm), KINK_RAD,
                                               closed_loop, breaks, 2.0, 0.98 * G1_TOL_RAD, per_cubic)
        if len(sw) == 0:                               # the chain is a single point
            v, cen, sw = np.vstack([ctrl[0, :1], ctrl[-1, 3:]]), None, None
        coarse = None if polyline else _samples_may_hide(ctrl, float(tol_mm))
        if coarse is None or not coarse.any():
            break                                      # the kernel's samples resolve the curve
        path = Path(v, cen, sw, closed=closed, **meta)
        worst = max(float(worst), _measured_deviation(path, ctrl[coarse], float(tol_mm)))
        if worst <= tol_mm:
            break
        share *= 0.7                                   # a tight loop slipped between samples
    return Path(v, cen, sw, closed=closed, deviation_mm=float(worst) + base_deviation_mm, **meta)


def _samples_may_hide(ctrl: np.ndarray, tol_mm: float) -> np.ndarray:
    """Which cubics the fit's samples (about _PER_CUBIC per cubic) may misjudge by more than
    the tolerance share kept in reserve (1 - SAMPLE_SHARE).

    Between samples s apart a curve of radius r strays s²/(8r) from their chord, and the
    second difference of the samples is about s²/r: where |Δ²p|/8 stays within the reserve
    the fit's own measure is close enough; elsewhere (tight loops, near-cusps, fine
    tolerances) the result is checked densely.
    """
    from labkit.geometry._biarcfit import _PER_CUBIC

    pts = cubic_samples(ctrl, _PER_CUBIC + 1).reshape(len(ctrl), _PER_CUBIC + 1, 2)
    d2 = pts[:, :-2] - 2.0 * pts[:, 1:-1] + pts[:, 2:]
    return np.hypot(d2[..., 0], d2[..., 1]).max(axis=1) / 8.0 > (1.0 - SAMPLE_SHARE) * tol_mm


def _measured_deviation(path: Path, ctrl: np.ndarray, tol_mm: float) -> float:
    """Largest distance (mm) from the given cubics to the fitted arcs, on dense curve samples.

    The fit judges pieces on about 40 samples per cubic, which a loop tighter than the
    tolerance can slip between. Here every cubic is sampled at least every tol/2 along
    its control polygon (which bounds its length); the arcs' distance back to the curve
    is the kernel's own measure.
    """
    from labkit.geometry.measure import path_distance

    polygon = np.hypot(*np.diff(ctrl, axis=1).transpose(2, 0, 1)).sum(axis=1)
    counts = np.clip(np.ceil(polygon / (0.5 * tol_mm)), 8, 4000).astype(np.int64)
    curve = cubic_samples(ctrl, counts + 1)
    return float(path_distance(path, curve).max())


def cubics_to_arcs(ctrls, tol_mm, *, arcs=True, start=None, method="greedy", **meta) -> Path:
    """A chain of cubic Beziers (m, 4, 2) as lines and arcs within ``tol_mm``.

    Parameters
    ----------
    ctrls : array_like, shape (m, 4, 2)
        Control points in mm; each cubic starts where the previous one ends.
    tol_mm : float
        Largest distance between the curve and the output, mm.
    arcs : bool
        False gives lines only (De Casteljau flattening, then simplification).
    start : array_like (2,), optional
        Start point to use instead of the first control point (the exact end
        of whatever came before).
    method : {"greedy", "biarc"}
        ``"greedy"`` (default) flattens them at ``FLATTEN_SHARE·tol_mm`` and
        fits the longest lines and arcs to the samples with the rest of the
        budget (fewest blocks); ``"biarc"`` fits the cubics directly and is
        tangent-continuous (see the module docstring).
    **meta
        Layer and colours of the :class:`Path`.

    Returns
    -------
    Path
        ``deviation_mm`` bounds the distance to the curve: greedy, the
        flattening share plus the fit's largest miss of the samples and of
        the chords between them; biarc, the largest distance measured on
        about 80 samples per cubic and 32 per piece, both ways (densely
        re-measured where those may miss).

    Notes
    -----
    [MicroCAM] §6.1.4 converts curves to arcs "by matching curve curvature
    radius values based on the input tolerance"; the biarc is the standard
    modern form of that idea.

    Examples
    --------
    A quarter circle drawn as the usual cubic (k = 0.5523) comes back as one arc:

    >>> k = 0.5522847498
    >>> p = cubics_to_arcs([[[10, 0], [10, 10 * k], [10 * k, 10], [0, 10]]], 0.01)
    >>> p.n_segments, int(p.is_arc.sum()), round(float(p.radii_mm()[0]), 2)
    (1, 1, 10.0)

    An S-curve: with ``method="biarc"`` arcs turning both ways, every joint
    within :data:`G1_TOL_RAD` of tangent-continuous:

    >>> from labkit.geometry.biarc import tangent_angles
    >>> s = cubics_to_arcs([[[0, 0], [10, 10], [20, -10], [30, 0]]], 0.01, method="biarc")
    >>> s.n_segments, sorted(set(np.sign(s.sweeps).tolist())), bool(tangent_angles(s).max() <= G1_TOL_RAD + 1e-12)
    (8, [-1.0, 1.0], True)
    """
    _check_method(method)
    if not tol_mm > 0:
        raise GeometryError(f"tol_mm must be > 0 mm, got {tol_mm!r}")
    c = np.array(ctrls, dtype=float).reshape(-1, 4, 2)
    if len(c) == 0:
        raise GeometryError("cubics_to_arcs needs at least one cubic, got none")
    if start is not None:
        c[0, 0] = np.asarray(start, dtype=float).reshape(2)
    if arcs and method == "biarc":
        return _fit(c, tol_mm, False, _NO_BREAKS, **meta)
    if arcs:
        return cubic_chains_to_arcs([c], tol_mm, **meta)[0]
    flat_tol, fit_tol = sampling_share(tol_mm)
    pts, _ = flatten_cubics(c, flat_tol)
    dense = np.vstack([c[:1, 0], pts])
    return fit_arcs(dense, fit_tol, arcs=arcs, base_deviation_mm=flat_tol,
                    method="greedy", **meta)


def cubic_chains_to_arcs(chains, tol_mm, **meta) -> list[Path]:
    """Many chains of cubic Beziers as lines and arcs, each as :func:`cubics_to_arcs` makes it
    with ``method="greedy"`` and arcs on: the same Paths, with every chain flattened in one
    kernel call and fitted in one more (a drawing's hundreds of chains cost two calls).

    Parameters
    ----------
    chains : sequence of array_like, each shape (m, 4, 2)
        Control points in mm; within a chain each cubic starts where the one before ends.
    tol_mm : float
        Largest distance between each curve and its Path, mm.
    **meta
        Layer and colours of every Path.

    Returns
    -------
    list of Path
        One per chain, open, in order.

    Examples
    --------
    >>> k = 0.5522847498
    >>> quarter = [[[10, 0], [10, 10 * k], [10 * k, 10], [0, 10]]]
    >>> a, b = cubic_chains_to_arcs([quarter, np.array(quarter) * 2], 0.01)
    >>> round(float(a.radii_mm()[0]), 2), round(float(b.radii_mm()[0]), 2)
    (10.0, 20.0)
    """
    return [Path(v, c, s, deviation_mm=dev, **meta) for v, c, s, dev in chain_fits(chains, tol_mm)]


def chain_fits(chains, tol_mm) -> list[tuple]:
    """:func:`cubic_chains_to_arcs` without making the Paths, for a reader that puts the pieces
    into Paths of its own.

    Parameters
    ----------
    chains : sequence of array_like, each shape (m, 4, 2)
        Control points in mm; within a chain each cubic starts where the one before ends.
    tol_mm : float
        Largest distance between each curve and its lines and arcs, mm.

    Returns
    -------
    list of tuple
        Per chain: vertices (k + 1, 2) in mm, centres (k, 2) in mm (NaN for lines), sweeps (k,)
        in rad (0 for lines) and the deviation bound in mm, as the Path would hold them.

    Examples
    --------
    >>> v, c, s, dev = chain_fits([[[[0, 0], [1, 1], [2, 1], [3, 0]]]], 0.01)[0]
    >>> v.shape[1], c.shape[1], len(s) == len(v) - 1, dev <= 0.01
    (2, 2, True, True)
    """
    if not tol_mm > 0:
        raise GeometryError(f"tol_mm must be > 0 mm, got {tol_mm!r}")
    if not len(chains):
        return []
    ctrl = [np.asarray(c, dtype=float).reshape(-1, 4, 2) for c in chains]
    if any(len(c) == 0 for c in ctrl):
        raise GeometryError("cubics_to_arcs needs at least one cubic, got none")
    flat_tol, fit_tol = sampling_share(tol_mm)
    pts, counts = flatten_cubics(np.concatenate(ctrl) if len(ctrl) > 1 else ctrl[0], flat_tol)
    # the points of each chain, its start first, without repeats (as fit_arcs keeps them)
    per_chain = np.array([len(c) for c in ctrl])
    sizes = np.add.reduceat(counts, np.concatenate([[0], np.cumsum(per_chain)[:-1]]))
    chain_of = np.repeat(np.arange(len(ctrl)), sizes + 1)
    dense = np.empty((len(pts) + len(ctrl), 2))
    heads = np.concatenate([[0], np.cumsum(sizes + 1)[:-1]])
    dense[heads] = [c[0, 0] for c in ctrl]
    body = np.ones(len(dense), bool)
    body[heads] = False
    dense[body] = pts
    keep = np.ones(len(dense), bool)
    keep[1:] = np.any(dense[1:] != dense[:-1], axis=1)
    keep[heads] = True
    dense, chain_of = dense[keep], chain_of[keep]
    bounds = np.searchsorted(chain_of, np.arange(len(ctrl) + 1))
    polylines = [dense[a:b] for a, b in zip(bounds[:-1], bounds[1:])]
    if any(len(q) < 2 for q in polylines):
        raise GeometryError("fit_arcs: all points coincide")
    return [(v, c, s, w + flat_tol) for v, c, s, w in _greedy_runs(polylines, fit_tol, True)]
