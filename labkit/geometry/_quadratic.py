"""The real roots of a quadratic, computed the stable way, for compiled kernels."""

from __future__ import annotations

import math

from labkit._jit import jit

#: Coefficients below this share of |a| + |b| + |c| count as zero: a leading one makes the
#: equation linear, a negative discriminant this close to zero a double root.
RELATIVE_EPS = 1e-12


@jit
def stable_quadratic_roots(a, b, c):
    """Real roots of a t² + b t + c = 0, ascending: (count, r1, r2), unused roots nan.

    Written as q = −(b + sign(b)·√(b² − 4ac))/2, roots q/a and c/q, so neither root
    loses digits to the subtraction of two nearly equal numbers. A leading
    coefficient within rounding of zero leaves the linear root; a discriminant
    within rounding below zero counts as a double root (a tangency, a cusp).

    >>> stable_quadratic_roots(1.0, -3.0, 2.0)
    (2, 1.0, 2.0)
    >>> stable_quadratic_roots(1e-20, 1.0, -1.0)[:2]
    (1, 1.0)
    >>> n, r1, r2 = stable_quadratic_roots(1.0, 1e8, 1.0)
    >>> n, abs(r2 + 1e-8) < 1e-22
    (2, True)
    """
    scale = abs(a) + abs(b) + abs(c)
    if scale == 0.0:
        return 0, math.nan, math.nan
    if abs(a) <= RELATIVE_EPS * scale:
        if abs(b) <= RELATIVE_EPS * scale:
            return 0, math.nan, math.nan
        return 1, -c / b, math.nan
    disc = b * b - 4.0 * a * c
    if disc < 0.0:
        if disc < -RELATIVE_EPS * b * b:
            return 0, math.nan, math.nan
        disc = 0.0
    sq = math.sqrt(disc)
    q = -0.5 * (b + (sq if b >= 0.0 else -sq))
    r1 = q / a
    r2 = c / q if q != 0.0 else r1
    if r1 > r2:
        r1, r2 = r2, r1
    return 2, r1, r2
