"""Edge detectors of [LaserApp] (§2.5.3): SXOR, Roberts cross, Sobel, Prewitt; Canny to compare.

Magnitudes are in the units of the input gray (0…255) with the kernels as
the seed draws them — no normalisation. scikit-image scales its filters
differently; the factor from labkit to scikit-image for a uint8 image is

==========  ==========================================  ==================
operator    scikit-image                                 labkit / skimage
==========  ==========================================  ==================
Roberts     sqrt((Gx² + Gy²) / 2) on 0…1 gray             255 · √2
Sobel       sqrt(((Gx/4)² + (Gy/4)²) / 2) on 0…1 gray     255 · 4 · √2
Prewitt     sqrt(((Gx/3)² + (Gy/3)²) / 2) on 0…1 gray     255 · 3 · √2
==========  ==========================================  ==================

(:data:`SKIMAGE_FACTOR`). Border handling: the 3×3 operators read one pixel
beyond every edge, the 2×2 Roberts window one pixel beyond the bottom and
right edges; those pixels come from ``border`` — ``"reflect"`` (default,
scikit-image's choice, the edge pixel mirrored), ``"nearest"`` or
``"constant"``. The seed's application simply skipped the outermost pixels;
with ``"reflect"`` a uniform image gives zero magnitude at the border too.
"""

from __future__ import annotations

import math

import numpy as np

from labkit.errors import RasterError
from labkit.raster import _edge_kernels as _k
from labkit.raster._border import check_border, check_image_2d, check_mask, pad
from labkit.raster.color import threshold as _threshold
from labkit.raster.filters import blur as _blur
from labkit.raster.filters import convolve3x3

__all__ = [
    "OPERATORS",
    "SKIMAGE_FACTOR",
    "WINDOW_WEIGHTS",
    "sxor",
    "roberts",
    "sobel",
    "prewitt",
    "gradients",
    "edge_angle",
    "max_magnitude",
    "detect_edges",
    "canny",
]

#: The gradient operators :func:`detect_edges` knows (plus ``"sxor"`` and ``"canny"``).
OPERATORS = ("roberts", "sobel", "prewitt")

#: labkit magnitude / scikit-image magnitude for a uint8 image (see the module docstring).
SKIMAGE_FACTOR = {
    "roberts": 255.0 * math.sqrt(2.0),
    "sobel": 255.0 * 4.0 * math.sqrt(2.0),
    "prewitt": 255.0 * 3.0 * math.sqrt(2.0),
}


def _window3(a: float) -> tuple[np.ndarray, np.ndarray]:
    gx = np.array([[-1, 0, 1], [-a, 0, a], [-1, 0, 1]], dtype=np.float64)
    gy = np.array([[1, a, 1], [0, 0, 0], [-1, -a, -1]], dtype=np.float64)
    return gx, gy


#: Gx, Gy weights as they lie on the window (P1 top-left … P9 bottom-right);
#: Gx = right − left, Gy = top − bottom. Roberts' are 2×2 on P1 P2 / P3 P4.
WINDOW_WEIGHTS = {
    "roberts": (np.array([[1.0, 0.0], [0.0, -1.0]]), np.array([[0.0, 1.0], [-1.0, 0.0]])),
    "sobel": _window3(2.0),
    "prewitt": _window3(1.0),
}

_A = {"sobel": 2.0, "prewitt": 1.0}


def _as_gray(gray) -> np.ndarray:
    arr = check_image_2d(gray, "gray")
    if arr.dtype == bool:
        raise RasterError("gray must be a gray image, not a boolean mask; use sxor for masks "
                          "or multiply the mask by 255")
    return arr


def sxor(mask, *, border: str = "constant") -> np.ndarray:
    """Simple XOR edge detection on a one-bit image (Diaconu & Sima; [LaserApp] eqs. 5–7).

    Parameters
    ----------
    mask : ndarray of bool, 2-D
        The binary image.
    border : {"constant", "nearest"}
        What lies beyond the last row and column: ``"constant"`` — unmarked
        pixels, so shapes touching the frame get an edge there; ``"nearest"``
        — a copy of the last row/column, so the frame adds no edges.

    Returns
    -------
    ndarray of bool
        Horizontal edges I(i,:) ⊕ I(i+1,:) OR vertical edges I(:,j) ⊕ I(:,j+1);
        the edge pixel is the upper (left) one of each differing pair.

    Examples
    --------
    >>> m = np.zeros((4, 4), bool); m[1:3, 1:3] = True
    >>> sxor(m).astype(int)
    array([[0, 1, 1, 0],
           [1, 0, 1, 0],
           [1, 1, 1, 0],
           [0, 0, 0, 0]])
    """
    m = check_mask(mask)
    if border not in ("constant", "nearest"):
        raise RasterError(f"border must be 'constant' or 'nearest' for sxor, got {border!r}")
    below = np.empty_like(m)
    below[:-1] = m[1:]
    below[-1] = False if border == "constant" else m[-1]
    right = np.empty_like(m)
    right[:, :-1] = m[:, 1:]
    right[:, -1] = False if border == "constant" else m[:, -1]
    return (m ^ below) | (m ^ right)


