"""Compiled kernels that fit biarcs to chains of cubic Beziers and to dense polylines.

Both grow a piece greedily (try the whole remaining run, then double or halve,
then bisect) as long as one biarc (:mod:`labkit.geometry.biarc`) through the
piece's ends, with the curve's tangents there, stays within the tolerance of
the curve measured both ways. Consecutive pieces share the curve's tangent at
their common point, so the output is tangent-continuous wherever the input is.
"""

from __future__ import annotations

import math

import numpy as np

from labkit._jit import jit
from labkit.geometry._quadratic import stable_quadratic_roots
from labkit.geometry.biarc import LINE_SAGITTA_MM, MAX_JOINT_REACH

_FULL_TURN = 2.0 * math.pi - 1e-6


@jit
def _unit(x, y):
    n = math.hypot(x, y)
    if n == 0.0:
        return 0.0, 0.0, 0.0
    return x / n, y / n, n


@jit
def _arc_from_tangent(ax, ay, tx, ty, bx, by):
    """Arc from A (unit tangent t) to B: (cx, cy, sweep); sweep 0 means a line, 2π none."""
    vx, vy = bx - ax, by - ay
    L2 = vx * vx + vy * vy
    if L2 == 0.0:
        return math.nan, math.nan, 0.0
    cr = tx * vy - ty * vx
    dt = tx * vx + ty * vy
    if cr == 0.0 and dt < 0.0:           # the tangent points straight away from B: no arc
        return math.nan, math.nan, 2.0 * math.pi
    sweep = 2.0 * math.atan2(cr, dt)
    k = 2.0 * cr / L2
    # sagitta of the arc over its chord: (L/2)·tan(|sweep|/4)
    if k == 0.0 or 0.5 * math.sqrt(L2) * math.tan(0.25 * abs(sweep)) <= LINE_SAGITTA_MM:
        return math.nan, math.nan, 0.0
    r = 1.0 / k
    return ax - r * ty, ay + r * tx, sweep


@jit
def _two_arcs(p0x, p0y, t0x, t0y, jx, jy, tjx, tjy, p1x, p1y, out):
    """The arcs p0 (tangent t0) → J and J (tangent tj) → p1 into out; False if either closes."""
    c1x, c1y, s1 = _arc_from_tangent(p0x, p0y, t0x, t0y, jx, jy)
    c2x, c2y, s2 = _arc_from_tangent(jx, jy, tjx, tjy, p1x, p1y)
    if abs(s1) >= _FULL_TURN or abs(s2) >= _FULL_TURN:
        return False
    out[0], out[1] = jx, jy
    out[2], out[3], out[4] = c1x, c1y, s1
    out[5], out[6], out[7] = c2x, c2y, s2
    return True


@jit
def _biarc(p0x, p0y, t0x, t0y, p1x, p1y, t1x, t1y, out):
    """Equal-tangent-length biarc; out = (jx, jy, c1x, c1y, s1, c2x, c2y, s2). False if none."""
    vx, vy = p1x - p0x, p1y - p0y
    c = vx * vx + vy * vy
    if c == 0.0:
        return False
    a = 2.0 * (t0x * t1x + t0y * t1y - 1.0)
    b = vx * (t0x + t1x) + vy * (t0y + t1y)
    den = b + math.sqrt(max(b * b - a * c, 0.0))
    if den <= 1e-12 * math.sqrt(c):
        return False
    d = c / den
    if d > MAX_JOINT_REACH * math.sqrt(c):
        return False
    q0x, q0y = p0x + d * t0x, p0y + d * t0y
    q1x, q1y = p1x - d * t1x, p1y - d * t1y
    jx, jy = 0.5 * (q0x + q1x), 0.5 * (q0y + q1y)
    ux, uy, n = _unit(q1x - q0x, q1y - q0y)
    if n == 0.0:
        return False
    return _two_arcs(p0x, p0y, t0x, t0y, jx, jy, ux, uy, p1x, p1y, out)


@jit
def _joint_circle(p0x, p0y, t0x, t0y, p1x, p1y, t1x, t1y):
    """The circle on which every biarc joint between these ends lies: (cx, cy, r); r = 0 when
    it is the straight line through p0 and p1 (equal tangents).

    At the joint the two arcs' tangents agree: twice the chord angle of each arc
    minus its end tangent angle match, so the angle between the chords p0→J and
    J→p1 is fixed and J sees p0p1 under a constant angle — a circle through both
    ends, leaving p0 at the chord direction turned by half the angle from t1 to t0."""
    half = 0.5 * math.atan2(t1x * t0y - t1y * t0x, t1x * t0x + t1y * t0y)
    ux, uy, L = _unit(p1x - p0x, p1y - p0y)
    ch, sh = math.cos(half), math.sin(half)
    cx, cy, sw = _arc_from_tangent(p0x, p0y, ch * ux - sh * uy, sh * ux + ch * uy, p1x, p1y)
    if sw == 0.0 or math.isnan(cx):
        return 0.0, 0.0, 0.0
    return cx, cy, math.hypot(p0x - cx, p0y - cy)


@jit
def _joint_side(qx, qy, p0x, p0y, p1x, p1y, cx, cy, r):
    """Signed side of q relative to the joint circle (or line when r == 0)."""
    if r == 0.0:
        return (p1x - p0x) * (qy - p0y) - (p1y - p0y) * (qx - p0x)
    return math.hypot(qx - cx, qy - cy) - r


