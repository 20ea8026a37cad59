"""GRBL protocol, link and virtual machine: status parsing, codes, discovery, $-commands."""

import errno
import re
import time

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from labkit.errors import MachineError
from labkit.machine import Grbl, open_link, parse_status
from labkit.machine.grbl import alarm_message, error_message
from labkit.machine.link import (
    Link,
    MachineConfig,
    _open_hint,
    config_path,
    describe_usb,
    load_config,
    save_config,
)


def connect(**opts):
    opts.setdefault("time_scale", 0)
    g = Grbl(open_link(virtual_options=opts))
    g.connect()
    return g


# -- status reports -----------------------------------------------------------------------------

def test_status_fields_any_order_and_optional():
    a = parse_status("<Idle|MPos:1.000,2.000,3.000|FS:0,0|Bf:15,127>")
    b = parse_status("<Idle|Bf:15,127|FS:0,0|MPos:1.000,2.000,3.000>")
    assert a.mpos == b.mpos == (1.0, 2.0, 3.0)
    assert (a.planner_free, a.rx_free) == (b.planner_free, b.rx_free) == (15, 127)
    bare = parse_status("<Alarm>")
    assert bare.state == "Alarm" and bare.mpos is None and bare.planner_free is None


def test_status_wpos_from_remembered_wco():
    first = parse_status("<Run|MPos:10,10,0|WCO:2,3,0>")
    assert first.wpos == (8.0, 7.0, 0.0)
    later = parse_status("<Run|MPos:12,10,0>", wco=first.wco)
    assert later.wpos == (10.0, 7.0, 0.0)
    hold = parse_status("<Hold:1|WPos:1,1,1|Ov:100,100,100|Pn:XYP|Ln:42|F:500>", wco=(1, 1, 1))
    assert hold.state == "Hold" and hold.substate == 1 and hold.mpos == (2.0, 2.0, 2.0)
    assert hold.pins == "XYP" and hold.line == 42 and hold.feed_mm_min == 500.0


@pytest.mark.parametrize("raw, match", [
    ("Idle|MPos:0,0,0", "not a status report"),
    ("<Dancing|MPos:0,0,0>", "unknown machine state"),
    ("<Idle|MPos:0,x,0>", "malformed MPos"),
    ("<Idle|MPos:nan,0,0>", "non-finite MPos"),
])
def test_status_errors(raw, match):
    with pytest.raises(MachineError, match=match):
        parse_status(raw)


@settings(max_examples=60, deadline=None)
@given(st.permutations(["MPos:1.5,-2.25,0.000", "Bf:3,90", "FS:1200,800", "Ov:110,100,90"]))
def test_status_every_field_order_gives_the_same_status(fields):
    s = parse_status("<Run|" + "|".join(fields) + ">")
    assert (s.mpos, s.planner_free, s.rx_free, s.feed_mm_min, s.spindle, s.overrides) == \
        ((1.5, -2.25, 0.0), 3, 90, 1200.0, 800.0, (110, 100, 90))


def test_codes_come_from_the_tables():
    # the shared status table wins where it has the number (one message per code)
    from labkit.errors import status_code

    assert error_message(22) == status_code(22).message
    assert "locked out" in error_message(9)
    assert "hard limit" in alarm_message(1)
    assert alarm_message(42) == "unknown alarm 42"


# -- link ---------------------------------------------------------------------------------------

def test_usb_ids():
    assert describe_usb(0x0403, 0x6001) == "FTDI FT232R"
    assert describe_usb(0x10C4, 0xEA60) == "CP210x"
    assert describe_usb(0x0483, 0x5740) == "STM32 VCP"
    assert describe_usb(0x0403, 0x9999) == "FTDI"


def test_missing_port_says_so():
    with pytest.raises(MachineError, match="does not exist.*labkit ports"):
        open_link("/dev/ttyLABKIT_NO_SUCH_PORT")


def test_bad_url_is_a_clear_error():
    with pytest.raises(MachineError, match="cannot open 'nosuch://x'"):
        open_link("nosuch://x")


@pytest.mark.parametrize("code, platform, match", [
    (errno.EACCES, "linux", "dialout"),
    (errno.EACCES, "darwin", "/dev/cu"),
    (errno.EACCES, "win32", "in use by another program"),
    (errno.EBUSY, "linux", "busy"),
])
def test_open_hints(monkeypatch, code, platform, match):
    monkeypatch.setattr("sys.platform", platform)
    assert match in _open_hint("/dev/ttyUSB0", OSError(code, "x"))


