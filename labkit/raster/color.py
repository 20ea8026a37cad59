"""Colour to gray, gray to one bit, inversion and gamma.

labkit's gray images are float64 arrays in 0…255 (0 black, 255 white), the
8-bit scale [LaserApp] works in (§3.4.1). A *mask* is a boolean array where
True marks a pixel the laser burns (a dark pixel).
"""

from __future__ import annotations

import math

import numpy as np

from labkit.errors import RasterError
from labkit.raster._border import check_image_2d

__all__ = [
    "GRAY_WEIGHTS",
    "SEED_DEPTHS",
    "to_gray",
    "blank_mask",
    "threshold",
    "depth_to_level",
    "threshold_depths",
    "invert",
    "adjust_gamma",
]

#: Luma weights (R, G, B) by name: [LaserApp] eq. (8), ITU-R BT.601 and BT.709.
GRAY_WEIGHTS = {
    "seed": (0.3, 0.59, 0.11),
    "rec601": (0.299, 0.587, 0.114),
    "rec709": (0.2126, 0.7152, 0.0722),
}

#: The nine depths (percent) [LaserApp]'s application keeps ready: 10 % … 90 %.
SEED_DEPTHS = (10, 20, 30, 40, 50, 60, 70, 80, 90)


def _to_255(arr: np.ndarray, name: str) -> np.ndarray:
    """Any supported dtype → float64 on the 0…255 scale."""
    if arr.dtype == bool:
        return arr.astype(np.float64) * 255.0
    if arr.dtype.kind in "ui":
        info = np.iinfo(arr.dtype)
        if arr.dtype.kind == "i" and arr.min() < 0:
            raise RasterError(f"{name} has negative values (min {arr.min()}); expected 0…{info.max}")
        return arr.astype(np.float64) * (255.0 / info.max)
    lo, hi = float(np.nanmin(arr)), float(np.nanmax(arr))
    if np.isnan(arr).any() or lo < 0.0 or hi > 1.0:
        raise RasterError(f"{name} is a float image with values {lo:g}…{hi:g}; floats must lie in "
                          f"0…1 (pass uint8 for 0…255)")
    return arr.astype(np.float64) * 255.0


def to_gray(image, weights="seed") -> np.ndarray:
    """Convert an image to labkit gray (float64, 0 = black … 255 = white).

    Parameters
    ----------
    image : array_like
        2-D gray, or 3-D with 1 (gray), 2 (gray + alpha), 3 (RGB) or 4 (RGBA)
        channels last. uint8/uint16 use their full range, booleans map to
        0/255 (True = white, as scikit-image's ``horse``), floats must lie in
        0…1. Transparent pixels are composited onto white (not burned).
    weights : str or sequence of 3 floats
        ``"seed"`` (0.3, 0.59, 0.11 — [LaserApp] eq. 8), ``"rec601"``
        (0.299, 0.587, 0.114) or ``"rec709"`` (0.2126, 0.7152, 0.0722), or
        your own R, G, B weights (they must sum to 1).

    Returns
    -------
    ndarray of float64, shape (rows, columns)

    Raises
    ------
    RasterError
        Unsupported shape, dtype, value range or weights.

    Notes
    -----
    Gray = wR·R + wG·G + wB·B on the 0…255 scale ([LaserApp] §3.4.1, the
    colour-TV luma). The result is not rounded; :func:`threshold` compares
    it with an 8-bit level.

    Examples
    --------
    >>> rgb = np.array([[[255, 0, 0], [0, 255, 0], [0, 0, 255]]], dtype=np.uint8)
    >>> to_gray(rgb).round(2).tolist()
    [[76.5, 150.45, 28.05]]
    >>> to_gray(rgb, "rec709").round(2).tolist()
    [[54.21, 182.38, 18.41]]
    """
    arr = np.asarray(image)
    if isinstance(weights, str):
        if weights not in GRAY_WEIGHTS:
            raise RasterError(f"weights must be one of {sorted(GRAY_WEIGHTS)} or 3 numbers, got {weights!r}")
        w = np.array(GRAY_WEIGHTS[weights])
    else:
        w = np.asarray(weights, dtype=float)
        if w.shape != (3,) or not math.isclose(float(w.sum()), 1.0, abs_tol=1e-6) or (w < 0).any():
            raise RasterError(f"weights must be 3 non-negative numbers summing to 1, got {weights!r}")
    if arr.ndim == 3 and arr.shape[2] == 1:
        arr = arr[:, :, 0]
    if arr.ndim == 2:
        return _to_255(check_image_2d(arr), "image")
    if arr.ndim != 3 or arr.shape[2] not in (2, 3, 4) or arr.size == 0:
        raise RasterError(f"image must be 2-D gray or 3-D with 1–4 channels last, got shape {arr.shape}")
    if arr.dtype.kind not in "buif":
        raise RasterError(f"image must hold numbers, got dtype {arr.dtype}")
    chans = _to_255(arr, "image")
    if chans.shape[2] in (2, 4):
        alpha = chans[:, :, -1:] / 255.0
        chans = chans[:, :, :-1] * alpha + 255.0 * (1.0 - alpha)
    if chans.shape[2] == 1:
        return chans[:, :, 0]
    return chans @ w


