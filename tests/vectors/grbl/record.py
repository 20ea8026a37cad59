"""Record conversations with GRBL 1.1h itself (grbl-sim) as JSON test vectors.

    python tests/vectors/grbl/record.py GRBL_SIM_EXE [OUT_DIR] [TOPIC ...]

GRBL_SIM_EXE is a grbl-sim binary built from gnea/grbl (see README.md in this
folder for the exact commits, build options and the patches the simulator
needs). This script never runs in CI: the transcripts it writes are
checked in and replayed by tests/firmware/test_grbl_transcripts.py.

Every topic starts a fresh simulator in an empty temporary directory, so GRBL
boots on a blank EEPROM, restores its compiled-in defaults (DEFAULTS_GENERIC)
and the boot output is discarded; the first exchange of every transcript is
a soft reset (ctrl-x) and its banner. Each step sends its bytes at once and
collects what GRBL answers:

* a line (bytes ending in ``\\n``) waits for its ``ok`` / ``error:N`` (at most
  ``wait_s``), then for ``quiet_s`` of silence (late messages, alarms);
* a real-time byte (``?``, ``!``, ``~``, ctrl-x, overrides) or a step marked
  ``answered=False`` (an M0 that holds its ``ok``) waits for silence only.

A ``pause_before_s`` holds the conversation before the bytes go out (motion
that must finish or stop first); it is recorded so that a replay can pause
the same way. What GRBL writes during that pause came before the step's
bytes: it is the previous exchange's. Every exchange also keeps ``at_s``: when GRBL received its first
byte, on GRBL's own clock (grbl-sim's simulated seconds, which its motion runs
on; patch 12 of README.md logs every byte's arrival on stderr), counted from the
first exchange's. It is the time GRBL had between two exchanges, its motion
running meanwhile, which a replay in simulated time gives the virtual machine.
"""
from __future__ import annotations

import datetime as _dt
import json
import os
import re
import select
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent

GRBL_COMMIT = "bfb67f0c7963fe3ce4aaf8a97f9009ea5a8db36e"      # gnea/grbl, GRBL 1.1h.20190830
GRBL_SIM_COMMIT = "9bdd1654c7eb6cacf03e35340b38c962bcebe013"  # grbl/grbl-sim

RESET = "\x18"
JOG_CANCEL = "\x85"
FEED_PLUS_10 = "\x91"
RAPID_50 = "\x96"
POWER_MINUS_10 = "\x9b"

_TERMINATOR = re.compile(r"^(ok|error:\d+|ALARM:\d+)$")   # an alarm can take the place of a line's ok
#: status-report fields whose values depend on when the report was taken while the machine moves
_TIMED_FIELDS = ("MPos", "WPos", "FS", "F", "Bf", "Ln")
_MOVING_STATES = ("Run", "Jog", "Hold", "Home", "Door")


def line(text, **kw):
    """A G-code or ``$`` line: ``text`` and a newline."""
    return dict(send=text + "\n", **kw)


def rt(byte, **kw):
    """Real-time bytes, sent without a newline."""
    return dict(send=byte, **kw)


def raw(data, **kw):
    """Bytes exactly as given (several lines at once, a line without its newline …)."""
    return dict(send=data, **kw)


def _sync(note="dwell: its ok means the planner is empty", **kw):
    # GRBL's G4 answers ok only when every queued move has finished: the in-band way to wait
    return line("G4 P0.01", note=note, **kw)


# --------------------------------------------------------------------------------------------
# The topics. Each is (title, steps); every transcript starts with a soft reset.

def _dollar_commands():
    return "Every $ command in idle (help, settings, parameters, parser state, build info, startup lines, " \
           "check mode, unlock, homing with homing disabled, jog, sleep, restore) and unknown ones", [
        line("$"), line("$$"), line("$#"), line("$G"), line("$I"),
        line("$I=LABKIT TEST"), line("$I"),
        line("$N"),
        line("$N0=G20 G91", note="a valid start-up line: stored, run at every reset"),
        line("$N1=G1 X1 Q1", note="GRBL checks a start-up line before storing it"),
        line("$N1=$X", note="a $ command is no start-up line"),
        line("$N2=G21", note="a third start-up line (config.h: N_STARTUP_LINE 2)"),
        line("$N1=G4 P0"),
        line("$N"),
        rt(RESET, note="the stored start-up lines run after the banner, each echoed with its reply"),
        line("$G"),
        line("$N0="), line("$N1="), line("$N"),
        rt(RESET),
        line("$G"),
        line("$C"), line("G0 X5"), line("?"), line("$C"),
        line("$X", note="unlock when not alarmed"),
        line("$H", note="homing disabled ($22=0)"),
        line("$J=G91 X1 F200"), rt("?", pause_before_s=2.0),
        line("$J=G90 X0 F200"), rt("?", pause_before_s=2.0),
        line("$J=X1", note="jog without a feed rate"),
        line("$J=G0 X1 F100", note="G0 is not a jog motion"),
        line("$J=G91 G20 X0.1 F10"), rt("?", pause_before_s=2.5), line("$G", note="a jog keeps G21"),
        line("$J=G53 X0 F200"), rt("?", pause_before_s=2.5),
        line("$J=G91 X1 F200 M3", note="a jog carries only G20/G21, G90/G91, G53 and axes"),
        line("$J="), line("$J=G4 P1"),
        line("$10", note="reading one setting is no command"),
        line("$G1"), line("$$$"), line("$#1"), line("$Z"), line("$ I"), line("$i"), line("$rst=gcode"),
        line("$HTTP/1.1"), line("$RST=x"), line("$C1"), line("$X1"), line("$H1"), line("$SLP1"),
        line("$RST=#"), line("$#"),
        line("$RST=$"), line("$$"),
        line("$RST=*"), line("$I"),
        line("$SLP"), rt("?"), line("G0 X1", answered=False), rt(RESET, pause_before_s=0.2), rt("?"), line("$X"), rt("?"),
    ]


