"""The greedy fit's kernels (``method="greedy"`` of :mod:`labkit.geometry.arcfit`).

From each sample, the longest run of samples that one line or one arc fits within the
tolerance (exponential then binary search). The arc for a run is chosen on the run's
chord by :func:`_arc_fits_band` (closed-form interval per sample), else the circle
through its first, middle and last samples (:func:`_arc_fits`); :func:`_arc_check`
alone accepts a circle — every sample radially within the tolerance and every chord
between samples too.
"""

from __future__ import annotations

import math

import numpy as np

from labkit._jit import jit
from labkit.geometry._quadratic import stable_quadratic_roots

_MAX_RADIUS_MM = 1e4
#: Lines are preferred only when this close (share of tol); otherwise an arc is tried first,
#: so that lines do not eat into the corner arcs of an offset.
LINE_SHARE = 0.05


@jit
def _line_fits(p, i, j, tol):
    sx, sy = p[i, 0], p[i, 1]
    dx, dy = p[j, 0] - sx, p[j, 1] - sy
    L2 = dx * dx + dy * dy
    worst = 0.0
    for k in range(i + 1, j):
        qx, qy = p[k, 0] - sx, p[k, 1] - sy
        if L2 == 0.0:
            d = math.hypot(qx, qy)
        else:
            t = min(1.0, max(0.0, (qx * dx + qy * dy) / L2))
            d = math.hypot(qx - t * dx, qy - t * dy)
        if d > tol:
            return -1.0
        worst = max(worst, d)
    return worst


@jit
def _arc_fits(p, i, j, tol, out):
    """Circle through p[i], p[mid], p[j]; out = (cx, cy, sweep).

    Returns the max error, -1 if it does not fit, -2 if the points are too
    nearly straight for a usable circle."""
    m = (i + j) // 2
    ax, ay = p[i, 0], p[i, 1]
    ux, uy = p[m, 0] - ax, p[m, 1] - ay
    vx, vy = p[j, 0] - ax, p[j, 1] - ay
    d = 2.0 * (ux * vy - uy * vx)
    u2 = ux * ux + uy * uy
    v2 = vx * vx + vy * vy
    if abs(d) <= 1e-14 * math.sqrt(u2 * v2) or d == 0.0:
        return -2.0
    cx = ax + (vy * u2 - uy * v2) / d
    cy = ay + (ux * v2 - vx * u2) / d
    return _arc_check(p, i, j, tol, cx, cy, out)


@jit
def _arc_check(p, i, j, tol, cx, cy, out):
    """Whether the arc about (cx, cy) from p[i] to p[j] stays within tol of the polyline
    p[i..j]; out = (cx, cy, sweep). Returns the max error, -1 if it does not fit, -2 if the
    radius is too large for a usable arc."""
    ax, ay = p[i, 0], p[i, 1]
    r = math.hypot(ax - cx, ay - cy)
    if r > _MAX_RADIUS_MM:
        return -2.0
    # the direction of travel: the turn from the chord to the far end, seen from the centre
    ex, ey = p[j, 0] - cx, p[j, 1] - cy
    sx, sy = ax - cx, ay - cy
    mid = (i + j) // 2
    qx, qy = p[mid, 0] - cx, p[mid, 1] - cy
    turn = (sx * qy - sy * qx) if mid != i else (sx * ey - sy * ex)
    sign = 1.0 if turn > 0 else -1.0
    sweep = 0.0
    worst = 0.0
    px, py = sx, sy
    e_prev = 0.0
    for k in range(i + 1, j + 1):
        qx, qy = p[k, 0] - cx, p[k, 1] - cy
        e = abs(math.hypot(qx, qy) - r)
        if e > tol:
            return -1.0
        worst = max(worst, e)
        step = math.atan2(px * qy - py * qx, px * qx + py * qy)
        if step * sign < 0.0:
            return -1.0
        # the input between two samples is a straight chord: the arc strays from it by
        # its sagitta plus the larger radial miss of the chord's two ends (both ends count:
        # a long chord after a sample off the circle drew a 0.13 mm miss at 0.1 mm)
        half = 0.5 * math.hypot(qx - px, qy - py)
        sag = r - math.sqrt(max(r * r - half * half, 0.0))
        if sag + max(e, e_prev) > tol:
            return -1.0
        sweep += step
        px, py = qx, qy
        e_prev = e
    if abs(sweep) >= 2.0 * math.pi - 1e-6:
        return -1.0
    out[0], out[1], out[2] = cx, cy, sweep
    return worst


@jit
def _band_root(A, B, e):
    """t = tan(θ/2) in [−1, 1] where A sin θ + B cos θ = 2e, on the branch where the left
    side falls as θ grows (there the distance it stands for falls too); nan when none.

    With sin θ = 2t/(1 + t²) and cos θ = (1 − t²)/(1 + t²) the equation is the
    quadratic −(B + 2e) t² + 2A t + (B − 2e) = 0 — no trigonometry."""
    a2, a1, a0 = -(B + 2.0 * e), 2.0 * A, B - 2.0 * e
    n, r1, r2 = stable_quadratic_roots(a2, a1, a0)
    # at most one root has the falling side (the derivative changes sign between them)
    if n >= 1 and -1.0 <= r1 <= 1.0 and 2.0 * a2 * r1 + a1 <= 0.0:
        return r1
    if n == 2 and -1.0 <= r2 <= 1.0 and 2.0 * a2 * r2 + a1 <= 0.0:
        return r2
    return math.nan


