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
    ("G1 X1.2.3 G5.5\n", 2),          # and right of it: the number is read first
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
