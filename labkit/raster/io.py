"""Read raster images (PNG, BMP, JPEG, …) with their resolution."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from labkit.errors import RasterError

__all__ = ["RasterImage", "read_image"]


@dataclass(frozen=True)
class RasterImage:
    """Pixels and the resolution stored in the file.

    Attributes
    ----------
    pixels : ndarray
        uint8 (or bool for 1-bit files), rows × columns [× channels].
    dpi : float or None
        Dots per inch from the file, None when it has none.
    path : str
        Where it came from.
    """

    pixels: np.ndarray
    dpi: float | None
    path: str


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

    path = Path(path)
    try:
        with Image.open(path) as im:
            dpi = im.info.get("dpi")
            if im.mode == "1":
                pixels = np.array(im, dtype=bool)
            elif im.mode in ("L", "RGB", "RGBA", "LA"):
                pixels = np.array(im)
            elif im.mode == "P" and "transparency" in im.info:
                pixels = np.array(im.convert("RGBA"))
            else:
                pixels = np.array(im.convert("RGB"))
    except UnidentifiedImageError as exc:
        raise RasterError(f"{path}: not an image file Pillow can read") from exc
    value = None
    if dpi:
        value = float(dpi[0]) if isinstance(dpi, tuple) else float(dpi)
        value = value if value > 1 else None
    return RasterImage(pixels, value, str(path))
