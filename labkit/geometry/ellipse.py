"""Ellipses and elliptical arcs as circular arcs ([LaserApp] §3.4.2, after Eberly).

G-code has circular arcs only, so an ellipse is cut as a chain of them. The
points where one arc hands over to the next are chosen where the curvature
changes, by the curvature weighting of [LaserApp] (eqs. 13–17): along the first
quadrant of the axis-aligned ellipse x²/a² + y²/b² = 1 the curvature runs
from K₀ = a/b² at (a, 0) to Kₙ = b/a² at (0, b); the i-th point is the one
whose curvature is Kᵢ = (1 − i/n)·K₀ + (i/n)·Kₙ, found with
λ = (a·b/K)^(2/3), x = a·√|(λ − a²)/(b² − a²)|, y = b·√|(λ − b²)/(b² − a²)|.
The quadrant is mirrored into the other three.

Each arc passes exactly through its two hand-over points and through a third
point of the ellipse; that third point is the choice of ``method``:

``"midpoint"`` (default)
    the ellipse point halfway in parameter between the two — the arc then
    crosses the ellipse three times and its error is small on both sides;
``"seed"``
    [LaserApp]'s choice, the previous hand-over point (circle Cᵢ through
    Pᵢ₋₁, Pᵢ, Pᵢ₊₁ carries the arc Pᵢ → Pᵢ₊₁; the arcs that touch an axis use
    the circle symmetric about that axis). Kept to compare; its error is
    several times larger at the same count (see notebook 04).

Every function reports the *true* maximum deviation, measured by sampling
the ellipse densely and taking each sample's distance to its arc's circle.
"""

from __future__ import annotations

import math

import numpy as np

from labkit._jit import jit
from labkit.errors import GeometryError
from labkit.geometry.circle import circumcentre, cross2
from labkit.geometry.path import Path
from labkit.geometry.transform import ellipse_image

__all__ = [
    "default_arcs_per_quadrant",
    "curvature_weighted_points",
    "ellipse_to_arcs",
    "ellipse_arc_to_arcs",
    "ellipse_arc_arrays",
    "ellipse_point",
]

_SAMPLES_PER_ARC = 33
_MAX_PER_QUADRANT = 4096


def default_arcs_per_quadrant(rx, ry) -> int:
    """[LaserApp]'s count: round(8 · max(rx, ry) / min(rx, ry)) arcs per quadrant.

    >>> default_arcs_per_quadrant(2.0, 1.0), default_arcs_per_quadrant(2.0, 1.5)
    (16, 11)
    """
    a, b = max(rx, ry), min(rx, ry)
    if not b > 0:
        raise GeometryError(f"ellipse radii must be > 0 mm, got rx={rx!r}, ry={ry!r}")
    return int(round(8.0 * a / b))


def curvature_weighted_points(a, b, n) -> np.ndarray:
    """The n + 1 hand-over points in the first quadrant, from (a, 0) to (0, b).

    Parameters
    ----------
    a, b : float
        Radii along x and y, mm (> 0).
    n : int
        Arcs per quadrant (≥ 1).

    Returns
    -------
    ndarray, shape (n + 1, 2)

    Notes
    -----
    [LaserApp] eqs. 15–17 (curvatures equally spaced between the two vertices).
    For a circle (a = b) the curvature is constant and the formula has no
    answer; the points are then spaced equally in angle.

    Examples
    --------
    >>> curvature_weighted_points(2.0, 1.0, 2).round(4)
    array([[2.    , 0.    ],
           [1.8376, 0.3948],
           [0.    , 1.    ]])
    """
    if not (a > 0 and b > 0):
        raise GeometryError(f"ellipse radii must be > 0 mm, got a={a!r}, b={b!r}")
    if int(n) < 1:
        raise GeometryError(f"arcs per quadrant must be >= 1, got {n!r}")
    w = np.arange(n + 1) / n
    if abs(a - b) <= 1e-9 * max(a, b):
        t = w * (math.pi / 2)
        return np.stack([a * np.cos(t), b * np.sin(t)], axis=1)
    k = (1.0 - w) * (a / b**2) + w * (b / a**2)
    lam = (a * b / k) ** (2.0 / 3.0)
    d = b * b - a * a
    x = a * np.sqrt(np.abs((lam - a * a) / d))
    y = b * np.sqrt(np.abs((lam - b * b) / d))
    pts = np.stack([np.clip(x, 0, a), np.clip(y, 0, b)], axis=1)
    pts[0], pts[-1] = (a, 0.0), (0.0, b)
    return pts


