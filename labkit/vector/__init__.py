"""Vector artwork import: SVG (svgelements) and DXF (ezdxf) into :class:`labkit.geometry.Path`.

The readers load on first use, so reading an SVG does not import the DXF reader.
"""

from labkit._lazy import lazy_names

_WHERE = {"Drawing": "svg", "read_svg": "svg", "svg_reference_samples": "svg", "read_dxf": "dxf"}

__all__ = ["Drawing", "read_svg", "read_dxf", "svg_reference_samples"]


__getattr__, __dir__ = lazy_names(__name__, _WHERE, __all__)
