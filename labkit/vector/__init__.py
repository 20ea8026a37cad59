"""Vector artwork import: SVG (svgelements) and DXF (ezdxf) into :class:`labkit.geometry.Path`.

The readers load on first use, so reading an SVG does not import the DXF reader.
"""

import importlib

_WHERE = {"Drawing": "svg", "read_svg": "svg", "svg_reference_samples": "svg", "read_dxf": "dxf"}

__all__ = ["Drawing", "read_svg", "read_dxf", "svg_reference_samples"]


def __getattr__(name):
    try:
        module = _WHERE[name]
    except KeyError:
        raise AttributeError(f"module 'labkit.vector' has no attribute {name!r}") from None
    value = getattr(importlib.import_module(f"labkit.vector.{module}"), name)
    globals()[name] = value          # later look-ups skip this function
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__))
