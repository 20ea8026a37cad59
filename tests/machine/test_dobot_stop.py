"""Issue 25 §2, the Dobot path: every end of a job stops the arm and the beam before the port
closes, and the report says only what was sent and confirmed.

A fake Dobot on a pty (the emulator's decoding and answers, executing one queued command every
few milliseconds) records every byte it receives and when the other end closed; it can stop
answering, leave one command unanswered or hang up. The stop frames are written out by hand
from the protocol document (header AA AA, length, id, ctrl, params, checksum), not by
``frame()``.
"""

import os
import re
import select
import signal
import subprocess
import sys
import textwrap
import threading
import time
import tty
from pathlib import Path

import pytest

from labkit.errors import MachineError
from labkit.gcode import parse
from labkit.machine.dobot import CMD, Dobot, DobotEmulator, job_commands

# SetQueuedCmdForceStopExec (242), write: payload F2 01, checksum -(0xF2 + 0x01) mod 256 = 0x0D
FORCE_STOP = bytes.fromhex("AAAA02F2010D")
# SetEndEffectorLaser (61), write, enable 1, on 0: payload 3D 01 01 00, checksum 0xC1
LASER_OFF = bytes.fromhex("AAAA043D010100C1")
# SetIOPWM (132), write, address 4, 10 kHz (float32 0x461C4000), duty 0.0: checksum 0xD5
PWM_ZERO = bytes.fromhex("AAAA0B84010400401C4600000000D5")
# SetQueuedCmdClear (245), write: payload F5 01, checksum 0x0A
QUEUE_CLEAR = bytes.fromhex("AAAA02F5010A")
STOP_BYTES = FORCE_STOP + LASER_OFF + PWM_ZERO + QUEUE_CLEAR

ALL_CONFIRMED = ("safe stop: force-stop confirmed, laser off confirmed, PWM 0 % confirmed, "
                 "queue clear confirmed — the Dobot acknowledged the laser-off command")


def drawing(lines: int = 300) -> str:
    """A hand-written zig-zag inside the arm's reach (canvas x 0-60, y 20-80 mm: 223-297 mm
    from the base), burning at S200 (20 % of GRBL's full power S1000)."""
    body = "".join(f"G1 X{60 * (k % 2)} Y{20 + 60 * k / lines:.3f}\n" for k in range(lines))
    return "G21 G90\nG0 X0 Y20\nM3 S200\nG1 F1200\n" + body + "M5\nG0 X0 Y20\n"


class SlowArm(DobotEmulator):
    """The emulator executing one queued command every ``every_s`` seconds of wall time;
    ``silent`` command ids, sent unqueued, are recorded but never answered; after
    ``mute_after`` frames nothing is answered."""

    def __init__(self, every_s=0.01, silent=(), mute_after=None):
        super().__init__(per_poll=1)
        self.every_s = every_s
        self.silent = set(silent)
        self.mute_after = mute_after
        self.next_step = 0.0

    def _step(self):
        now = time.monotonic()
        if now >= self.next_step:
            self.next_step = now + self.every_s
            super()._step()

    def _answer(self, f, params=b""):
        if f.cmd_id in self.silent and not f.queued:
            return
        if self.mute_after is not None and self.frames > self.mute_after:
            return
        super()._answer(f, params)


class PtyDobot:
    """``arm`` behind a pty: ``path`` is the device the host opens. ``raw`` holds every byte
    received, ``closed_at`` how many of them had arrived when the host closed its end;
    ``hang_up_after`` closes the fake's end once that many queued frames have arrived."""

    def __init__(self, arm, *, hang_up_after=None):
        self.arm = arm
        self.hang_up_after = hang_up_after
        self.master, slave = os.openpty()
        tty.setraw(slave)                      # no echo: the host's bytes never come back
        self.path = os.ttyname(slave)
        os.close(slave)
        self.raw = bytearray()
        self.closed_at = None
        self.hung_up = False
        self.quit = False
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    def queued_frames(self) -> int:
        return sum(f.queued for f in self.arm.received)

    def _serve(self):
        opened = False
        while not self.quit:
            ready, _, _ = select.select([self.master], [], [], 0.005)
            if ready:
                try:
                    data = os.read(self.master, 4096)
                except OSError:                # EIO: no process holds the device open
                    if opened:
                        self.closed_at = len(self.raw)
                        return
                    time.sleep(0.01)
                    continue
                opened = True
                self.raw += data
                self.arm.write(data)
            if (self.hang_up_after is not None
                    and self.queued_frames() >= self.hang_up_after):
                self.hung_up = True
                os.close(self.master)
                return
            out = self.arm.read(len(self.arm.out))
            if out:
                os.write(self.master, out)

    def wait(self, what, timeout_s=240.0):      # generous: a cold numba cache compiles first
        deadline = time.monotonic() + timeout_s
        while not what():
            assert time.monotonic() < deadline, "the fake Dobot waited in vain"
            time.sleep(0.01)

    def stop(self):
        self.quit = True
        self.thread.join(5)
        if not self.hung_up:
            os.close(self.master)


