"""Bitmaps an SVG embeds (``<image>``), read and placed where the drawing puts them.

``labkit job`` engraves them through :mod:`labkit.raster` (a layer with ``operation = "image"``
on the SVG); :func:`labkit.vector.read_svg` names them as not cut.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from labkit.errors import InputError

__all__ = ["PlacedImage", "svg_images"]


@dataclass
class PlacedImage:
    """An SVG ``<image>`` read and placed: its pixels and where they go, mm (lower-left corner)."""

    image: object
    name: str
    x_mm: float
    y_mm: float
    width_mm: float
    height_mm: float

    @property
    def engraving_item(self) -> tuple:
        """(image, width mm, pixel aspect, (x, y) mm): one item of :func:`labkit.jobfile.engrave_images`."""
        rows, cols = self.image.pixels.shape[:2]
        return self.image, self.width_mm, (self.height_mm / rows) / (self.width_mm / cols), (self.x_mm, self.y_mm)


def svg_images(source, *, flip_y: bool = True) -> list:
    """The bitmaps an SVG embeds (``<image>`` with a ``data:`` URI or a file beside the SVG), placed.

    The drawn rectangle follows ``preserveAspectRatio``: ``none`` fills the element's box, anything
    else (the default ``xMidYMid meet``) fits the bitmap inside it, centred, at its own aspect. Each
    bitmap is read by :func:`labkit.raster.io.read_image` (its budget, orientation and transparency).

    Raises
    ------
    InputError
        A rotated or skewed image, ``slice``, a missing file, or data that is not an image.
    """
    import base64
    import tempfile
    import urllib.parse

    import numpy as np
    import svgelements as se

    from labkit.errors import LabkitError
    from labkit.geometry import transform as tf
    from labkit.raster.io import read_image

    from labkit.vector.svg import _load, _page_matrix

    src = Path(source)
    doc, _, _, _ = _load(src)                # the reader's parse: its structure checks included
    page = _page_matrix(doc, flip_y)
    out = []
    for k, e in enumerate(doc.elements()):
        if not isinstance(e, se.Image):
            continue
        name = f"image#{e.id}" if e.id else f"image[{k}]"
        m = e.transform
        if abs(m.b) > 1e-12 or abs(m.c) > 1e-12:
            raise InputError(f"{src}: {name} is rotated or skewed; expected an image drawn upright (engrave it "
                             "with img2gcode after turning it)")
        url = e.url or ""
        with tempfile.TemporaryDirectory() as tmp:
            if url.startswith("data:"):
                head, _, payload = url.partition(",")
                data = base64.b64decode(payload) if head.endswith(";base64") else \
                    urllib.parse.unquote_to_bytes(payload)
                file = Path(tmp) / "embedded"
                file.write_bytes(data)
            else:
                file = src.parent / urllib.parse.unquote(url.removeprefix("file://"))
                if not file.is_file():
                    raise InputError(f"{src}: {name} links {url!r}, which is not a file beside the SVG ({file})")
            try:
                img = read_image(file)
            except LabkitError as exc:
                raise InputError(f"{src}: {name}: {exc}") from None
        rows, cols = img.pixels.shape[:2]
        w, hh = float(e.width), float(e.height)
        x, y = float(e.x), float(e.y)
        aspect = str(e.values.get("preserveAspectRatio") or "xMidYMid meet")
        if "slice" in aspect:
            raise InputError(f"{src}: {name}: preserveAspectRatio {aspect!r} crops the bitmap; expected meet or none")
        if aspect.strip() != "none":                       # fit inside the box, centred
            scale = min(w / cols, hh / (rows * img.pixel_aspect))
            dw, dh = cols * scale, rows * img.pixel_aspect * scale
            x, y, w, hh = x + (w - dw) / 2, y + (hh - dh) / 2, dw, dh
        corners = tf.apply(page @ tf.matrix(m.a, m.b, m.c, m.d, m.e, m.f), np.array([[x, y], [x + w, y + hh]]))
        lo, hi = corners.min(axis=0), corners.max(axis=0)
        out.append(PlacedImage(img, name, float(lo[0]), float(lo[1]), float(hi[0] - lo[0]), float(hi[1] - lo[1])))
    return out
