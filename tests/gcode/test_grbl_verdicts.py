"""labkit's verdict on each line against GRBL 1.1h's own answer (issue 27): the lines of
tests/vectors/grbl/issue27_lines.json, recorded from GRBL's code in grbl-sim, are checked
as one program with labkit.gcode.check in the grbl dialect — every line GRBL answers ok
is accepted, every line it refuses gets GRBL's error number."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from labkit.gcode import reader
from labkit.gcode.reader import check, grbl_system_verdict, parse
from labkit.toolpath.moves import MoveKind

TRANSCRIPT = Path(__file__).resolve().parents[1] / "vectors" / "grbl" / "issue27_lines.json"


def grbl_lines():
    """(line sent, GRBL's ok or error number) for every newline-terminated line."""
    out = []
    for x in json.loads(TRANSCRIPT.read_text("utf-8"))["exchanges"]:
        if x["send"].endswith("\n"):
            verdict = [r for r in x["replies"] if r == "ok" or r.startswith("error:")][-1]
            out.append((x["send"], 0 if verdict == "ok" else int(verdict.split(":")[1])))
    return out


def test_every_recorded_line_gets_grbls_verdict():
    lines = grbl_lines()
    assert len(lines) == 29 and sum(code != 0 for _, code in lines) == 8
    errors = {e.line: e.code for e in check("".join(text for text, _ in lines))}
    ours = [(text, errors.get(i, 0)) for i, (text, _) in enumerate(lines, 1)]
    assert ours == lines


@pytest.mark.parametrize("line, code", [
    ("M118 T\n", 20),                 # GRBL reads M118 (unsupported) before the bare T
    ("G5.5 X1.2.3\n", 20),            # a command left of a malformed number
    ("G1 X1.2.3 G5.5\n", 1),          # and right of it: GRBL reads X1.2, then '.' is no letter
                                      # (recorded: 'G0 X1.2.3' is error:1, errors.json)
    ("M3 M5 T\n", 21),                # M5 breaks M3's modal group before T is read
    ("G0 X1 ? Y2\n", 0),              # ? is taken out of the stream (a status request)
    ("%\n", 1), ("% comment\n", 1),
    ("$RST=$\n", 0), ("$RST=gcode\n", 3), ("$SLP\n", 0), ("$SLEEP\n", 3), ("$H\n", 5),
    ("$100=250.5\n", 0), ("$140=1\n", 3), ("$256=1\n", 3), ("$0=2\n", 6), ("$20=1\n", 10),
    ("$1=-5\n", 4), ("$x=1\n", 3), ("$y=1\n", 2), ("$N0=G20 G90\n", 0), ("$N0=G5\n", 20), ("$G X\n", 3),
])
def test_first_fault_in_grbls_parser_order(line, code):
    assert [e.code for e in check(line)] == ([code] if code else [])


def test_the_labkit_firmware_keeps_its_own_rules():
    """labkit-fw (its C parser) answers 101 for an unclosed comment, 33 for a short R, and
    takes a lone % as the program delimiter; parse() in the grbl dialect reads a program
    with % delimiters and $ lines as before (only check() answers as streamed to GRBL)."""
    assert [e.code for e in check("G0 X2 (unclosed\n%\nG2 X10 Y0 R2 F100\n", dialect="labkit-fw")] == [101, 33]
    m = parse("%\n$H\nG0 X1 (open comment\n%\n")
    assert [r.text for r in m.records] == ["$H"] and m.end[0, 0] == 1.0


def test_system_verdict_reasons_name_the_rule():
    assert grbl_system_verdict("$rst=gcode") == ("invalid_statement", "$RST= takes $, # or *")
    assert grbl_system_verdict("$ H (home)") == ("setting_disabled",
                                                 "homing is disabled ($22=0), so $H is refused")
    (err,) = check("G0 X1\n$RST=gcode\n")
    assert str(err) == ("<string>:2:1: error 3: GRBL refuses this $ line (got '$RST=gcode'; "
                        "expected $RST= takes $, # or *)")
    assert reader.__all__.count("grbl_system_verdict") == 1


def test_refused_system_lines_count_once():
    m = parse("$RST=gcode\nG0 X1\n%\n", lenient=True, streaming=True)
    assert [e.code for e in m.diagnostics] == [3, 1] and m.dropped_diagnostics == 0
    assert [r.text for r in m.records] == []


# ---- GRBL's number on each line the transcripts of issue 26 recorded (task: every line of
# tests/vectors/grbl/*.json where labkit's grbl dialect answered otherwise) -------------------

#: (transcript, exchange index) of each line; GRBL's answer is read from the recording.
RECORDED_LINES = [
    ("errors", 6),      # *              : GRBL has no checksum, '*' is no letter
    ("errors", 7),      # G0 X1 #
    ("errors", 8),      # G0 X1 =2       : X1 is read, then '=' is no letter
    ("errors", 9),      # %              : streamed, no program delimiter
    ("errors", 10),     # G0 X1 %
    ("errors", 11),     # G0 @
    ("errors", 18),     # G0 X1.2.3      : X1.2, then '.' is no letter
    ("errors", 25),     # N-5 G0 X1      : negative, as N is read (4, not 27)
    ("errors", 72),     # N1.5 G0 X1     : N's whole part
    ("errors", 97),     # N10000000 G0 X1: GRBL's largest N
    ("errors", 60),     # G0 G1 X1       : two axis commands (24) before the modal group (21)
    ("errors", 83),     # G10 L2 P1 G28 X1
    ("check_mode", 22),  # G0 X1 G1
    ("errors", 74),     # G10 L2.5 P1 X1 : L's whole part
    ("errors", 76),     # G10 L2 P1.5 X1 : P's whole part
    ("errors", 100),    # G10 L2 X1      : no P is P0, the active system
    ("errors", 103),    # G10 P1 X1      : no L is L0, unsupported (20)
    ("errors", 120),    # G3 I1 J1 F100  : no axis words (26) before the plane (32)
    ("errors", 124),    # G2 X0 Y0 I0 J0 F100: radius 0, the end within 0.005 mm of it
    ("dollar_commands", 41),  # $J=G4 P1: the jog's F (22) before its commands (16)
    ("dollar_commands", 11),  # $N1=$X  : a start-up line is G-code, '$' no letter
]


def _recorded(topic, index):
    """(line sent without its line end, GRBL's verdict: 0 for ok, else the error number)."""
    path = TRANSCRIPT.parent / f"{topic}.json"
    exchange = json.loads(path.read_text("utf-8"))["exchanges"][index]
    verdict = [r for r in exchange["replies"] if r == "ok" or r.startswith("error:")][-1]
    return exchange["send"].rstrip("\n"), 0 if verdict == "ok" else int(verdict.split(":")[1])


@pytest.mark.parametrize("topic, index", RECORDED_LINES,
                         ids=[f"{t}-{i}" for t, i in RECORDED_LINES])
def test_recorded_line_gets_grbls_number(topic, index):
    """check() on the line as sent and the streaming Interpreter (what the virtual machine
    runs) on the line as GRBL's reader keeps it (spaces dropped) both answer as GRBL did."""
    line, code = _recorded(topic, index)
    assert [e.code for e in check(line + "\n")] == ([code] if code else []), line
    if not line.startswith("$N"):                  # $N lines are the machine's, not the parser's
        _, error = reader.Interpreter("grbl", streaming=True).feed(line.replace(" ", ""))
        assert (error.code if error else 0) == code, line


def test_recorded_lines_are_the_ones_labkit_answered_otherwise():
    """The vectors above are the recorded lines, and GRBL refused most of them."""
    lines = [_recorded(t, i) for t, i in RECORDED_LINES]
    assert [text for text, _ in lines][:3] == ["*", "G0 X1 #", "G0 X1 =2"]
    assert sum(code == 0 for _, code in lines) == 6 and len(lines) == 21


@pytest.mark.parametrize("line, code", [
    ("G2 I5 F10\n", 26),             # GRBL: an arc without any axis word (26), not 32
    ("G2 Z1 I5 F10\n", 32),          # with an axis word outside the plane: 32
    ("G43.1 Z1 G49\n", 24),          # both axis commands (GRBL: G43.1 and G49 are)
    ("G0 G80\n", 21),                # G80 is no axis command: the modal group
    ("T300 T1\n", 38),               # T above 255 as it is read, before the repeat
    ("S-1 M3 M3\n", 4),              # the negative S is read before the second M3
    ("$J=G4 P1 F100\n", 16),         # with F, the jog's command is refused last
    ("$J=X1 F100 S5\n", 36),         # S is a word a jog does not use
    ("$J=G5 X1 F100\n", 20),         # GRBL reads a jog's G words as any line's
    ("G10 X1\n", 28),                # neither L nor P
    ("G2 X0.01 Y0 I0 J0 F10\n", 33),  # radius 0, the end 0.01 mm away: beyond 0.005 mm
])
def test_grbls_order_of_checks_beyond_the_recordings(line, code):
    """Hand-written lines: GRBL's order read from its gcode.c (STEP 2 word by word, then
    STEP 3), each answered as that order gives."""
    assert [e.code for e in check(line)] == [code]


def test_a_zero_radius_arc_moves_as_a_line_and_labkit_fw_refuses_it():
    m = parse("G0 X5\nG2 X5.004 Y0 I0 J0 F100\n")
    assert [MoveKind(k).name for k in m.kind] == ["RAPID", "LINE"] and m.end[-1, 0] == 5.004
    assert [e.code for e in check("G2 X0 Y0 I0 J0 F100\n", dialect="labkit-fw")] == [33]
    assert [e.code for e in check("G0 G1 X1\nN1.5 G0 X1\nG0 X1.2.3\n", dialect="labkit-fw")] == [21, 27, 2]


def test_grbl_verdicts_as_python_equal_compiled():
    """The compiled kernel and its Python twin (labkit/_jit.py) answer every line above alike:
    number, line and column."""
    from labkit import _jit

    text = "".join(_recorded(t, i)[0] + "\n" for t, i in RECORDED_LINES) + (
        "G2 I5 F10\nG43.1 Z1 G49\nT300 T1\nS-1 M3 M3\n$J=G4 P1 F100\n$J=X1 F100 S5\n"
        "$J=G5 X1 F100\nG10 X1\nG0 X5\nG2 X5.004 Y0 I0 J0 F100\n")
    answers = {}
    for how in ("python", "compiled"):
        with _jit.forced(how):
            answers[how] = [(e.line, e.code, e.column) for e in check(text)]
    assert answers["python"] == answers["compiled"] and len(answers["python"]) == 23
