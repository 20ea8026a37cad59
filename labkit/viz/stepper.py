"""A step-through G-code simulator for the classroom: play a program line by line.

The controller's view of a program is its modal state after each line. This widget
shows exactly that, one line at a time: the listing with the current line
highlighted, the state after it (motion mode, units, distance mode, feed, power,
laser) and the tool's position on the path drawn so far. The lines go one by one
through :class:`labkit.gcode.Interpreter`, as a controller reads them, so it shows
what labkit's parser (and a GRBL controller) does, not a separate model.
"""

from __future__ import annotations

import html
import math

__all__ = ["gcode_stepper", "listing_html", "state_html"]

#: What the table under the listing shows of a :class:`~labkit.gcode.ModalState`, labelled
#: for students: each entry is (label, the words for a state).
STATE_ROWS = (
    ("motion", lambda s: f"G{s.motion:g}" if s.motion < 100 else f"G{s.motion / 10:g}"),
    ("units", lambda s: f"G{s.units}"),
    ("distance", lambda s: f"G{s.distance}"),
    ("plane", lambda s: f"G{s.plane}"),
    ("feed (mm/min)", lambda s: "not set" if math.isnan(s.feed_mm_min) else f"{s.feed_mm_min:g}"),
    ("power S", lambda s: f"{s.s_word:g}"),
    ("laser", lambda s: f"M{s.laser}"),
    ("X (mm)", lambda s: f"{s.position[0]:g}"),
    ("Y (mm)", lambda s: f"{s.position[1]:g}"),
    ("Z (mm)", lambda s: f"{s.position[2]:g}"),
)


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


def state_html(state) -> str:
    """A :class:`~labkit.gcode.ModalState` as a small HTML table (:data:`STATE_ROWS`).

    Examples
    --------
    >>> from labkit.gcode import ModalState
    >>> "<td style='padding-right:1em'>feed (mm/min)</td><td><b>not set</b>" in state_html(ModalState())
    True
    """
    cells = [f"<tr><td style='padding-right:1em'>{label}</td><td><b>{html.escape(words(state))}</b></td></tr>"
             for label, words in STATE_ROWS]
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
    import numpy as np

    from labkit.gcode import Interpreter
    from labkit.toolpath import Moves
    from labkit.viz._widgets import show
    from labkit.viz.gcode import plot_moves

    lines = text.rstrip("\n").split("\n")
    reader = Interpreter(dialect)
    parts, states, errors = [], [], []
    for k, source in enumerate(lines, start=1):
        moves, error = reader.feed(source)
        moves.line[:] = k                  # fed one at a time, each line reads as line 1
        parts.append(moves)
        states.append(reader.state)        # a rejected line keeps the state before it
        errors.append(error)
    moves = Moves.concat(parts)

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
        state.value = state_html(states[k - 1]) + (
            f"<p style='color:#b00'>error {errors[k - 1].code} on this line</p>" if errors[k - 1] else "")
        x, y = states[k - 1].position[:2]
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