@jit
def _biarc_joint(p0x, p0y, t0x, t0y, p1x, p1y, jx, jy, out):
    """The biarc whose joint is J (a point of the joint circle); out as in _biarc."""
    ux, uy, L = _unit(jx - p0x, jy - p0y)
    wx, wy, L2 = _unit(p1x - jx, p1y - jy)
    if L == 0.0 or L2 == 0.0:
        return False
    d = 2.0 * (t0x * ux + t0y * uy)
    tjx, tjy = d * ux - t0x, d * uy - t0y           # t0 mirrored in the first chord
    return _two_arcs(p0x, p0y, t0x, t0y, jx, jy, tjx, tjy, p1x, p1y, out)


@jit
def _seg_distance(qx, qy, ax, ay, bx, by):
    dx, dy = bx - ax, by - ay
    L2 = dx * dx + dy * dy
    if L2 == 0.0:
        return math.hypot(qx - ax, qy - ay)
    t = ((qx - ax) * dx + (qy - ay) * dy) / L2
    t = min(1.0, max(0.0, t))
    return math.hypot(qx - ax - t * dx, qy - ay - t * dy)


@jit
def _arc_distance(qx, qy, ax, ay, cx, cy, sweep, bx, by):
    """Distance from q to the arc A→B (centre c, signed sweep); a line when sweep == 0."""
    if sweep == 0.0:
        return _seg_distance(qx, qy, ax, ay, bx, by)
    sx, sy = ax - cx, ay - cy
    wx, wy = qx - cx, qy - cy
    phi = math.atan2(sx * wy - sy * wx, sx * wx + sy * wy)
    if sweep < 0.0:
        phi = -phi
    if phi < 0.0:
        phi += 2.0 * math.pi
    if phi <= abs(sweep):
        return abs(math.hypot(wx, wy) - math.hypot(sx, sy))
    return min(math.hypot(qx - ax, qy - ay), math.hypot(qx - bx, qy - by))


@jit
def _biarc_error(samples, n, p0x, p0y, p1x, p1y, ba, tol):
    """Two-sided distance between the polyline samples[:n] and the biarc (stops early above tol).

    Curve → biarc: every sample's distance to the nearer arc. Biarc → curve:
    points along each arc to the sample polyline (catches arcs that bulge or
    loop where the samples do not go)."""
    jx, jy = ba[0], ba[1]
    worst = 0.0
    for k in range(n):
        qx, qy = samples[k, 0], samples[k, 1]
        e = min(_arc_distance(qx, qy, p0x, p0y, ba[2], ba[3], ba[4], jx, jy),
                _arc_distance(qx, qy, jx, jy, ba[5], ba[6], ba[7], p1x, p1y))
        if e > worst:
            worst = e
            if worst > tol:
                return worst
    for half in range(2):
        if half == 0:
            ax, ay, cx, cy, sw = p0x, p0y, ba[2], ba[3], ba[4]
        else:
            ax, ay, cx, cy, sw = jx, jy, ba[5], ba[6], ba[7]
        if sw == 0.0:
            continue                      # a line: its points lie between the samples' ends
        sx, sy = ax - cx, ay - cy
        for i in range(1, 8):
            ang = sw * i / 8.0
            ca, sa = math.cos(ang), math.sin(ang)
            qx, qy = cx + ca * sx - sa * sy, cy + sa * sx + ca * sy
            best = math.inf
            for k in range(n - 1):
                dd = _seg_distance(qx, qy, samples[k, 0], samples[k, 1], samples[k + 1, 0], samples[k + 1, 1])
                if dd < best:
                    best = dd
            if best > worst:
                worst = best
                if worst > tol:
                    return worst
    return worst


@jit
def _emit(ba, p0x, p0y, p1x, p1y, verts, centres, sweeps, k):
    """Append the biarc's one or two segments (zero-length ones skipped); returns the new count."""
    jx, jy = ba[0], ba[1]
    if jx != p0x or jy != p0y:
        verts[k + 1, 0], verts[k + 1, 1] = jx, jy
        centres[k, 0], centres[k, 1], sweeps[k] = ba[2], ba[3], ba[4]
        k += 1
    if jx != p1x or jy != p1y:
        verts[k + 1, 0], verts[k + 1, 1] = p1x, p1y
        centres[k, 0], centres[k, 1], sweeps[k] = ba[5], ba[6], ba[7]
        k += 1
    return k


@jit
def _emit_line(p1x, p1y, verts, centres, sweeps, k):
    verts[k + 1, 0], verts[k + 1, 1] = p1x, p1y
    centres[k, 0], centres[k, 1], sweeps[k] = math.nan, math.nan, 0.0
    return k + 1


