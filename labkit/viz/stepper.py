"""A step-through G-code simulator for the classroom: play a program line by line.

The controller's view of a program is its modal state after each line. This widget
shows exactly that, one line at a time: the listing with the current line
highlighted, the state after it (motion mode, units, distance mode, feed, power,
laser) and the tool's position on the path drawn so far — driven by
:func:`labkit.gcode.modal_trace` and the parsed Moves, so it shows what labkit's
parser (and a GRBL controller) does, not a separate model.
"""

from __future__ import annotations

import html

__all__ = ["gcode_stepper", "listing_html", "state_html"]

#: Columns of the modal trace shown under the listing, with their labels for students.
STATE_COLUMNS = {"motion": "motion", "units": "units", "distance": "distance", "plane": "plane",
                 "feed_mm_min": "feed (mm/min)", "S": "power S", "laser": "laser",
                 "x": "X (mm)", "y": "Y (mm)", "z": "Z (mm)"}


def listing_html(lines, current: int) -> str:
    """The program as HTML with line ``current`` (1-based) highlighted and earlier lines greyed.

    Examples
    --------
    >>> "background" in listing_html(["G0 X1", "G1 X2 F100"], 2).split("\\n")[1]
    True
    """
    rows = []
    for k, text in enumerate(lines, start=1):
        body = f"{k:>3}  {html.escape(text) or '&nbsp;'}"
        if k == current:
            rows.append(f'<span style="background:#ffe08a;font-weight:bold">{body}</span>')
        elif k < current:
            rows.append(f'<span style="color:#777">{body}</span>')
        else:
            rows.append(body)
    return '<pre style="line-height:1.35;margin:0">' + "\n".join(rows) + "</pre>"


def state_html(row) -> str:
    """The modal state of one trace row (a mapping of :data:`STATE_COLUMNS`) as a small HTML table."""
    cells = []
    for key, label in STATE_COLUMNS.items():
        value = row[key]
        if isinstance(value, float):
            text = "not set" if value != value else f"{value:g}"      # NaN: no F word seen yet
        else:
            text = str(value)
        cells.append(f"<tr><td style='padding-right:1em'>{label}</td><td><b>{html.escape(text)}</b></td></tr>")
    return "<table>" + "".join(cells) + "</table>"


def gcode_stepper(text: str, *, dialect: str = "grbl", interval_ms: int = 900):
    """Widget: play a G-code program line by line, as the controller reads it.

    Parameters
    ----------
    text : str
        The program.
    dialect : str
        Controller dialect (``grbl``, ``labkit-fw``, ``marlin``).
    interval_ms : int
        Time per line when playing, ms.

    Returns
    -------
    ipywidgets.VBox
        Play button and line slider, then the listing, the state and the picture;
        ``.controls["line"]`` is the slider (1-based line number).
    """
    import ipywidgets as w
    import matplotlib.pyplot as plt

    from labkit.gcode import modal_trace, parse
    from labkit.viz._widgets import show
    from labkit.viz.gcode import plot_moves

    lines = text.rstrip("\n").split("\n")
    trace = modal_trace(text, dialect=dialect)
    moves = parse(text, dialect=dialect, lenient=True)
    import numpy as np

    ends = np.vstack([moves.start[:, :2], moves.end[:, :2], [[0.0, 0.0]]])
    lo, hi = ends.min(axis=0), ends.max(axis=0)
    pad = 0.08 * max(hi[0] - lo[0], hi[1] - lo[1], 1.0)

    line = w.IntSlider(value=1, min=1, max=len(lines), description="line", continuous_update=True)
    play = w.Play(value=1, min=1, max=len(lines), interval=interval_ms, description="play")
    w.jslink((play, "value"), (line, "value"))
    listing = w.HTML()
    state = w.HTML()
    picture = w.Output()

    def redraw(*_):
        k = line.value
        listing.value = listing_html(lines, k)
        rows = trace[trace["line"] <= k]
        if len(rows):
            row = rows.iloc[-1]
            error = int(row["error"])
            state.value = state_html(row) + (f"<p style='color:#b00'>error {error} on this line</p>"
                                             if error and int(row["line"]) == k else "")
            x, y = float(row["x"]), float(row["y"])
        else:
            state.value, x, y = "", 0.0, 0.0
        fig, ax = plt.subplots(figsize=(4.6, 4.0))
        done = moves[moves.line <= k] if len(moves) else moves
        if len(done):
            plot_moves(done, ax, colorbar=False, title=f"after line {k}")
        else:
            ax.set_title(f"after line {k}: no motion yet")
        ax.plot([x], [y], "o", color="tab:green", markersize=10, zorder=5)
        ax.set_xlim(lo[0] - pad, hi[0] + pad)
        ax.set_ylim(lo[1] - pad, hi[1] + pad)
        ax.set_aspect("equal")
        ax.set_xlabel("X (mm)")            # also before the first move, when plot_moves has not run
        ax.set_ylabel("Y (mm)")
        show(picture, figure=fig)

    line.observe(redraw, names="value")
    redraw()
    box = w.VBox([w.HBox([play, line]), w.HBox([listing, state]), picture])
    box.controls = {"line": line}
    return box