def ellipse_point(centre, rx, ry, rotation, t) -> np.ndarray:
    """Point(s) c + R(rotation)·(rx cos t, ry sin t) of an ellipse, mm."""
    t = np.asarray(t, dtype=float)
    x, y = rx * np.cos(t), ry * np.sin(t)
    c, s = math.cos(rotation), math.sin(rotation)
    return np.asarray(centre, dtype=float) + np.stack([c * x - s * y, s * x + c * y], axis=-1)


def _breakpoints(a, b, n) -> np.ndarray:
    """Hand-over parameters u (rad) around the whole ellipse, sorted in [0, 2π)."""
    q = curvature_weighted_points(a, b, n)
    u = np.arctan2(q[:, 1] / b, q[:, 0] / a)            # 0 … π/2
    full = np.concatenate([u[:-1], math.pi - u[::-1][:-1], math.pi + u[:-1], 2 * math.pi - u[::-1][:-1]])
    return np.sort(np.mod(full, 2 * math.pi))


def _arc_through(p0, pm, p1):
    """Centres and CCW sweeps of the arcs p0 → p1 on the circles through pm (rows).

    On the canonical ellipse, increasing u always runs counter-clockwise, so
    every arc is CCW whichever side of the interval the third point lies on.
    """
    c = circumcentre(p0, pm, p1)
    r0, r1 = p0 - c, p1 - c
    ang = np.arctan2(cross2(r0, r1), np.sum(r0 * r1, axis=-1))
    ang = np.where(ang <= 0, ang + 2 * math.pi, ang)
    straight = np.isnan(c[:, 0])
    return c, np.where(straight, 0.0, ang)


@jit
def _peak1(f):
    """Maximum of smoothly varying samples, refined by the parabola through the largest
    sample and its neighbours (the true peak lies between samples)."""
    k = 0
    for i in range(f.shape[0]):
        if f[i] > f[k]:
            k = i
    best = f[k]
    if 0 < k < f.shape[0] - 1:
        curv = 2.0 * f[k] - f[k - 1] - f[k + 1]
        if curv > 0.0:
            best = max(best, f[k] + (f[k + 1] - f[k - 1]) ** 2 / (8.0 * curv))
    return best


@jit
def _deviations(a, b, u_a, u_b, cx, cy, sweep, samples):
    """Measured deviation of each arc (or chord, sweep 0) from its piece of the ellipse:
    ellipse samples → circle (radial distance) and arc samples → ellipse polyline."""
    n = u_a.shape[0]
    out = np.empty(n)
    ex = np.empty(samples)
    ey = np.empty(samples)
    f1 = np.empty(samples)
    f2 = np.empty(samples)
    for i in range(n):
        for k in range(samples):
            u = u_a[i] + (u_b[i] - u_a[i]) * k / (samples - 1)
            ex[k] = a * math.cos(u)
            ey[k] = b * math.sin(u)
        x0, y0, x1, y1 = ex[0], ey[0], ex[samples - 1], ey[samples - 1]
        if sweep[i] == 0.0:
            dx, dy = x1 - x0, y1 - y0
            L = max(math.hypot(dx, dy), 1e-300)
            for k in range(samples):
                f1[k] = abs(dx * (ey[k] - y0) - dy * (ex[k] - x0)) / L
            out[i] = _peak1(f1)
            continue
        r = math.hypot(x0 - cx[i], y0 - cy[i])
        a0 = math.atan2(y0 - cy[i], x0 - cx[i])
        for k in range(samples):
            f1[k] = abs(math.hypot(ex[k] - cx[i], ey[k] - cy[i]) - r)
            ang = a0 + sweep[i] * k / (samples - 1)
            qx, qy = cx[i] + r * math.cos(ang), cy[i] + r * math.sin(ang)
            best = np.inf
            for j in range(samples - 1):
                vx, vy = ex[j + 1] - ex[j], ey[j + 1] - ey[j]
                wx, wy = qx - ex[j], qy - ey[j]
                t = (wx * vx + wy * vy) / max(vx * vx + vy * vy, 1e-300)
                t = min(1.0, max(0.0, t))
                best = min(best, math.hypot(wx - t * vx, wy - t * vy))
            f2[k] = best
        out[i] = max(_peak1(f1), _peak1(f2))
    return out


