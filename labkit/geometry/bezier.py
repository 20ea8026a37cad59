"""Bezier curves: evaluation, De Casteljau split and flattening ([LaserApp] §3.4.2, [DobotLaser]).

A cubic is a (4, 2) array of control points S, C1, C2, E in mm; a quadratic
(S, C, E) is raised to the cubic S, (S + 2C)/3, (E + 2C)/3, E ([LaserApp]
eq. 21), so everything downstream handles cubics only.

Two flatteners turn a cubic into a polyline:

:func:`flatten_cubics` — recursive De Casteljau halving ([LaserApp]): split at
t = ½ until the control points lie close to the chord. [LaserApp] stops at a
distance of 1 % of the chord (``chord_fraction=0.01``); a machine needs an
absolute tolerance in mm (``tol_mm``), which also *bounds* the error: the
curve lies in the convex hull of its control points, so if both control
points are within ``tol_mm`` of the chord *segment*, so is every curve point.
([LaserApp] measures the distance to the infinite chord line; the segment
distance also catches curves that overshoot the chord's ends.)

:func:`flatten_adaptive_t` — [DobotLaser]'s t-stepping (the svg-to-gcode library's
``line_segment_approximation``): walk t from 0 to 1, try a step, measure the
largest curve-to-line distance on that t range; above ``error_cap`` shrink
the step by ``increment_growth`` and retry, below ``error_floor`` grow it.
"""

from __future__ import annotations

import math

import numpy as np

from labkit._jit import jit
from labkit.errors import GeometryError

__all__ = [
    "quad_to_cubic",
    "cubic_point",
    "split_cubic",
    "flatness",
    "flatten_cubic",
    "flatten_cubics",
    "flatten_adaptive_t",
    "cubic_samples",
]


def _cubic(ctrl) -> np.ndarray:
    c = np.asarray(ctrl, dtype=float)
    if c.shape != (4, 2):
        raise GeometryError(f"a cubic Bezier needs 4 control points (4, 2), got shape {c.shape}")
    return c


def quad_to_cubic(start, control, end) -> np.ndarray:
    """Exact degree elevation of a quadratic Bezier ([LaserApp] eq. 21).

    >>> quad_to_cubic((0, 0), (3, 3), (6, 0))
    array([[0., 0.],
           [2., 2.],
           [4., 2.],
           [6., 0.]])
    """
    s, c, e = (np.asarray(p, dtype=float) for p in (start, control, end))
    return np.array([s, (s + 2 * c) / 3, (e + 2 * c) / 3, e])


def cubic_point(ctrl, t) -> np.ndarray:
    """Point(s) of a cubic at parameter(s) t (Bernstein form, [LaserApp] eq. 20)."""
    c = _cubic(ctrl)
    return _bernstein(c, np.asarray(t, dtype=float)[..., None])


def _bernstein(c, t):
    """Σ Bᵢ(t)·cᵢ for control points c[..., i, :] and parameters t broadcast against them."""
    u = 1.0 - t
    return (u**3 * c[..., 0, :] + 3 * u * u * t * c[..., 1, :] + 3 * u * t * t * c[..., 2, :]
            + t**3 * c[..., 3, :])


def split_cubic(ctrl, t=0.5) -> tuple[np.ndarray, np.ndarray]:
    """De Casteljau split at t into two cubics that together trace the same curve.

    Repeated linear interpolation of the control polygon ([LaserApp] eqs.
    22–23 give the t = ½ case).

    Examples
    --------
    >>> left, right = split_cubic([[0, 0], [0, 10], [10, 10], [10, 0]])
    >>> left
    array([[0. , 0. ],
           [0. , 5. ],
           [2.5, 7.5],
           [5. , 7.5]])
    >>> bool((left[-1] == right[0]).all())
    True
    """
    c = _cubic(ctrl)
    if not 0.0 <= t <= 1.0:
        raise GeometryError(f"split parameter t must be in [0, 1], got {t!r}")
    ab = c[0] + t * (c[1] - c[0])
    bc = c[1] + t * (c[2] - c[1])
    cd = c[2] + t * (c[3] - c[2])
    abc = ab + t * (bc - ab)
    bcd = bc + t * (cd - bc)
    mid = abc + t * (bcd - abc)
    return np.array([c[0], ab, abc, mid]), np.array([mid, bcd, cd, c[3]])