def _settings():
    valid = [("$0=5", None), ("$1=255", None), ("$2=7", None), ("$3=2", None), ("$4=1", None),
             ("$5=1", None), ("$6=1", None), ("$10=2", None), ("$11=0.02", None), ("$12=0.005", None),
             ("$13=1", None), ("$21=1", "hard limits on: no switch is wired, so nothing trips"),
             ("$21=0", None), ("$23=3", None), ("$24=50", None), ("$25=1000", None), ("$26=100", None),
             ("$27=2.5", None), ("$30=255", None), ("$31=10", None), ("$32=1", None),
             ("$100=80", None), ("$101=80.5", None), ("$102=400", None),
             ("$110=1000", None), ("$111=1200.5", None), ("$112=300", None),
             ("$120=20", None), ("$121=25", None), ("$122=5", None),
             ("$130=300", None), ("$131=250.25", None), ("$132=50", None)]
    bad = [("$0=2", "step pulse below 3 µs"), ("$0=-1", None), ("$0=abc", None), ("$0=", None),
           ("$0=10.7", "an integer setting given a fraction"), ("$1=256", "an integer setting over 255"),
           ("$2=255", None), ("$10=1.5", None), ("$11=-0.01", None), ("$12=0", None),
           ("$13=2", None), ("$20=1", "soft limits need homing"), ("$22=2", None), ("$23=-1", None),
           ("$24=0", None), ("$26=1000", None), ("$30=0", None), ("$31=-5", None), ("$32=2", None),
           ("$100=0", None), ("$100=-5", None), ("$110=1e3", "no exponent in GRBL's numbers"),
           ("$110=1,000", None), ("$120=0x10", None), ("$130=+5", None), ("$130=.5", None),
           ("$7=1", "no such setting"), ("$9=1", None), ("$14=1", None), ("$19=1", None), ("$28=1", None),
           ("$33=1", None), ("$103=1", None), ("$113=1", None), ("$133=1", None), ("$200=1", None),
           ("$1000=1", None), ("$=1", None), ("$-1=1", None), ("$1.5=1", None), ("$A=1", None),
           ("$ 1 1 0 = 7 5 0", "spaces are dropped before GRBL reads the line"), ("$110 =750.0", None)]
    steps = [line("$$")]
    for text, note in valid:
        steps.append(line(text, **({"note": note} if note else {})))
    steps.append(line("$$"))
    for text, note in bad:
        steps.append(line(text, **({"note": note} if note else {})))
    steps += [line("$$"), rt(RESET), line("$$", note="settings live in EEPROM: kept through a reset"),
              line("$RST=$"), line("$$")]
    return "Every setting read, written with a valid value, out of range and with the wrong type", steps


# G-code lines GRBL refuses, in idle, fresh after the reset (G21 G90 G54 G17 G94, no F yet).
_ERROR_LINES = [
    ("X", "a word without a value is read as a letter with a bad number"), ("1", None), ("10 X1", None),
    ("G0 X0 1", "spaces go before GRBL reads a line: this is G0X01"), ("*", None), ("G0 X1 #", None), ("G0 X1 =2", None), ("%", "a % line"),
    ("G0 X1 %", None), ("G0 @", None), ("/G0 X1", "block delete is not GRBL's"),
    ("G", None), ("G0 X", None), ("G0 X-", None), ("G0 X.", None), ("G0 X1.2.3", None),
    ("G0 X+", None), ("G0 X1e3", None), ("F", None), ("G0 X--1", None),
    ("F-100", None), ("S-1", None), ("N-5 G0 X1", None), ("G4 P-1", None), ("T-1", None),
    ("G1 X1 F-1", None),
    ("G4.1", None), ("G5 X1", None), ("G7", None), ("G41", None), ("G64", None), ("G81 X1 Y1 Z-1 R1", None),
    ("G95", None), ("G96", None), ("G99", None), ("G100", None), ("M6", None), ("M7", "M7 needs mist coolant, a build option"),
    ("M50", None), ("M100", None), ("M118 (hello) T", "issue 27: GRBL refuses M118 before looking at T"),
    ("M3.5", None), ("G20.1", None), ("G38.1 Z-1 F10", None), ("G38.6 Z-1 F10", None), ("G59.3", None),
    ("A1", None), ("B1", None), ("C1", None), ("D1", None), ("E1", None), ("H1", None), ("O1", None),
    ("Q1", None), ("U1", None), ("V1", None), ("W1", None),
    ("G0 G1 X1", None), ("G20 G21", None), ("G90 G91", None), ("M3 M5", None), ("G17 G18", None),
    ("G54 G55", None), ("G93 G94", None), ("M8 M9", None), ("G4 G10 L2 P1 X1", None),
    ("G1 X1", "no feed rate yet"), ("G93 G1 X1", "inverse time needs F on the line"),
    ("G1.5 X1", None), ("N1.5 G0 X1", None), ("G10 L2.5 P1 X1", None), ("G10 L2 P1.5 X1", None),
    ("T1.5", None), ("M3.1", None),
    ("G1 G28 X1 F100", "two commands that both want the axis words"), ("G0 G92 X1", None),
    ("G10 L2 P1 G28 X1", None), ("G53 G28 X1", None),
    ("G0 X1 X2", None), ("G1 F1 F2", None), ("N1 N2", None), ("S1 S2", None), ("G0 X1 Y1 Y2", None),
    ("T1 T2", None), ("G4 P1 P2", None),
    ("G10 L2 P1", "no axis words"), ("G92", None), ("G10 L20 P1", None), ("G43.1", None),
    ("G38.2 F100", None),
    ("N10000000 G0 X1", None), ("N99999999", None),
    ("G10 L2 X1", "missing P"), ("G4", None), ("G10 P1 X1", None), ("G38.2 Z-1", None),
    ("G1 X1", None),
    ("G59.1", None), ("G59.2", None), ("G10 L2 P7 X1", None), ("G10 L2 P10 X1", None),
    ("G53 G2 X1 I1", None), ("G53 G3 X1 J1", None), ("G53 G38.2 Z-1 F10", None),
    ("G80 X1", None), ("G17 X1 G80", None), ("G4 P1 X1", None), ("M5 X1", None),
    ("G2 Z1 I1 F100", None), ("G3 I1 J1 F100", None), ("G18 G2 Y1 I1 F100", None),
    ("G2 X0 Y0 R1 F100", "the target is the current point"), ("G2 X0 Y0 I0 J0 F100", None),
    ("G3 X1 Y0 I0 J0 F100", None), ("G38.2 Z0 F100", None),
    ("G2 X10 Y0 R2 F100", "chord longer than 2R (issue 27)"), ("G2 X10 Y0 I1 J0 F100", None),
    ("G3 X2 Y0 I1 J1 F100", None),
    ("G2 X1 F100", "no I/J/K or R"), ("G18 G2 X1 Z1 F100", None), ("G2 X1 K1 F100", None),
    ("G0 X1 I1", None), ("G0 X1 R1", None), ("M3 P1", None), ("G21 X1", None), ("G1 X1 F100 L2", None),
    ("G43.1 X1", None), ("G43.1 Y1", None), ("G43.1 X1 Z1", None),
    ("T256", None), ("T1000", None), ("G10 L2 P1 X1 Y1 Z1 R1", None), ("M30 X1", None), ("M2 S100", None),
]