@pytest.fixture
def job_file(tmp_path):
    p = tmp_path / "zigzag.gcode"
    p.write_text(drawing())
    return p


def labkit_stream(job, port):
    exe = Path(sys.executable).with_name("labkit")
    return subprocess.Popen([str(exe), "stream", str(job), "--protocol", "dobot", "--port", port],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


@pytest.mark.parametrize("sig, status, words", [(signal.SIGINT, 130, "interrupted (Ctrl-C)"),
                                                (signal.SIGTERM, 143, "terminated (SIGTERM)")])
def test_signal_to_labkit_stream_stops_the_arm_then_the_beam_before_the_port_closes(
        job_file, sig, status, words):
    fake = PtyDobot(SlowArm())
    try:
        proc = labkit_stream(job_file, fake.path)
        fake.wait(lambda: fake.queued_frames() >= 60 or proc.poll() is not None)
        assert fake.arm.laser_on and fake.arm.running, "the job should be burning mid-way"
        proc.send_signal(sig)
        out, err = proc.communicate(timeout=240)
        fake.wait(lambda: fake.closed_at is not None)
    finally:
        fake.stop()
    assert proc.returncode == status, err
    # the last bytes before the port closed: force-stop, laser off, PWM 0, queue clear
    assert bytes(fake.raw).endswith(STOP_BYTES) and fake.closed_at == len(fake.raw)
    assert not fake.arm.laser_on and fake.arm.pwm_duty == 0.0
    assert not fake.arm.running and fake.arm.queue == []
    assert out.splitlines()[1] == f"STOPPED: {words}"
    assert out.splitlines()[2].startswith(ALL_CONFIRMED)
    assert "last queued: source line" in out and "Traceback" not in err


def test_arm_that_stops_answering_mid_job_gets_every_stop_frame_before_the_port_closes(job_file):
    fake = PtyDobot(SlowArm(mute_after=80))
    try:
        proc = labkit_stream(job_file, fake.path)
        out, err = proc.communicate(timeout=240)
        fake.wait(lambda: fake.closed_at is not None)
    finally:
        fake.stop()
    assert proc.returncode == 1, err
    assert bytes(fake.raw).endswith(STOP_BYTES) and fake.closed_at == len(fake.raw)
    first, second = out.splitlines()[1:3]
    assert first.startswith("STOPPED: no answer from the Dobot to command ")
    assert second.startswith("safe stop: force-stop sent, no answer within 0.5 s, laser off sent, "
                             "no answer within 0.5 s, PWM 0 % sent, no answer within 0.5 s, "
                             "queue clear sent, no answer within 0.5 s — the laser-off command "
                             "was sent but not acknowledged: check the beam")
    assert "the laser switched off" not in out and "acknowledged the" not in out
    assert not fake.arm.laser_on          # this arm acts on what it hears, it only never answers


def test_second_ctrl_c_during_the_stop_is_held_until_the_laser_is_off(job_file):
    # force-stop and the immediate PWM 0 go unanswered, so the stop takes two 0.5 s timeouts:
    # the second Ctrl-C lands inside it
    fake = PtyDobot(SlowArm(silent={CMD["queue_force_stop"], CMD["io_pwm"]}))
    try:
        proc = labkit_stream(job_file, fake.path)
        fake.wait(lambda: fake.queued_frames() >= 40 or proc.poll() is not None)
        proc.send_signal(signal.SIGINT)
        fake.wait(lambda: FORCE_STOP in fake.raw)
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=240)
        fake.wait(lambda: fake.closed_at is not None)
    finally:
        fake.stop()
    assert proc.returncode == 130, err
    assert bytes(fake.raw).endswith(STOP_BYTES)
    assert ("force-stop sent, no answer within 0.5 s, laser off confirmed, PWM 0 % sent, no answer "
            "within 0.5 s, queue clear confirmed — the Dobot acknowledged the laser-off "
            "command") in out
    assert ("labkit: SIGINT again — still stopping the machine safely (force-stop, laser off, "
            "PWM 0 %, queue clear; at most about 2 s)") in err


