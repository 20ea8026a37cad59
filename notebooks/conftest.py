"""Every figure a chapter draws has labelled axes: checked while nbval runs the chapter.

For each notebook nbval collects, two items are added to its kernel's run: before the first cell,
``tests/notebooks/figure_axes.py`` is loaded into the kernel and hooks figure rendering; after the last
cell, the figures found with an unlabelled axis fail the item ``figures have labelled axes``, naming the
cell and the axis. The chapters are executed once, by nbval; this adds two short kernel calls.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

CHECKER = Path(__file__).resolve().parents[1] / "tests" / "notebooks" / "figure_axes.py"
FINDINGS = "_labkit_figure_findings"


def _run(notebook, code: str, timeout_s: float = 60.0) -> str:
    """Run ``code`` in the notebook's nbval kernel; its printed text (an error fails the item)."""
    from queue import Empty

    kernel = notebook.kernel
    if kernel is None or not kernel.is_alive():
        pytest.fail("the chapter's kernel is not running")
    msg_id = kernel.execute_cell_input(code, allow_stdin=False)
    kernel.await_reply(msg_id, timeout=timeout_s)
    text = []
    while True:
        try:
            msg = notebook.get_kernel_message(timeout=timeout_s)
        except Empty:
            pytest.fail("no answer from the chapter's kernel")
        if msg["parent_header"].get("msg_id") != msg_id:
            continue
        kind, content = msg["msg_type"], msg["content"]
        if kind == "stream":
            text.append(content["text"])
        elif kind == "error":
            pytest.fail(f"the figure check failed in the kernel: {content['ename']}: {content['evalue']}")
        elif kind == "status" and content["execution_state"] == "idle":
            return "".join(text)


class FigureRecorder(pytest.Item):
    def runtest(self):
        # the checker runs in a namespace of its own: the chapter's names stay as they were
        source = CHECKER.read_text(encoding="utf-8")
        _run(self.parent, f"_labkit_ns = {{'__name__': 'figure_axes'}}\n"
                          f"exec(compile({source!r}, {str(CHECKER)!r}, 'exec'), _labkit_ns)\n"
                          f"{FINDINGS} = _labkit_ns['install'](get_ipython())\ndel _labkit_ns\n")

    def reportinfo(self):
        return self.path, None, "figures: start checking"


class FigureCheck(pytest.Item):
    def runtest(self):
        found = json.loads(_run(self.parent, f"import json as _j; print(_j.dumps({FINDINGS}))"))
        assert not found, ("figures with an unlabelled axis:\n"
                           + "\n".join(f"  cell starting {cell!r}: {what}" for cell, what in found))

    def reportinfo(self):
        return self.path, None, "figures have labelled axes"


@pytest.hookimpl(trylast=True)
def pytest_collection_modifyitems(session, config, items):
    try:
        from nbval.plugin import IPyNbCell
    except ImportError:
        return
    first, last = {}, {}
    for k, item in enumerate(items):
        if isinstance(item, IPyNbCell):
            first.setdefault(item.parent, k)
            last[item.parent] = k
    # insert from the end so that earlier positions stay valid
    for notebook in sorted(first, key=lambda nb: first[nb], reverse=True):
        items.insert(last[notebook] + 1, FigureCheck.from_parent(notebook, name="figures have labelled axes"))
        items.insert(first[notebook], FigureRecorder.from_parent(notebook, name="figures: start checking"))