def _errors():
    # a line GRBL accepts is followed by a dwell, so that no motion is left running under the next
    steps = []
    for text, note in _ERROR_LINES:
        steps.append(line(text, sync_if_ok=True, **({"note": note} if note else {})))
    steps.append(_sync())
    steps.append(line("$G", note="none of the refused lines changed the modal state"))
    steps.append(line("$#"))
    # errors that need a state: alarm, motion
    steps += [
        line("$32=1"), line("G1 X40 F300", note="8 s of motion for the lines below"),
        line("$$"), line("$X"), line("$C"), line("$H"), line("$I"), line("$N"), line("$#"), line("$G"),
        line("$10=2"), line("$N0=G20"), line("$RST=$"), line("$J=G91 X1 F100"), line("G0 X1 I1"),
        line("$SLP", note="$SLP while moving"), rt("?", pause_before_s=0.5), rt("?", pause_before_s=9.0),
    ]
    return "Erroneous lines for every GRBL error number a line can produce, in idle and while moving", steps


def _issue27_lines():
    return "The G-code lines of issue 27's last section, as GRBL answers them", [
        line("%"), line("G0 X1", note="the program goes on after a % line"), _sync(), line("%"),
        line("G2 X10 Y0 R2 F100"),
        line("G0 X2 (unclosed comment", note="GRBL ends the comment at the line end"), _sync(), rt("?"),
        line("G0 X3 (closed) Y1"), _sync(), rt("?"), line("G0 (a) X0 (b) Y0 (c)"), _sync(), rt("?"),
        line("G0 X1 ; a semicolon comment"), _sync(), rt("?"),
        line("; only a comment"), line("(only a comment)"),
        line("$rst=gcode"), line("$HTTP/1.1 200"), line("$HTTP/"),
        raw("?\n", note="a lone ? line: ? is answered at once as a status report, the empty line with ok"),
        line("M118 P0 (hello) T1"), line("M118 T"),
        line(""), line("   "), line("\t"), line("g0 x1.5 y0.5", note="lower case"), _sync(), rt("?"),
        line("G0X0Y0"), _sync(), rt("?"), line("$G"),
    ]


def _program_flow():
    return "Program flow: M0 holds until ~, M1, M2 and M30 end the program (modal state reset)", [
        line("$32=1"), line("G1 X2 F300"),
        line("M0", answered=False, quiet_s=1.5, timed=(),
             note="GRBL finishes the queued move, holds, and answers ok only after ~"),
        rt("?", timed=()), line("G0 X0", answered=False, note="queued behind the pause: no ok yet"),
        rt("~", note="cycle start: the M0's ok, then the queued line's"),
        _sync(), rt("?"),
        line("M1", note="optional stop"), rt("?"), line("M0", answered=False, quiet_s=1.0), rt("?", timed=()),
        rt(RESET, note="a reset during the M0 pause"), rt("?"),
        line("G91 G20 G2 X0.1 Y0.1 I0.05 J0.05 F200"), _sync(),
        line("M4 S300 M8"), line("G55 G93 G18"), line("$G"),
        line("M2"), line("$G", note="after M2"), rt("?"),
        line("G91 G20 G1 M3 S200 F300 G56"), line("$G"), line("M30"), line("$G", note="after M30"),
        line("G90 G21 G1 X1 F300"), line("M2", note="M2 behind a queued move"), rt("?"),
        _sync(), rt("?"), line("M30 M5"), line("M2 M30"), line("M0 M1"),
    ]


def _check_mode():
    return "Check mode ($C) in and out, and what it accepts, refuses and reports", [
        line("$C"), rt("?"), line("$G"), line("G0 X10 Y10"), line("G1 X5"), line("G1 X5 F100"),
        line("G2 X0 Y0 R1"), line("M0", note="no pause in check mode"), line("$#"), rt("?"),
        line("G10 L2 P1 X5"), line("$#", note="does a G10 in check mode change the offsets?"),
        line("M2"), line("$G"), line("G20"), line("$G"), line("$$"),
        line("$C", note="leaving check mode resets GRBL"), rt("?"), line("$G"),
        line("$C"), line("G0 X1 G1"), line("$C"), line("$C"), line("$C"),
    ]


def _offsets():
    return "Work offsets: G10 L2/L20, G92, G92.1, G54-G59, G28/G30 and .1, G53, G43.1/G49 and $#", [
        line("$#"), rt("?"),
        line("G10 L2 P1 X5 Y6 Z-1"), line("$#"), rt("?"), line("$G"),
        line("G10 L2 P2 X10"), line("G10 L2 P6 Y-3"), line("G10 L2 P0 Z2", note="P0: the current system"),
        line("$#"), rt("?"),
        line("G0 X1 Y1"), _sync(), rt("?"),
        line("G10 L20 P1 X0 Y0", note="set work zero here"), line("$#"), rt("?"),
        line("G10 L20 P3 X2"), line("G55"), line("$G"), rt("?"), line("G56"), rt("?"), line("G57"),
        line("G58"), line("G59"), rt("?"), line("$G"), line("G54"),
        line("G92 X0 Y0"), line("$#"), rt("?"), line("G92 X3"), line("$#"), rt("?"),
        line("G92.1"), line("$#"), rt("?"),
        line("G92 X1"), line("G92.2", note="G92.2/G92.3 are not GRBL's"), line("G92.3"), line("G92.1"),
        line("G0 X2 Y3"), _sync(),
        line("G28.1"), line("G30.1"), line("$#"),
        line("G0 X0 Y0"), _sync(), line("G28"), _sync(), rt("?"), line("G0 X0 Y0"), _sync(),
        line("G30"), _sync(), rt("?"),
        line("G28 X1"), _sync(), rt("?"), line("G30 Y1"), _sync(), rt("?"),
        line("G28.1 X1", note="axis words after G28.1"),
        line("G53 G0 X4 Y4"), _sync(), rt("?"), line("G53 G1 X5 F300"), _sync(), rt("?"),
        line("G53 X6"), _sync(), rt("?"),
        line("G43.1 Z0.5"), line("$#"), rt("?"), line("$G"), line("G49"), line("$#"), rt("?"),
        line("G20 G10 L2 P1 X1"), line("$#"), line("G21"),
        line("G91 G10 L20 P1 X1"), line("$#"), line("G90"),
        rt(RESET, pause_before_s=0.2), line("$#", note="what a reset keeps of the offsets"),
        rt("?"), line("$G"),
        line("G10 L2 P1 X0 Y0 Z0"), line("G10 L2 P2 X0 Y0 Z0"), line("G10 L2 P3 X0 Y0 Z0"),
        line("$RST=#"), line("$#"), rt("?"),
    ]


