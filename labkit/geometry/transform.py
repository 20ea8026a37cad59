"""Affine transforms in the plane as 3×3 matrices, and what they do to ellipses.

A transform is the matrix ``[[a, c, e], [b, d, f], [0, 0, 1]]`` of [LaserApp]
§3.4.2 (eq. 25): a point (x, y) maps to (a·x + c·y + e, b·x + d·y + f). SVG
writes the same six numbers as ``matrix(a b c d e f)``. Transforms compose by
matrix product; ``compose(outer, inner)`` applies ``inner`` first, as nested
SVG groups do.

Circles stay circles only under a *similarity* (rotation, uniform scale,
mirror, translation). Under any other affine map a circle becomes an ellipse,
and an ellipse stays an ellipse: :func:`ellipse_image` gives its new radii and
rotation from the singular value decomposition of the 2×2 part.
"""

from __future__ import annotations

import math

import numpy as np

from labkit.errors import GeometryError

__all__ = [
    "identity",
    "translate",
    "scale",
    "rotate",
    "skew",
    "matrix",
    "compose",
    "apply",
    "is_similarity",
    "similarity_scale",
    "ellipse_image",
]


def identity() -> np.ndarray:
    """The 3×3 identity transform."""
    return np.eye(3)


def matrix(a, b, c, d, e=0.0, f=0.0) -> np.ndarray:
    """The transform of SVG's ``matrix(a b c d e f)`` ([LaserApp] eq. 25).

    >>> matrix(1, 0, 0, 1, 5, 7) @ [0, 0, 1]
    array([5., 7., 1.])
    """
    return np.array([[a, c, e], [b, d, f], [0.0, 0.0, 1.0]], dtype=float)


def translate(tx_mm, ty_mm=0.0) -> np.ndarray:
    """Shift by (tx, ty) mm."""
    return matrix(1, 0, 0, 1, tx_mm, ty_mm)


def scale(sx, sy=None) -> np.ndarray:
    """Scale by sx along x and sy along y (sy defaults to sx)."""
    return matrix(sx, 0, 0, sx if sy is None else sy)


def rotate(angle_rad, about=(0.0, 0.0)) -> np.ndarray:
    """Rotate counter-clockwise by ``angle_rad`` about the point ``about`` (mm).

    >>> (rotate(math.pi / 2) @ [1, 0, 1]).round(12)
    array([0., 1., 1.])
    """
    c, s = math.cos(angle_rad), math.sin(angle_rad)
    r = matrix(c, s, -s, c)
    px, py = about
    return translate(px, py) @ r @ translate(-px, -py)


def skew(ax_rad=0.0, ay_rad=0.0) -> np.ndarray:
    """Skew: x += tan(ax)·y and y += tan(ay)·x (SVG ``skewX``/``skewY``)."""
    return matrix(1, math.tan(ay_rad), math.tan(ax_rad), 1)


def compose(*transforms) -> np.ndarray:
    """Product of transforms; the LAST one is applied first (like nested groups).

    >>> compose(translate(10), scale(2)) @ [1, 1, 1]     # scale, then shift
    array([12.,  2.,  1.])
    """
    out = np.eye(3)
    for t in transforms:
        out = out @ _check(t)
    return out


def _check(m) -> np.ndarray:
    m = np.asarray(m, dtype=float)
    if m.shape == (2, 3):
        m = np.vstack([m, [0.0, 0.0, 1.0]])
    if m.shape != (3, 3):
        raise GeometryError(f"a transform must be a 3x3 (or 2x3) matrix, got shape {m.shape}")
    if not np.all(np.isfinite(m)):
        raise GeometryError("a transform must hold finite numbers, got NaN or inf")
    return m


def apply(m, points) -> np.ndarray:
    """Map points (…, 2) through the transform ``m``.

    >>> apply(scale(2, 3), [[1, 1], [2, 0]])
    array([[2., 3.],
           [4., 0.]])
    """
    m = _check(m)
    pts = np.asarray(points, dtype=float)
    return pts @ m[:2, :2].T + m[:2, 2]


def similarity_scale(m, rel_tol=1e-9) -> float | None:
    """The scale factor s if the 2×2 part is s·(rotation or mirror), else None."""
    a = _check(m)[:2, :2]
    sv = np.linalg.svd(a, compute_uv=False)
    if sv[0] == 0 or sv[0] - sv[1] > rel_tol * sv[0]:
        return None
    return float(sv[0])


def is_similarity(m, rel_tol=1e-9) -> bool:
    """True if the transform maps circles to circles (rotation, uniform scale, mirror, shift).

    >>> is_similarity(compose(rotate(0.3), scale(-2, 2))), is_similarity(skew(0.2))
    (True, False)
    """
    return similarity_scale(m, rel_tol) is not None


def ellipse_image(jacobian):
    """Put ``p(t) = c + J·(cos t, sin t)`` into standard ellipse form.

    Any affine image of a circle or ellipse can be written with a 2×2 matrix
    J (for an ellipse of radii rx, ry and rotation φ mapped by the 2×2 part A
    of a transform, J = A·R(φ)·diag(rx, ry)). Its SVD J = U·S·Vᵀ gives the
    image's radii (the singular values), its rotation (the angle of U's first
    column) and how the parameter t carries over.

    Parameters
    ----------
    jacobian : array_like, shape (2, 2)

    Returns
    -------
    rx, ry : float
        Radii in mm, rx ≥ ry ≥ 0 (rx along the rotated x axis).
    rotation : float
        Angle of the rx axis, rad.
    t_sign, t_shift : float
        The same point is ``c + R(rotation)·(rx cos u, ry sin u)`` with
        u = t_sign·t + t_shift; t_sign = −1 when the map mirrors.

    Examples
    --------
    A unit circle sheared by skewX(45°) becomes an ellipse with radii
    (√5 ± 1)/2 — the golden ratio and its inverse:

    >>> rx, ry, rot, sgn, shift = ellipse_image(skew(math.pi / 4)[:2, :2])
    >>> round(rx, 6), round(ry, 6), round(rx * ry, 6)
    (1.618034, 0.618034, 1.0)
    """
    j = np.asarray(jacobian, dtype=float)
    u, s, vt = np.linalg.svd(j)
    if np.linalg.det(u) < 0:          # make U a rotation: U·S·Vᵀ = (U·F)·S·(F·Vᵀ), F = diag(1, −1)
        u = u * np.array([1.0, -1.0])
        vt = vt * np.array([[1.0], [-1.0]])
    rotation = math.atan2(u[1, 0], u[0, 0])
    psi = math.atan2(vt[0, 1], vt[0, 0])
    if np.linalg.det(vt) > 0:         # Vᵀ = R(−ψ): u = t − ψ
        return float(s[0]), float(s[1]), rotation, 1.0, -psi
    return float(s[0]), float(s[1]), rotation, -1.0, psi    # Vᵀ a mirror: u = ψ − t
