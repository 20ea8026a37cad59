"""Errors raised by labkit, and the status-code table shared with the firmware.

Every error says what was wrong, where, and what was expected. G-code errors
carry the file, 1-based line and column, the offending text and a numeric
status code from ``status_codes.csv`` — the same table the firmware's header
is generated from, with GRBL's numbers where GRBL has the same error.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from importlib import resources

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
]


@dataclass(frozen=True)
class StatusCode:
    """One row of the shared status-code table."""

    code: int
    name: str
    message: str


def _load_status_codes() -> dict[str, StatusCode]:
    text = resources.files("labkit").joinpath("status_codes.csv").read_text("utf-8")
    rows = csv.DictReader(text.splitlines())
    return {r["name"]: StatusCode(int(r["code"]), r["name"], r["message"]) for r in rows}


STATUS_CODES: dict[str, StatusCode] = _load_status_codes()
_BY_NUMBER = {s.code: s for s in STATUS_CODES.values()}


def status_code(key: str | int) -> StatusCode:
    """Look a status code up by name or number.

    >>> status_code("bad_checksum").code
    100
    >>> status_code(33).name
    'invalid_arc'
    """
    table = _BY_NUMBER if isinstance(key, int) else STATUS_CODES
    try:
        return table[key]
    except KeyError:
        raise KeyError(f"unknown status code {key!r}") from None


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
