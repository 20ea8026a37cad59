"""Compiled kernels of :mod:`labkit.motion.bresenham` (the sequential walks).

These are the readable reference loops, compiled with numba. They work on
integer lattice coordinates (steps) only; the public wrappers convert and
check arguments.
"""

from __future__ import annotations

import numpy as np

from labkit._jit import jit

# Per CCW octant k (angles [45k°, 45(k+1)°)): driver axis, driver direction,
# driven axis, driven direction. Axis 0 = x, 1 = y (of the arc plane).
OCTANT_MOVES = np.array([
    [1, +1, 0, -1],   # 0: [0°, 45°)     y up, x falls back toward the centre
    [0, -1, 1, +1],   # 1: [45°, 90°)    x left, y still rises
    [0, -1, 1, -1],   # 2: [90°, 135°)
    [1, -1, 0, -1],   # 3: [135°, 180°)
    [1, -1, 0, +1],   # 4: [180°, 225°)
    [0, +1, 1, -1],   # 5: [225°, 270°)
    [0, +1, 1, +1],   # 6: [270°, 315°)
    [1, +1, 0, +1],   # 7: [315°, 360°)
], dtype=np.int64)


@jit
def line_walk(start, end):
    """Bresenham line through the lattice: points (N + 1, d), start and end included.

    Every axis keeps an integer error ``err = 2·|Δ_i| − N`` (N = the driver's
    |Δ|); each tick the axis steps when ``err >= 0`` (then ``err -= 2N``),
    and ``err += 2·|Δ_i|``. The driver (|Δ_i| = N) steps every tick. The walk
    itself is :func:`lines_walk`'s, on a batch of one line.
    """
    d = start.shape[0]
    n = 0
    for i in range(d):
        n = max(n, abs(end[i] - start[i]))
    out = np.empty((n + 1, d), np.int64)
    offsets = np.zeros(2, np.int64)
    offsets[1] = n + 1
    lines_walk(start.reshape((1, d)), end.reshape((1, d)), offsets, out)
    return out


@jit
def lines_walk(starts, ends, offsets, out):
    """Many Bresenham lines into one preallocated array: line j fills
    ``out[offsets[j]:offsets[j + 1]]`` by the same integer-error walk as :func:`line_walk`."""
    n_lines, d = starts.shape
    delta = np.empty(d, np.int64)
    sgn = np.empty(d, np.int64)
    err = np.empty(d, np.int64)
    pos = np.empty(d, np.int64)
    for j in range(n_lines):
        n = 0
        for i in range(d):
            delta[i] = abs(ends[j, i] - starts[j, i])
            sgn[i] = 1 if ends[j, i] > starts[j, i] else -1
            if delta[i] > n:
                n = delta[i]
        row = offsets[j]
        for i in range(d):
            err[i] = 2 * delta[i] - n
            pos[i] = starts[j, i]
            out[row, i] = pos[i]
        for k in range(1, n + 1):
            for i in range(d):
                if err[i] >= 0:
                    pos[i] += sgn[i]
                    err[i] -= 2 * n
                err[i] += 2 * delta[i]
                out[row + k, i] = pos[i]


@jit
def octant_ccw(X, Y):
    """CCW octant 0…7 of the relative point (X, Y): angle in [45k°, 45(k+1)°)."""
    if Y >= 0 and X > 0 and Y < X:
        return 0
    if Y > 0 and X > 0 and X <= Y:
        return 1
    if Y > 0 and X <= 0 and -X < Y:
        return 2
    if Y > 0 and X < 0:
        return 3
    if Y <= 0 and X < 0 and -Y < -X:
        return 4
    if Y < 0 and X < 0:
        return 5
    if Y < 0 and X >= 0 and X < -Y:
        return 6
    return 7


@jit
def _err(X, Y, r2):
    e = X * X + Y * Y - r2
    return e if e >= 0 else -e


