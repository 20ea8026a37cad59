"""The notebook panel stops the machine on every end (issue 25 §2): a job cancelled by a
disconnect or by the kernel closing ends with feed hold, soft reset and M5 S0 reaching the
controller before the port closes, and the panel's own session ends the same way."""

import time

import pytest

pytest.importorskip("ipywidgets")

from labkit.viz.machine import DISCONNECTED, ControlPanel, _close_panels_at_exit  # noqa: E402

from ._pty_controller import PtyController  # noqa: E402
from .test_panel import JOB  # noqa: E402
from .test_stream_end import assert_stopped_after, wait_burning  # noqa: E402


@pytest.fixture
def panel_on_a_pty():
    controller = PtyController()
    panel = ControlPanel()
    panel.port.options = [("pty", controller.port)]
    panel.port.value = controller.port
    panel.connect()
    yield panel, controller
    panel.disconnect()
    controller.close()


def test_the_kernel_closing_under_a_job_stops_the_machine(panel_on_a_pty):
    panel, controller = panel_on_a_pty
    panel.load(JOB)
    panel.start()
    wait_burning(controller)
    t = time.monotonic()
    _close_panels_at_exit()                  # what the interpreter runs when the kernel exits
    assert panel.state == DISCONNECTED and panel.machine is None
    assert panel.report.fault == "the notebook kernel is closing"
    assert_stopped_after(controller, t)
    assert "safe stop: feed hold; stopped (Hold:0); soft reset (buffers flushed, laser off); " \
           "M5 S0" in panel.console_log.value


def test_disconnect_after_a_manual_burn_switches_the_beam_off(panel_on_a_pty):
    panel, controller = panel_on_a_pty
    panel.send("G1 X100 F300 M3 S300")       # a slow burning move from the console
    wait_burning(controller, lines=1)
    t = time.monotonic()
    panel.disconnect()
    assert panel.state == DISCONNECTED
    assert_stopped_after(controller, t)
