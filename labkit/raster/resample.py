"""Pixel density adjustment: one pixel = one beam diameter ([LaserApp] §3.4.1).

The tool paths put the beam on pixel centres, so a pixel should be as wide
as the beam: then neighbouring lines touch without overlapping. The image
is resampled to ``round(size_mm / beam_mm)`` pixels per side; the rounding
changes the engraved size slightly, and that error is reported in mm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from labkit.errors import RasterError
from labkit.raster._border import check_image_2d

__all__ = ["Resampled", "physical_size_mm", "resample_to_beam"]

_METHODS = ("nearest", "bicubic")


@dataclass(frozen=True)
class Resampled:
    """A resampled image and what the resampling did to its size.

    Attributes
    ----------
    image : ndarray
        The new image (bool mask if the input was a mask, else labkit gray).
    pixel_mm : float
        Size of one new pixel = the beam diameter, mm.
    target_mm : tuple of float
        Requested (width, height), mm.
    size_mm : tuple of float
        Engraved (width, height) = pixels × pixel_mm, mm.
    method : str
        ``"nearest"`` or ``"bicubic"``.
    """

    image: np.ndarray
    pixel_mm: float
    target_mm: tuple[float, float]
    size_mm: tuple[float, float]
    method: str

    @property
    def error_mm(self) -> tuple[float, float]:
        """Engraved minus requested size (width, height), mm."""
        return (self.size_mm[0] - self.target_mm[0], self.size_mm[1] - self.target_mm[1])

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, columns) of the new image."""
        return self.image.shape


def physical_size_mm(shape, *, width_mm=None, height_mm=None, pixel_mm=None, dpi=None,
                     pixel_aspect: float = 1.0):
    """The (width, height) in mm an image of ``shape`` should be engraved at.

    Give exactly one of ``width_mm``, ``height_mm`` (the other follows the
    aspect ratio), ``pixel_mm`` (width of one source pixel) or ``dpi``
    (horizontal resolution).

    ``pixel_aspect`` is the height / width of one source pixel (1 for square
    pixels; a file with 200 dpi across and 100 dpi down has 2): the engraved
    image keeps the true aspect ratio, as a viewer shows it.

    Examples
    --------
    >>> physical_size_mm((100, 200), width_mm=50)
    (50.0, 25.0)
    >>> physical_size_mm((100, 200), dpi=254)
    (20.0, 10.0)
    >>> physical_size_mm((100, 200), dpi=254, pixel_aspect=2.0)
    (20.0, 20.0)
    """
    rows, cols = int(shape[0]), int(shape[1])
    given = {k: v for k, v in dict(width_mm=width_mm, height_mm=height_mm, pixel_mm=pixel_mm,
                                   dpi=dpi).items() if v is not None}
    if len(given) != 1:
        raise RasterError(f"give exactly one of width_mm, height_mm, pixel_mm, dpi; got {sorted(given) or 'none'}")
    (name, value), = given.items()
    if not (value > 0 and math.isfinite(value)):
        raise RasterError(f"{name} must be a finite number > 0, got {value!r}")
    if not (pixel_aspect > 0 and math.isfinite(pixel_aspect)):
        raise RasterError(f"pixel_aspect must be a finite number > 0, got {pixel_aspect!r}")
    if name == "width_mm":
        px = value / cols
    elif name == "height_mm":
        px = value / rows / pixel_aspect
    elif name == "pixel_mm":
        px = value
    else:
        px = 25.4 / value
    return (cols * px, rows * px * pixel_aspect)


def _nearest(image: np.ndarray, rows: int, cols: int) -> np.ndarray:
    # Each new pixel takes the old pixel under its centre.
    r = np.minimum(((np.arange(rows) + 0.5) * image.shape[0] / rows).astype(np.int64), image.shape[0] - 1)
    c = np.minimum(((np.arange(cols) + 0.5) * image.shape[1] / cols).astype(np.int64), image.shape[1] - 1)
    return image[r[:, None], c[None, :]]


def _beam_shape(target_mm, beam_mm: float) -> tuple[int, int]:
    return max(1, int(round(target_mm[1] / beam_mm))), max(1, int(round(target_mm[0] / beam_mm)))


def beam_shape(shape, beam_mm: float, *, width_mm=None, height_mm=None, pixel_mm=None,
               dpi=None, pixel_aspect: float = 1.0) -> tuple[int, int]:
    """(rows, columns) of the image once resampled to one pixel per beam diameter.

    What :func:`resample_to_beam` makes, known before any pixel is touched (for memory
    estimates and to skip the resampling when it would give the pixels back).

    >>> beam_shape((10, 20), 0.3, width_mm=10.0)
    (17, 33)
    """
    if not (beam_mm > 0 and math.isfinite(beam_mm)):
        raise RasterError(f"beam_mm must be a finite number > 0, got {beam_mm!r}")
    target = physical_size_mm(tuple(shape)[:2], width_mm=width_mm, height_mm=height_mm,
                              pixel_mm=pixel_mm, dpi=dpi, pixel_aspect=pixel_aspect)
    return _beam_shape(target, beam_mm)