def test_busy_real_pty_port():
    import os
    import pty

    master, slave = pty.openpty()
    name = os.ttyname(slave)
    try:
        first = open_link(name)
        with pytest.raises(MachineError, match="busy"):
            open_link(name)
        first.close()
    finally:
        os.close(master)
        os.close(slave)


def test_loop_url_sends_newline_only():
    link = open_link("loop://")
    link.write_line("G1 X1")
    assert link.read(0.2) == b"G1 X1\n"
    link.close()
    with pytest.raises(MachineError, match="closed"):
        link.write_line("G0")


def test_config_round_trip(tmp_path):
    assert load_config() == MachineConfig()
    save_config(MachineConfig(port="/dev/ttyACM0", baud=250000, protocol="labkit-fw",
                              machine="cbr40-laser"))
    assert config_path().parent == tmp_path / "config"
    assert load_config() == MachineConfig("/dev/ttyACM0", 250000, "labkit-fw", "cbr40-laser")
    config_path().write_text("{not json")
    assert load_config() == MachineConfig()


# -- GRBL on the virtual machine ----------------------------------------------------------------

def test_connect_reads_buffer_sizes_from_i():
    g = connect()
    assert (g.info.rx_bytes, g.info.planner_blocks, g.info.from_machine) == (128, 15, True)
    assert g.info.banner.startswith("Grbl 1.1")
    g.close()
    big = connect(rx_bytes=1024, planner_blocks=32)       # grblHAL-sized buffers
    assert (big.info.rx_bytes, big.info.planner_blocks) == (1024, 32)
    big.close()


def test_settings_state_offsets():
    g = connect()
    assert g.setting(32) == 1.0 and g.setting(30) == 1000.0
    g.set_setting(30, 255)
    assert g.read_settings()[30] == "255"
    g.command("G91 G1 X5 F600 M4 S100")
    assert g.parser_state().split()[:5] == ["G1", "G54", "G17", "G21", "G91"]
    g.wait_status(lambda st: st.state == "Idle", 10.0)   # GRBL answers $# only when idle (error:8)
    assert g.offsets()["G54"] == "0.000,0.000,0.000"
    # GRBL reads '$Q' as a setting whose number is missing: error:2 (recorded: '$Z', dollar_commands)
    with pytest.raises(MachineError, match=r"error:2: malformed number"):
        g.command("$Q")
    with pytest.raises(MachineError, match=r"error:3: unknown or malformed \$ system command"):
        g.command("$999=1")
    g.close()


def test_no_banner_is_a_clear_error():
    link = Link(open_link("loop://").port, "loop://")      # echoes, never a banner
    g = Grbl(link)
    with pytest.raises(MachineError, match="no GRBL start-up banner"):
        g.connect(timeout_s=0.3)
    g.close()


def test_jog_and_soft_limit_alarm_then_unlock():
    g = connect()
    g.set_setting(22, 1)            # GRBL ships soft limits off; they need homing enabled
    g.set_setting(20, 1)
    g.jog(x=-20, y=-5, feed_mm_min=3000)      # GRBL's machine space: −$130…0 per axis
    st = g.wait_status(lambda s: s.state == "Idle", 5)
    assert st.mpos == (-20.0, -5.0, 0.0)
    with pytest.raises(MachineError, match="error:15: jog target outside"):
        g.jog(x=50, feed_mm_min=1000)
    with pytest.raises(MachineError, match="ALARM:2 while sending .*: soft limit"):
        g.command("G90 G0 X9999")
    # GRBL answers nothing after ALARM:2 until a reset, then the alarmed line's ok before its
    # banner: soft_reset sets that ok aside, so the next command gets its own answer
    g.soft_reset()
    assert [ev.text for ev in g.reset_answers] == ["ok"]
    assert [ev.kind for ev in g.drain_events()] == ["reset"]
    with pytest.raises(MachineError, match="error:9: G-code is locked out"):
        g.command("G0 X0")
    g.unlock()
    g.command("G0 X0 Y0")
    assert g.wait_status(lambda s: s.state == "Idle", 5).mpos == (0.0, 0.0, 0.0)
    g.close()


def test_laser_mode_check_refuses_spindle_mode():
    g = connect()
    assert g.check_laser_job(True) is None
    g.set_setting(32, 0)
    with pytest.raises(MachineError, match=r"\$32=0"):
        g.check_laser_job(True)
    assert g.check_laser_job(True, allow_spindle_mode=True).startswith("warning")
    assert g.check_laser_job(False) is None
    g.close()