def _fit(a, b, u_a, u_b, third_u):
    """Arcs on the canonical ellipse (centre 0, rotation 0) over [u_a, u_b] per row,
    with each arc's measured deviation (both ways: ellipse → arc and arc → ellipse)."""
    pt = lambda u: np.stack([a * np.cos(u), b * np.sin(u)], axis=-1)   # noqa: E731
    p0, p1 = pt(u_a), pt(u_b)
    c, sweep = _arc_through(p0, pt(third_u), p1)
    cc = np.where(np.isnan(c), 0.0, c)
    dev = _deviations(float(a), float(b), np.ascontiguousarray(u_a, dtype=float),
                      np.ascontiguousarray(u_b, dtype=float), np.ascontiguousarray(cc[:, 0]),
                      np.ascontiguousarray(cc[:, 1]), np.ascontiguousarray(sweep, dtype=float),
                      _SAMPLES_PER_ARC)
    return p0, p1, c, sweep, dev


def _intervals(a, b, u0, du, n):
    """Hand-over parameters from lo to hi (ascending) with the breakpoints inside."""
    bp = _breakpoints(a, b, n)
    lo, hi = (u0, u0 + du) if du > 0 else (u0 + du, u0)
    k0 = math.floor(lo / (2 * math.pi)) - 1
    k1 = math.ceil(hi / (2 * math.pi)) + 1
    allbp = (bp[None, :] + 2 * math.pi * np.arange(k0, k1 + 1)[:, None]).ravel()
    eps = 1e-9 + 1e-6 * abs(du)
    inner = allbp[(allbp > lo + eps) & (allbp < hi - eps)]
    return np.concatenate([[lo], inner, [hi]]), allbp, eps


def _seed_third(u_a, u_b, allbp, eps):
    """[LaserApp]'s third point: the previous hand-over point (or, for the arc ending on an
    axis, the next one, so that arc's circle is symmetric about the axis)."""
    third = 0.5 * (u_a + u_b)
    last = len(allbp) - 1
    idx = np.searchsorted(allbp, u_a - eps)
    is_bp_a = np.isclose(allbp[np.clip(idx, 0, last)], u_a, atol=eps)
    is_bp_b = np.isclose(allbp[np.clip(np.searchsorted(allbp, u_b - eps), 0, last)], u_b, atol=eps)
    prev_bp = allbp[np.clip(idx - 1, 0, last)]
    next_bp = allbp[np.clip(np.searchsorted(allbp, u_b + eps), 0, last)]
    on_axis = lambda uu: np.abs(uu / (math.pi / 2) - np.round(uu / (math.pi / 2))) < 1e-9  # noqa: E731
    seed = np.where(on_axis(u_b) & ~on_axis(u_a), next_bp, prev_bp)
    return np.where(is_bp_a & is_bp_b, seed, third)


def _canonical_arcs(a, b, u0, du, n, method, tol=None):
    """Vertices, centres, sweeps and deviation for u from u0 over du on x²/a²+y²/b²=1.

    With ``tol`` (midpoint method) intervals whose arc deviates more are halved in
    parameter until every arc fits: the seed's points stay, more are added where needed.
    """
    if method not in ("midpoint", "seed"):
        raise GeometryError(f"method must be 'midpoint' or 'seed', got {method!r}")
    u, allbp, eps = _intervals(a, b, u0, du, n)
    for _ in range(40):
        u_a, u_b = u[:-1], u[1:]
        third = _seed_third(u_a, u_b, allbp, eps) if method == "seed" else 0.5 * (u_a + u_b)
        p0, p1, c, sweep, dev = _fit(a, b, u_a, u_b, third)
        if tol is None or method == "seed" or not np.any(dev > tol):
            break
        bad = dev > tol
        u = np.sort(np.concatenate([u, 0.5 * (u_a[bad] + u_b[bad])]))
    verts = np.vstack([p0, p1[-1:]])
    if du < 0:
        verts, c, sweep = verts[::-1], c[::-1], -sweep[::-1]
    return verts, c, sweep, float(dev.max()) if dev.size else 0.0


