"""G-code: text → Moves (:func:`parse`), arcs, Moves → text (:func:`emit`), simulation."""

from labkit.gcode import arcs
from labkit.gcode.dialects import DIALECTS, Dialect, get_dialect
from labkit.gcode.emit import decimals_for, emit, format_number, write_gcode
from labkit.gcode.parse import check, modal_trace, parse, parse_file

__all__ = [
    "parse",
    "parse_file",
    "check",
    "modal_trace",
    "emit",
    "write_gcode",
    "decimals_for",
    "format_number",
    "arcs",
    "Dialect",
    "DIALECTS",
    "get_dialect",
]
