"""The notebook control panel: seed 000's three states and the controls each enables."""

import pytest

pytest.importorskip("ipywidgets")

from labkit.viz.machine import DISCONNECTED, MANUAL, PRINTING, ControlPanel  # noqa: E402

JOB = "G21 G90\nM4 S300 F3000\n" + "".join(f"G1 X{10 + k % 2 * 20} Y{k} \n" for k in range(40)) + "M5\n"


def enabled(panel):
    return {g for g, ws in panel.groups.items() if not any(w.disabled for w in ws)}


def test_three_states_enable_only_their_controls():
    panel = ControlPanel(virtual_options={"time_scale": 20})
    assert panel.state == DISCONNECTED and enabled(panel) == {"connection"}
    panel.connect_button.click()
    assert panel.state == MANUAL and enabled(panel) == {"manual"}
    assert "Idle" in panel.status.value
    panel.step.value = 10.0
    panel.jog_buttons["X+"].click()
    panel.machine.wait_status(lambda s: s.state == "Idle", 5)
    panel.refresh()
    assert "MPos (10.000, 0.000, 0.000)" in panel.status.value
    panel.console_line.value = "$G"
    panel.console_button.click()
    assert "< [GC:" in panel.console_log.value
    panel.load(JOB)
    states = []
    panel.start()
    states.append((panel.state, enabled(panel)))
    panel.console_line.value = "G0 X0"
    panel.send(panel.console_line.value)                  # locked while printing
    panel._thread.join(30)
    assert states == [(PRINTING, {"printing"})]
    assert panel.state == MANUAL and panel.report.ok
    assert "> G0 X0" not in panel.console_log.value
    assert panel.progress.value == len(panel.job.source_lines)          # the last line, M5
    panel.disconnect_button.click()
    assert panel.state == DISCONNECTED


def test_stop_button_stops_safely():
    panel = ControlPanel(virtual_options={"time_scale": 2})
    panel.connect()
    panel.load(JOB)
    panel.start()
    import time

    time.sleep(0.5)
    panel.stop_button.click()
    panel._thread.join(30)
    assert panel.report.fault == "cancelled by the user"
    assert panel.machine.link.port.laser_output() == 0
    assert panel.state == MANUAL
    panel.disconnect()


def test_bad_port_is_logged_not_raised(monkeypatch):
    panel = ControlPanel()
    panel.port.options = [("nowhere", "/dev/ttyLABKIT_NONE")]
    panel.port.value = "/dev/ttyLABKIT_NONE"
    panel.connect()
    assert panel.state == DISCONNECTED and "does not exist" in panel.console_log.value