@jit
def _merge(verts, centres, sweeps, k, eps):
    """Merge neighbours that are one primitive: co-circular arcs turning the same way (their
    union sweeping less than a full turn) and collinear lines. Returns the new count."""
    if k == 0:
        return 0
    w = 0
    for i in range(1, k):
        s0, s1 = sweeps[w], sweeps[i]
        same = False
        if s0 != 0.0 and s1 != 0.0 and s0 * s1 > 0.0 and abs(s0 + s1) < 2.0 * math.pi - 1e-3:
            r0 = math.hypot(verts[w, 0] - centres[w, 0], verts[w, 1] - centres[w, 1])
            r1 = math.hypot(verts[i, 0] - centres[i, 0], verts[i, 1] - centres[i, 1])
            dc = math.hypot(centres[w, 0] - centres[i, 0], centres[w, 1] - centres[i, 1])
            same = dc <= eps and abs(r0 - r1) <= eps
        elif s0 == 0.0 and s1 == 0.0:
            ax, ay = verts[w, 0], verts[w, 1]
            bx, by = verts[i + 1, 0], verts[i + 1, 1]
            # the shared vertex lies on the combined chord, between its ends
            mx, my = verts[i, 0], verts[i, 1]
            dx, dy = bx - ax, by - ay
            L2 = dx * dx + dy * dy
            if L2 > 0.0:
                t = ((mx - ax) * dx + (my - ay) * dy) / L2
                same = 0.0 < t < 1.0 and abs((mx - ax) * dy - (my - ay) * dx) <= eps * math.sqrt(L2)
        if same:
            sweeps[w] = s0 + s1
            verts[w + 1] = verts[i + 1]
        else:
            w += 1
            verts[w + 1] = verts[i + 1]
            centres[w] = centres[i]
            sweeps[w] = sweeps[i]
    return w + 1



#: Samples of the curve per whole cubic (at least ``_MIN_SAMPLES`` per piece) when measuring.
_PER_CUBIC = 80
_MIN_SAMPLES = 32
#: Bisection steps after the bracket is found (piece end within 1/2**steps of the best).
_BISECT = 7
_MIN_STEP = 1e-9
#: Joint positions (share of the joint circle's arc from p0 to p1) tried when the joint
#: where the curve crosses that circle does not fit.
_JOINTS = np.array([0.5, 0.35, 0.65, 0.25, 0.75])


@jit
def _blossom(c, u1, u2, u3):
    ax0 = c[0, 0] + u1 * (c[1, 0] - c[0, 0])
    ay0 = c[0, 1] + u1 * (c[1, 1] - c[0, 1])
    ax1 = c[1, 0] + u1 * (c[2, 0] - c[1, 0])
    ay1 = c[1, 1] + u1 * (c[2, 1] - c[1, 1])
    ax2 = c[2, 0] + u1 * (c[3, 0] - c[2, 0])
    ay2 = c[2, 1] + u1 * (c[3, 1] - c[2, 1])
    bx0 = ax0 + u2 * (ax1 - ax0)
    by0 = ay0 + u2 * (ay1 - ay0)
    bx1 = ax1 + u2 * (ax2 - ax1)
    by1 = ay1 + u2 * (ay2 - ay1)
    return bx0 + u3 * (bx1 - bx0), by0 + u3 * (by1 - by0)


@jit
def _point(c, t):
    u = 1.0 - t
    b0, b1, b2, b3 = u * u * u, 3.0 * u * u * t, 3.0 * u * t * t, t * t * t
    return (b0 * c[0, 0] + b1 * c[1, 0] + b2 * c[2, 0] + b3 * c[3, 0],
            b0 * c[0, 1] + b1 * c[1, 1] + b2 * c[2, 1] + b3 * c[3, 1])


@jit
def _piece_tangent(c, ta, tb, at_end):
    """Unit tangent at the start (or end) of the part [ta, tb] of cubic c, from the part's own
    control polygon: the first non-vanishing of c1 − c0, c2 − c0, c3 − c0 (ends: c3 − c2, …),
    which is the limit direction even where the derivative is zero (cusps, coincident
    control points)."""
    px = np.empty(4)
    py = np.empty(4)
    px[0], py[0] = _blossom(c, ta, ta, ta)
    px[1], py[1] = _blossom(c, ta, ta, tb)
    px[2], py[2] = _blossom(c, ta, tb, tb)
    px[3], py[3] = _blossom(c, tb, tb, tb)
    size = 0.0
    for k in range(1, 4):
        size = max(size, abs(px[k] - px[0]), abs(py[k] - py[0]))
    eps = 1e-9 * size
    for k in range(1, 4):
        if at_end:
            dx, dy = px[3] - px[3 - k], py[3] - py[3 - k]
        else:
            dx, dy = px[k] - px[0], py[k] - py[0]
        if abs(dx) > eps or abs(dy) > eps:
            ux, uy, _ = _unit(dx, dy)
            return ux, uy
    return 0.0, 0.0


@jit
def _turnarounds(c, out):
    """Parameters in (0, 1) where a straight (collinear) cubic stops and runs back: roots of
    B′(t)·d with d along its line."""
    dx, dy = 0.0, 0.0
    for k in range(1, 4):
        if abs(c[k, 0] - c[0, 0]) + abs(c[k, 1] - c[0, 1]) > abs(dx) + abs(dy):
            dx, dy = c[k, 0] - c[0, 0], c[k, 1] - c[0, 1]
    a = (c[1, 0] - c[0, 0]) * dx + (c[1, 1] - c[0, 1]) * dy
    b = (c[2, 0] - c[1, 0]) * dx + (c[2, 1] - c[1, 1]) * dy
    e = (c[3, 0] - c[2, 0]) * dx + (c[3, 1] - c[2, 1]) * dy
    # B'·d / 3 = a(1-t)² + 2b(1-t)t + e t² = (a - 2b + e) t² + 2(b - a) t + a
    return _roots_in_unit(a - 2.0 * b + e, 2.0 * (b - a), a, out)