def flatness(ctrl, *, segment=True) -> float:
    """Larger distance of the two inner control points from the chord S–E, mm.

    ``segment=False`` gives [LaserApp]'s eq. 24 (distance to the infinite line).

    >>> flatness([[0, 0], [1, 2], [3, -1], [4, 0]])
    2.0
    """
    c = _cubic(ctrl)
    return float(_flatness(c[0, 0], c[0, 1], c[1, 0], c[1, 1], c[2, 0], c[2, 1], c[3, 0], c[3, 1],
                           segment))


@jit
def _point_distance(px, py, sx, sy, ex, ey, segment):
    dx, dy = ex - sx, ey - sy
    L2 = dx * dx + dy * dy
    if L2 == 0.0:
        return math.hypot(px - sx, py - sy)
    if not segment:
        return abs(dy * px - dx * py + ex * sy - ey * sx) / math.sqrt(L2)
    t = ((px - sx) * dx + (py - sy) * dy) / L2
    t = min(1.0, max(0.0, t))
    return math.hypot(px - sx - t * dx, py - sy - t * dy)


@jit
def _flatness(x0, y0, x1, y1, x2, y2, x3, y3, segment):
    return max(_point_distance(x1, y1, x0, y0, x3, y3, segment),
               _point_distance(x2, y2, x0, y0, x3, y3, segment))


#: Curves the numpy twin of _flatten_kernel halves at once (a few tens of MB at fine tolerances).
_CURVES_AT_ONCE = 4096


def _flatten_numpy(ctrl, tol, frac, max_depth, segment):
    """:func:`_flatten_kernel` as numpy, for when it runs as Python: every piece of one depth
    is tested and halved at once, then the accepted pieces are put back in the kernel's order
    (curve by curve, by where each starts on its curve). The same halving arithmetic, so the
    same points."""
    m = ctrl.shape[0]
    if m == 0:
        return np.empty((0, 2)), np.zeros(0, np.int64)
    if m > _CURVES_AT_ONCE:              # bounded memory: curves are independent, in order
        parts = [_flatten_numpy(ctrl[k:k + _CURVES_AT_ONCE], tol, frac, max_depth, segment)
                 for k in range(0, m, _CURVES_AT_ONCE)]
        return np.concatenate([p for p, _ in parts]), np.concatenate([n for _, n in parts])
    cid = np.arange(m)
    t0 = np.zeros(m)                        # where a piece starts on its curve
    depth = 0
    c = ctrl
    keep_c, keep_id, keep_t = [], [], []
    while len(c):
        s, e = c[:, 0], c[:, 3]
        f = np.maximum(_point_distance_np(c[:, 1], s, e, segment),
                       _point_distance_np(c[:, 2], s, e, segment))
        limit = frac * np.hypot(e[:, 0] - s[:, 0], e[:, 1] - s[:, 1]) if frac > 0.0 else tol
        done = (f <= limit) | (depth >= max_depth)
        keep_c.append(e[done])
        keep_id.append(cid[done])
        keep_t.append(t0[done])
        c, cid, t0 = c[~done], cid[~done], t0[~done]
        ab = 0.5 * (c[:, 0] + c[:, 1])
        bc = 0.5 * (c[:, 1] + c[:, 2])
        cd = 0.5 * (c[:, 2] + c[:, 3])
        abc = 0.5 * (ab + bc)
        bcd = 0.5 * (bc + cd)
        mid = 0.5 * (abc + bcd)
        depth += 1
        c = np.concatenate([np.stack([c[:, 0], ab, abc, mid], axis=1),
                            np.stack([mid, bcd, cd, c[:, 3]], axis=1)])
        cid = np.concatenate([cid, cid])
        t0 = np.concatenate([t0, t0 + 0.5 ** depth])
    ids = np.concatenate(keep_id)
    order = np.lexsort((np.concatenate(keep_t), ids))
    return np.concatenate(keep_c).reshape(-1, 2)[order], np.bincount(ids, minlength=m).astype(np.int64)


def _point_distance_np(p, s, e, segment):
    """:func:`_point_distance` of many points (k, 2) to their chords s–e (k, 2)."""
    dx, dy = e[:, 0] - s[:, 0], e[:, 1] - s[:, 1]
    L2 = dx * dx + dy * dy
    px, py = p[:, 0] - s[:, 0], p[:, 1] - s[:, 1]
    with np.errstate(invalid="ignore", divide="ignore"):
        if not segment:
            d = np.abs(dy * p[:, 0] - dx * p[:, 1] + e[:, 0] * s[:, 1] - e[:, 1] * s[:, 0]) / np.sqrt(L2)
            return np.where(L2 == 0.0, np.hypot(px, py), d)
        t = np.clip((px * dx + py * dy) / L2, 0.0, 1.0)
    t = np.where(L2 == 0.0, 0.0, t)
    return np.hypot(px - t * dx, py - t * dy)


