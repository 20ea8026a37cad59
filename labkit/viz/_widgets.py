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