@jit
def _roots_in_unit(A, B, C, out):
    """Roots of A t² + B t + C strictly inside (0, 1), ascending, written to out; returns how
    many. A near-double root (discriminant within rounding of 0) counts once: a cusp."""
    lo, hi = 1e-7, 1.0 - 1e-7
    n, r1, r2 = stable_quadratic_roots(A, B, C)
    k = 0
    if n >= 1 and lo < r1 < hi:
        out[k] = r1
        k += 1
    if n == 2 and lo < r2 < hi and (k == 0 or r2 - out[k - 1] > 1e-9):
        out[k] = r2
        k += 1
    return k


@jit
def _inflections(c, out):
    """Parameters in (0, 1) where the curvature changes sign or the speed vanishes (cusp):
    roots of cross(B', B''), a quadratic in t. Returns how many were written to out."""
    def f(t):
        u = 1.0 - t
        d1x = 3.0 * (u * u * (c[1, 0] - c[0, 0]) + 2.0 * u * t * (c[2, 0] - c[1, 0]) + t * t * (c[3, 0] - c[2, 0]))
        d1y = 3.0 * (u * u * (c[1, 1] - c[0, 1]) + 2.0 * u * t * (c[2, 1] - c[1, 1]) + t * t * (c[3, 1] - c[2, 1]))
        d2x = 6.0 * (u * (c[2, 0] - 2.0 * c[1, 0] + c[0, 0]) + t * (c[3, 0] - 2.0 * c[2, 0] + c[1, 0]))
        d2y = 6.0 * (u * (c[2, 1] - 2.0 * c[1, 1] + c[0, 1]) + t * (c[3, 1] - 2.0 * c[2, 1] + c[1, 1]))
        return d1x * d2y - d1y * d2x
    f0, fh, f1 = f(0.0), f(0.5), f(1.0)
    # f(t) = A t² + B t + C through the three values
    A = 2.0 * (f1 + f0) - 4.0 * fh
    if abs(A) + abs(f1 - f0 - A) + abs(f0) == 0.0:
        return _turnarounds(c, out)            # a straight cubic: only where it turns back
    return _roots_in_unit(A, f1 - f0 - A, f0, out)


@jit
def _chain_point(shape, T):
    """The point of the chain ``shape`` at global parameter T (cubic i spans [i, i + 1])."""
    m = shape.shape[0]
    i = min(int(math.floor(T)), m - 1)
    return _point(shape[i], T - i)


@jit
def _sample_chain(shape, Ta, Tb, p0x, p0y, buf, tbuf, per_cubic):
    """Samples of the chain ``shape`` between global parameters Ta < Tb into buf (their
    parameters in tbuf); returns (count, buf, tbuf).

    Cubic i covers T in [i, i + 1]. The first sample is the given start point
    (the previous piece's end) so pieces join exactly. Each cubic's part gets
    ``per_cubic`` evenly spaced samples, ending on its end; 0 samples by density
    (``_PER_CUBIC`` per whole cubic, at least ``_MIN_SAMPLES`` per piece)."""
    m = shape.shape[0]
    span = Tb - Ta
    dens = max(float(_PER_CUBIC), _MIN_SAMPLES / span)
    i0 = min(int(math.floor(Ta)), m - 1)
    i1 = max(int(math.ceil(Tb)) - 1, i0)
    need = int(dens * span) + 2 * (i1 - i0 + 1) + 4
    if buf.shape[0] < need:
        buf = np.empty((2 * need, 2))
        tbuf = np.empty(2 * need)
    buf[0, 0], buf[0, 1] = p0x, p0y
    tbuf[0] = Ta
    n = 1
    for i in range(i0, i1 + 1):
        lo = max(Ta - i, 0.0)
        hi = min(Tb - i, 1.0)
        if hi <= lo:
            continue
        k = per_cubic if per_cubic > 0 else max(1, int(math.ceil(dens * (hi - lo))))
        for j in range(1, k + 1):
            t = hi if j == k else lo + (hi - lo) * j / k
            x, y = _point(shape[i], t)
            buf[n, 0], buf[n, 1] = x, y
            tbuf[n] = i + t
            n += 1
    return n, buf, tbuf


@jit
def _curve_joint(shape, buf, tbuf, n, p0x, p0y, t0x, t0y, p1x, p1y, t1x, t1y, ba):
    """The biarc whose joint is where the curve crosses the joint circle (the crossing nearest
    the middle sample, refined on the cubic); the equal-tangent-length biarc when the
    curve does not cross it."""
    cx, cy, r = _joint_circle(p0x, p0y, t0x, t0y, p1x, p1y, t1x, t1y)
    best = -1
    mid = 0.5 * (n - 1)
    prev = _joint_side(buf[1, 0], buf[1, 1], p0x, p0y, p1x, p1y, cx, cy, r)
    for q in range(2, n - 1):
        cur = _joint_side(buf[q, 0], buf[q, 1], p0x, p0y, p1x, p1y, cx, cy, r)
        if (prev < 0.0) != (cur < 0.0):
            if best < 0 or abs(q - 0.5 - mid) < abs(best - 0.5 - mid):
                best = q
        prev = cur
    if best < 0:
        return _biarc(p0x, p0y, t0x, t0y, p1x, p1y, t1x, t1y, ba)
    ta, tb = tbuf[best - 1], tbuf[best]
    fa = _joint_side(buf[best - 1, 0], buf[best - 1, 1], p0x, p0y, p1x, p1y, cx, cy, r)
    jx, jy = buf[best, 0], buf[best, 1]
    for _ in range(40):
        tm = 0.5 * (ta + tb)
        jx, jy = _chain_point(shape, tm)
        fm = _joint_side(jx, jy, p0x, p0y, p1x, p1y, cx, cy, r)
        if (fm < 0.0) == (fa < 0.0):
            ta, fa = tm, fm
        else:
            tb = tm
        if tb - ta <= 1e-13:
            break
    if _biarc_joint(p0x, p0y, t0x, t0y, p1x, p1y, jx, jy, ba):
        return True
    return _biarc(p0x, p0y, t0x, t0y, p1x, p1y, t1x, t1y, ba)