@jit
def arc_walk_ccw(sx, sy, ex, ey, cxq, cyq, rq, q, n_cross, max_ticks):
    """Counter-clockwise octant walk from (sx, sy) to (ex, ey); returns (points, ok).

    Lattice points (steps) are compared to the circle of centre (cxq, cyq)/q
    and radius rq/q (fixed point, ``q`` sub-steps per step) by the integer
    error e = X² + Y² − rq² with X = q·x − cxq, Y = q·y − cyq.

    Each tick the octant's driver axis steps; the driven axis steps forward
    when that lowers |e| strictly ([CBR40] eq. 4), or backward when that
    lowers it further — which happens only while the walk recovers from a
    start point that rounding left off the circle. The walk counts octant
    crossings and stops in the end point's octant (``n_cross`` crossings
    after the start) once its driver coordinate reaches the end's, or when its
    next tick would leave that octant; a short Bresenham line then lands
    exactly on the end point.
    """
    r2 = rq * rq
    if rq < 2 * q:
        return np.empty((0, 2), np.int64), False
    pts = np.empty((max_ticks + 3, 2), np.int64)
    x = sx
    y = sy
    pts[0, 0] = x
    pts[0, 1] = y
    n = 1
    octant = octant_ccw(q * x - cxq, q * y - cyq)
    crossed = 0
    while True:
        mv = OCTANT_MOVES[octant]
        if crossed > n_cross:
            break
        if crossed == n_cross:
            e_end = ex if mv[0] == 0 else ey
            p_now = x if mv[0] == 0 else y
            if mv[1] * (p_now - e_end) >= 0:
                break
        if n > max_ticks:
            return pts[:n], False
        X = q * x - cxq
        Y = q * y - cyq
        if n == 1:
            # First tick: to the 8-neighbour closest to the circle (by |e|)
            # among those that do not go backwards along the arc. From a start
            # on the circle this is the walk's own first tick; from a start
            # that rounding left off the circle it pulls the walk back at once.
            bx = 0
            by = 0
            e_best = -1
            for dx in range(-1, 2):
                for dy in range(-1, 2):
                    if (dx == 0 and dy == 0) or X * dy - Y * dx < 0:
                        continue
                    e = _err(X + q * dx, Y + q * dy, r2)
                    if e_best < 0 or e < e_best:
                        e_best = e
                        bx = dx
                        by = dy
            x += bx
            y += by
        else:
            # driver step, then the driven axis: stay, forward or back,
            # whichever leaves the smallest |e| (ties: stay, then forward)
            if mv[0] == 0:
                X += q * mv[1]
                x += mv[1]
            else:
                Y += q * mv[1]
                y += mv[1]
            step = q * mv[3]
            if mv[2] == 0:
                e_stay = _err(X, Y, r2)
                e_fwd = _err(X + step, Y, r2)
                e_back = _err(X - step, Y, r2)
            else:
                e_stay = _err(X, Y, r2)
                e_fwd = _err(X, Y + step, r2)
                e_back = _err(X, Y - step, r2)
            best = 0
            e_best = e_stay
            if e_fwd < e_best:
                best = 1
                e_best = e_fwd
            if e_back < e_best:
                best = -1
            if mv[2] == 0:
                x += best * mv[3]
            else:
                y += best * mv[3]
        o_new = octant_ccw(q * x - cxq, q * y - cyq)
        if crossed == n_cross and o_new != octant:
            # the end lies in this octant: do not walk past it into the next
            x = pts[n - 1, 0]
            y = pts[n - 1, 1]
            break
        # Last tick: if this point is in the end's octant and its driver has
        # reached the end's coordinate, go to the end itself when it is a
        # neighbour of the previous point (no back-step to correct later).
        c_new = crossed
        if o_new == (octant + 1) % 8:
            c_new += 1
        if c_new == n_cross:
            mvn = OCTANT_MOVES[o_new]
            p_new = x if mvn[0] == 0 else y
            e_end = ex if mvn[0] == 0 else ey
            if (mvn[1] * (p_new - e_end) >= 0 and abs(ex - pts[n - 1, 0]) <= 1
                    and abs(ey - pts[n - 1, 1]) <= 1):
                x = ex
                y = ey
                o_new = octant_ccw(q * x - cxq, q * y - cyq)
        pts[n, 0] = x
        pts[n, 1] = y
        n += 1
        if o_new != octant:
            if o_new == (octant + 1) % 8:
                crossed += 1
            elif o_new == (octant + 7) % 8:
                crossed -= 1
            else:
                return pts[:n], False
            octant = o_new
    # land exactly on the end point with a short line
    tail = line_walk(np.array([x, y], np.int64), np.array([ex, ey], np.int64))
    out = np.empty((n + tail.shape[0] - 1, 2), np.int64)
    out[:n] = pts[:n]
    out[n:] = tail[1:]
    return out, True
