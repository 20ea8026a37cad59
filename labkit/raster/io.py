"""Read raster images (PNG, BMP, JPEG, …) as a viewer shows them, with their resolution.

Every image command and chapter reads files through :func:`read_image`, so one set of
rules holds everywhere: the EXIF orientation is applied (a phone photo is the right way
up), every kind of transparency (alpha, a ``tRNS`` colour key on gray, 16-bit gray or RGB,
palette transparency) becomes an alpha channel, whose fully transparent pixels mean
"nothing here" (:func:`~labkit.raster.color.blank_mask`), and non-square pixels (JFIF or
PNG ``pHYs`` with different x and y densities) keep their shape as ``pixel_aspect``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from labkit.errors import LabkitError, RasterError

__all__ = ["RasterImage", "read_image"]


@dataclass(frozen=True)
class RasterImage:
    """Pixels and the resolution stored in the file.

    Attributes
    ----------
    pixels : ndarray
        rows × columns [× channels], the right way up (EXIF orientation applied):
        uint8, uint16 (16-bit files), uint32 (32-bit integer files) or float 0…1
        (float files); 0 is black. Transparency of any kind is the last channel
        (alpha, 0 = transparent).
    dpi : float or None
        Horizontal dots per inch from the file, None when it has none.
    path : str
        Where it came from.
    pixel_aspect : float
        Height / width of one pixel (the file's horizontal over vertical density;
        1 for square pixels and for files that state no density).
    """

    pixels: np.ndarray
    dpi: float | None
    path: str
    pixel_aspect: float = 1.0

    @property
    def blank(self) -> np.ndarray | None:
        """Pixels with nothing here (fully transparent), never burned; None when the
        image has no transparency (:func:`~labkit.raster.color.blank_mask`)."""
        from labkit.raster.color import blank_mask

        return blank_mask(self.pixels)


def _pixels(im) -> np.ndarray:
    """Pixels of a Pillow image as the numbers :func:`~labkit.raster.color.to_gray` reads.

    Every mode keeps its meaning: 0 is black (burn) at every bit depth, and
    transparency of every kind is kept as an alpha channel (transparent = not burned).
    """
    mode = im.mode
    key = im.info.get("transparency")
    if key is not None and mode in ("1", "L"):
        return np.array(im.convert("LA"))            # gray colour key (tRNS)
    if key is not None and mode == "RGB":
        return np.array(im.convert("RGBA"))          # RGB colour key (tRNS)
    if key is not None and isinstance(key, int) and (mode.startswith("I;16") or mode == "I"):
        # 16-bit gray colour key: Pillow has no 16-bit gray + alpha mode, so the alpha
        # channel is made here, on the 16-bit scale.
        gray = _pixels(_without_transparency(im))
        alpha = np.where(gray == key, 0, np.iinfo(gray.dtype).max).astype(gray.dtype)
        return np.stack([gray, alpha], axis=-1)
    if mode == "1":
        # Pillow's 1-bit True is *white*: read it as 8-bit gray, never as a burn mask.
        return np.array(im.convert("L"))
    if mode in ("L", "RGB", "RGBA", "LA"):
        return np.array(im)
    if mode.startswith("I;16"):                       # 16-bit gray, any byte order
        return np.array(im).astype(np.uint16)
    if mode == "I":
        # 32-bit integer gray. Pillow also stores 16-bit PNGs in this mode, so data
        # that fits 16 bits is read on the 16-bit scale, other data on the 32-bit one.
        data = np.array(im, dtype=np.int64)
        if data.size and data.min() < 0:
            raise RasterError(f"{getattr(im, 'filename', 'image')}: 32-bit image with negative "
                              f"values (min {data.min()}); expected 0 or more")
        if data.size == 0 or data.max() <= 0xFFFF:
            return data.astype(np.uint16)
        return data.astype(np.uint32)
    if mode == "F":
        data = np.array(im, dtype=np.float64)
        lo, hi = (float(np.nanmin(data)), float(np.nanmax(data))) if data.size else (0.0, 1.0)
        if not np.isfinite(data).all() or lo < 0.0:
            raise RasterError(f"{getattr(im, 'filename', 'image')}: float image with values "
                              f"{lo:g}…{hi:g}; expected finite values 0…1 (or 0…255)")
        return data / 255.0 if hi > 1.0 else data   # 0…255 floats are common in TIFF
    if mode in ("P", "PA") and ("transparency" in im.info or mode == "PA"):
        return np.array(im.convert("RGBA"))
    if mode in ("RGBa", "La"):                        # premultiplied alpha
        return np.array(im.convert("RGBA" if mode == "RGBa" else "LA"))
    return np.array(im.convert("RGB"))                # P, CMYK, YCbCr, LAB, HSV


def _without_transparency(im):
    plain = im.copy()
    plain.info.pop("transparency", None)
    return plain


#: EXIF orientations that turn the image by a quarter turn (its width and height swap).
_QUARTER_TURNS = (5, 6, 7, 8)
_ORIENTATION_TAG = 0x0112


def _upright(im):
    """The image as a viewer shows it (EXIF orientation applied) and whether it turned a
    quarter turn. Pillow's ``exif_transpose`` keeps the other metadata."""
    from PIL import ImageOps

    try:
        orientation = im.getexif().get(_ORIENTATION_TAG, 1)
    except Exception:        # an unreadable EXIF block: shown as stored, as viewers do
        return im, False
    if orientation not in range(2, 9):
        return im, False
    return ImageOps.exif_transpose(im), orientation in _QUARTER_TURNS