@jit
def _chain_fit(ctrl, shape, Ta, Tb, p0x, p0y, t0x, t0y, single, kink, tol, buf, tbuf, ba, per_cubic):
    """Error over the chain piece [Ta, Tb] of one arc leaving p0 along t0 (``single``), or of
    the biarc from (p0, t0) to the curve's end point and tangent (``ctrl``'s); inf when none
    exists. Fills ba; returns (error, end x, end y, buf, tbuf)."""
    m = ctrl.shape[0]
    n, buf, tbuf = _sample_chain(shape, Ta, Tb, p0x, p0y, buf, tbuf, per_cubic)
    p1x, p1y = buf[n - 1, 0], buf[n - 1, 1]
    ba2 = np.empty(8)
    if single:
        if kink > 0.0:
            # turn the start tangent (by at most kink) toward the circle through the piece's
            # ends and middle sample
            q = n // 2
            if per_cubic > 0:
                q -= q % per_cubic                # a cubic's end (a vertex), not a sample inside
            ux, uy, _ = _unit(p1x - p0x, p1y - p0y)
            mx, my = buf[q, 0] - p0x, buf[q, 1] - p0y
            vx, vy = p1x - p0x, p1y - p0y
            # tangent at p0 of the circle through p0, m, p1: the chord turned back by the
            # turn at m (tangent-chord angle = half the arc = the exterior angle at m)
            cr = mx * (vy - my) - my * (vx - mx)
            dt = mx * (vx - mx) + my * (vy - my)
            ang = -math.atan2(cr, dt)
            cx3 = math.cos(ang) * ux - math.sin(ang) * uy
            cy3 = math.sin(ang) * ux + math.cos(ang) * uy
            dlt = math.atan2(t0x * cy3 - t0y * cx3, t0x * cx3 + t0y * cy3)
            dlt = min(kink, max(-kink, dlt))
            cd, sd = math.cos(dlt), math.sin(dlt)
            t0x, t0y = cd * t0x - sd * t0y, sd * t0x + cd * t0y
        if not _arc_only(p0x, p0y, t0x, t0y, p1x, p1y, ba):
            return math.inf, p1x, p1y, buf, tbuf
        return _biarc_error(buf, n, p0x, p0y, p1x, p1y, ba, tol), p1x, p1y, buf, tbuf
    ia = min(int(math.floor(Ta)), m - 1)
    ib = max(int(math.ceil(Tb)) - 1, ia)
    t1x, t1y = _piece_tangent(ctrl[ib], max(Ta - ib, 0.0), Tb - ib, True)
    if t1x == 0.0 and t1y == 0.0:
        return math.inf, p1x, p1y, buf, tbuf
    if not _curve_joint(shape, buf, tbuf, n, p0x, p0y, t0x, t0y, p1x, p1y, t1x, t1y, ba):
        e = math.inf
    else:
        e = _biarc_error(buf, n, p0x, p0y, p1x, p1y, ba, tol)
    if e <= tol or _JOINTS.shape[0] == 0:
        return e, p1x, p1y, buf, tbuf
    # other joints along the joint circle: the first that fits
    cx, cy, r = _joint_circle(p0x, p0y, t0x, t0y, p1x, p1y, t1x, t1y)
    sw = 0.0
    if r > 0.0:
        ux, uy, _ = _unit(p1x - p0x, p1y - p0y)
        half = 0.5 * math.atan2(t1x * t0y - t1y * t0x, t1x * t0x + t1y * t0y)
        ch, sh = math.cos(half), math.sin(half)
        _, _, sw = _arc_from_tangent(p0x, p0y, ch * ux - sh * uy, sh * ux + ch * uy, p1x, p1y)
    best_e = e
    for q in range(_JOINTS.shape[0]):
        lam = _JOINTS[q]
        if r == 0.0:
            jx, jy = p0x + lam * (p1x - p0x), p0y + lam * (p1y - p0y)
        else:
            ca, sa = math.cos(lam * sw), math.sin(lam * sw)
            jx = cx + ca * (p0x - cx) - sa * (p0y - cy)
            jy = cy + sa * (p0x - cx) + ca * (p0y - cy)
        if not _biarc_joint(p0x, p0y, t0x, t0y, p1x, p1y, jx, jy, ba2):
            continue
        e2 = _biarc_error(buf, n, p0x, p0y, p1x, p1y, ba2, tol)
        if e2 <= tol:
            ba[:] = ba2
            return e2, p1x, p1y, buf, tbuf
    return best_e, p1x, p1y, buf, tbuf


@jit
def _arc_only(p0x, p0y, t0x, t0y, p1x, p1y, out):
    """One arc from p0 along t0 to p1, stored as a biarc whose joint is p1."""
    cx, cy, sw = _arc_from_tangent(p0x, p0y, t0x, t0y, p1x, p1y)
    if abs(sw) >= _FULL_TURN or (p0x == p1x and p0y == p1y):
        return False
    out[0], out[1] = p1x, p1y
    out[2], out[3], out[4] = cx, cy, sw
    out[5], out[6], out[7] = math.nan, math.nan, 0.0
    return True