# as Python the numpy twin above runs: ~4 µs a control value at 0.01 mm (measured on 20,000
# and 200,000), so Python costs a load of numba (LOAD_COST_S) at about 200,000
@jit(python_below=200_000, python=_flatten_numpy)
def _flatten_kernel(ctrl, tol, frac, max_depth, segment):
    """Flatten m cubics (m, 4, 2); returns (points, counts): counts[i] points per curve,
    the first point of each curve omitted (it is the previous curve's end)."""
    m = ctrl.shape[0]
    cap = 64 * m + 16
    out = np.empty((cap, 2))
    counts = np.zeros(m, np.int64)
    k = 0
    stack = np.empty((max_depth + 2, 4, 2))
    depth = np.empty(max_depth + 2, np.int64)
    for i in range(m):
        top = 0
        stack[0] = ctrl[i]
        depth[0] = 0
        while top >= 0:
            c = stack[top].copy()
            d = depth[top]
            top -= 1
            f = _flatness(c[0, 0], c[0, 1], c[1, 0], c[1, 1], c[2, 0], c[2, 1], c[3, 0], c[3, 1], segment)
            limit = tol
            if frac > 0.0:
                limit = frac * math.hypot(c[3, 0] - c[0, 0], c[3, 1] - c[0, 1])
            if f <= limit or d >= max_depth:
                if k >= cap:
                    bigger = np.empty((2 * cap, 2))
                    bigger[:cap] = out
                    out = bigger
                    cap *= 2
                out[k, 0] = c[3, 0]
                out[k, 1] = c[3, 1]
                k += 1
                counts[i] += 1
                continue
            # De Casteljau at t = 1/2; push the right half first so the left is cut first
            ab = 0.5 * (c[0] + c[1])
            bc = 0.5 * (c[1] + c[2])
            cd = 0.5 * (c[2] + c[3])
            abc = 0.5 * (ab + bc)
            bcd = 0.5 * (bc + cd)
            mid = 0.5 * (abc + bcd)
            top += 1
            stack[top, 0] = mid
            stack[top, 1] = bcd
            stack[top, 2] = cd
            stack[top, 3] = c[3]
            depth[top] = d + 1
            top += 1
            stack[top, 0] = c[0]
            stack[top, 1] = ab
            stack[top, 2] = abc
            stack[top, 3] = mid
            depth[top] = d + 1
    return out[:k], counts


def _check_tol(tol_mm, chord_fraction):
    if (tol_mm is None) == (chord_fraction is None):
        raise GeometryError("give exactly one of tol_mm (absolute, mm) or chord_fraction "
                            "([LaserApp]'s relative rule, e.g. 0.01)")
    if tol_mm is not None and not tol_mm > 0:
        raise GeometryError(f"tol_mm must be > 0 mm, got {tol_mm!r}")
    if chord_fraction is not None and not 0 < chord_fraction < 1:
        raise GeometryError(f"chord_fraction must be in (0, 1), got {chord_fraction!r}")


def flatten_cubics(ctrls, tol_mm=None, *, chord_fraction=None, max_depth=24,
                   segment=True) -> tuple[np.ndarray, np.ndarray]:
    """Flatten many cubics at once by recursive De Casteljau halving (compiled kernel).

    Parameters
    ----------
    ctrls : array_like, shape (m, 4, 2)
        Control points, mm.
    tol_mm : float, optional
        Absolute flatness limit, mm (bounds the deviation; see module notes).
    chord_fraction : float, optional
        [LaserApp]'s rule instead: stop when the flatness is below this fraction
        of the chord (0.01 in the seed). Gives no bound in mm.
    max_depth : int
        Deepest halving (2**24 pieces per curve at most).
    segment : bool
        Measure to the chord segment (True) or its infinite line ([LaserApp]).

    Returns
    -------
    points : ndarray, shape (k, 2)
        The end point of every piece, curve after curve (each curve's start
        is left out: it is the previous end or the caller's start).
    counts : ndarray of int, shape (m,)
        Pieces per curve.
    """
    _check_tol(tol_mm, chord_fraction)
    c = np.ascontiguousarray(ctrls, dtype=float).reshape(-1, 4, 2)
    return _flatten_kernel(c, float(tol_mm or 0.0), float(chord_fraction or 0.0), int(max_depth),
                           bool(segment))


