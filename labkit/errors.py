"""Errors raised by labkit, and the table of what a controller says, shared with the firmware.

Every error says what was wrong, where, and what was expected. G-code errors
carry the file, 1-based line and column, the offending text and a numeric
status code from ``status_codes.csv`` — the same table the firmware's header
is generated from, with GRBL's numbers where GRBL has the same error.

The table has a ``kind`` column: ``error`` (``error:N`` / ``er:N``; 0 is ``ok``),
``alarm`` (``ALARM:N``) and ``reply`` (GRBL's ``[MSG:…]`` feedback, by GRBL's
message number; the message is the exact text the controller sends). Each kind's
names are an :class:`~enum.IntEnum` here (:class:`ErrorCode`, :class:`AlarmCode`,
:class:`Feedback`), so code that speaks GRBL writes names, not numbers.

Provenance: the numbers are GRBL 1.1's, from the error, alarm and feedback-message
numbering GRBL documents publicly; the messages of the ``error`` and ``alarm`` rows are
labkit's own wording (an error labkit itself raises keeps labkit's sentence), the
``reply`` messages are the controller's exact text. Codes 100 and up are labkit's.
"""

from __future__ import annotations

import csv
import enum
from dataclasses import dataclass
from pathlib import Path

__all__ = [
    "LabkitError",
    "GcodeError",
    "BoundsError",
    "GeometryError",
    "RasterError",
    "MotionError",
    "MachineError",
    "InputError",
    "BudgetError",
    "EmitError",
    "StatusCode",
    "STATUS_CODES",
    "status_code",
    "ErrorCode",
    "AlarmCode",
    "Feedback",
    "name_list",
]


#: The kinds of the table's rows, in its order.
KINDS = ("error", "alarm", "reply")


@dataclass(frozen=True)
class StatusCode:
    """One row of the shared table of what a controller says."""

    code: int
    name: str
    message: str
    kind: str = "error"


def _load_status_codes() -> dict[str, dict[str, StatusCode]]:
    """kind → name → row, read once from the package's ``status_codes.csv``."""
    # beside this module, as labkit's other data files are read (importlib.resources would
    # import tempfile, random and zipfile into every command: ~8 ms of start-up)
    text = (Path(__file__).parent / "status_codes.csv").read_text("utf-8")
    table: dict[str, dict[str, StatusCode]] = {k: {} for k in KINDS}
    for r in csv.DictReader(text.splitlines()):
        table[r["kind"]][r["name"]] = StatusCode(int(r["code"]), r["name"], r["message"], r["kind"])
    return table


_TABLE = _load_status_codes()
#: The ``error`` rows by name (what a line can be refused for; 0 is ``ok``).
STATUS_CODES: dict[str, StatusCode] = _TABLE["error"]
_BY_NUMBER = {k: {s.code: s for s in rows.values()} for k, rows in _TABLE.items()}


def status_code(key: str | int, kind: str = "error") -> StatusCode:
    """Look a row of the table up by name or number.

    Parameters
    ----------
    key : str or int
        The row's name or number.
    kind : {"error", "alarm", "reply"}
        Which numbering.

    >>> status_code("bad_checksum").code
    100
    >>> status_code(33).name
    'invalid_arc'
    >>> status_code(2, "alarm").name
    'soft_limit'
    """
    if kind not in _TABLE:
        raise KeyError(f"unknown kind {kind!r}; expected one of {', '.join(KINDS)}")
    table = _BY_NUMBER[kind] if isinstance(key, int) else _TABLE[kind]
    try:
        return table[key]
    except KeyError:
        raise KeyError(f"unknown {'status' if kind == 'error' else kind} code {key!r}") from None


def _names(cls_name: str, kind: str, doc: str) -> type[enum.IntEnum]:
    """The names of one kind's rows as an IntEnum (upper case: ``soft_limit`` → ``SOFT_LIMIT``)."""
    rows = sorted(_TABLE[kind].values(), key=lambda s: s.code)
    names = enum.IntEnum(cls_name, [(s.name.upper(), s.code) for s in rows], module=__name__)
    names.__doc__ = doc
    return names