def _magnitude(gray, operator: str, pseudo: bool, border: str, cval: float) -> np.ndarray:
    arr = _as_gray(gray)
    check_border(border)
    out = np.empty(arr.shape, dtype=np.float64)
    if operator == "roberts":
        _k.magnitude2x2(pad(arr, 0, 1, border, cval), bool(pseudo), out)
    else:
        _k.magnitude3x3(pad(arr, 1, 1, border, cval), _A[operator], bool(pseudo), out)
    return out


def roberts(gray, *, pseudo: bool = False, border: str = "reflect", cval: float = 0.0) -> np.ndarray:
    """Roberts cross gradient magnitude on the 2×2 window P1 P2 / P3 P4.

    Parameters
    ----------
    gray : array_like, 2-D
        labkit gray (0…255) or uint8.
    pseudo : bool
        False: |G| = sqrt(Gx² + Gy²) with Gx = P1 − P4, Gy = P2 − P3 (seed
        eq. 1). True: the single-pass pseudo-convolution |P1 − P4| + |P2 − P3|
        (seed eq. 3), which equals |Gx| + |Gy| and lies between |G| and √2·|G|.
    border : {"reflect", "nearest", "constant"}
        Values beyond the bottom and right edges.
    cval : float
        Outside value for ``border="constant"``.

    Returns
    -------
    ndarray of float64 (0 … 255·√2, pseudo 0 … 510)

    Examples
    --------
    >>> g = np.array([[0, 0], [0, 255]], dtype=np.uint8)
    >>> roberts(g, border="constant").tolist(), roberts(g, pseudo=True, border="constant").tolist()
    ([[255.0, 255.0], [255.0, 255.0]], [[255.0, 255.0], [255.0, 255.0]])
    """
    return _magnitude(gray, "roberts", pseudo, border, cval)


def sobel(gray, *, pseudo: bool = False, border: str = "reflect", cval: float = 0.0) -> np.ndarray:
    """Sobel gradient magnitude (kernel weight a = 2).

    Parameters
    ----------
    gray : array_like, 2-D
        As for :func:`roberts`.
    pseudo : bool
        False: sqrt(Gx² + Gy²) from the two 3×3 kernels (:data:`WINDOW_WEIGHTS`).
        True: [LaserApp] eq. (4) with a = 2, which equals |Gx| + |Gy|.
    border, cval
        As for :func:`roberts`, but beyond all four edges (see the module docstring).

    Returns
    -------
    ndarray of float64

    Notes
    -----
    One compiled pass computes Gx and Gy per pixel from its eight
    neighbours and writes the magnitude; ``sobel(img) / SKIMAGE_FACTOR["sobel"]``
    equals :func:`skimage.filters.sobel` on a uint8 image.

    Examples
    --------
    >>> step = np.array([[0, 0, 255, 255]] * 3, dtype=np.uint8)
    >>> sobel(step)[1].tolist(), sobel(step, pseudo=True)[1].tolist()
    ([0.0, 1020.0, 1020.0, 0.0], [0.0, 1020.0, 1020.0, 0.0])
    """
    return _magnitude(gray, "sobel", pseudo, border, cval)


def prewitt(gray, *, pseudo: bool = False, border: str = "reflect", cval: float = 0.0) -> np.ndarray:
    """Prewitt gradient magnitude (kernel weight a = 1); see :func:`sobel` for the parameters.

    Examples
    --------
    >>> step = np.array([[0, 0, 255, 255]] * 3, dtype=np.uint8)
    >>> prewitt(step)[1].tolist()
    [0.0, 765.0, 765.0, 0.0]
    """
    return _magnitude(gray, "prewitt", pseudo, border, cval)


