"""Small array helpers shared by every subpackage."""

from __future__ import annotations

import numpy as np


def scalar_or_array(value):
    """Return a Python scalar for 0-d results and the array otherwise.

    Functions that broadcast over numpy arrays use this so that a call with
    plain numbers gives plain numbers back (readable in doctests and prints).
    """
    arr = np.asarray(value)
    return arr.item() if arr.ndim == 0 else arr
