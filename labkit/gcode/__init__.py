"""G-code: text → Moves (:func:`parse`), arcs, Moves → text (:func:`emit`), simulation.

Modules: :mod:`~labkit.gcode.reader` (text → Moves: :func:`parse`, :func:`parse_file`,
:func:`parse_with_states`, :func:`check`, :func:`modal_trace`, :class:`Interpreter`: line by line),
:mod:`~labkit.gcode.state` (:class:`ModalState`, :func:`restate`: the modal state's one home),
:mod:`~labkit.gcode.split` (restartable parts), :mod:`~labkit.gcode.writer` (Moves → text: :func:`emit`,
:func:`write_gcode`), :mod:`~labkit.gcode.dialects`, :mod:`~labkit.gcode.arcs`,
:mod:`~labkit.gcode.simulate`; the compiled kernels ``_kernel`` (reader) and ``_emit_kernel``
(writer). ``labkit.gcode.parse`` and ``labkit.gcode.emit`` are the functions.
"""

from labkit.gcode import arcs
from labkit.gcode.dialects import DIALECTS, Dialect, get_dialect
from labkit.gcode.writer import decimals_for, emit, format_number, write_gcode
from labkit.gcode.reader import (Interpreter, check, grbl_sync_lines, modal_trace, parse, parse_file,
                                 parse_with_states)
from labkit.gcode.state import ModalState, restate

__all__ = [
    "parse",
    "parse_file",
    "parse_with_states",
    "check",
    "modal_trace",
    "grbl_sync_lines",
    "Interpreter",
    "ModalState",
    "restate",
    "emit",
    "write_gcode",
    "decimals_for",
    "format_number",
    "arcs",
    "Dialect",
    "DIALECTS",
    "get_dialect",
]
