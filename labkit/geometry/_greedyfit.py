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
from labkit.geometry._quadratic import RELATIVE_EPS, stable_quadratic_roots

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


def _fit_runs_python(p, tol, allow_arcs):
    """:func:`fit_runs` as plain Python, for when it runs as Python: the same search and the same
    arithmetic in the same order (so the same runs, centres and sweeps), with the samples as
    lists of floats and each test's loop written out — the per-sample helpers (the band's two
    roots a sample) inlined, which makes it about three times faster than ``fit_runs`` itself
    run as Python."""
    xs, ys = p[:, 0].tolist(), p[:, 1].tolist()
    n = len(xs)
    hypot, sqrt, atan2, nan = math.hypot, math.sqrt, math.atan2, math.nan
    eps, max_r, near_tol, two_tol = RELATIVE_EPS, _MAX_RADIUS_MM, LINE_SHARE * tol, 2.0 * tol
    full_turn = 2.0 * math.pi - 1e-6

    def line_fits(i, j, limit):
        sx, sy = xs[i], ys[i]
        dx, dy = xs[j] - sx, ys[j] - sy
        L2 = dx * dx + dy * dy
        worst = 0.0
        for k in range(i + 1, j):
            qx, qy = xs[k] - sx, ys[k] - sy
            if L2 == 0.0:
                d = hypot(qx, qy)
            else:
                t = (qx * dx + qy * dy) / L2
                t = t if t > 0.0 else 0.0
                t = t if t < 1.0 else 1.0
                d = hypot(qx - t * dx, qy - t * dy)
            if d > limit:
                return -1.0
            if d > worst:
                worst = d
        return worst

    def arc_check(i, j, cx, cy):
        ax, ay = xs[i], ys[i]
        r = hypot(ax - cx, ay - cy)
        if r > max_r:
            return -2.0, 0.0
        ex, ey = xs[j] - cx, ys[j] - cy
        sx, sy = ax - cx, ay - cy
        mid = (i + j) // 2
        qx, qy = xs[mid] - cx, ys[mid] - cy
        turn = (sx * qy - sy * qx) if mid != i else (sx * ey - sy * ex)
        sign = 1.0 if turn > 0 else -1.0
        sweep = worst = e_prev = 0.0
        px, py = sx, sy
        rr = r * r
        for k in range(i + 1, j + 1):
            qx, qy = xs[k] - cx, ys[k] - cy
            e = abs(hypot(qx, qy) - r)
            if e > tol:
                return -1.0, 0.0
            if e > worst:
                worst = e
            step = atan2(px * qy - py * qx, px * qx + py * qy)
            if step * sign < 0.0:
                return -1.0, 0.0
            half = 0.5 * hypot(qx - px, qy - py)
            s2 = rr - half * half
            sag = r - sqrt(0.0 if 0.0 > s2 else s2)
            if sag + (e_prev if e_prev > e else e) > tol:
                return -1.0, 0.0
            sweep += step
            px, py = qx, qy
            e_prev = e
        if abs(sweep) >= full_turn:
            return -1.0, 0.0
        return worst, sweep

    def root(a2, a1, a0):
        """_band_root's root of −a2… written out: stable_quadratic_roots(a2, a1, a0), then the
        root in [−1, 1] on the falling branch (NaN when none)."""
        scale = abs(a2) + abs(a1) + abs(a0)
        if scale == 0.0:
            return nan
        if abs(a2) <= eps * scale:
            if abs(a1) <= eps * scale:
                return nan
            r1 = -a0 / a1
            return r1 if -1.0 <= r1 <= 1.0 and 2.0 * a2 * r1 + a1 <= 0.0 else nan
        disc = a1 * a1 - 4.0 * a2 * a0
        if disc < 0.0:
            if disc < -eps * a1 * a1:
                return nan
            disc = 0.0
        sq = sqrt(disc)
        q = -0.5 * (a1 + (sq if a1 >= 0.0 else -sq))
        r1 = q / a2
        r2 = a0 / q if q != 0.0 else r1
        if r1 > r2:
            r1, r2 = r2, r1
        if -1.0 <= r1 <= 1.0 and 2.0 * a2 * r1 + a1 <= 0.0:
            return r1
        if -1.0 <= r2 <= 1.0 and 2.0 * a2 * r2 + a1 <= 0.0:
            return r2
        return nan

    def band(i, j):
        ax, ay = xs[i], ys[i]
        bx, by = xs[j], ys[j]
        ux, uy = bx - ax, by - ay
        L = hypot(ux, uy)
        if L == 0.0:
            return -2.0, 0.0, 0.0, 0.0
        h = 0.5 * L
        ux, uy = ux / L, uy / L
        mx, my = 0.5 * (ax + bx), 0.5 * (ay + by)
        hh, tt = h * h, tol * tol
        lo, hi = -1.0, 1.0
        for k in range(i + 1, j):
            dx, dy = xs[k] - mx, ys[k] - my
            x = dx * ux + dy * uy
            y = -dx * uy + dy * ux
            A = (x * x + y * y - hh - tt) / h
            if A > two_tol:
                return -2.0, 0.0, 0.0, 0.0
            if A >= -two_tol:
                continue
            # _band_root(A, 2y, tol) and _band_root(A, 2y, -tol): the quadratics −(B ± 2tol) t² +
            # 2A t + (B ∓ 2tol) share 2A (< 0 here), their discriminant and so √ and q; where
            # either is near linear or the discriminant is negative, the general root below
            # (each root's choice written out, not a call: a call per root costs a tenth of the fit)
            B = 2.0 * y
            a1 = 2.0 * A
            a2, a0 = -(B + two_tol), B - two_tol           # ε = tol
            b2, b0 = -(B - two_tol), B + two_tol           # ε = −tol
            m2, m0, m1 = abs(a2), abs(a0), -a1
            disc = a1 * a1 - 4.0 * a2 * a0
            if m2 > eps * (m2 + m1 + m0) and m0 > eps * (m0 + m1 + m2) and disc >= 0.0:
                q = -0.5 * (a1 - sqrt(disc))
                r1, r2 = q / a2, a0 / q
                if r1 > r2:
                    r1, r2 = r2, r1
                if -1.0 <= r1 <= 1.0 and 2.0 * a2 * r1 + a1 <= 0.0:
                    t_lo = r1
                elif -1.0 <= r2 <= 1.0 and 2.0 * a2 * r2 + a1 <= 0.0:
                    t_lo = r2
                else:
                    t_lo = nan
                r1, r2 = q / b2, b0 / q
                if r1 > r2:
                    r1, r2 = r2, r1
                if -1.0 <= r1 <= 1.0 and 2.0 * b2 * r1 + a1 <= 0.0:
                    t_hi = r1
                elif -1.0 <= r2 <= 1.0 and 2.0 * b2 * r2 + a1 <= 0.0:
                    t_hi = r2
                else:
                    t_hi = nan
            else:
                t_lo, t_hi = root(a2, a1, a0), root(b2, a1, b0)
            if t_lo == t_lo:                               # not NaN: ε ≤ tol from here up
                if t_lo > lo:
                    lo = t_lo
            elif y > tol:
                return -2.0, 0.0, 0.0, 0.0
            if t_hi == t_hi:                               # ε ≥ −tol up to here
                if t_hi < hi:
                    hi = t_hi
            elif y < -tol:
                return -2.0, 0.0, 0.0, 0.0
            if lo > hi:
                return -2.0, 0.0, 0.0, 0.0
        t = 0.5 * (lo + hi)
        if abs(t) * 2.0 * max_r <= h * (1.0 + t * t):
            return -2.0, 0.0, 0.0, 0.0
        off = h * (1.0 - t * t) / (2.0 * t)
        cx, cy = mx + uy * off, my - ux * off
        e, sweep = arc_check(i, j, cx, cy)
        return e, cx, cy, sweep

    def three_point(i, j):
        m = (i + j) // 2
        ax, ay = xs[i], ys[i]
        ux, uy = xs[m] - ax, ys[m] - ay
        vx, vy = xs[j] - ax, ys[j] - ay
        d = 2.0 * (ux * vy - uy * vx)
        u2 = ux * ux + uy * uy
        v2 = vx * vx + vy * vy
        if abs(d) <= 1e-14 * sqrt(u2 * v2) or d == 0.0:
            return -2.0, 0.0, 0.0, 0.0
        cx = ax + (vy * u2 - uy * v2) / d
        cy = ay + (ux * v2 - vx * u2) / d
        e, sweep = arc_check(i, j, cx, cy)
        return e, cx, cy, sweep

    def attempt(i, j):
        """_try: (miss, kind, cx, cy, sweep)."""
        if not allow_arcs:
            return line_fits(i, j, tol), 0, 0.0, 0.0, 0.0
        e = line_fits(i, j, near_tol)
        if e >= 0.0:
            return e, 0, 0.0, 0.0, 0.0
        if j - i >= 2:
            e, cx, cy, sweep = band(i, j)
            if e >= 0.0:
                return e, 1, cx, cy, sweep
            e, cx, cy, sweep = three_point(i, j)
            if e >= 0.0:
                return e, 1, cx, cy, sweep
            if e == -1.0:
                return -1.0, 0, 0.0, 0.0, 0.0
        return line_fits(i, j, tol), 0, 0.0, 0.0, 0.0

    ends, cxs, cys, sweeps = [], [], [], []
    worst_all = 0.0
    i = 0
    while i < n - 1:
        best = (0.0, 0, 0.0, 0.0, 0.0)
        best_j, lo, hi, step = i + 1, i + 1, n, 2
        while True:
            j = i + step
            if j >= n:
                j = n - 1
            got = attempt(i, j)
            if got[0] >= 0.0:
                lo, best_j, best = j, j, got
                if j == n - 1:
                    hi = n
                    break
                step *= 2
            else:
                hi = j
                break
        while hi - lo > 1:
            j = (lo + hi) // 2
            got = attempt(i, j)
            if got[0] >= 0.0:
                lo, best_j, best = j, j, got
            else:
                hi = j
        err, kind, cx, cy, sweep = best
        ends.append(best_j)
        if kind == 1:
            cxs.append(cx), cys.append(cy), sweeps.append(sweep)
        else:
            cxs.append(nan), cys.append(nan), sweeps.append(0.0)
        worst_all = max(worst_all, err)
        i = best_j
    return (np.array(ends, np.int64), np.array([cxs, cys]).T.reshape(-1, 2).copy(),
            np.array(sweeps, float), worst_all)


