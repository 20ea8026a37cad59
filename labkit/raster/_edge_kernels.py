"""Compiled single-pass edge kernels (numba). Inputs are padded images.

Each kernel reads the window around an output pixel from a padded copy of
the image (see :mod:`labkit.raster._border`) and writes one float64 value:
there is no intermediate Gx/Gy image, which is what makes them faster than
two separate convolutions.
"""

from __future__ import annotations

import math

import numpy as np

from labkit._jit import jit


@jit
def magnitude3x3(p, a, pseudo, out):
    """Sobel (a = 2) or Prewitt (a = 1) magnitude on the window P1 … P9 (row-major).

    Gx = (P3 + aP6 + P9) − (P1 + aP4 + P7) (right − left), Gy = (P1 + aP2 + P3)
    − (P7 + aP8 + P9) (top − bottom); writes sqrt(Gx² + Gy²), or with
    ``pseudo`` [LaserApp] eq. (4), |Gx| + |Gy|.
    """
    rows, cols = out.shape
    for i in range(rows):
        for j in range(cols):
            p1 = np.float64(p[i, j])
            p2 = np.float64(p[i, j + 1])
            p3 = np.float64(p[i, j + 2])
            p4 = np.float64(p[i + 1, j])
            p6 = np.float64(p[i + 1, j + 2])
            p7 = np.float64(p[i + 2, j])
            p8 = np.float64(p[i + 2, j + 1])
            p9 = np.float64(p[i + 2, j + 2])
            gx = (p3 + a * p6 + p9) - (p1 + a * p4 + p7)
            gy = (p1 + a * p2 + p3) - (p7 + a * p8 + p9)
            if pseudo:
                out[i, j] = abs(gx) + abs(gy)
            else:
                out[i, j] = math.sqrt(gx * gx + gy * gy)


@jit
def magnitude2x2(p, pseudo, out):
    """Roberts cross on the window P1 P2 / P3 P4: Gx = P1 − P4, Gy = P2 − P3.

    Writes sqrt(Gx² + Gy²), or with ``pseudo`` [LaserApp] eq. (3), |P1 − P4| + |P2 − P3|.
    """
    rows, cols = out.shape
    for i in range(rows):
        for j in range(cols):
            gx = np.float64(p[i, j]) - np.float64(p[i + 1, j + 1])
            gy = np.float64(p[i, j + 1]) - np.float64(p[i + 1, j])
            if pseudo:
                out[i, j] = abs(gx) + abs(gy)
            else:
                out[i, j] = math.sqrt(gx * gx + gy * gy)
