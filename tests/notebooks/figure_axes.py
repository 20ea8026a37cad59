"""Which axes of a matplotlib figure are drawn without a label: the check the chapters' figures pass.

An axis needs a label when it shows tick labels: numbers without a name and a unit teach nothing. An axes
turned off (a picture), an empty axes and an axis whose tick labels are hidden (the inner panels of shared
axes, a twin's second x axis) need none. A colour bar is an axes too: its scale needs its label.

This file runs in two places: imported by its unit tests, and sent as text into a chapter's kernel by
``notebooks/conftest.py``, where :func:`install` makes every figure the chapter renders — shown inline or
drawn into a widget — pass through :func:`unlabelled_axes` as it is drawn. It imports only matplotlib.
"""

from __future__ import annotations


def _shows_tick_labels(axis) -> bool:
    return any(t.get_visible() and t.get_text().strip() for t in axis.get_ticklabels())


def unlabelled_axes(fig) -> list:
    """The axis labels a drawn figure lacks.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        Drawn (tick labels are only known after a draw).

    Returns
    -------
    list of str
        One entry per axis that shows tick labels but has no label, naming the axes by its title
        (or its position) and the axis (x, y or z); empty when every axis is labelled.
    """
    missing = []
    for k, ax in enumerate(fig.axes):
        # 3-D axes keep their own switch (their 2-D frame is always off)
        axis_on = getattr(ax, "_axis3don", ax.axison) if ax.name == "3d" else ax.axison
        if not ax.get_visible() or not axis_on:
            continue
        if not (ax.lines or ax.collections or ax.images or ax.patches) and ax.get_label() != "<colorbar>":
            continue                       # an empty panel (a table, a text box): nothing to read off
        name = ax.get_title() or ("colour bar" if ax.get_label() == "<colorbar>" else f"axes {k + 1}")
        for letter in ("x", "y", "z"):
            axis = getattr(ax, f"{letter}axis", None)
            if axis is None or not axis.get_visible() or not _shows_tick_labels(axis):
                continue
            if not axis.get_label_text().strip():
                missing.append(f"{name!r}: no {letter} label")
    return missing


def install(shell=None) -> list:
    """Check every figure as it is rendered; returns the list the findings are appended to.

    Each finding is ``(first line of the cell that drew it, what is missing)``.
    """
    from matplotlib.backend_bases import FigureCanvasBase

    findings: list = []
    current = {"cell": ""}
    if shell is not None:
        def note_cell(info):
            current["cell"] = (info.raw_cell.strip().splitlines() or [""])[0][:80]
        shell.events.register("pre_run_cell", note_cell)
    original = FigureCanvasBase.print_figure

    def print_figure(self, *args, **kwargs):
        result = original(self, *args, **kwargs)
        for problem in unlabelled_axes(self.figure):
            findings.append((current["cell"], problem))
        return result

    FigureCanvasBase.print_figure = print_figure
    return findings