def _cubic(gray: np.ndarray, rows: int, cols: int) -> np.ndarray:
    """scikit-image's ``resize(gray, (rows, cols), order=3, mode="edge", anti_aliasing=shrinking,
    preserve_range=True)``, value for value, from the scipy calls it makes: a Gaussian of
    σ = (factor − 1)/2 per axis first when shrinking, then ``ndimage.zoom`` (cubic spline,
    pixel-area grid, edges repeated), clipped to the input's range. Without importing
    scikit-image (0.2 s of a gray job's second or two)."""
    from scipy import ndimage

    factors = np.divide(gray.shape, (rows, cols))
    low, high = gray.min(), gray.max()
    if rows < gray.shape[0] or cols < gray.shape[1]:
        gray = ndimage.gaussian_filter(gray, np.maximum(0, (factors - 1) / 2), cval=0, mode="nearest")
    out = ndimage.zoom(gray, [1 / f for f in factors], order=3, mode="nearest", cval=0, grid_mode=True)
    return np.clip(out, low, high, out=out)


def resample_to_beam(image, *, beam_mm: float, width_mm=None, height_mm=None, pixel_mm=None,
                     dpi=None, method: str = "bicubic", level: float = 128,
                     pixel_aspect: float = 1.0) -> Resampled:
    """Resample so that one pixel is one beam diameter.

    Parameters
    ----------
    image : array_like, 2-D
        A mask (bool, True = burn) or labkit gray (0…255) / uint8.
    beam_mm : float
        Beam (spot) diameter, mm — the new pixel size.
    width_mm, height_mm, pixel_mm, dpi : float
        The engraved size; exactly one (see :func:`physical_size_mm`).
    method : {"bicubic", "nearest"}
        ``"nearest"`` keeps pixel art crisp (each new pixel copies the old
        one under its centre); ``"bicubic"`` interpolates smoothly (cubic,
        scikit-image ``order=3``, anti-aliased when shrinking) — a mask is
        then re-thresholded at ``level`` on the 0…255 scale.
    level : float
        Re-threshold level for masks resampled bicubically.
    pixel_aspect : float
        Height / width of one source pixel (see :func:`physical_size_mm`); the
        new pixels are square, so non-square source pixels are resampled to the
        true aspect ratio.

    Returns
    -------
    Resampled

    Notes
    -----
    The new size is ``max(1, round(size / beam))`` pixels per side, so the
    size error per side is at most half a beam diameter ([LaserApp] §3.4.1
    calls it negligible for beams under 0.2 mm).

    Examples
    --------
    >>> r = resample_to_beam(np.ones((10, 20), bool), beam_mm=0.3, width_mm=10.0)
    >>> r.shape, [round(e, 3) for e in r.error_mm]
    ((17, 33), [-0.1, 0.1])
    """
    arr = check_image_2d(image)
    if not (beam_mm > 0 and math.isfinite(beam_mm)):
        raise RasterError(f"beam_mm must be a finite number > 0, got {beam_mm!r}")
    if method not in _METHODS:
        raise RasterError(f"method must be one of {_METHODS}, got {method!r}")
    target = physical_size_mm(arr.shape, width_mm=width_mm, height_mm=height_mm,
                              pixel_mm=pixel_mm, dpi=dpi, pixel_aspect=pixel_aspect)
    rows, cols = _beam_shape(target, beam_mm)
    if (rows, cols) == arr.shape:
        # Already one pixel per beam: both methods give the pixels back (cubic splines
        # interpolate, so at the pixel centres they are the data) — skip the work and
        # scikit-image's import (~1 s).
        out = arr if arr.dtype in (bool, np.float64) else arr.astype(np.float64)
    elif method == "nearest":
        out = _nearest(arr, rows, cols)
        if arr.dtype != bool:
            out = out.astype(np.float64)
    else:
        gray = arr.astype(np.float64) * (255.0 if arr.dtype == bool else 1.0)
        out = _cubic(gray, rows, cols)
        np.clip(out, 0.0, 255.0, out=out)
        if arr.dtype == bool:
            out = out >= level
    return Resampled(out, float(beam_mm), (float(target[0]), float(target[1])),
                     (cols * float(beam_mm), rows * float(beam_mm)), method)