def flatten_cubic(ctrl, tol_mm=None, *, chord_fraction=None, max_depth=24, segment=True) -> np.ndarray:
    """One cubic as a polyline (start included), by De Casteljau halving.

    Examples
    --------
    >>> arch = [[0, 0], [0, 10], [10, 10], [10, 0]]
    >>> len(flatten_cubic(arch, tol_mm=0.1)) - 1, len(flatten_cubic(arch, tol_mm=0.01)) - 1
    (16, 32)
    >>> len(flatten_cubic(arch, chord_fraction=0.01)) - 1      # [LaserApp]'s 1 % rule
    78
    """
    c = _cubic(ctrl)
    pts, _ = flatten_cubics(c[None], tol_mm, chord_fraction=chord_fraction, max_depth=max_depth,
                            segment=segment)
    return np.vstack([c[:1], pts])


def _max_distance_to_line(ctrl, t0, t1, p0, p1, samples):
    ts = np.linspace(t0, t1, samples)
    pts = cubic_point(ctrl, ts)
    d = p1 - p0
    L = math.hypot(*d)
    if L == 0:
        return float(np.max(np.hypot(*(pts - p0).T)))
    s = np.clip(((pts - p0) @ d) / (L * L), 0.0, 1.0)
    return float(np.max(np.hypot(*(pts - p0 - s[:, None] * d).T)))


def flatten_adaptive_t(ctrl, error_cap, *, increment_growth=1.1, error_floor=None,
                       samples=16, counter=None) -> np.ndarray:
    """[DobotLaser]'s adaptive t-stepping: a polyline whose pieces stay within ``error_cap`` mm.

    Parameters
    ----------
    ctrl : array_like, shape (4, 2)
    error_cap : float
        Largest allowed curve-to-line distance, mm (measured on ``samples``
        points of each trial range, so not a strict bound).
    increment_growth : float
        Factor (> 1) by which the t step shrinks after a failed try and grows
        after a very good one ([DobotLaser] default 1.1).
    error_floor : float, optional
        Below this the step grows; default (growth − 1)·cap as in [DobotLaser].
    samples : int
        Points per trial range at which the distance is measured.
    counter : dict, optional
        If given, ``counter["trials"]`` counts the trial steps (work measure).

    Returns
    -------
    ndarray, shape (k + 1, 2)

    Examples
    --------
    >>> arch = [[0, 0], [0, 10], [10, 10], [10, 0]]
    >>> work = {}
    >>> pts = flatten_adaptive_t(arch, 0.1, counter=work)
    >>> len(pts) - 1, work["trials"] > len(pts)
    (9, True)
    """
    c = _cubic(ctrl)
    if not error_cap > 0:
        raise GeometryError(f"error_cap must be > 0 mm, got {error_cap!r}")
    if not increment_growth > 1:
        raise GeometryError(f"increment_growth must be > 1, got {increment_growth!r}")
    floor = (increment_growth - 1) * error_cap if error_floor is None else error_floor
    t, step = 0.0, 1.0
    pts = [c[0]]
    trials = 0
    while t < 1.0:
        t_new = min(1.0, t + step)
        end = cubic_point(c, t_new)
        trials += 1
        dist = _max_distance_to_line(c, t, t_new, pts[-1], end, samples)
        if dist > error_cap:
            step /= increment_growth
            continue
        if dist < floor:
            step *= increment_growth
        pts.append(end)
        t = t_new
    if counter is not None:
        counter["trials"] = counter.get("trials", 0) + trials
    return np.array(pts)


def cubic_samples(ctrls, per_curve) -> np.ndarray:
    """Points of many cubics at evenly spaced parameters, curve after curve.

    Parameters
    ----------
    ctrls : array_like, shape (m, 4, 2)
        Control points, mm.
    per_curve : int or array_like of int, shape (m,)
        Samples of each curve (≥ 2), its end points included.

    Returns
    -------
    ndarray, shape (sum(per_curve), 2)

    Examples
    --------
    >>> cubic_samples([[[0, 0], [1, 2], [2, 2], [3, 0]]], 3).tolist()
    [[0.0, 0.0], [1.5, 1.5], [3.0, 0.0]]
    """
    c = np.asarray(ctrls, dtype=float).reshape(-1, 4, 2)
    n = np.broadcast_to(np.maximum(np.asarray(per_curve, dtype=np.int64), 2), (len(c),))
    idx = np.repeat(np.arange(len(c)), n)
    first = np.repeat(np.cumsum(n) - n, n)
    t = ((np.arange(len(idx)) - first) / (n[idx] - 1))[:, None]
    return _bernstein(c[idx], t)
