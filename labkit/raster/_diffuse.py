"""Compiled error diffusion (used by :mod:`labkit.raster.diffusion`)."""

from __future__ import annotations

import numpy as np

from labkit._jit import jit


@jit(python_below=300_000)  # pixels: ~2.6 µs each as Python, ~1 s at 300,000 (issue 29's rule)
def diffuse(gray, level, dr, dc, w, serpentine):
    """Threshold each pixel in raster order and push its error to the neighbours ahead.

    ``gray`` (float64, 0…255) is modified in place; (dr[k], dc[k], w[k]) are
    the diffusion offsets and weights (dc mirrored on right-to-left rows when
    ``serpentine``). Returns the mask of black (burned) pixels.
    """
    rows, cols = gray.shape
    out = np.zeros((rows, cols), dtype=np.bool_)
    for r in range(rows):
        backwards = serpentine and r % 2 == 1
        for k in range(cols):
            c = cols - 1 - k if backwards else k
            old = gray[r, c]
            if old < level:
                new = 0.0
                out[r, c] = True
            else:
                new = 255.0
            err = old - new
            for t in range(w.shape[0]):
                rr = r + dr[t]
                cc = c - dc[t] if backwards else c + dc[t]
                if rr < rows and 0 <= cc < cols:
                    gray[rr, cc] += err * w[t]
    return out
