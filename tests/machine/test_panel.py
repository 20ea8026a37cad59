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


def test_set_origin_and_test_pulse_on_the_virtual_machine():
    """Set origin sends GRBL's G10 L20 P0 X0 Y0: the work position reads 0 where the head is,
    the machine position is unchanged. Test pulse: the beam burns only while moving in laser mode, so the pulse
    is a slow step out and back — the machine burned at the chosen power for the chosen time,
    ended where it started with the laser off, and the modal state (G90, F) is restored."""
    panel = ControlPanel(virtual_options={"time_scale": 0})
    panel.connect()
    m = panel.machine
    m.command("G0 X10 Y5")
    m.command("G1 X10 F1234")
    m.wait_status(lambda s: s.state == "Idle", 5)
    vm = m.link.port
    accepted = vm.lines_accepted
    panel.origin_button.click()
    assert vm.lines_accepted == accepted + 1 and "! " not in panel.console_log.value
    assert "> set origin (G10 L20 P0 X0 Y0)" in panel.console_log.value
    st = m.wait_status(lambda s: s.wco is not None and s.wco[:2] == pytest.approx((10, 5)), 5)
    assert st.mpos[:2] == pytest.approx((10, 5)) and st.wpos[:2] == pytest.approx((0, 0))
    before = len(vm.executed)
    panel.pulse_power.value = 2.0                          # 2 % of $30
    panel.pulse_button.click()
    m.wait_status(lambda s: s.state == "Idle", 5)
    burned = [p for p in vm.executed[before:] if p.power > 0]
    s_max = m.setting(30, 1000.0)
    assert burned and all(p.power == pytest.approx(0.02) for p in burned)      # share of $30
    import numpy as np

    burned_mm = sum(float(np.linalg.norm(np.subtract(p.end, p.start))) for p in burned)
    assert burned_mm == pytest.approx(2 * 0.05)            # 0.05 mm out and back at F30:
    assert burned[0].start[:2] == pytest.approx((10, 5)) and burned[-1].end[:2] == pytest.approx((10, 5))
    assert vm.laser_output() == 0 and not vm.unsafe_stops
    state = m.parser_state().split()
    assert "G90" in state and "F1234" in state and "M5" in state
    assert s_max > 0
    assert any(t.startswith("G91 G1 X0.05 F30 S") for t in {p.text for p in burned})   # 0.1 mm at 0.5 mm/s = 0.2 s
    with pytest.raises(Exception, match=r"test pulse power S0: expected 0 < S ≤ \$30"):
        m.test_pulse(0)
    panel.disconnect()
