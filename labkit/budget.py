"""Work budgets: estimate a job's size before doing it, refuse beyond a stated limit.

A laser job that would take hours to compute or gigabytes to hold is almost always
a mistake (a tolerance of 1e-12 mm, a width of 3 m, a million passes). Every stage
that can explode estimates its work first and calls :func:`check_budget`, which
raises :class:`~labkit.errors.BudgetError` naming the quantity, the estimate, the
limit and the option that raises it. The limits below are the one list of them;
``LABKIT_BUDGET_SCALE`` multiplies all of them (e.g. ``10`` on a big workstation).

=====================  ===========  ===================================================
budget                 default      what it bounds
=====================  ===========  ===================================================
``moves``              20,000,000   moves (rows of a Moves table) one job may have
``segments``           20,000,000   line/arc segments produced by curve flattening
``pixels``             200,000,000  pixels of an image after resampling (~14,000²)
``output_bytes``       2,000,000,000 bytes of G-code text one command may write
``steps``              10,000,000,000 Bresenham steps of one job (streamed, not held)
``held_steps``         50,000,000   lattice points of one line or arc held in memory at once
``hatch_lines``        1,000,000    hatch lines of one fill (each becomes a path; 100 m of
                                    shapes at a 0.1 mm spacing)
``elements``           2,000,000    SVG/DXF elements after expanding ``use``/``INSERT``
``diagnostics``        10,000       diagnostics kept in lenient mode (the rest counted)
``preview_lines``      2,000,000    lines of a G-code file drawn by ``labkit preview`` (it holds
                                    every move: ~400 bytes per line at its peak)
``raster_bytes``       4,000,000,000 estimated working memory of one image → moves conversion
                                    (:func:`labkit.raster.engrave.working_bytes`)
=====================  ===========  ===================================================
"""

from __future__ import annotations

import os

from labkit.errors import BudgetError

__all__ = ["BUDGETS", "budget", "check_budget"]

BUDGETS: dict[str, float] = {
    "moves": 20_000_000,
    "segments": 20_000_000,
    "pixels": 200_000_000,
    "output_bytes": 2_000_000_000,
    "steps": 10_000_000_000,
    "held_steps": 50_000_000,
    "hatch_lines": 1_000_000,
    "elements": 2_000_000,
    "diagnostics": 10_000,
    "preview_lines": 2_000_000,
    "raster_bytes": 4_000_000_000,
}


def budget(name: str) -> float:
    """The limit for ``name`` (see the table above), scaled by ``LABKIT_BUDGET_SCALE``.

    >>> budget("moves") >= 1
    True
    """
    try:
        base = BUDGETS[name]
    except KeyError:
        raise KeyError(f"unknown budget {name!r}; expected one of {sorted(BUDGETS)}") from None
    try:
        scale = float(os.environ.get("LABKIT_BUDGET_SCALE", "1"))
    except ValueError:
        scale = 1.0
    if not (scale > 0 and scale < float("inf")):
        scale = 1.0
    return base * scale


def check_budget(name: str, estimate: float, *, cause: str, option: str = "") -> None:
    """Raise :class:`BudgetError` when ``estimate`` exceeds the ``name`` budget.

    Parameters
    ----------
    name : str
        A key of :data:`BUDGETS`.
    estimate : float
        The estimated work, in the budget's unit (NaN or inf always fail).
    cause : str
        What made the work this large, in words ("tolerance 1e-12 mm on 40 curves").
    option : str
        The option that would reduce the work ("--tol"), named in the message.

    Examples
    --------
    >>> check_budget("moves", 10, cause="a test")
    >>> check_budget("moves", float("inf"), cause="passes=inf", option="--passes")
    Traceback (most recent call last):
    ...
    labkit.errors.BudgetError: too much work: inf moves (budget 20,000,000) from passes=inf; reduce --passes, or raise every budget with LABKIT_BUDGET_SCALE
    """
    limit = budget(name)
    if estimate == estimate and estimate <= limit:      # NaN fails this test
        return
    shown = f"{estimate:,.0f}" if estimate == estimate and estimate != float("inf") else str(estimate)
    hint = f"reduce {option}, or raise" if option else "raise"
    raise BudgetError(f"too much work: {shown} {name.replace('_', ' ')} (budget {limit:,.0f}) "
                      f"from {cause}; {hint} every budget with LABKIT_BUDGET_SCALE")