def ellipse_arc_to_arcs(centre, jacobian, t0, dt, *, arcs_per_quadrant=None, tol_mm=None,
                        method="midpoint", **meta) -> Path:
    """Circular arcs along the elliptical arc p(t) = c + J·(cos t, sin t), t from t0 over dt.

    This form covers every affine image of a circle or ellipse: an SVG arc of
    radii (rx, ry) and rotation φ mapped by a transform with 2×2 part A has
    J = A·R(φ)·diag(rx, ry). The standard form comes from
    :func:`labkit.geometry.transform.ellipse_image` (SVD of J).

    Parameters
    ----------
    centre : array_like, shape (2,)
        mm.
    jacobian : array_like, shape (2, 2)
    t0, dt : float
        Start parameter and signed parameter sweep, rad (|dt| ≤ 2π).
    arcs_per_quadrant : int, optional
        Curvature-weighted hand-over points per quarter ellipse; default seed
        000's round(8·rx/ry). With ``tol_mm`` and no count, the curvature-
        weighted start is 2 per quadrant and every arc that deviates more
        than ``tol_mm`` is halved (in parameter) until all fit.
    tol_mm : float, optional
        Largest allowed deviation from the ellipse, mm.
    method : {"midpoint", "seed"}
        Third point of each arc (module docstring).
    **meta
        Layer and colours for the :class:`Path`.

    Returns
    -------
    Path
        ``deviation_mm`` holds the measured maximum deviation.

    Examples
    --------
    >>> import numpy as np
    >>> p = ellipse_arc_to_arcs((0, 0), np.diag([20.0, 10.0]), 0.0, np.pi / 2, tol_mm=0.01)
    >>> p.start.round(9).tolist(), p.end.round(9).tolist(), p.deviation_mm <= 0.01
    ([20.0, 0.0], [0.0, 10.0], True)
    """
    verts, c, sweep, dev, full = ellipse_arc_arrays(centre, jacobian, t0, dt, arcs_per_quadrant,
                                                     tol_mm, method)
    return Path(verts, c, sweep, closed=full, deviation_mm=dev, **meta)