def test_reset_answers_are_set_aside_only_after_an_alarm():
    """The ok GRBL sends at a reset for the line it was in, as recorded from GRBL 1.1h
    (tests/vectors/grbl/reset_wait.json: a G4 waiting behind a move, then ctrl-x gives
    ALARM:3, ok, the banner), is not the next command's answer; a reset at rest with nothing
    waiting sets nothing aside, and a line answered before the reset keeps its ok."""
    g = connect(time_scale=1.0)
    g.command("G1 X-50 F600")                 # 5 s of motion
    g.send_line("G4 P0.01")                   # waits for the move: no answer yet
    time.sleep(0.2)
    assert g.drain_events() == []
    g.soft_reset()                            # ALARM:3, then the G4's ok, then the banner
    assert g.alarm == 3 and [ev.text for ev in g.reset_answers] == ["ok"]
    assert [ev.kind for ev in g.drain_events()] == ["alarm", "reset"]
    g.unlock()
    g.command("G4 P0")                        # its own answer
    g.soft_reset()
    assert g.reset_answers == []
    g.close()


def test_realtime_hold_resume_and_reset_while_moving_alarms():
    g = connect()
    g.command("G1 X100 F600")
    g.feed_hold()
    st = g.wait_status(lambda s: s.state == "Hold", 2)
    x = st.mpos[0]
    assert 0 < x < 100
    assert g.get_status().mpos[0] == x                    # held: not moving
    g.resume()
    assert g.wait_status(lambda s: s.state == "Run", 2)
    g.soft_reset()                                        # reset while moving: ALARM:3
    assert g.alarm == 3 and "position is likely lost" in alarm_message(3)
    g.close()


class _ScriptedPort:
    """Answers every line with the next scripted reply (a labkit-firmware stand-in)."""

    def __init__(self, replies):
        self.replies = list(replies)
        self.out = bytearray(b"labkit-fw 0.1 ['$' for help]\r\n")
        self.timeout = 0.05

    @property
    def in_waiting(self):
        return len(self.out)

    def write(self, data):
        for _ in range(data.count(b"\n")):
            self.out += (self.replies.pop(0) if self.replies else "ok").encode() + b"\r\n"
        return len(data)

    def read(self, n=1):
        import time

        if not self.out:
            time.sleep(self.timeout)
            return b""
        data = bytes(self.out[:n])
        del self.out[:n]
        return data

    def close(self):
        pass


def test_labkit_firmware_er_codes_use_the_shared_table():
    from labkit.errors import status_code
    from labkit.machine.labkitfw import LabkitFirmware

    fw = LabkitFirmware(Link(_ScriptedPort(["er:22", "er", "ok"]), "fw"))
    assert fw._banner.wait(1.0) and fw.dialect == "labkit-fw"
    assert [e.kind for e in fw.drain_events()] == ["reset"]      # the banner
    with pytest.raises(MachineError, match=re.escape(f"error:22: {status_code(22).message}")):
        fw.command("G1 X10")
    with pytest.raises(MachineError, match="no code"):
        fw.command("G1 X10 F10")
    assert fw.command("G1 X10 F10") == []
    fw.close()


@pytest.mark.parametrize("call, match", [
    (lambda: open_link({"port": "/dev/ttyUSB0"}), r"open_link: port must be a device name or "
                                                  r"URL .* got dict"),
    (lambda: open_link("virtual://", "115200"), r"open_link: baud must be a positive whole number"),
    (lambda: open_link("virtual://", virtual_options="grbl-diode"),
     r"open_link: virtual_options must be a dict .* got str"),
    (lambda: open_link(virtual_options={"machine": {"travel_mm": 300}}),
     r"open_link: virtual_options\['machine'\]: machine must be a MachineSpec, a machine's name "
     r"or a TOML file, got dict"),
    (lambda: open_link(virtual_options={"speed": 2}), r"open_link: virtual_options has 'speed'"),
    (lambda: Grbl("virtual://"), r"Grbl: link must be an open Link .* got str"),
])
def test_the_wrong_kind_of_argument_is_named(call, match):
    """Issue 25 §5: a str or dict where a machine (a port, a link, its options) is expected gets
    labkit's own error naming the argument, never an AttributeError from deep inside."""
    with pytest.raises(MachineError, match=match):
        call()