# as Python (the twin above): 5.2–5.9 µs a sample coordinate at 0.1 and 0.01 mm (measured on
# drawings of 4 to 1,800 shapes), so Python costs a load of numba (LOAD_COST_S) at ~180,000
@jit(python_below=180_000, python=_fit_runs_python)
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


def _fit_many_python(p, starts, tol, allow_arcs):
    """:func:`fit_runs_many` as Python: :func:`_fit_runs_python` on each curve."""
    parts = [(_fit_runs_python(p[a:b], tol, allow_arcs), a)
             for a, b in zip(starts[:-1].tolist(), starts[1:].tolist()) if b - a >= 2]
    m = len(starts) - 1
    counts, worst = np.zeros(m, np.int64), np.zeros(m)
    live = np.flatnonzero(np.diff(starts) >= 2)
    for c, ((e, _, _, w), _) in zip(live, parts):
        counts[c], worst[c] = len(e), w
    if not parts:
        return np.zeros(0, np.int64), np.zeros((0, 2)), np.zeros(0), counts, worst
    return (np.concatenate([e + a for (e, _, _, _), a in parts]), np.vstack([r[1] for r, _ in parts]),
            np.concatenate([r[2] for r, _ in parts]), counts, worst)


@jit(python_below=180_000, python=_fit_many_python)      # as fit_runs: ~5.5 µs a coordinate
def fit_runs_many(p, starts, tol, allow_arcs):
    """:func:`fit_runs` on each curve ``p[starts[c]:starts[c + 1]]`` (curves of fewer than two
    samples give no runs), in one call.

    Returns ``ends`` (indices into ``p`` of each run's last sample), ``centres`` and ``sweeps``
    of every run, curve after curve, ``counts`` (runs per curve) and ``worst`` (each curve's
    largest miss)."""
    m = starts.shape[0] - 1
    total = max(p.shape[0], 1)
    ends = np.empty(total, np.int64)
    centres = np.empty((total, 2))
    sweeps = np.empty(total)
    counts = np.zeros(m, np.int64)
    worst = np.zeros(m)
    k = 0
    for c in range(m):
        a, b = starts[c], starts[c + 1]
        if b - a < 2:
            continue
        e, cen, sw, w = fit_runs(p[a:b], tol, allow_arcs)
        r = e.shape[0]
        ends[k:k + r] = e + a
        centres[k:k + r] = cen
        sweeps[k:k + r] = sw
        counts[c] = r
        worst[c] = w
        k += r
    return ends[:k], centres[:k], sweeps[:k], counts, worst