@jit
def _end_tangent(ba, p0x, p0y, p1x, p1y):
    """Unit tangent at p1 of the piece stored in ba (its last non-empty segment)."""
    jx, jy = ba[0], ba[1]
    if jx != p1x or jy != p1y:
        ax, ay, cx, cy, sw = jx, jy, ba[5], ba[6], ba[7]
    else:
        ax, ay, cx, cy, sw = p0x, p0y, ba[2], ba[3], ba[4]
    if sw == 0.0:
        ux, uy, _ = _unit(p1x - ax, p1y - ay)
        return ux, uy
    rx, ry = p1x - cx, p1y - cy
    ux, uy, _ = _unit(-ry, rx)
    if sw < 0.0:
        return -ux, -uy
    return ux, uy


@jit
def _search(ctrl, shape, Ta, rem, guess, p0x, p0y, t0x, t0y, single, kink, tol, buf, tbuf, ba, best,
            per_cubic):
    """Longest piece from Ta (at most rem) that fits: try guess, double or halve, bisect.
    Returns (length, bracket end or -1, error, end x, end y, buf, tbuf); best holds the fit.

    One fit per pass; what was learnt picks the next length: while nothing failed, double
    (up to rem); while nothing fitted, halve (down to _MIN_STEP); once a fit and a failure
    bracket the length, bisect _BISECT times."""
    s = min(guess, rem)
    lo, hi = 0.0, -1.0
    best_e, bx, by = math.inf, 0.0, 0.0
    bisections = 0
    while True:
        e, ex, ey, buf, tbuf = _chain_fit(ctrl, shape, Ta, Ta + s, p0x, p0y, t0x, t0y, single, kink, tol, buf,
                                          tbuf, ba, per_cubic)
        if e <= tol:
            lo, best_e, bx, by = s, e, ex, ey
            best[:] = ba
        else:
            hi = s
        if hi < 0.0:
            if lo >= rem:
                break
            s = min(2.0 * lo, rem)
        elif lo == 0.0:
            if hi * 0.5 < _MIN_STEP:
                break
            s = 0.5 * hi
        else:
            if bisections == _BISECT:
                break
            bisections += 1
            s = 0.5 * (lo + hi)
    return lo, hi, best_e, bx, by, buf, tbuf


@jit
def _grow(verts, centres, sweeps, k, need):
    if k + need + 1 < sweeps.shape[0]:
        return verts, centres, sweeps
    cap = 2 * (k + need + 1)
    v2 = np.empty((cap + 1, 2))
    c2 = np.empty((cap, 2))
    s2 = np.empty(cap)
    v2[:k + 1] = verts[:k + 1]
    c2[:k] = centres[:k]
    s2[:k] = sweeps[:k]
    return v2, c2, s2


