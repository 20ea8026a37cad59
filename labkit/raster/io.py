"""Read raster images (PNG, BMP, JPEG, …) with their resolution."""

from __future__ import annotations

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
        rows × columns [× channels]: uint8, uint16 (16-bit files), uint32
        (32-bit integer files) or float 0…1 (float files); 0 is black.
    dpi : float or None
        Dots per inch from the file, None when it has none.
    path : str
        Where it came from.
    """

    pixels: np.ndarray
    dpi: float | None
    path: str


def _pixels(im) -> np.ndarray:
    """Pixels of a Pillow image as the numbers :func:`~labkit.raster.color.to_gray` reads.

    Every mode keeps its meaning: 0 is black (burn) at every bit depth, and
    transparency is kept as an alpha channel (transparent = not burned).
    """
    mode = im.mode
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


def read_image(path) -> RasterImage:
    """Read an image file with Pillow.

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
            dpi = im.info.get("dpi")
            pixels = _pixels(im)
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
    value = None
    if dpi:
        value = float(dpi[0]) if isinstance(dpi, tuple) else float(dpi)
        value = value if value > 1 else None
    return RasterImage(pixels, value, str(path))