def _densities(info: dict, quarter_turn: bool):
    """(horizontal dpi or None, pixel aspect) from Pillow's ``info``: ``dpi`` (JFIF,
    PNG pHYs in metres, TIFF, BMP), or JFIF/PNG densities without a unit (aspect only)."""
    dpi = info.get("dpi")
    ratio = None
    if dpi:
        x, y = (dpi if isinstance(dpi, tuple) else (dpi, dpi))
        x, y = float(x), float(y)
        ratio = (x, y)
    else:
        unitless = info.get("aspect") or (info.get("jfif_density") if info.get("jfif_unit") == 0 else None)
        if unitless:
            ratio = (float(unitless[0]), float(unitless[1]))
    if ratio is None or not (ratio[0] > 0 and ratio[1] > 0 and all(map(math.isfinite, ratio))):
        return None, 1.0
    if quarter_turn:            # the turned image's rows were the file's columns
        ratio = ratio[::-1]
    aspect = ratio[0] / ratio[1]
    if abs(aspect - 1.0) < 1e-4:             # PNG stores whole dots per metre: 72 dpi rounds
        aspect = 1.0
    x_dpi = ratio[0] if dpi else None
    return (x_dpi if x_dpi and x_dpi > 1 else None), aspect


def read_image(path) -> RasterImage:
    """Read an image file with Pillow, as a viewer shows it.

    The EXIF orientation is applied (a photo taken with the phone turned comes out
    the right way up; a quarter turn swaps width, height and the two densities),
    every kind of transparency becomes an alpha channel (see :class:`RasterImage`),
    and the horizontal resolution and the pixels' aspect are read from the file.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    RasterImage

    Raises
    ------
    RasterError
        The file is not an image Pillow can read.
    OSError
        The file cannot be opened.
    """
    from PIL import Image, UnidentifiedImageError

    from labkit._files import check_input_file

    from labkit.budget import check_budget

    path = check_input_file(path, what="image file")
    # labkit's pixels budget decides how big an image may be, before it is decoded;
    # Pillow's own guard (a warning above 89 Mpx, an exception above 179 Mpx) is off here.
    guard, Image.MAX_IMAGE_PIXELS = Image.MAX_IMAGE_PIXELS, None
    try:
        with Image.open(path) as im:
            w, h = im.size
            check_budget("pixels", float(w) * float(h), cause=f"reading the {w:,} × {h:,} px image {path}",
                         option="the image (scale it down first)")
            upright, quarter_turn = _upright(im)
            dpi, aspect = _densities(im.info, quarter_turn)
            pixels = _pixels(upright)
    except UnidentifiedImageError as exc:
        raise RasterError(f"{path}: not an image file Pillow can read "
                          "(expected PNG, BMP, JPEG, TIFF, GIF, …)") from exc
    except (OSError, SyntaxError, ValueError) as exc:     # truncated or corrupt data
        if isinstance(exc, LabkitError):
            raise
        raise RasterError(f"{path}: the image data cannot be decoded ({exc}); "
                          "expected a complete image file") from exc
    finally:
        Image.MAX_IMAGE_PIXELS = guard
    return RasterImage(pixels, dpi, str(path), aspect)