@jit
def fit_cubic_chain(ctrl, shape, tol, kink_rad, closed, extra_breaks, a_factor, g1_tol, per_cubic):
    """Tangent-continuous arcs for a chain of cubics (m, 4, 2), each starting where the
    previous ends.

    ``ctrl`` gives the tangents the pieces follow (and the corners, cusps and
    inflections); ``shape`` (m, 4, 2) is the curve the pieces are measured
    against, sampled ``per_cubic`` times per cubic (0: by density) — ``ctrl``
    itself for a Bézier chain; for a polyline, its straight segments as cubics
    while ``ctrl`` carries the tangents estimated at its vertices.

    The chain is cut into runs at corners — joints between cubics whose
    tangents differ by more than ``kink_rad`` — and cusps (pieces run on
    through inflections, where the tangent carries on), and at
    ``extra_breaks`` (global parameters, cubic i spanning [i, i + 1]). Along a
    run every piece leaves along the tangent the previous piece arrived with
    (the curve's own at the run's start), so the run is G1. Each piece is the
    longer-reaching per block of: one arc from that tangent (1 block), or a
    biarc to the curve's end point and tangent (2 blocks, and back on the
    curve's tangent). On a ``closed`` smooth loop the last piece is a biarc so
    the loop closes on its starting tangent. Returns (vertices, centres,
    sweeps, worst measured error, pieces)."""
    m = ctrl.shape[0]
    # breaks in the global parameter T; hard ones (corners, cusps) reset the tangent
    brk = np.empty(3 * m + 2 + extra_breaks.shape[0])
    hard = np.zeros(brk.shape[0], np.bool_)
    nb = 0
    brk[nb] = 0.0
    hard[nb] = True
    nb += 1
    roots = np.empty(2)
    for i in range(m):
        r = _inflections(ctrl[i], roots)
        for j in range(r):
            t = roots[j]
            ax, ay = _piece_tangent(ctrl[i], 0.0, t, True)
            bx, by = _piece_tangent(ctrl[i], t, 1.0, False)
            if ax * bx + ay * by < 0.99:            # a cusp
                brk[nb] = i + t
                hard[nb] = True
                nb += 1
        for j in range(extra_breaks.shape[0]):
            if i < extra_breaks[j] < i + 1:
                brk[nb] = extra_breaks[j]
                nb += 1
        if i < m - 1:
            ax, ay = _piece_tangent(ctrl[i], 0.0, 1.0, True)
            bx, by = _piece_tangent(ctrl[i + 1], 0.0, 1.0, False)
            ang = abs(math.atan2(ax * by - ay * bx, ax * bx + ay * by))
            corner = ang > kink_rad or (ax == 0.0 and ay == 0.0) or (bx == 0.0 and by == 0.0)
            extra = False
            for j in range(extra_breaks.shape[0]):
                extra = extra or extra_breaks[j] == i + 1.0
            if corner or extra:
                brk[nb] = i + 1.0
                hard[nb] = corner
                nb += 1
    brk[nb] = float(m)
    hard[nb] = True
    nb += 1
    # sort the breaks (inflections and extra breaks of one cubic may interleave)
    order = np.argsort(brk[:nb], kind="mergesort")
    brk, hard = brk[:nb][order], hard[:nb][order]
    sx, sy = _piece_tangent(ctrl[0], 0.0, 1.0, False)
    ex_, ey_ = _piece_tangent(ctrl[m - 1], 0.0, 1.0, True)
    smooth_loop = closed and abs(math.atan2(ex_ * sy - ey_ * sx, ex_ * sx + ey_ * sy)) <= kink_rad
    cap = 4 * m + 8
    verts = np.empty((cap + 1, 2))
    centres = np.empty((cap, 2))
    sweeps = np.empty(cap)
    verts[0, 0], verts[0, 1] = ctrl[0, 0, 0], ctrl[0, 0, 1]
    k = 0
    worst = 0.0
    pieces = 0
    buf = np.empty((256, 2))
    tbuf = np.empty(256)
    ba = np.empty(8)
    best_a = np.empty(8)
    best_b = np.empty(8)
    tx, ty = 0.0, 0.0
    guess_a = guess_b = float(m)
    for r in range(nb - 1):
        Ra, Rb = brk[r], brk[r + 1]
        if Rb - Ra <= _MIN_STEP:
            continue
        free = False
        if hard[r] or (tx == 0.0 and ty == 0.0):
            i = min(int(math.floor(Ra)), m - 1)
            tx, ty = _piece_tangent(ctrl[i], Ra - i, min(Rb - i, 1.0), False)
            free = not (smooth_loop and r == 0)
        # a piece ending on a closing smooth loop or at a soft break must arrive on the curve's
        # tangent (a biarc), so the joint there stays G1 with what follows
        last_closing = (smooth_loop and r == nb - 2) or not hard[r + 1]
        Ta = Ra
        while Rb - Ta > _MIN_STEP:
            p0x, p0y = verts[k, 0], verts[k, 1]
            rem = Rb - Ta
            lo_a, hi_a, e_a, ax, ay, buf, tbuf = _search(ctrl, shape, Ta, rem, guess_a, p0x, p0y, tx, ty, True,
                                                         math.pi if free else g1_tol, tol,
                                                         buf, tbuf, ba, best_a, per_cubic)
            if lo_a > 0.0:
                guess_a = lo_a
            a_ok = lo_a > 0.0 and not (last_closing and lo_a >= rem)   # a closing piece needs a biarc
            lo_b = 0.0
            if not (a_ok and lo_a >= rem):
                lo_b, hi_b, e_b, bx, by, buf, tbuf = _search(ctrl, shape, Ta, rem, guess_b, p0x, p0y, tx, ty, False,
                                                             0.0, tol, buf, tbuf, ba, best_b, per_cubic)
                if lo_b > 0.0:
                    guess_b = lo_b
            if lo_b >= rem:
                use_a = a_ok and lo_a >= rem
            else:
                use_a = a_ok and a_factor * lo_a >= lo_b
            if lo_a == 0.0 and lo_b == 0.0:
                # nothing fits even the shortest piece (a degenerate spot): a straight chord
                step = min(rem, 4.0 * _MIN_STEP)
                n, buf, tbuf = _sample_chain(shape, Ta, Ta + step, p0x, p0y, buf, tbuf, per_cubic)
                ex, ey = buf[n - 1, 0], buf[n - 1, 1]
                for q in range(n):
                    d = math.hypot(buf[q, 0] - p0x, buf[q, 1] - p0y)
                    worst = max(worst, min(d, math.hypot(buf[q, 0] - ex, buf[q, 1] - ey)))
                if ex != p0x or ey != p0y:
                    verts, centres, sweeps = _grow(verts, centres, sweeps, k, 2)
                    k = _emit_line(ex, ey, verts, centres, sweeps, k)
                    tx, ty, _ = _unit(ex - p0x, ey - p0y)
                Ta += step
                pieces += 1
                continue
            verts, centres, sweeps = _grow(verts, centres, sweeps, k, 2)
            if use_a:
                k = _emit(best_a, p0x, p0y, ax, ay, verts, centres, sweeps, k)
                tx, ty = _end_tangent(best_a, p0x, p0y, ax, ay)
                worst = max(worst, e_a)
                step = lo_a
            else:
                k = _emit(best_b, p0x, p0y, bx, by, verts, centres, sweeps, k)
                tx, ty = _end_tangent(best_b, p0x, p0y, bx, by)
                worst = max(worst, e_b)
                step = lo_b
            pieces += 1
            free = False
            Ta = Ta + step if step < rem else Rb
    # arcs whose centres and radii agree within a thousandth of the tolerance are one arc
    # (their union moves by at most twice that)
    eps = 1e-3 * tol
    k = _merge(verts, centres, sweeps, k, eps)
    return verts[:k + 1], centres[:k], sweeps[:k], worst + 2.0 * eps, pieces