def _homing_limits():
    return "Homing disabled, soft limits without and with homing, the homing alarm lock, a probe " \
           "that never touches", [
        line("$130=200"), line("$131=200"), line("$132=200"), line("$110=500"), line("$120=10"),
        line("$H"), line("$20=1"), line("$21=1"), rt("?"), line("$21=0"),
        line("$22=1"), rt(RESET, note="a soft reset is no power-up: no homing lock"), rt("?"),
        line("G0 X1"), _sync(), line("$J=G91 X1 F100"), line("$G", pause_before_s=2.0), line("$#"), line("$$"),
        line("$X"), rt("?"), line("$20=1"),
        line("$J=G91 X5 F100", note="outside the travel (machine space is -$130..0)"),
        line("$J=G53 X-250 F100"), line("$J=G91 X-1 F300"), rt("?", pause_before_s=2.0),
        line("G0 X5", quiet_s=1.5, note="soft limit: alarm, the line is not run"), rt("?"),
        line("G0 X-1", answered=False, note="nothing is answered until the reset"), line("$X", answered=False),
        rt(RESET), rt("?"), line("$X"), rt("?"),
        line("G0 X-300", quiet_s=1.5), rt("?"), rt(RESET), line("$X"),
        line("G1 X-2 F300"), _sync(), rt("?"),
        line("G1 X10", quiet_s=1.5, note="a line that leaves the travel, from idle"), rt("?"), rt(RESET),
        rt("?"), line("$X"), line("G0 X-1"), _sync(), rt("?"),
        line("$20=0"), line("$22=0"), rt(RESET), rt("?"),
        line("G38.2 Z-1 F200", quiet_s=1.5, note="the probe pin never trips: ALARM:5"), rt("?"),
        rt(RESET), rt("?"), line("$X"),
        line("G38.3 Z-0.5 F200", note="G38.3: no alarm when nothing touches"), _sync(), rt("?"),
        line("G38.4 Z-0.5 F200"), rt("?", pause_before_s=1.0), rt(RESET), line("$X"), line("$#"),
    ]


#: Simulated limit switches per topic (grbl-sim patch 7, README.md): axis:mm from the power-up
#: position (the sign says on which side), or axis:stuck (always pressed); no entry, no switch.
SWITCHES = {
    "homing": "X:+5,Y:+5,Z:+5",
    "homing_stuck": "X:stuck,Y:+5,Z:+5",
    "hard_limits": "X:+5,Y:+5,Z:+5",
}

#: The probe input per topic (grbl-sim patch 11), in the same form; no entry, no contact ever.
PROBES = {
    "probe": "Z:-2",
}


def _homing():
    return "The homing cycle with limit switches 5 mm from power-up on +X +Y +Z: $H, its machine " \
           "position, homing again, a switch that is not found, a reset during the cycle", [
        line("$130=20"), line("$131=20"), line("$132=20"), line("$25=200"), line("$24=100"),
        line("$27=3"), line("$H"), line("$22=1"),
        line("$H", wait_s=120.0, quiet_s=2.5, note="$23=0: each axis seeks toward +, Z first, then X and Y"),
        rt("?"), line("$G"),
        line("G0 X-10 Y-5"), _sync(), rt("?"),
        line("$H", wait_s=120.0, quiet_s=6.0, note="homing again from X-10 Y-5"), rt("?"),
        line("$23=3", note="X and Y now home toward -, where there are no switches"),
        line("$H", wait_s=120.0, quiet_s=6.0, note="no switch within 1.5 x $130"),
        rt("?"), rt(RESET), rt("?"), line("$X"), rt("?"),
        line("$23=0"),
        line("$H", answered=False, note="a reset during the cycle"),
        rt(RESET, pause_before_s=0.5, quiet_s=6.0),
        rt("?", timed=("MPos",), note="where the reset stopped the cycle"), line("$X"),
        rt("?", timed=("MPos",)),
        line("$22=0"), line("$H"),
    ]


def _homing_stuck():
    return "The homing cycle with the X limit switch always pressed (the pull-off cannot clear it)", [
        line("$130=20"), line("$131=20"), line("$132=20"), line("$25=200"), line("$24=100"),
        line("$27=3"), line("$22=1"),
        line("$H", wait_s=120.0, quiet_s=6.0, note="X: pressed from the start and after the pull-off"),
        rt("?"), rt(RESET), rt("?"), line("$X"), rt("?"),
    ]


def _hold_resume():
    return "Feed hold and resume, overrides, jog cancel, while idle and while cutting", [
        line("$32=1"), rt("!", note="feed hold while idle"), rt("?"), rt("~"), rt("?"),
        line("M4 S500"), line("G1 X15 F300"), rt("?", pause_before_s=0.3),
        rt("!"), rt("?", note="decelerating or stopped"), rt("?", pause_before_s=1.5),
        line("G1 X0", answered=False, note="a line sent during a hold waits"),
        line("$$", answered=False), line("$G", answered=False), line("$X", answered=False),
        line("$C", answered=False),
        rt("~"), rt("?"), rt("!", pause_before_s=0.5), rt("?", pause_before_s=1.5),
        rt(FEED_PLUS_10), rt(RAPID_50), rt(POWER_MINUS_10), rt("?"), rt("~"), rt("?"),
        rt("\x90\x95\x99", note="feed, rapid and power overrides back to 100 %"),
        _sync(), rt("?"), rt("?"),
        line("M5"),
        line("$J=G91 X20 F300"), rt("?", pause_before_s=0.3), rt(JOG_CANCEL), rt("?", timed=("MPos",), pause_before_s=1.0),
        line("$J=G91 X-5 F300"), rt("!", pause_before_s=0.3), rt("?", timed=("MPos",), pause_before_s=1.0), rt("~"),
        rt("?", timed=("MPos",)), line("G0 X0", pause_before_s=1.0), _sync(), rt("?"),
    ]


