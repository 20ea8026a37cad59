"""Vector artwork import: SVG (svgelements) and DXF (ezdxf) into :class:`labkit.geometry.Path`."""

from labkit.vector.dxf import read_dxf
from labkit.vector.svg import Drawing, read_svg, svg_reference_samples

__all__ = ["Drawing", "read_svg", "read_dxf", "svg_reference_samples"]