def gradients(gray, operator: str = "sobel", *, border: str = "reflect",
              cval: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """The two gradient components Gx (right − left) and Gy (top − bottom).

    Computed by plain kernel convolution (:func:`labkit.raster.filters.convolve3x3`,
    or two shifted differences for Roberts) — a separate code path from the
    fused magnitude kernels, which the tests compare against it.

    Parameters
    ----------
    gray : array_like, 2-D
        labkit gray (0…255) or uint8.
    operator : {"roberts", "sobel", "prewitt"}
    border : {"reflect", "nearest", "constant"}
    cval : float

    Returns
    -------
    gx, gy : ndarray of float64

    Examples
    --------
    >>> gx, gy = gradients(np.array([[0, 0], [0, 255]], dtype=np.uint8), "roberts")
    >>> gx.tolist(), gy.tolist()
    ([[-255.0, -255.0], [-255.0, 0.0]], [[0.0, -255.0], [255.0, 0.0]])
    """
    if operator not in OPERATORS:
        raise RasterError(f"operator must be one of {OPERATORS}, got {operator!r}")
    arr = _as_gray(gray).astype(np.float64)
    if operator == "roberts":
        p = pad(arr, 0, 1, check_border(border), cval)
        gx = p[:-1, :-1] - p[1:, 1:]
        gy = p[:-1, 1:] - p[1:, :-1]
        return gx, gy
    wx, wy = WINDOW_WEIGHTS[operator]
    # convolve3x3 flips its kernel; flip the window weights back to correlate.
    return (convolve3x3(arr, wx[::-1, ::-1], border=border, cval=cval),
            convolve3x3(arr, wy[::-1, ::-1], border=border, cval=cval))


def edge_angle(gx, gy, *, roberts_offset: bool = True):
    """Orientation of the edge from the gradient components, rad.

    [LaserApp] eq. (2): θ = atan(Gy / Gx) − 3π/4 for the Roberts cross, whose
    kernels are rotated 45° (plus a quarter turn) from the pixel grid; the
    quadrant comes from atan2. ``roberts_offset=False`` gives the plain
    gradient direction atan2(Gy, Gx) for Sobel and Prewitt.

    Examples
    --------
    >>> round(edge_angle(1.0, 0.0), 4), round(edge_angle(1.0, 0.0, roberts_offset=False), 4)
    (-2.3562, 0.0)
    """
    theta = np.arctan2(gy, gx)
    if roberts_offset:
        theta = theta - 0.75 * np.pi
    return theta.item() if np.ndim(theta) == 0 else theta


def max_magnitude(operator: str, *, pseudo: bool = False) -> float:
    """An upper bound of the magnitude on 0…255 gray (for threshold sliders).

    Examples
    --------
    >>> max_magnitude("sobel", pseudo=True), round(max_magnitude("roberts"), 1)
    (2040.0, 360.6)
    """
    if operator not in OPERATORS:
        raise RasterError(f"operator must be one of {OPERATORS}, got {operator!r}")
    per_axis = 255.0 if operator == "roberts" else 255.0 * (2.0 + _A[operator])
    return 2.0 * per_axis if pseudo else math.sqrt(2.0) * per_axis


def detect_edges(gray, operator: str = "sobel", *, threshold: float | None = None,
                 pseudo: bool = False, blur: bool = False, level: float = 128,
                 border: str = "reflect", sigma: float = 1.0) -> np.ndarray:
    """Edge pixels of a gray image as a mask ready for pathing.

    Parameters
    ----------
    gray : array_like, 2-D
        labkit gray (0…255) or uint8.
    operator : {"sobel", "prewitt", "roberts", "sxor", "canny"}
        The detector. ``"sxor"`` first thresholds the gray at ``level``;
        ``"canny"`` is scikit-image's (with ``sigma``), for comparison.
    threshold : float, optional
        Gradient magnitudes ≥ this are edges (units of :func:`sobel` & co.);
        default a quarter of :func:`max_magnitude`. Ignored by sxor and canny.
    pseudo : bool
        Use the pseudo-convolution (|Gx| + |Gy|) instead of sqrt(Gx² + Gy²).
    blur : bool
        Blur with :data:`~labkit.raster.filters.BLUR_KERNEL` first ([LaserApp]
        Fig. 3.14: fewer noise edges).
    level : float
        Threshold level for sxor (0…256).
    border : str
        Border mode of the 3×3 / 2×2 operators.
    sigma : float
        Gaussian width for canny, pixels.

    Returns
    -------
    ndarray of bool (True = edge pixel to burn)

    Examples
    --------
    >>> g = np.full((5, 5), 255.0); g[1:4, 1:4] = 0
    >>> int(detect_edges(g, "sobel").sum()), int(detect_edges(g, "sxor").sum())
    (24, 11)
    """
    arr = _as_gray(gray)
    if blur:
        arr = _blur(arr, border=border)
    if operator == "sxor":
        return sxor(_threshold(arr, level))
    if operator == "canny":
        return canny(arr, sigma=sigma)
    if operator not in OPERATORS:
        raise RasterError(f"operator must be one of {OPERATORS + ('sxor', 'canny')}, got {operator!r}")
    if threshold is None:
        threshold = 0.25 * max_magnitude(operator, pseudo=pseudo)
    if not threshold >= 0:
        raise RasterError(f"threshold must be >= 0, got {threshold!r}")
    return _magnitude(arr, operator, pseudo, border, 0.0) >= threshold


def canny(gray, *, sigma: float = 1.0, low: float | None = None, high: float | None = None) -> np.ndarray:
    """scikit-image's Canny detector on labkit gray, for comparison with the seed's operators.

    Parameters
    ----------
    gray : array_like, 2-D
        labkit gray (0…255).
    sigma : float
        Gaussian smoothing, pixels.
    low, high : float, optional
        Hysteresis thresholds on the 0…1 gradient scale (scikit-image defaults).
    """
    from skimage.feature import canny as _canny

    arr = _as_gray(gray).astype(np.float64) / 255.0
    if not sigma > 0:
        raise RasterError(f"sigma must be > 0 pixels, got {sigma!r}")
    return _canny(arr, sigma=sigma, low_threshold=low, high_threshold=high)