def _reset():
    return "Soft reset (ctrl-x) in idle, mid-job, in a hold, in check mode and in alarm", [
        rt(RESET), rt("?"), line("$32=1"), line("G0 X1"), _sync(),
        line("M4 S400 G1 X20 F300"), line("G1 Y5"), rt("?", pause_before_s=0.3),
        rt(RESET, quiet_s=1.5, note="reset while moving: ALARM:3, then the banner once stopped"),
        rt("?", timed=("MPos",), note="where the reset stopped it"), line("G0 X0"), line("$G"),
        line("$X"), rt("?", timed=("MPos",)), line("$G"),
        line("G0 X0"), _sync(),
        line("G1 X10 F300"), rt("!", pause_before_s=0.5), rt("?", pause_before_s=1.5),
        rt(RESET, quiet_s=1.0, note="reset in a completed hold"), rt("?", timed=("MPos",)), line("$X"),
        line("G0 X0"), _sync(),
        line("$C"), line("G0 X1"), rt(RESET, note="reset in check mode"), rt("?"), line("$G"),
        raw("G0 X1", note="half a line"), rt(RESET, note="the reset discards the half line"),
        line(" Y1"), line("$G"), _sync(), rt("?"),
    ]


def _status_reports():
    steps = [rt("?"), line("$10")]
    for mask in (0, 1, 2, 3):
        steps += [line(f"$10={mask}"), rt("?"), rt("?"),
                  line("G92 X1"), rt("?"), line("G92.1"),
                  line("G1 X8 F300"), rt("?", pause_before_s=0.3), _sync(), rt("?"),
                  line("G0 X0"), _sync(), rt("?")]
    steps += [line("$10=1")] + [rt("?") for _ in range(12)]
    steps += [line("N42 G1 X20 F300", note="4 s of motion: every report below sees it run"),
              rt("?", pause_before_s=0.3)] + [rt("?") for _ in range(6)]
    steps += [_sync(), rt("?"), line("$32=0"), line("M3 S250"), rt("?"), line("M5"), rt("?"),
              line("$32=1"), line("M4 S250"), rt("?"), line("G1 X0 F300 S800"), rt("?", pause_before_s=0.3),
              _sync(), rt("?"), line("M5"), line("G20"), rt("?"), line("$13=1"), rt("?"), line("$13=0"),
              line("G21"), line("$10=1")]
    return "Status reports under each $10 value, in idle and while moving; WCO/Ov cadence; Ln; FS", steps


def _line_length():
    def pad(prefix, n, fill="0"):
        return prefix + fill * (n - len(prefix))
    return "Line length: GRBL's 80-byte line buffer counts what is left after spaces and comments", [
        line(pad("G0 X1.", 79), note="79 characters, 78 without the space"),
        line(pad("G0X1.", 79), note="79 characters"),
        line(pad("G0X1.", 80), note="80 characters"),
        line(pad("G0X1.", 81)), line(pad("G0X1.", 100)), line(pad("G0X1.", 127)),
        line(pad("G0X1.", 128)), line(pad("G0X1.", 200)),
        line("G0 X1 " + "(" + "c" * 110 + ")", note="long only because of a comment"),
        line("G0" + " " * 120 + "X0", note="long only because of spaces"),
        line("G0 X1 ; " + "c" * 110),
        _sync(note="the three lines above moved: the $ lines below need an idle GRBL"),
        line(pad("$N0=G0X1.", 81)), line(pad("$I=", 81)), line(pad("$I=", 79)), line("$I"),
        line(pad("$N0=G0X1.", 79)), line("$N"), line("$N0="),
        line(pad("$J=G91F100X0.", 81)),
        line("G0 X0"), _sync(), rt("?"),
    ]


def _planner_sync():
    return "Lines GRBL runs only once its planner is empty (a new M3/M4/M5, S or M8, G92, G10, a " \
           "new coordinate system or tool offset), an arc's chords entering a full planner, a " \
           "dwell, a cycle start while a hold still brakes, a reset while a line waits", [
        line("$32=1"), line("$10=3", note="reports with Bf: the planner's free blocks and the RX"),
        line("G1 X10 F300"),
        line("M3 S100", answered=False, note="a new spindle state: ok once the move has ended"),
        rt("?", note="still moving: the M3 line is read, not planned"),
        line("G4 P0.01", note="the M3's ok, then the dwell's"), rt("?"),
        line("G1 X0 S200", note="laser mode: a new S on a motion line rides with the move"),
        line("S300", answered=False, note="a new S on its own while M3 is on: synced"), rt("?"),
        _sync(), rt("?"),
        line("M5"), line("G1 X10"), line("M8", answered=False), rt("?"), _sync(), rt("?"),
        line("M9"), line("G1 X0"), line("G92 X0", answered=False), rt("?"), _sync(), rt("?"),
        line("G92.1"), line("G1 X10"), line("G10 L2 P2 X1", answered=False), rt("?"), _sync(),
        line("G1 X0"), line("G55", answered=False), rt("?"), _sync(), rt("?"), line("G54"),
        line("G1 X10"), line("G43.1 Z1", answered=False), rt("?"), _sync(), line("G49"),
        line("G1 X0"), line("M3 S100 X", note="a line GRBL refuses is answered at once"), rt("?"),
        _sync(), line("M5"),
        line("G1 X5 F300"),
        line("G2 X5 Y0 I-2 J0", answered=False, note="a full circle: its chords fill the planner, "
                                                   "the ok comes with the last one"),
        rt("?", pause_before_s=0.5), rt("?", pause_before_s=2.0), _sync(), rt("?"),
        line("G4 P2", answered=False, note="GRBL dwells with its planner empty"),
        rt("?", pause_before_s=0.5), _sync(note="the dwell's ok, then this one's"),
        line("G1 X20 F300"), rt("!", pause_before_s=0.5),
        rt("~", note="a cycle start while the hold still brakes"), rt("?", pause_before_s=1.0),
        rt("~"), rt("?"), rt("!"), rt("?", pause_before_s=1.0), line("G4 P0.01", answered=False),
        rt(RESET, pause_before_s=0.3, quiet_s=1.5, note="a reset in a hold, a line waiting"), line("$X"),
        line("G1 X0 F300"), line("G4 P0.01", answered=False),
        rt(RESET, pause_before_s=0.3, quiet_s=1.5, note="a reset while moving, a line waiting"),
        rt("?", timed=("MPos",), note="where the reset stopped the move"),
        line("$X"), line("G0 X0"), _sync(), line("$10=1"),
    ]


def _probe():
    stop = dict(timed=("MPos",))     # where a probe's motion cancel stopped the axis
    return "A probe (grbl-sim's contact 2 mm below the power-up position): the planner is emptied " \
           "before a probe move, the axis brakes past the touch, [PRB:] gives the touch point", [
        line("$10=3"), line("G91 G1 X2 F300", note="relative moves from here"),
        line("G38.2 Z-5 F100", note="planned only once the move before it has ended"),
        rt("?", pause_before_s=0.2, note="stopped past the touch", **stop), _sync(),
        rt("?", **stop), line("$#"),
        line("G38.4 Z1 F50", note="from the contact up until it opens"), _sync(), rt("?", **stop),
        line("$#"),
        line("G1 Z0.5 F100", note="from where it stopped"), _sync(), rt("?", **stop),
        line("G38.3 Z-2 F100"), _sync(), rt("?", **stop), line("$#"),
        line("G90 G0 Z0"), _sync(), rt("?"),
    ]