def blank_mask(image) -> np.ndarray | None:
    """Where an image has nothing: its fully transparent pixels (alpha 0).

    The one rule of transparency in labkit: these pixels are never burned, in any mode
    and whatever the colour stored under them (:func:`~labkit.raster.engrave.image_to_job`
    honours it after inverting, filtering and resampling). Partly transparent pixels are
    not blank: :func:`to_gray` composites them onto white, as a viewer shows them.

    Parameters
    ----------
    image : array_like
        An image :func:`to_gray` takes; 3-D with 2 (gray + alpha) or 4 (RGBA) channels
        carries transparency (:func:`~labkit.raster.io.read_image` turns every kind —
        alpha, ``tRNS`` colour keys, palette transparency — into that channel).

    Returns
    -------
    ndarray of bool, shape (rows, columns), or None
        True = nothing here; None when the image has no alpha channel or no pixel is
        fully transparent.

    Examples
    --------
    >>> la = np.array([[[0, 255], [0, 0], [200, 7]]], dtype=np.uint8)    # gray, alpha
    >>> blank_mask(la).tolist()
    [[False, True, False]]
    >>> blank_mask(np.zeros((2, 3))) is None
    True
    """
    arr = np.asarray(image)
    if arr.ndim != 3 or arr.shape[2] not in (2, 4):
        return None
    blank = arr[:, :, -1] == 0
    return blank if blank.any() else None


def threshold(gray, level: float = 128) -> np.ndarray:
    """One bit per pixel: True (burn) where the gray is darker than ``level``.

    Parameters
    ----------
    gray : array_like, 2-D
        labkit gray (0…255) or uint8.
    level : float
        Threshold on the 0…256 scale; pixels with ``gray < level`` burn.

    Returns
    -------
    ndarray of bool

    Examples
    --------
    >>> threshold(np.array([[0, 127, 128, 255]]), 128).tolist()
    [[True, True, False, False]]
    """
    arr = check_image_2d(gray, "gray")
    if not 0 <= level <= 256:
        raise RasterError(f"level must be in 0…256, got {level!r}")
    return arr < level


def depth_to_level(percent: float) -> int:
    """[LaserApp]'s depth in percent → 8-bit threshold level.

    Notes
    -----
    The seed pairs 10 % with 25 and 90 % with 230 (§3.4.1); ⌊p/100 · 256⌋
    gives both (p/100 · 255 rounded would give 26 for 10 %), so that is the
    rule used here.

    Examples
    --------
    >>> [depth_to_level(p) for p in SEED_DEPTHS]
    [25, 51, 76, 102, 128, 153, 179, 204, 230]
    """
    if not 0 <= percent <= 100:
        raise RasterError(f"percent must be in 0…100, got {percent!r}")
    return int(math.floor(percent / 100.0 * 256.0 + 1e-9)) if percent < 100 else 256


def threshold_depths(gray, depths=SEED_DEPTHS) -> dict[int, np.ndarray]:
    """The seed's set of ready-made black-and-white versions, one per depth.

    Parameters
    ----------
    gray : array_like, 2-D
        labkit gray (0…255).
    depths : sequence of float
        Depths in percent (default the seed's nine, 10 … 90).

    Returns
    -------
    dict
        depth → boolean mask (True = burn); a larger depth burns more.

    Examples
    --------
    >>> masks = threshold_depths(np.array([[20.0, 100.0, 240.0]]))
    >>> [int(masks[p].sum()) for p in (10, 50, 90)]
    [1, 2, 2]
    """
    arr = check_image_2d(gray, "gray")
    return {p: arr < depth_to_level(p) for p in depths}


def invert(image) -> np.ndarray:
    """Negative image: 255 − value ([LaserApp] eq. 9); masks swap True and False.

    Parameters
    ----------
    image : array_like
        bool mask, uint8 image (any channels), or labkit gray (float 0…255).

    Examples
    --------
    >>> invert(np.array([[0, 100, 255]], dtype=np.uint8)).tolist()
    [[255, 155, 0]]
    >>> invert(np.array([[True, False]])).tolist()
    [[False, True]]
    """
    arr = np.asarray(image)
    if arr.dtype == bool:
        return ~arr
    if arr.dtype == np.uint8:
        return 255 - arr
    if arr.dtype.kind == "f":
        if arr.size and (np.nanmin(arr) < 0 or np.nanmax(arr) > 255):
            raise RasterError("a float image to invert must be labkit gray in 0…255, "
                              f"got {np.nanmin(arr):g}…{np.nanmax(arr):g}")
        return 255.0 - arr
    raise RasterError(f"invert takes bool, uint8 or float gray images, got dtype {arr.dtype}")


def adjust_gamma(gray, gamma: float) -> np.ndarray:
    """Gamma correction on labkit gray: 255 · (g / 255) ** gamma.

    ``gamma`` > 1 darkens the mid-tones (more burn), < 1 lightens them;
    black and white stay.

    Examples
    --------
    >>> adjust_gamma(np.array([[0.0, 63.75, 255.0]]), 2.0).tolist()
    [[0.0, 15.9375, 255.0]]
    """
    arr = check_image_2d(gray, "gray").astype(np.float64)
    if not (gamma > 0 and math.isfinite(gamma)):
        raise RasterError(f"gamma must be a finite number > 0, got {gamma!r}")
    if arr.min() < 0 or arr.max() > 255:
        raise RasterError(f"gray must lie in 0…255, got {arr.min():g}…{arr.max():g}")
    return 255.0 * (arr / 255.0) ** gamma
