"""The firmware's alarms, feedback texts and statuses come from labkit/status_codes.csv alone.

``firmware/tools/gen_status_codes.py`` writes ``status_codes.h`` from the CSV; its ``--check``
(run by ``make -C firmware test``) refuses C sources that name a code the CSV lacks, define one
by hand, or spell out a ``[MSG:]`` text instead of its name. Checked here against the CSV read
with :mod:`csv` (not through the generator) and on hand-made sources that break each rule.
"""
from __future__ import annotations

import csv
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
FW = ROOT / "firmware"
CSV = ROOT / "labkit/status_codes.csv"
GEN = FW / "tools/gen_status_codes.py"


def _rows(kind):
    with CSV.open(newline="", encoding="utf-8") as f:
        return [r for r in csv.DictReader(f) if r["kind"] == kind]


def _check(*files):
    return subprocess.run([sys.executable, str(GEN), str(CSV), "--check", *map(str, files)],
                          capture_output=True, text=True)


def test_header_has_every_alarm_and_message_of_the_table(tmp_path):
    out = tmp_path / "status_codes.h"
    subprocess.run([sys.executable, str(GEN), str(CSV), str(out)], check=True)
    text = out.read_text()
    for r in _rows("alarm"):
        assert f"#define ALARM_{r['name'].upper()} {r['code']}\n" in text
    for r in _rows("reply"):
        assert f"#define MSG_{r['name'].upper()} \"{r['message']}\"" in text
    for r in _rows("error"):
        assert f"  STATUS_{r['name'].upper()} = {r['code']},\n" in text


def test_firmware_sources_define_no_code_by_hand():
    sources = sorted(FW.glob("src/*.[ch]")) + sorted(FW.glob("board/*.c")) + sorted(FW.glob("host/*.c"))
    run = _check(*sources)
    assert run.returncode == 0, run.stderr
    report_h = (FW / "src/report.h").read_text()
    assert not re.search(r"#\s*define\s+(ALARM|MSG|REPLY)_", report_h)
    protocol_c = (FW / "src/protocol.c").read_text()
    for r in _rows("reply"):
        assert f'"{r["message"]}"' not in protocol_c, r["message"]


def test_check_refuses_each_broken_rule(tmp_path):
    cases = {
        "unknown.c": ("report_alarm(ALARM_NO_SUCH_ALARM);\n", "ALARM_NO_SUCH_ALARM is not in the status table"),
        "by_hand.c": ("#define ALARM_SOFT_LIMIT 2\n", "ALARM_SOFT_LIMIT is defined by hand"),
        "literal.c": ('report_feedback("Pgm End");\n', "use MSG_PROGRAM_END"),
    }
    for name, (text, said) in cases.items():
        path = tmp_path / name
        path.write_text(text)
        run = _check(path)
        assert run.returncode == 1 and said in run.stderr, (name, run.stderr)
    fine = tmp_path / "fine.c"
    fine.write_text('report_feedback(MSG_PROGRAM_END);\nreport_feedback("E-stop");\n')
    assert _check(fine).returncode == 0
