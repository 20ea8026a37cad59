"""Error-diffusion dithering: gray → dots of full power (engraving photos on a one-level laser).

Each pixel is set black or white by a threshold and the rounding error is
shared among the pixels not yet visited, with weights that sum to one (or
less, for Atkinson's, which keeps more contrast). The average darkness of
an area is kept, so the dot density follows the gray level.
"""

from __future__ import annotations

import numpy as np

from labkit.errors import RasterError
from labkit.raster import _diffuse
from labkit.raster._border import check_image_2d

__all__ = ["DIFFUSION", "dither"]

#: Diffusion tables: (row offset, column offset, weight) for the pixels ahead.
DIFFUSION = {
    "floyd-steinberg": [(0, 1, 7 / 16), (1, -1, 3 / 16), (1, 0, 5 / 16), (1, 1, 1 / 16)],
    "atkinson": [(0, 1, 1 / 8), (0, 2, 1 / 8), (1, -1, 1 / 8), (1, 0, 1 / 8), (1, 1, 1 / 8),
                 (2, 0, 1 / 8)],
    "jarvis": [(0, 1, 7 / 48), (0, 2, 5 / 48),
               (1, -2, 3 / 48), (1, -1, 5 / 48), (1, 0, 7 / 48), (1, 1, 5 / 48), (1, 2, 3 / 48),
               (2, -2, 1 / 48), (2, -1, 3 / 48), (2, 0, 5 / 48), (2, 1, 3 / 48), (2, 2, 1 / 48)],
    "stucki": [(0, 1, 8 / 42), (0, 2, 4 / 42),
               (1, -2, 2 / 42), (1, -1, 4 / 42), (1, 0, 8 / 42), (1, 1, 4 / 42), (1, 2, 2 / 42),
               (2, -2, 1 / 42), (2, -1, 2 / 42), (2, 0, 4 / 42), (2, 1, 2 / 42), (2, 2, 1 / 42)],
}


def dither(gray, method: str = "floyd-steinberg", *, level: float = 128, serpentine: bool = False) -> np.ndarray:
    """Dither labkit gray to a mask of dots to burn.

    Parameters
    ----------
    gray : array_like, 2-D
        labkit gray (0…255) or uint8.
    method : {"floyd-steinberg", "atkinson", "jarvis", "stucki"}
        Diffusion table (:data:`DIFFUSION`).
    level : float
        A pixel (with the error it received) darker than this becomes a dot.
    serpentine : bool
        Scan every other row right to left (mirrored weights), which breaks
        up the diagonal "worm" patterns of plain raster order.

    Returns
    -------
    ndarray of bool (True = dot to burn)

    Notes
    -----
    Floyd and Steinberg (1976): 7/16 to the right, 3/16, 5/16, 1/16 to the row
    below. Atkinson's table spreads only 6/8 of the error; Jarvis–Judice–Ninke
    and Stucki spread it over 12 pixels in two rows.

    Examples
    --------
    >>> dither(np.array([[100.0, 100.0, 100.0]])).tolist()   # 0 → +43.75 → 143.75 ≥ 128 …
    [[True, False, True]]
    """
    arr = check_image_2d(gray, "gray")
    if method not in DIFFUSION:
        raise RasterError(f"method must be one of {sorted(DIFFUSION)}, got {method!r}")
    if not 0 <= level <= 256:
        raise RasterError(f"level must be in 0…256, got {level!r}")
    table = np.array(DIFFUSION[method])
    work = np.array(arr, dtype=np.float64)
    return _diffuse.diffuse(work, float(level), table[:, 0].astype(np.int64),
                            table[:, 1].astype(np.int64), table[:, 2].copy(), bool(serpentine))