def _soft_limit_moving():
    return "Soft limits: a line outside the travel while the machine moves: GRBL brakes to a " \
           "stop, then ALARM:2", [
        line("$22=1"), line("$20=1"), line("$10=3"),
        line("G1 X-20 F300"),
        line("G1 X5", answered=False, quiet_s=2.5, note="outside (machine space is -$130..0)"),
        rt("?", note="after the alarm GRBL answers nothing until a reset"),
        rt(RESET, note="the line's ok, then the banner"),
        rt("?", timed=("MPos",), note="where the hold before the alarm stopped it"),
        line("$X"), line("G0 X0"), _sync(), line("$20=0"), line("$22=0"), line("$10=1"),
    ]


def _reset_wait():
    return "A reset while a line waits: a dwell from rest (GRBL dwells in Idle), and a G4, M0, M2, " \
           "G10 L20 and G38.2 waiting for the move before them", [
        line("G4 P3", answered=False, note="a dwell from rest: GRBL dwells with its planner empty"),
        rt("?", pause_before_s=0.3, note="the state during the dwell"),
        rt(RESET, pause_before_s=0.3, quiet_s=1.5, note="a reset during the dwell: nothing moves"),
        rt("?"),
        line("G1 X10 F300"),
        line("G4 P0.01", answered=False, note="waits for the move"), rt("?", pause_before_s=0.5),
        rt(RESET, quiet_s=1.5, note="a reset while the G4 waits for the move"),
        rt("?", timed=("MPos",), note="where the reset stopped the move"), line("$X"),
        line("G0 X0"), _sync(),
        line("G1 X10 F300"), line("M0", answered=False, note="M0 behind a move waits for it"),
        rt(RESET, pause_before_s=0.5, quiet_s=1.5), line("$X"),
        line("G0 X0"), _sync(),
        line("G1 X10 F300"), line("M2", answered=False, note="M2 behind a move: the program ends once the move has"),
        rt(RESET, pause_before_s=0.5, quiet_s=1.5, note="a reset while the M2 waits"), line("$X"),
        line("G0 X0"), _sync(),
        line("G1 X10 F300"), line("G10 L20 P1 X0", answered=False, note="an offset write waits for the move"),
        rt(RESET, pause_before_s=0.5, quiet_s=1.5), line("$X"),
        line("$#", note="was the offset written? (G10 L20 takes the parser's position: the move's end)"),
        line("G10 L2 P1 X0"), line("G0 X0"), _sync(),
        line("G1 X10 F300"), line("G38.2 Z-5 F100", answered=False, note="a probe cycle starts from rest: it waits"),
        rt(RESET, pause_before_s=0.5, quiet_s=1.5, note="a reset while the probe line waits for the move"),
        rt("?", timed=("MPos",)), line("$X"), line("G0 X0"), _sync(), rt("?"),
    ]


def _hard_limits():
    return "Hard limits ($21=1) with limit switches 5 mm from power-up on +X +Y +Z: a move, a job and " \
           "a jog into a switch, moving off it, the reset with a switch pressed, homing with hard limits on", [
        line("$21=1"),
        line("G1 X10 F300", note="X's switch is pressed at X5: GRBL's limit pin-change interrupt"),
        rt("?", pause_before_s=6.0, quiet_s=1.5, note="the alarm came; nothing is reported until a reset"),
        line("G0 X0", answered=False, note="nothing is read until the reset"),
        rt(RESET, quiet_s=1.5, note="a reset with the switch still pressed"),
        rt("?", timed=("MPos",), note="where the alarm stopped the move"), line("G0 X0"), line("$X"),
        rt("?", timed=("MPos",)),
        line("G0 X4", quiet_s=1.5, note="moving off the switch releases it: a change of the pin too"),
        rt("?", pause_before_s=1.0), rt(RESET, quiet_s=1.5), rt("?", timed=("MPos",)), line("$X"),
        line("$21=0"), line("G0 X0"), _sync(), line("$21=1"),
        raw("G1X1F300\nG1X2\nG1X3\nG1X4\nG1X6\nG0X7\n", note="a job that runs into the switch"),
        line("G4 P0.01", answered=False, note="waits for the job"),
        rt("?", pause_before_s=8.0, quiet_s=1.5, note="the job ran into the switch"),
        rt(RESET, quiet_s=1.5, note="the reset answers the G4 that waited"), rt("?", timed=("MPos",)),
        line("$X"), line("$21=0"), line("G0 X0"), _sync(), line("$21=1"),
        line("$J=G91 X10 F300", note="a jog into the switch"),
        rt("?", pause_before_s=6.0, quiet_s=1.5), rt(RESET, quiet_s=1.5), line("$X"),
        line("$J=G91 X-2 F300", quiet_s=1.5, note="a jog off the switch"),
        rt("?", pause_before_s=1.0), rt(RESET, quiet_s=1.5), line("$X"),
        line("$21=0"), line("G0 X0 Y0"), _sync(), line("$21=1"),
        line("$130=20"), line("$131=20"), line("$132=20"), line("$25=200"), line("$24=100"),
        line("$27=3"), line("$22=1"),
        line("$H", wait_s=120.0, quiet_s=6.0, note="homing with hard limits on: the cycle meets the switches"),
        rt("?"), line("G0 X-1"), _sync(), rt("?"),
        line("G0 X1", note="machine X0 is the switch"), rt("?", pause_before_s=4.0, quiet_s=1.5),
        rt(RESET, quiet_s=1.5), line("$X"), line("$21=0"), line("$22=0"), rt("?", timed=("MPos",)),
    ]


def _startup_jog():
    return "A start-up line that is a jog ($N0=$J=...): checked and run as a jog when stored and after " \
           "each reset; a bad one; G-code during a jog", [
        line("$N0=$J=G91X2F60", note="a jog as a start-up line: GRBL checks it by running it"),
        rt("?"), line("$N"),
        rt(RESET, note="the start-up jog runs after the banner"), rt("?"), rt("?", pause_before_s=5.0),
        line("$N1=$J=X1", note="a jog without a feed rate"), line("$N1=$J=G0X1F100"),
        line("$N1=$J=G91X1F100M3"), line("$N1=$J="), line("$N1=$J"), line("$N1=$X"),
        line("$N1=$XYG91X1F100", note="what GRBL reads of a start-up line that begins with $"),
        rt("?", pause_before_s=4.0), line("$N"), line("$N1="), line("$N10=$J"),
        line("$J=G91X3F100"), line("G0X0", note="G-code during a jog"), line("$G"),
        line("$N0=", note="a start-up line during a jog"), line("$C"), rt("?", pause_before_s=5.0),
        line("$N0="), line("$N"), rt(RESET), rt("?"),
    ]


