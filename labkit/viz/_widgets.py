"""Widget plumbing shared by the chapters.

An ``ipywidgets.Output`` fills itself by capturing what runs inside
``with out:`` — which needs a live frontend to route the messages. Headless
runs (nbval, nbconvert, CI) then leak the output into the cell instead.
:func:`show` sets the widget's outputs directly, which works everywhere.
"""

from __future__ import annotations


def show(out, *, text: str | None = None, figure=None, dpi: int = 90) -> None:
    """Replace what an Output widget shows by ``text`` and/or a matplotlib ``figure``.

    The figure is rendered to PNG and closed, so it is not shown a second
    time by the inline backend at the end of the cell.
    """
    import base64
    import io

    outputs = []
    if text is not None:
        outputs.append({"output_type": "stream", "name": "stdout", "text": text.rstrip("\n") + "\n"})
    if figure is not None:
        import matplotlib.pyplot as plt

        buf = io.BytesIO()
        figure.savefig(buf, format="png", dpi=dpi, bbox_inches="tight")
        plt.close(figure)
        outputs.append({"output_type": "display_data", "metadata": {},
                        "data": {"image/png": base64.b64encode(buf.getvalue()).decode("ascii"),
                                 "text/plain": "<figure>"}})
    out.outputs = tuple(outputs)


def interact_figure(draw, **controls):
    """Like ``ipywidgets.interactive`` for a function that draws a matplotlib figure.

    ``draw(**values)`` is called with the controls' values whenever one
    changes; it returns the figure (or draws into ``plt.gcf()``), which is
    shown through :func:`show` — so the panel renders the same in a browser,
    in nbconvert and under nbval.

    Parameters
    ----------
    draw : callable
        Takes one keyword argument per control; returns a figure, or a
        (figure, text) pair to show a report under the figure.
    **controls : ipywidgets.ValueWidget
        The controls, by argument name; a control without a description gets its name.

    Returns
    -------
    ipywidgets.VBox
        The controls, then the figure (``.children[-1]``, an Output);
        ``.controls`` maps argument names to their controls.
    """
    import ipywidgets as w
    import matplotlib.pyplot as plt

    out = w.Output()
    for name, control in controls.items():
        if not getattr(control, "description", ""):
            control.description = name

    def redraw(*_):
        result = draw(**{name: c.value for name, c in controls.items()})
        fig, text = result if isinstance(result, tuple) else (result, None)
        show(out, text=text, figure=fig if fig is not None else plt.gcf())

    for control in controls.values():
        control.observe(redraw, names="value")
    redraw()
    box = w.VBox(list(controls.values()) + [out])
    box.controls = dict(controls)
    return box
