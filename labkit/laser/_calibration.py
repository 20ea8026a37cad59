"""What the raster calibrations (scan offset, tone curve) share: their scans registered, their JSON files."""

from __future__ import annotations

import json

import numpy as np

from labkit.errors import InputError


def save_document(path, doc: dict) -> None:
    """Write ``doc`` as indented JSON, whole or not at all (:func:`labkit._files.atomic_output`)."""
    from labkit._files import atomic_output

    with atomic_output(path) as fh:
        json.dump(doc, fh, indent=1)


def read_document(path, *, what: str, format: str, version, maker: str) -> dict:
    """The JSON object in ``path`` if its ``format`` and ``version`` are these, else a clear error.

    ``version`` is the one version read or a tuple of those read (a format whose keys changed
    reads its older versions too); ``what`` names the file in messages ("tone curve"),
    ``maker`` the command that writes one.
    """
    from labkit._files import read_json

    versions = version if isinstance(version, tuple) else (version,)
    doc = read_json(path, what=f"{what} file")
    if not isinstance(doc, dict) or doc.get("format") != format:
        raise InputError(f"{path}: not a {what} (format {format!r}); write one with '{maker}'")
    if doc.get("version") not in versions:
        read = " and ".join(map(str, versions))
        raise InputError(f"{path}: {what} version {doc.get('version')!r}; this labkit reads "
                         f"version{'s' if len(versions) > 1 else ''} {read}")
    return doc


def registered_scan(image, layout: dict, *, kind: str, maker: str):
    """(the scan as a float array, the layout → pixel transform, the layout in its current
    version) of a scanned calibration pattern.

    The layout must be a test-grid layout (:func:`labkit.laser.measure.check_layout`) of this
    ``kind`` (written by ``maker``); the scan registers on its corner crosses and engraved numbers
    (:func:`labkit.laser.measure.register`).
    """
    from labkit.laser.measure import check_layout, register

    layout = check_layout(layout)
    if layout.get("kind") != kind:
        raise InputError(f"layout: kind is {layout.get('kind')!r}; expected {kind!r} (write one with '{maker}')")
    img = np.asarray(image, float)
    if img.ndim != 2:
        raise InputError(f"the scan must be a 2-D grey image, got shape {img.shape}")
    return img, register(img, layout), layout
