"""Small array helpers shared by every subpackage."""

from __future__ import annotations

from dataclasses import fields

import numpy as np


def scalar_or_array(value):
    """Return a Python scalar for 0-d results and the array otherwise.

    Functions that broadcast over numpy arrays use this so that a call with
    plain numbers gives plain numbers back (readable in doctests and prints).
    """
    arr = np.asarray(value)
    return arr.item() if arr.ndim == 0 else arr


class ColumnTable:
    """What a frozen dataclass of numpy columns, one row per item (a block, a tick), is as a
    table: its length and its rows.

    The length is that of the first field holding an array; fields that are not arrays of
    that length (a ramp law's name) are carried whole into a selection.

    Examples
    --------
    >>> from dataclasses import dataclass
    >>> @dataclass(frozen=True)
    ... class Ticks(ColumnTable):
    ...     law: str
    ...     time_s: np.ndarray
    ...     steps: np.ndarray
    >>> t = Ticks("linear", np.array([0.0, 0.5, 1.0]), np.array([[1, 0], [0, 1], [1, 1]]))
    >>> len(t), t[1:].time_s.tolist(), t[-1].steps.tolist(), t[t.time_s > 0.2].law
    (3, [0.5, 1.0], [[1, 1]], 'linear')
    """

    __slots__ = ()

    def __len__(self) -> int:
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, np.ndarray):
                return len(value)
        return 0

    def __getitem__(self, index):
        """Rows by slice, mask or index array; an integer gives a one-row table."""
        if isinstance(index, (int, np.integer)):
            index = slice(index, index + 1 if index != -1 else None)
        n = len(self)
        picked = {}
        for f in fields(self):
            value = getattr(self, f.name)
            row_wise = isinstance(value, np.ndarray) and value.ndim >= 1 and len(value) == n
            picked[f.name] = value[index] if row_wise else value
        return type(self)(**picked)

    @classmethod
    def concat(cls, tables):
        """One table of ``tables``' rows in order (fields that are not columns from the first).

        >>> from labkit.motion.timer import StepTrace
        >>> one = StepTrace(*(np.zeros((1, 3) if n == 4 else 1) for n in range(7)))
        >>> len(StepTrace.concat([one, one, one]))
        3
        """
        tables = list(tables)
        first = tables[0]
        joined = {}
        for f in fields(cls):
            value = getattr(first, f.name)
            joined[f.name] = (np.concatenate([getattr(t, f.name) for t in tables])
                              if isinstance(value, np.ndarray) else value)
        return cls(**joined)
