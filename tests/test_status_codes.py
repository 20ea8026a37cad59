"""The one table of what a controller says (labkit/status_codes.csv): its kinds, the Python
names, GRBL's lines, and the firmware header generated from it.

Independent references: the conversations recorded from GRBL 1.1h itself
(tests/vectors/grbl/*.json) — every ``error:N``, ``ALARM:N`` and ``[MSG:…]`` GRBL sent there
must be a row, and every ``[MSG:…]`` text must be a reply row's text exactly; and a C
compiler, which must accept the generated header beside the firmware's hand-written alarm
numbers.
"""

from __future__ import annotations

import csv
import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from labkit.errors import AlarmCode, ErrorCode, Feedback, STATUS_CODES, status_code
from labkit.machine.grbl import alarm_message, error_message, grbl_reply

ROOT = Path(__file__).resolve().parents[1]
CSV = ROOT / "labkit" / "status_codes.csv"
GRBL_TRANSCRIPTS = sorted((ROOT / "tests" / "vectors" / "grbl").glob("*.json"))


def _rows():
    with open(CSV, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def _grbl_replies():
    for path in GRBL_TRANSCRIPTS:
        for ex in json.loads(path.read_text("utf-8")).get("exchanges", []):
            yield from ex.get("replies", [])


def test_one_table_with_three_kinds_each_numbered_once():
    rows = _rows()
    assert set(rows[0]) == {"kind", "code", "name", "message"}
    assert {r["kind"] for r in rows} == {"error", "alarm", "reply"}
    for kind in ("error", "alarm", "reply"):
        mine = [r for r in rows if r["kind"] == kind]
        assert len({int(r["code"]) for r in mine}) == len(mine), kind
        assert len({r["name"] for r in mine}) == len(mine), kind
    assert not (ROOT / "labkit" / "machine" / "grbl_codes.csv").exists()


def test_python_names_are_the_rows():
    rows = _rows()
    for kind, names in (("error", ErrorCode), ("alarm", AlarmCode), ("reply", Feedback)):
        assert {(r["name"].upper(), int(r["code"])) for r in rows if r["kind"] == kind} == \
               {(m.name, m.value) for m in names}
    # the error rows keep their place as the status codes of labkit's own errors
    assert set(STATUS_CODES) == {r["name"] for r in rows if r["kind"] == "error"}
    assert status_code("invalid_arc").code == ErrorCode.INVALID_ARC == 33
    assert status_code(2, "alarm").name == "soft_limit"
    with pytest.raises(KeyError, match="unknown alarm code 99"):
        status_code(99, "alarm")


def test_grbl_lines_by_name():
    assert [grbl_reply(n) for n in (ErrorCode.OK, ErrorCode.NOT_IDLE, ErrorCode.GCODE_LOCKED,
                                    AlarmCode.SOFT_LIMIT, AlarmCode.ABORT_CYCLE)] == \
           ["ok", "error:8", "error:9", "ALARM:2", "ALARM:3"]
    assert grbl_reply(Feedback.ALARM_LOCK) == "[MSG:'$H'|'$X' to unlock]"
    with pytest.raises(TypeError, match="expected an ErrorCode, AlarmCode or Feedback"):
        grbl_reply(8)


def test_every_reply_grbl_sent_is_a_row():
    """What GRBL 1.1h itself answered in the recorded conversations: every number has a row
    with a message, every [MSG:] text is a reply row's text to the letter."""
    replies = list(_grbl_replies())
    assert len(replies) > 100                       # the conversations were found and read
    errors = {int(m[1]) for r in replies if (m := re.fullmatch(r"error:(\d+)", r))}
    alarms = {int(m[1]) for r in replies if (m := re.fullmatch(r"ALARM:(\d+)", r))}
    texts = {m[1] for r in replies if (m := re.fullmatch(r"\[MSG:(.*)\]", r))}
    assert errors and alarms and texts
    for code in errors:
        assert error_message(code) == status_code(code).message      # a row, not "unknown error N"
        assert grbl_reply(ErrorCode(code)) == f"error:{code}"
    for code in alarms:
        assert alarm_message(code) == status_code(code, "alarm").message
        assert grbl_reply(AlarmCode(code)) == f"ALARM:{code}"
    by_text = {status_code(int(f), "reply").message: f for f in Feedback}
    for text in texts:
        assert text in by_text, text
        assert grbl_reply(by_text[text]) == f"[MSG:{text}]"


@pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler")
def test_generated_header_has_every_kind_and_compiles_beside_the_firmware(tmp_path):
    header = tmp_path / "status_codes.h"
    subprocess.run([sys.executable, str(ROOT / "firmware/tools/gen_status_codes.py"), str(CSV), str(header)],
                   check=True)
    # the firmware's report.h states alarm numbers by hand: an identical #define must stay legal
    (tmp_path / "probe.c").write_text(
        '#include <stdio.h>\n#include "status_codes.h"\n#define ALARM_SOFT_LIMIT  2   /* as report.h */\n'
        'int main(void) {\n'
        '  printf("%d %d %d\\n", STATUS_NOT_IDLE, ALARM_SOFT_LIMIT, ALARM_HOMING_FAIL_DOOR);\n'
        '  printf("%s\\n%s\\n%s\\n", alarm_message(ALARM_SOFT_LIMIT), MSG_RESET_TO_CONTINUE, status_message(33));\n'
        '  return alarm_message(99) != 0;\n}\n', "utf-8")
    exe = tmp_path / "probe"
    subprocess.run(["cc", "-std=c11", "-Wall", "-Wextra", "-Werror", "-I", str(tmp_path), "-o", str(exe),
                    str(tmp_path / "probe.c")], check=True)
    out = subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout.splitlines()
    assert out == [f"{ErrorCode.NOT_IDLE:d} {AlarmCode.SOFT_LIMIT:d} {AlarmCode.HOMING_FAIL_DOOR:d}",
                   alarm_message(2), status_code(1, "reply").message, error_message(33)]