def _startup_store():
    return "A start-up line's G-code runs when it is stored, as GRBL checks it by running it " \
           "($N0=G20 G91 changes the modal state at once; a stored move moves the machine)", [
        line("$G"),
        line("$N0=G20G91", note="stored: GRBL runs it to check it, so its modes apply now"),
        line("$G"),
        line("$N1=G0X0.1", note="a move stored as a start-up line moves the machine (0.1 in, relative)"),
        rt("?", pause_before_s=2.0),
        line("$G"),
        line("$N0="), line("$N1="), line("$G"),
        rt(RESET), line("$G"), rt("?"),
    ]


def _program_end_moving():
    return "M2 and M30 behind a move: GRBL ends the program once the move has ended, and only " \
           "then resets the modal state (coordinate system, distance mode, offsets as GRBL's " \
           "program end does); reports during the move show the state before it", [
        line("$10=3"), line("G10 L2 P2 X5"), line("G55"), line("G91"),
        line("G1 X10 F300"),
        line("M2", answered=False, note="program end behind a move: its ok once the move has ended"),
        rt("?", note="still moving: WCO still G55's"), line("$G", answered=False),
        rt("?", pause_before_s=2.5), line("$G"), rt("?"),
        line("G55"), line("G92 X1"), line("G1 X3 F300"),
        line("M30", answered=False), rt("?"), rt("?", pause_before_s=2.0), line("$G"), rt("?"),
    ]


TOPICS = {
    "dollar_commands": _dollar_commands,
    "settings": _settings,
    "errors": _errors,
    "issue27_lines": _issue27_lines,
    "program_flow": _program_flow,
    "check_mode": _check_mode,
    "offsets": _offsets,
    "homing_limits": _homing_limits,
    "homing": _homing,
    "homing_stuck": _homing_stuck,
    "hold_resume": _hold_resume,
    "reset": _reset,
    "status_reports": _status_reports,
    "line_length": _line_length,
    "planner_sync": _planner_sync,
    "probe": _probe,
    "soft_limit_moving": _soft_limit_moving,
    "reset_wait": _reset_wait,
    "hard_limits": _hard_limits,
    "startup_jog": _startup_jog,
    "startup_store": _startup_store,
    "program_end_moving": _program_end_moving,
}


# --------------------------------------------------------------------------------------------

class GrblSim:
    """grbl-sim on pipes, in its own empty directory (a blank EEPROM).

    Its stderr (patch 12, README.md) tells GRBL's own clock (simulated seconds, the time its
    motion runs on): ``t SECONDS`` every 10 ms, ``rx HH SECONDS`` when it received a byte,
    ``tx SECONDS`` when a piece of its output left. The recorder waits on that clock, so a
    transcript is the same on a loaded host, where grbl-sim runs slower than the wall clock.
    """

    #: Wall seconds without any sign of GRBL's clock before the recorder calls it frozen.
    FROZEN_S = 60.0

    def __init__(self, exe, switches="", probe=""):
        self.dir = tempfile.TemporaryDirectory(prefix="grbl-sim-")
        env = dict(os.environ, GRBL_SIM_SWITCHES=switches, GRBL_SIM_PROBE=probe)
        self.proc = subprocess.Popen([exe, "-n", "-b", "/dev/null", "-s", "/dev/null"], cwd=self.dir.name,
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=subprocess.PIPE, bufsize=0, env=env)
        self.sent = 0                    # bytes written so far
        self.arrivals: list[float] = []  # GRBL's clock (s) when it received each of them
        self.clock = 0.0                 # GRBL's clock as last told
        self.last_tx = 0.0               # GRBL's clock when it last wrote something
        self._log = b""
        self._out = b""                  # output read while pumping the log

    def send(self, data: bytes):
        self.proc.stdin.write(data)
        self.sent += len(data)

    def _pump(self, timeout_s):
        """Wait up to ``timeout_s`` (wall) for either pipe; take in what is there."""
        pipes = [self.proc.stdout, self.proc.stderr]
        ready, _, _ = select.select(pipes, [], [], max(0.0, timeout_s))
        if self.proc.stderr in ready:
            chunk = os.read(self.proc.stderr.fileno(), 65536)
            if not chunk:
                raise RuntimeError("grbl-sim closed its stderr (did it exit?)")
            self._log += chunk
            *lines, self._log = self._log.split(b"\n")
            for ln in lines:
                words = ln.split()
                if words[:1] == [b"t"]:
                    self.clock = float(words[1])
                elif words[:1] == [b"rx"]:
                    self.arrivals.append(float(words[2]))
                elif words[:1] == [b"tx"]:
                    self.last_tx = float(words[1])
                    self.clock = max(self.clock, self.last_tx)
        if self.proc.stdout in ready:
            self._out += os.read(self.proc.stdout.fileno(), 65536)
        return bool(ready)

    def read(self, timeout_s):
        """GRBL's output: what is there, or the first that comes within ``timeout_s`` (wall)."""
        deadline = time.monotonic() + timeout_s
        while not self._out and time.monotonic() < deadline:
            self._pump(deadline - time.monotonic())
        out, self._out = self._out, b""
        return out

    def read_for(self, seconds, *, quiet=False):
        """GRBL's output during ``seconds`` of GRBL's clock from now; ``quiet``: until GRBL has
        written nothing for that long (its clock counted from now or from its last output)."""
        start = self.clock
        last_sign = time.monotonic()
        while True:
            ref = max(start, self.last_tx) if quiet else start
            if self.clock >= ref + seconds:
                break
            if self._pump(0.2):
                last_sign = time.monotonic()
            elif time.monotonic() - last_sign > self.FROZEN_S:
                raise RuntimeError(f"grbl-sim's clock stood still for {self.FROZEN_S:g} s at "
                                   f"{self.clock:.3f}: is it frozen, or built without patch 12?")
        while self._pump(0.0):       # what it wrote before that moment is in the pipe by now
            pass
        out, self._out = self._out, b""
        return out

    def arrival(self, k):
        """GRBL's clock (s) when it received byte ``k`` (0-based, in the order written)."""
        deadline = time.monotonic() + self.FROZEN_S
        while len(self.arrivals) <= k:
            if time.monotonic() > deadline:
                raise RuntimeError(f"grbl-sim logged no arrival of byte {k} within "
                                   f"{self.FROZEN_S:g} s: is it built with patch 12 (README.md)?")
            self._pump(0.2)
        return self.arrivals[k]

    def close(self):
        try:
            self.send(b"\x06")           # grbl-sim's exit byte
            self.proc.wait(timeout=3)
        except Exception:
            self.proc.kill()
            self.proc.wait()
        self.dir.cleanup()