def test_lost_link_says_the_controller_was_not_told_to_stop(job_file, capsys):
    from labkit.cli import main

    fake = PtyDobot(SlowArm(), hang_up_after=30)
    try:
        assert main(["stream", str(job_file), "--protocol", "dobot", "--port", fake.path]) == 1
    finally:
        fake.stop()
    out = capsys.readouterr().out
    assert out.splitlines()[1].startswith("STOPPED: the link to the Dobot is gone")
    assert "the controller was not told to stop: the link to the Dobot is gone" in out
    assert "its own behaviour is all that applies" in out
    assert "acknowledged" not in out and "switched off" not in out
    assert FORCE_STOP not in fake.raw and LASER_OFF not in fake.raw
    resume = re.search(rf"labkit stream {job_file} --protocol dobot --port {fake.path} "
                       rf"--resume-from (\d+)$", out, re.M)
    # the 30 commands queued before the hang-up draw lines 2-30; the next one is line 31's
    assert resume and 2 <= int(resume[1]) <= 31
    assert out.splitlines()[-1].startswith("record: ")       # the stream's record, even after a lost link


def burning_job():
    return job_commands(parse(drawing(80)))


def test_exception_in_progress_callback_stops_first():
    arm = DobotEmulator(per_poll=1)

    def progress(line, n, total):
        if n == 30:
            raise ZeroDivisionError("a bug in the caller's progress bar")

    bot = Dobot(arm)
    with pytest.raises(ZeroDivisionError) as info:
        bot.run(burning_job(), ahead=8, progress=progress)
    received = b"".join(_bytes(f) for f in arm.received)
    assert received.endswith(STOP_BYTES)
    assert not arm.laser_on and arm.pwm_duty == 0.0 and arm.queue == []
    assert bot.last_stop.summary().startswith(ALL_CONFIRMED)
    assert info.value.__notes__ == [bot.last_stop.summary()]


def _bytes(f):
    from labkit.machine.dobot import frame

    return frame(f.cmd_id, f.params, write=f.write, queued=f.queued)


def test_mute_arm_every_stop_frame_is_still_sent_and_nothing_is_claimed():
    arm = SlowArm(every_s=0.0, mute_after=25)
    bot = Dobot(arm, timeout_s=0.3)
    with pytest.raises(MachineError, match=r"no answer from the Dobot .* within 0\.3 s"):
        bot.run(burning_job(), ahead=8, stop_timeout_s=0.1)
    assert b"".join(_bytes(f) for f in arm.received).endswith(STOP_BYTES)
    text = bot.last_stop.summary()
    assert text.startswith("safe stop: force-stop sent, no answer within 0.1 s, laser off sent, "
                           "no answer within 0.1 s, PWM 0 % sent, no answer within 0.1 s, queue "
                           "clear sent, no answer within 0.1 s — the laser-off command was sent "
                           "but not acknowledged")
    assert "acknowledged the" not in text and "switched off" not in text
    assert not bot.last_stop.laser_off_confirmed and bot.last_stop.told_to_stop


def test_force_stop_timeout_does_not_skip_the_laser_off_frame():
    # the case: the force-stop timed out, the laser-off frame was never sent, and the
    # report said "the laser switched off"
    silent = SlowArm(every_s=0.0, silent={CMD["queue_force_stop"]})
    bot = Dobot(silent)
    with pytest.raises(MachineError, match="cancelled"):
        bot.run(burning_job(), ahead=4, cancel=lambda: len(silent.executed) > 12,
                stop_timeout_s=0.1)
    assert b"".join(_bytes(f) for f in silent.received).endswith(STOP_BYTES)
    assert bot.last_stop.summary().startswith(
        "safe stop: force-stop sent, no answer within 0.1 s, laser off confirmed, PWM 0 % "
        "confirmed, queue clear confirmed — the Dobot acknowledged the laser-off command")
    assert not silent.laser_on


KERNEL_CELL = textwrap.dedent("""
    import serial
    from labkit.gcode import parse
    from labkit.machine.dobot import Dobot, job_commands
    port = serial.Serial({path!r}, 115200, timeout=0.05)
    Dobot(port).run(job_commands(parse({text!r})))
""")


def test_closing_the_notebook_kernel_mid_job_stops_the_arm_and_the_beam():
    jupyter_client = pytest.importorskip("jupyter_client")
    fake = PtyDobot(SlowArm())
    km = jupyter_client.KernelManager(kernel_name="python3")
    try:
        km.start_kernel()
        kc = km.client()
        kc.start_channels()
        kc.wait_for_ready(timeout=60)
        kc.execute(KERNEL_CELL.format(path=fake.path, text=drawing()))
        fake.wait(lambda: fake.queued_frames() >= 60)
        assert fake.arm.laser_on
        kc.stop_channels()
        km.shutdown_kernel()                   # as JupyterLab's "Shut Down Kernel" does
        fake.wait(lambda: fake.closed_at is not None)
    finally:
        if km.has_kernel:
            km.shutdown_kernel(now=True)
        fake.stop()
    assert bytes(fake.raw).endswith(STOP_BYTES) and fake.closed_at == len(fake.raw)
    assert not fake.arm.laser_on and fake.arm.queue == []