def ellipse_arc_arrays(centre, jacobian, t0, dt, arcs_per_quadrant, tol_mm, method):
    """:func:`ellipse_arc_to_arcs` as arrays, for importers that append them to a path.

    Returns ``(vertices (k+1, 2), centres (k, 2), sweeps (k,), deviation_mm, full_turn)``.
    """
    if not abs(dt) > 0:
        raise GeometryError("elliptical arc sweep dt must be non-zero")
    if abs(dt) > 2 * math.pi + 1e-9:
        raise GeometryError(f"elliptical arc sweep must be within ±2π rad, got {dt!r}")
    if tol_mm is not None and not tol_mm > 0:
        raise GeometryError(f"tol_mm must be > 0 mm, got {tol_mm!r}")
    centre = np.asarray(centre, dtype=float)
    full = abs(abs(dt) - 2 * math.pi) < 1e-9
    j = np.asarray(jacobian, dtype=float)
    s0, s1 = np.linalg.svd(j, compute_uv=False)
    if arcs_per_quadrant is None and s1 > 1e-12 * max(s0, 1.0) and s0 - s1 <= 1e-9 * s0:
        # a circle's image is a circle: exact arcs, cut only so that none sweeps more than
        # a half turn, straight from the parametrisation (no standard form needed)
        k = max(1, math.ceil(abs(dt) / math.pi - 1e-9))
        t = t0 + dt * np.arange(k + 1) / k
        verts = centre + np.stack([np.cos(t), np.sin(t)], axis=1) @ j.T
        if full:
            verts[-1] = verts[0]
        turn = 1.0 if j[0, 0] * j[1, 1] - j[0, 1] * j[1, 0] > 0 else -1.0
        return verts, np.tile(centre, (k, 1)), np.full(k, turn * dt / k), 0.0, full
    a, b, rot, sgn, shift = ellipse_image(j)
    u0, du = sgn * t0 + shift, sgn * dt
    if not b > 1e-12 * max(a, 1.0):
        raise GeometryError(f"ellipse is degenerate (radii {a:.6g} and {b:.6g} mm): it has no area")
    if arcs_per_quadrant is not None:
        if int(arcs_per_quadrant) < 1:
            raise GeometryError(f"arcs_per_quadrant must be >= 1, got {arcs_per_quadrant!r}")
        n = int(arcs_per_quadrant)
    elif tol_mm is None:
        n = default_arcs_per_quadrant(a, b)
    else:
        n = 2
    if method == "seed" and tol_mm is not None and arcs_per_quadrant is None:
        while True:     # the seed's scheme has no local refinement: raise the count
            verts, c, sweep, dev = _canonical_arcs(a, b, u0, du, n, method)
            if dev <= tol_mm or n >= _MAX_PER_QUADRANT:
                break
            n = min(_MAX_PER_QUADRANT, max(n + 1, int(n * 1.5)))
    else:
        verts, c, sweep, dev = _canonical_arcs(a, b, u0, du, n, method, tol_mm)
    if tol_mm is not None and dev > tol_mm:
        raise GeometryError(f"could not reach tol_mm={tol_mm} on an ellipse of radii {a:.6g}, "
                            f"{b:.6g} mm (reached {dev:.3g} mm)")
    cr, sr = math.cos(rot), math.sin(rot)
    rmat = np.array([[cr, -sr], [sr, cr]])
    verts = verts @ rmat.T + centre
    c = c @ rmat.T + centre
    if full:
        verts[-1] = verts[0]
    return verts, c, sweep, dev, full


def ellipse_to_arcs(centre, rx, ry, rotation=0.0, *, arcs_per_quadrant=None, tol_mm=None,
                    method="midpoint", **meta) -> Path:
    """A whole ellipse as a closed chain of circular arcs ([LaserApp] §3.4.2).

    Parameters
    ----------
    centre : array_like, shape (2,)
        mm.
    rx, ry : float
        Radii along the ellipse's own x and y axes, mm.
    rotation : float
        Angle of the ellipse's x axis, rad (CCW).
    arcs_per_quadrant, tol_mm, method, **meta
        As in :func:`ellipse_arc_to_arcs`; the default count is [LaserApp]'s
        round(8·max/min).

    Returns
    -------
    Path
        Closed, counter-clockwise, starting at the end of the rx axis;
        ``deviation_mm`` is the measured maximum deviation.

    Examples
    --------
    [LaserApp]'s default for a 2 : 1 ellipse is 16 arcs per quadrant; on a
    40 × 20 mm ellipse they deviate by 0.011 mm. Asking for a tolerance starts
from 2 per quadrant and halves only the arcs that miss it:

    >>> p = ellipse_to_arcs((0, 0), 20, 10)
    >>> p.n_segments, p.closed, round(p.deviation_mm, 3)
    (64, True, 0.011)
    >>> [ellipse_to_arcs((0, 0), 20, 10, tol_mm=t).n_segments for t in (0.05, 0.01, 0.001)]
    [12, 24, 44]
    """
    if not (rx > 0 and ry > 0):
        raise GeometryError(f"ellipse radii must be > 0 mm, got rx={rx!r}, ry={ry!r}")
    c, s = math.cos(rotation), math.sin(rotation)
    jac = np.array([[c, -s], [s, c]]) @ np.diag([rx, ry])
    return ellipse_arc_to_arcs(centre, jac, 0.0, 2 * math.pi, arcs_per_quadrant=arcs_per_quadrant,
                               tol_mm=tol_mm, method=method, **meta)