@jit
def _vertex_tangents(p, closed, corner_rad, reach):
    """Tangent estimates (into, out of) every vertex of a polyline, and corner flags.

    A vertex turning by more than ``corner_rad`` is a corner. A smooth vertex
    takes the tangent at it of the circle through it and the nearest vertices
    at least ``reach`` mm away on either side (not beyond a corner; exact on
    circle samples, and blind to the tiny joins an offset leaves at each
    polygon vertex) — or, when one of those chords is four or more times the
    other, that long chord's direction (a straight edge meeting a tangent
    curve). At a corner or an open end the one-sided tangent is the
    smooth neighbour's tangent mirrored in the chord between them (an arc's
    end tangents mirror in its chord)."""
    n = p.shape[0]
    tin = np.zeros((n, 2))
    tout = np.zeros((n, 2))
    corner = np.zeros(n, np.bool_)
    dx = np.empty(n - 1)
    dy = np.empty(n - 1)
    for i in range(n - 1):
        ux, uy, L = _unit(p[i + 1, 0] - p[i, 0], p[i + 1, 1] - p[i, 1])
        dx[i], dy[i] = ux, uy
    for i in range(n):
        if (i == 0 or i == n - 1) and not closed:
            corner[i] = True
            continue
        a = i - 1 if i > 0 else n - 2          # closed: vertex 0 is vertex n - 1
        b = i if i < n - 1 else 0
        phi = math.atan2(dx[a] * dy[b] - dy[a] * dx[b], dx[a] * dx[b] + dy[a] * dy[b])
        corner[i] = abs(phi) > corner_rad
    if closed:
        corner[n - 1] = corner[0]
    for i in range(n):
        if corner[i]:
            tin[i, 0], tin[i, 1] = dx[max(i - 1, 0)], dy[max(i - 1, 0)]
            tout[i, 0], tout[i, 1] = dx[min(i, n - 2)], dy[min(i, n - 2)]
            continue
        px, py = p[i, 0], p[i, 1]
        # walk back and forward to vertices at least `reach` away (wrapping on a loop)
        j = i
        for _ in range(n):
            j = j - 1 if j > 0 else (n - 2 if closed else 0)
            if corner[j] or math.hypot(p[j, 0] - px, p[j, 1] - py) >= reach or j == 0:
                break
        q = i
        for _ in range(n):
            q = q + 1 if q < n - 1 else (1 if closed else n - 1)
            if corner[q] or math.hypot(p[q, 0] - px, p[q, 1] - py) >= reach or q == n - 1:
                break
        ux, uy, la = _unit(px - p[j, 0], py - p[j, 1])
        wx, wy, lb = _unit(p[q, 0] - px, p[q, 1] - py)
        if la == 0.0 or lb == 0.0:
            tx, ty = (wx, wy) if la == 0.0 else (ux, uy)
        elif la >= 4.0 * lb:                   # a straight edge meeting a curve: follow the edge
            tx, ty = ux, uy
        elif lb >= 4.0 * la:
            tx, ty = wx, wy
        else:
            phi = math.atan2(ux * wy - uy * wx, ux * wx + uy * wy)
            # the tangent-chord angle at the middle point of the circle through three points
            alpha = math.atan2(lb * math.sin(phi), la + lb * math.cos(phi))
            ca, sa = math.cos(-alpha), math.sin(-alpha)
            tx, ty = ca * wx - sa * wy, sa * wx + ca * wy
        tin[i, 0], tin[i, 1] = tx, ty
        tout[i, 0], tout[i, 1] = tx, ty
    for i in range(n):
        if not corner[i]:
            continue
        if i < n - 1 and not corner[i + 1]:
            tx, ty = _mirror(tin[i + 1, 0], tin[i + 1, 1], dx[i], dy[i])
            tout[i, 0], tout[i, 1] = tx, ty
        if i > 0 and not corner[i - 1]:
            tx, ty = _mirror(tout[i - 1, 0], tout[i - 1, 1], dx[i - 1], dy[i - 1])
            tin[i, 0], tin[i, 1] = tx, ty
    return tin, tout, corner


@jit
def _mirror(tx, ty, ux, uy):
    """The unit vector t mirrored in the line along unit u."""
    d = 2.0 * (tx * ux + ty * uy)
    return d * ux - tx, d * uy - ty


@jit
def hermite_chain(p, closed, corner_rad, reach):
    """A tangent-continuous chain of cubics (n − 1, 4, 2) through the polyline's vertices:
    cubic Hermite pieces with handles of a third of the chord along the estimated tangents
    (straight where both ends are corners, so polygons stay polygons)."""
    n = p.shape[0]
    tin, tout, corner = _vertex_tangents(p, closed, corner_rad, reach)
    out = np.empty((n - 1, 4, 2))
    for i in range(n - 1):
        L = math.hypot(p[i + 1, 0] - p[i, 0], p[i + 1, 1] - p[i, 1]) / 3.0
        out[i, 0, 0], out[i, 0, 1] = p[i, 0], p[i, 1]
        out[i, 1, 0], out[i, 1, 1] = p[i, 0] + L * tout[i, 0], p[i, 1] + L * tout[i, 1]
        out[i, 2, 0], out[i, 2, 1] = p[i + 1, 0] - L * tin[i + 1, 0], p[i + 1, 1] - L * tin[i + 1, 1]
        out[i, 3, 0], out[i, 3, 1] = p[i + 1, 0], p[i + 1, 1]
    return out
