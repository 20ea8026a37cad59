"""G-code: text → Moves (:func:`parse`), arcs, Moves → text (:func:`emit`), simulation.

Modules: :mod:`~labkit.gcode.reader` (text → Moves: :func:`parse`, :func:`parse_file`,
:func:`parse_with_states`, :func:`check`, :func:`modal_trace`, :class:`Interpreter`: line by line),
:mod:`~labkit.gcode.state` (:class:`ModalState`, :func:`restate`: the modal state's one home),
:mod:`~labkit.gcode.split` (restartable parts), :mod:`~labkit.gcode.writer` (Moves → text: :func:`emit`,
:func:`write_gcode`), :mod:`~labkit.gcode.dialects`, :mod:`~labkit.gcode.arcs`,
:mod:`~labkit.gcode.simulate`; the compiled kernels ``_kernel`` (reader) and ``_emit_kernel``
(writer). ``labkit.gcode.parse`` and ``labkit.gcode.emit`` are the functions.
"""

# The names load on first use: a command that writes G-code (svg2gcode) does not import the
# reader and its compiled parser's module (~20 ms).
from labkit._lazy import lazy_names

_WHERE = {
    'arcs': None,
    'DIALECTS': 'dialects',
    'Dialect': 'dialects',
    'get_dialect': 'dialects',
    'decimals_for': 'writer',
    'emit': 'writer',
    'format_number': 'writer',
    'write_gcode': 'writer',
    'Interpreter': 'reader',
    'check': 'reader',
    'modal_trace': 'reader',
    'parse': 'reader',
    'parse_file': 'reader',
    'parse_with_states': 'reader',
    'grbl_sync_lines': 'reader',
    'ModalState': 'state',
    'restate': 'state',
}

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


__getattr__, __dir__ = lazy_names(__name__, _WHERE, __all__)