def _timed_fields(reply):
    """Names of the fields of a status report whose values depend on timing (see README)."""
    if not (reply.startswith("<") and reply.endswith(">")):
        return None
    fields = reply[1:-1].split("|")
    state = fields[0].split(":")[0]
    if state not in _MOVING_STATES:
        return None
    if fields[0] == "Hold:0":           # stopped: where it stopped depends on when the hold came
        return [f.split(":")[0] for f in fields[1:] if f.split(":")[0] in ("MPos", "WPos")] or None
    timed = [f.split(":")[0] for f in fields[1:] if f.split(":")[0] in _TIMED_FIELDS]
    if state == "Hold":
        timed.insert(0, "state")
    return timed


def exchange(sim, step, origin=None, then_wait_s=0.0):
    """Send one step's bytes; return the exchange record (``at_s``: when GRBL received the
    first of them, on its clock, s after ``origin``, the first exchange's; None: this is the
    first). ``then_wait_s``: the next step's ``pause_before_s``, during which what GRBL writes
    is still this exchange's (it came before the next one). Every wait but the one for a
    line's answer (a frozen simulator must not be recorded as silence) is on GRBL's clock."""
    data = step["send"].encode("latin-1")
    lines_sent = data.count(b"\n")
    answered = step.get("answered", True) and lines_sent > 0
    quiet_s = step.get("quiet_s", 0.35)
    t0 = time.monotonic()
    first_byte = sim.sent
    sim.send(data)
    received = sim.arrival(first_byte)
    out = b""
    finals = 0
    if answered:
        deadline = t0 + step.get("wait_s", 30.0)
        while finals < lines_sent and time.monotonic() < deadline:
            chunk = sim.read(deadline - time.monotonic())
            if chunk:
                out += chunk
                finals = sum(1 for ln in out.decode("latin-1").split("\r\n") if _TERMINATOR.match(ln))
    out += sim.read_for(quiet_s, quiet=True)
    if then_wait_s:
        out += sim.read_for(then_wait_s)
    last = sim.last_tx if out else received
    text = out.decode("latin-1")
    replies = [ln for ln in text.split("\r\n") if ln]
    rec = {"send": step["send"], "replies": replies,
           "at_s": round(received - (received if origin is None else origin), 4)}
    if text and ("".join(r + "\r\n" for r in replies) != text.replace("\r\n\r\n", "\r\n").lstrip("\r\n")):
        rec["raw"] = text                  # not plain \r\n-terminated lines: keep the bytes
    if "timed" in step:                # the step says which fields depend on timing (none: M0)
        timing = {str(i): list(step["timed"]) for i, r in enumerate(replies)
                  if r.startswith("<") and step["timed"]}
    else:
        timing = {str(i): f for i, r in enumerate(replies) if (f := _timed_fields(r))}
    if timing:
        rec["timing"] = timing
    for key in ("pause_before_s", "quiet_s", "note"):
        if step.get(key):
            rec[key] = step[key]
    if not step.get("answered", True):
        rec["answered"] = False
    rec["elapsed_s"] = round(max(0.0, last - received), 3)
    rec["_received"] = received        # on GRBL's clock (dropped by record())
    if answered and finals < lines_sent:
        sim.send(b"?")                     # what state it is in, for the message
        state = sim.read(1.0).decode("latin-1").strip()
        raise RuntimeError(f"GRBL did not answer {step['send']!r} (got {replies}; a '?' now: "
                           f"{state!r}): is grbl-sim frozen? Mark a line GRBL holds its answer to "
                           f"with answered=False.")
    return rec


def record(exe, topic):
    title, steps = TOPICS[topic]()
    sim = GrblSim(exe, SWITCHES.get(topic, ""), PROBES.get(topic, ""))
    try:
        boot = b""
        deadline = time.monotonic() + 5.0
        while b"['$' for help]" not in boot and time.monotonic() < deadline:
            boot += sim.read(deadline - time.monotonic())
        sim.read_for(max(0.0, 1.5 - sim.clock))   # it reads no input in its first simulated second
        sim.read_for(0.3, quiet=True)
        exchanges = []
        origin = None
        steps = [rt(RESET)] + steps
        for k, step in enumerate(steps):
            # a dwell follows an accepted sync_if_ok line: the next step's pause comes after it
            pause_next = steps[k + 1].get("pause_before_s", 0.0) if k + 1 < len(steps) else 0.0
            sync_next = step.get("sync_if_ok")
            exchanges.append(exchange(sim, step, origin, 0.0 if sync_next else pause_next))
            origin = exchanges[0]["_received"]
            if sync_next:
                if exchanges[-1]["replies"][-1:] == ["ok"]:
                    exchanges.append(exchange(sim, _sync(), origin, pause_next))
                elif pause_next:
                    exchanges[-1]["replies"] += [ln for ln in sim.read_for(pause_next).decode(
                        "latin-1").split("\r\n") if ln]
    finally:
        sim.close()
    for rec in exchanges:
        del rec["_received"]
    return {
        "topic": topic,
        "title": title,
        "recorded_from": {
            "grbl": f"gnea/grbl {GRBL_COMMIT} (GRBL 1.1h.20190830, config.h as released: DEFAULTS_GENERIC)",
            "grbl_sim": f"grbl/grbl-sim {GRBL_SIM_COMMIT} (with the patches listed in README.md)",
            "recorded": _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d"),
            "script": "tests/vectors/grbl/record.py",
        },
        **({"switches": SWITCHES[topic]} if topic in SWITCHES else {}),
        **({"probe": PROBES[topic]} if topic in PROBES else {}),
        "exchanges": exchanges,
    }


def main(argv):
    if len(argv) < 2:
        print(__doc__)
        return 2
    exe = argv[1]
    out = Path(argv[2]) if len(argv) > 2 else HERE
    topics = argv[3:] or list(TOPICS)
    for topic in topics:
        t = time.monotonic()
        data = record(exe, topic)
        path = out / f"{topic}.json"
        path.write_text(json.dumps(data, indent=1, ensure_ascii=True) + "\n", "utf-8")
        n = len(data["exchanges"])
        print(f"{topic}: {n} exchanges, {time.monotonic() - t:.1f} s -> {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