@jit
def _arc_fits_band(p, i, j, tol, out):
    """The circle through p[i] and p[j] that best fits the samples between them: of the arcs
    of at most half a turn on that chord (half-sweep θ, curvature sin θ / h), the middle of
    the range of t = tan(θ/2) over which every sample lies within ``tol`` radially.

    A sample q at (x, y) in the chord's frame (origin at its middle, half length
    h) is a signed distance ε(θ) from the arc, with ε = e exactly where
    (K − e²)/h · sin θ + 2y cos θ = 2e, K = x² + y² − h²; near the arc ε falls
    as θ grows, so each sample allows one interval of θ (found by
    :func:`_band_root`). A minor arc stays inside the circle on its chord, so a
    sample more than ``tol`` outside that circle rules the chord out. The
    chosen circle is then checked by :func:`_arc_check`, which alone decides;
    returns its result, or -2 when no θ suits every sample."""
    ax, ay = p[i, 0], p[i, 1]
    bx, by = p[j, 0], p[j, 1]
    ux, uy = bx - ax, by - ay
    L = math.hypot(ux, uy)
    if L == 0.0:
        return -2.0
    h = 0.5 * L
    ux, uy = ux / L, uy / L
    mx, my = 0.5 * (ax + bx), 0.5 * (ay + by)
    lo, hi = -1.0, 1.0
    for k in range(i + 1, j):
        dx, dy = p[k, 0] - mx, p[k, 1] - my
        x = dx * ux + dy * uy
        y = -dx * uy + dy * ux
        A = (x * x + y * y - h * h - tol * tol) / h
        if A > 2.0 * tol:                  # farther than tol outside the chord's circle
            return -2.0
        if A >= -2.0 * tol:                # near the chord's ends every arc passes close
            continue
        t = _band_root(A, 2.0 * y, tol)    # ε ≤ tol from here up
        if not math.isnan(t):
            lo = max(lo, t)
        elif y > tol:
            return -2.0
        t = _band_root(A, 2.0 * y, -tol)   # ε ≥ −tol up to here
        if not math.isnan(t):
            hi = min(hi, t)
        elif y < -tol:
            return -2.0
        if lo > hi:
            return -2.0
    t = 0.5 * (lo + hi)
    if abs(t) * 2.0 * _MAX_RADIUS_MM <= h * (1.0 + t * t):
        return -2.0                        # straight: a line fits or nothing does
    # the centre lies on the chord's bisector, R cos θ = h (1 − t²) / 2t from its middle,
    # on the side away from the bulge (the bulge is to the chord's left for t > 0)
    off = h * (1.0 - t * t) / (2.0 * t)
    cx, cy = mx + uy * off, my - ux * off
    return _arc_check(p, i, j, tol, cx, cy, out)


@jit
def _try(p, i, j, tol, allow_arcs, buf):
    """Fit samples i..j: a near-exact line, else an arc, else (if the samples are too
    straight for a circle of usable radius) a line within tol."""
    if not allow_arcs:
        return _line_fits(p, i, j, tol), 0
    e = _line_fits(p, i, j, LINE_SHARE * tol)
    if e >= 0.0:
        return e, 0
    if j - i >= 2:
        e = _arc_fits_band(p, i, j, tol, buf)
        if e >= 0.0:
            return e, 1
        e = _arc_fits(p, i, j, tol, buf)
        if e >= 0.0:
            return e, 1
        if e == -1.0:
            return -1.0, 0
    return _line_fits(p, i, j, tol), 0


# views: as Python it indexes p element by element, on Python floats (twice as fast)
@jit(python_below=20_000, views=True)  # sample coordinates: ~1 µs each as Python (n log n)
def fit_runs(p, tol, allow_arcs):
    n = p.shape[0]
    ends = np.empty(n, np.int64)
    centres = np.full((n, 2), np.nan)
    sweeps = np.zeros(n)
    k = 0
    worst_all = 0.0
    buf = np.empty(3)
    best_buf = np.empty(3)
    i = 0
    while i < n - 1:
        # exponential then binary search for the longest run i..j one primitive fits
        best_j, best_kind, best_err = i + 1, 0, 0.0
        lo, hi = i + 1, n          # lo fits (adjacent points always fit a line); hi does not
        step = 2
        while True:
            j = i + step
            if j >= n:
                j = n - 1
            e, kind = _try(p, i, j, tol, allow_arcs, buf)
            if e >= 0.0:
                lo, best_j, best_kind, best_err = j, j, kind, e
                best_buf[:] = buf
                if j == n - 1:
                    hi = n
                    break
                step *= 2
            else:
                hi = j
                break
        while hi - lo > 1:
            j = (lo + hi) // 2
            e, kind = _try(p, i, j, tol, allow_arcs, buf)
            if e >= 0.0:
                lo, best_j, best_kind, best_err = j, j, kind, e
                best_buf[:] = buf
            else:
                hi = j
        ends[k] = best_j
        if best_kind == 1:
            centres[k, 0] = best_buf[0]
            centres[k, 1] = best_buf[1]
            sweeps[k] = best_buf[2]
        worst_all = max(worst_all, best_err)
        k += 1
        i = best_j
    return ends[:k], centres[:k], sweeps[:k], worst_all