ErrorCode = _names("ErrorCode", "error", "The ``error`` rows: ``ErrorCode.NOT_IDLE == 8`` (``error:8``); "
                                         "``ErrorCode.OK`` is 0 (``ok``).")
AlarmCode = _names("AlarmCode", "alarm", "The ``alarm`` rows: ``AlarmCode.SOFT_LIMIT == 2`` (``ALARM:2``).")
Feedback = _names("Feedback", "reply", "The ``reply`` rows, GRBL's ``[MSG:…]`` by its message number: "
                                       "``Feedback.RESET_TO_CONTINUE == 1``.")


class LabkitError(Exception):
    """Base class of every error labkit raises on purpose."""


class GcodeError(LabkitError, ValueError):
    """A G-code line that cannot be accepted.

    Parameters
    ----------
    message : str
        What is wrong, in words.
    filename : str or None
        File the text came from (``None`` for text given directly).
    line : int
        1-based line number.
    column : int
        1-based column of the offending text.
    text : str
        The offending text itself (a word, a number, the whole line).
    expected : str
        What would have been accepted instead.
    code : str
        Name of the status code (a row of ``status_codes.csv``).
    source_line : str
        The whole source line, for context.
    """

    def __init__(self, message, *, filename=None, line=0, column=0, text="",
                 expected="", code="unsupported_command", source_line=""):
        self.message = message
        self.filename = filename
        self.line = line
        self.column = column
        self.text = text
        self.expected = expected
        self.status = status_code(code)
        self.source_line = source_line
        super().__init__(self.format())

    @property
    def code(self) -> int:
        """Numeric status code (GRBL's number where GRBL has the same error)."""
        return self.status.code

    def format(self) -> str:
        """``file:line:col: message (got …; expected …)`` — the compiler convention."""
        where = f"{self.filename or '<string>'}:{self.line}:{self.column}"
        detail = []
        if self.text:
            detail.append(f"got {self.text!r}")
        if self.expected:
            detail.append(f"expected {self.expected}")
        tail = f" ({'; '.join(detail)})" if detail else ""
        return f"{where}: error {self.code}: {self.message}{tail}"

    def __reduce__(self):
        return (_rebuild_gcode_error, (self.message, self.__dict__.copy()))


def _rebuild_gcode_error(message, state):
    err = GcodeError(message, filename=state["filename"], line=state["line"],
                     column=state["column"], text=state["text"], expected=state["expected"],
                     code=state["status"].name, source_line=state["source_line"])
    return err


class BoundsError(GcodeError):
    """A move leaves the machine envelope (raised by simulation, names the source line)."""

    def __init__(self, message, **kw):
        kw.setdefault("code", "out_of_bounds")
        super().__init__(message, **kw)


class GeometryError(LabkitError, ValueError):
    """Geometry that cannot be built or converted (degenerate curves, bad tolerances)."""


class RasterError(LabkitError, ValueError):
    """An image or raster setting that cannot be used."""


class MotionError(LabkitError, ValueError):
    """A motion plan that cannot be made (limits, machine description)."""


class MachineError(LabkitError, RuntimeError):
    """A machine or link fault: alarms, timeouts, disconnects, rejected lines."""


class InputError(LabkitError, ValueError):
    """A file or option the user gave that cannot be used (not a regular file, input
    named as output, an option out of its range)."""


class BudgetError(LabkitError, ValueError):
    """A job whose estimated work exceeds a documented budget (:mod:`labkit.budget`)."""


class EmitError(LabkitError, ValueError):
    """Moves that cannot be written as G-code: a coordinate, feed, power or dwell that is not
    finite, out of range, or too large to write exactly at the requested resolution."""


def name_list(names, most: int = 10) -> str:
    """The names a message shows: the first ``most`` joined by commas, `` …`` after them
    when there are more (a warning about 3,000 skipped entities names ten).

    >>> name_list(["rect#a", "circle#b", "path#c"], most=2)
    'rect#a, circle#b …'
    """
    names = list(names)
    return ", ".join(names[:most]) + (" …" if len(names) > most else "")
