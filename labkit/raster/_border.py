"""Border handling shared by the 2×2 and 3×3 neighbourhood operators.

A neighbourhood operator needs pixels outside the image at its border. The
choices, named as in :func:`scipy.ndimage.convolve` so results can be
compared one to one:

``"reflect"``   the image mirrored about its edge, edge pixel repeated
                (``d c b a | a b c d``); scikit-image's default.
``"nearest"``   the edge pixel repeated (``a a a a | a b c d``).
``"constant"``  a constant value (``cval``) outside the image.
"""

from __future__ import annotations

import numpy as np

from labkit.errors import RasterError

#: Border names → :func:`numpy.pad` modes.
BORDERS = {"reflect": "symmetric", "nearest": "edge", "constant": "constant"}


def check_border(border: str) -> str:
    """Return ``border`` if it is a known border mode, else raise RasterError."""
    if border not in BORDERS:
        raise RasterError(f"border must be one of {sorted(BORDERS)}, got {border!r}")
    return border


def pad(image: np.ndarray, before: int, after: int, border: str, cval: float = 0.0) -> np.ndarray:
    """Pad a 2-D image by ``before`` rows/columns at the top/left and ``after`` at the bottom/right."""
    mode = BORDERS[check_border(border)]
    widths = ((before, after), (before, after))
    if mode == "constant":
        return np.pad(image, widths, mode="constant", constant_values=cval)
    return np.pad(image, widths, mode=mode)


def check_image_2d(image, name: str = "image") -> np.ndarray:
    """The argument as a 2-D real numeric array, or a RasterError naming it."""
    arr = np.asarray(image)
    if arr.ndim != 2:
        raise RasterError(f"{name} must be a 2-D array (rows, columns), got shape {arr.shape}")
    if arr.size == 0:
        raise RasterError(f"{name} is empty (shape {arr.shape})")
    if arr.dtype.kind not in "biuf":
        raise RasterError(f"{name} must hold numbers or booleans, got dtype {arr.dtype}")
    return arr


def check_mask(mask, name: str = "mask") -> np.ndarray:
    """The argument as a 2-D boolean array (True = marked for the laser)."""
    arr = check_image_2d(mask, name)
    if arr.dtype != bool:
        raise RasterError(f"{name} must be a boolean array (True = burn), got dtype {arr.dtype}; "
                          f"use labkit.raster.threshold to make one")
    return arr
