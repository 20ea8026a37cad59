"""3×3 kernel convolution: blur and sharpen ([LaserApp] §3.4.1, "Sharp and Blur").

Blurring before edge detection removes noise that would otherwise turn into
edges; sharpening brings out fine detail. Both are a convolution of the gray
image with a 3×3 kernel. The seed shows its two kernels only as a picture
(Fig. 3.12), so labkit uses the textbook ones: the 4-neighbour sharpen
kernel and the binomial (Gaussian-like) blur, with a box blur as an option.
"""

from __future__ import annotations

import numpy as np

from labkit.errors import RasterError
from labkit.raster._border import check_image_2d, pad

__all__ = ["SHARPEN_KERNEL", "BLUR_KERNEL", "BOX_KERNEL", "convolve3x3", "blur", "sharpen"]

#: Sharpen: the pixel counted five times minus its four neighbours (weights sum to 1).
SHARPEN_KERNEL = np.array([[0, -1, 0], [-1, 5, -1], [0, -1, 0]], dtype=np.float64)
#: Binomial blur, 1/16 · [1 2 1]ᵀ[1 2 1] (weights sum to 1).
BLUR_KERNEL = np.array([[1, 2, 1], [2, 4, 2], [1, 2, 1]], dtype=np.float64) / 16.0
#: Box blur, the mean of the 3×3 neighbourhood.
BOX_KERNEL = np.full((3, 3), 1.0 / 9.0)

_BLURS = {"gaussian": BLUR_KERNEL, "box": BOX_KERNEL}


def convolve3x3(gray, kernel, *, border: str = "reflect", cval: float = 0.0) -> np.ndarray:
    """Convolve a 2-D image with a 3×3 kernel.

    Parameters
    ----------
    gray : array_like, 2-D
        labkit gray (0…255) or any real image.
    kernel : array_like, shape (3, 3)
        Weights; convolution flips it (as :func:`scipy.ndimage.convolve`),
        which matters only for kernels that are not point-symmetric.
    border : {"reflect", "nearest", "constant"}
        Values assumed outside the image (see :mod:`labkit.raster._border`).
    cval : float
        The outside value for ``border="constant"``.

    Returns
    -------
    ndarray of float64, same shape

    Examples
    --------
    >>> img = np.zeros((3, 3)); img[1, 1] = 16
    >>> convolve3x3(img, BLUR_KERNEL, border="constant").tolist()
    [[1.0, 2.0, 1.0], [2.0, 4.0, 2.0], [1.0, 2.0, 1.0]]
    """
    arr = check_image_2d(gray, "gray").astype(np.float64, copy=False)
    k = np.asarray(kernel, dtype=np.float64)
    if k.shape != (3, 3):
        raise RasterError(f"kernel must have shape (3, 3), got {k.shape}")
    p = pad(arr, 1, 1, border, cval)
    rows, cols = arr.shape
    out = np.zeros((rows, cols))
    flipped = k[::-1, ::-1]
    for di in range(3):
        for dj in range(3):
            w = flipped[di, dj]
            if w != 0.0:
                out += w * p[di:di + rows, dj:dj + cols]
    return out


def blur(gray, *, kind: str = "gaussian", border: str = "reflect") -> np.ndarray:
    """Low-pass 3×3 blur of labkit gray.

    Parameters
    ----------
    gray : array_like, 2-D
        labkit gray (0…255).
    kind : {"gaussian", "box"}
        :data:`BLUR_KERNEL` (binomial) or :data:`BOX_KERNEL` (mean).
    border : {"reflect", "nearest", "constant"}
        Outside values (see :func:`convolve3x3`).

    Examples
    --------
    >>> blur(np.array([[0.0, 0.0, 255.0, 0.0, 0.0]]), kind="box").round(1).tolist()
    [[0.0, 85.0, 85.0, 85.0, 0.0]]
    """
    if kind not in _BLURS:
        raise RasterError(f"kind must be one of {sorted(_BLURS)}, got {kind!r}")
    return convolve3x3(gray, _BLURS[kind], border=border)


def sharpen(gray, *, border: str = "reflect", clip: bool = True) -> np.ndarray:
    """High-pass 3×3 sharpen of labkit gray (:data:`SHARPEN_KERNEL`).

    Parameters
    ----------
    gray : array_like, 2-D
        labkit gray (0…255).
    border : {"reflect", "nearest", "constant"}
        Outside values (see :func:`convolve3x3`).
    clip : bool
        Clip the result to 0…255 (sharpening overshoots at edges).

    Examples
    --------
    >>> sharpen(np.array([[100.0, 100.0, 200.0, 200.0]])).tolist()
    [[100.0, 0.0, 255.0, 200.0]]
    """
    out = convolve3x3(gray, SHARPEN_KERNEL, border=border)
    return np.clip(out, 0.0, 255.0) if clip else out
