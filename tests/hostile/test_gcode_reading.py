"""Hostile G-code for the readers (issue 9): absurd numbers, GRBL's line rules, work bombs.

Each case states the exact outcome: the error with its place, or the program GRBL would run.
Big inputs are generated at test time; the runner (conftest.py) holds time and memory ceilings.
"""

from __future__ import annotations

import json
import math
import os

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from labkit.errors import GcodeError
from labkit.gcode import check, parse
from labkit.gcode.dialects import DIALECTS
from labkit.toolpath import MoveKind

HUGE = "1" + "0" * 400          # "X = 1 followed by 400 zeros": infinity as a float


# ---- numbers that are not finite, or absurdly large ---------------------------------------

@pytest.mark.parametrize("dialect", list(DIALECTS))
@pytest.mark.parametrize("word", [f"X{HUGE}", f"Y-{HUGE}", "Z9007199254740992", f"F{HUGE}",
                                  f"S{HUGE}", "X123456789012345678901"])
def test_absurd_numbers_are_rejected_with_their_place_in_every_dialect(dialect, word):
    with pytest.raises(GcodeError, match=rf"^f.nc:2:4: error 2: number too large \(got '{word[:8]}"):
        parse(f"G21\nG1 {word} F100\n", dialect=dialect, filename="f.nc")


def test_the_largest_exact_number_still_reads():
    m = parse("G0 X9007199254740991 Y-9007199254740991")
    assert m.end[0, :2].tolist() == [9007199254740991.0, -9007199254740991.0]


def test_positions_that_grow_out_of_range_are_rejected_not_nan():
    text = "G91 G0 X9007199254740990\nX9007199254740990\n"
    with pytest.raises(GcodeError, match=r"<string>:2:1: error 103: position out of range "
                                         r"\(got 'X9007199254740990'"):
        parse(text)
    m = parse(text, lenient=True)
    assert len(m) == 1 and np.isfinite(m.end).all()
    # Inches scale a legal number past the limit: same error, at the word.
    with pytest.raises(GcodeError, match=r":1:8: error 103"):
        parse("G20 G0 X900719925474099")


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.sampled_from("XYZIJRF"),
                          st.text("0123456789.-", min_size=1, max_size=40)), max_size=6),
       st.sampled_from(["G0", "G1", "G2", "G3", "G91 G1", "G20 G1"]))
def test_fuzz_no_position_is_ever_non_finite(words, motion):
    line = motion + " " + " ".join(f"{a}{v}" for a, v in words) + " F100"
    for dialect in DIALECTS:
        m = parse(line + "\n" + line, dialect=dialect, lenient=True)
        for col in (m.start, m.end, m.feed_mm_min):
            assert np.isfinite(col).all()
        assert np.isfinite(m.centre[m.is_arc]).all()
        assert np.all(np.abs(m.end) < 2.0 ** 53)


def test_check_rejects_infinity_and_info_json_is_strict_json(tmp_path, run_labkit):
    bad = tmp_path / "inf.nc"
    bad.write_text(f"G1 X{HUGE} F100\n")
    r = run_labkit(["check", bad, "--dialect", "marlin"], time_s=60)
    assert r.code == 1
    assert r.stdout.splitlines() == [
        f"{bad}:1:4: error 2: number too large (got 'X{HUGE[:119]}…'; expected a magnitude "
        "below 9007199254740992 (2**53; a machine coordinate in mm))"]
    r = run_labkit(["preview", bad, "-o", tmp_path / "p.png"], time_s=60)
    assert r.code == 1 and f"{bad}:1:4: error 2: number too large" in r.stderr
    assert not (tmp_path / "p.png").exists()
    empty = tmp_path / "empty.nc"
    empty.write_text("G21 G90\n")
    r = run_labkit(["info", empty, "--json"], time_s=60)
    assert r.code == 0

    def no_constants(name):
        raise AssertionError(f"not JSON: {name}")
    summary = json.loads(r.stdout, parse_constant=no_constants)
    assert summary["bounds"] == [[None] * 3, [None] * 3] and summary["moves"] == 0


# ---- reading lines as GRBL does ---------------------------------------------------------------

def test_a_lone_cr_ends_a_line_as_in_grbl():
    # GRBL's protocol loop ends a line at '\n' or '\r': two moves, not one diagonal.
    m = parse(b"G1 X10 F100\rY5\nG1 X0\r\nY0\n")
    assert [MoveKind(k).name for k in m.kind] == ["LINE"] * 4
    assert m.end[:, :2].tolist() == [[10, 0], [10, 5], [0, 5], [0, 0]]
    assert m.line.tolist() == [1, 2, 3, 4]   # CRLF stays one line end


def test_percent_inside_a_line_is_error_1_a_lone_percent_is_the_delimiter():
    with pytest.raises(GcodeError, match=r"<string>:2:1: error 1: '%' inside a line \(got '%'"):
        parse("%\n%G1 X5 F100\n%\n")
    assert parse("%\n  %  \nG0 X1\n%").end[:, 0].tolist() == [1.0]


def test_jog_lines_are_the_jog_they_are():
    m = parse("G21 G90 M3 S200\nG0 X1\n$J=G91 G20 X1 F10\nG1 Y1 F100\n$J=G53 X2 Y2 F300\n")
    assert [MoveKind(k).name for k in m.kind] == ["RAPID", "LINE", "LINE", "LINE"]
    # The jog is incremental in inches for its own line only (GRBL jogging.md).
    assert m.end[1].tolist() == pytest.approx([26.4, 0, 0])
    assert m.feed_mm_min[1] == pytest.approx(254.0)
    assert m.end[2].tolist() == pytest.approx([26.4, 1, 0])           # G90 G21 again
    assert m.end[3].tolist() == [2.0, 2.0, 0.0]
    assert [(r.kind, r.index, r.line) for r in m.records] == [("jog", 1, 3), ("jog", 3, 5)]
    assert m.feed_mm_min[2] == 100.0                                   # F of a jog is not modal


@pytest.mark.parametrize("line, message", [
    ("$J=G1 X1 F100", r":1:4: error 16: a jog cannot take this command \(got 'G1'"),
    ("$J=X1 F100 M3", r":1:12: error 16: a jog cannot take this command \(got 'M3'"),
    ("$J=X1 F100 S5", r":1:12: error 36: a jog cannot take this word \(got 'S5'"),
    ("$J=X1", r":1:1: error 22: feed motion without a feed rate"),
])
def test_invalid_jogs_get_grbls_errors(line, message):
    with pytest.raises(GcodeError, match=message):
        parse(line)


def test_grbl_line_buffer_in_check_not_in_parse():
    # 79 significant characters fit GRBL's 80-byte buffer; the 80th is error 11 (protocol.c).
    fits = "G1F100X" + "1" * 6 + "." + "0" * 65
    assert len(fits) == 79
    assert check(fits) == []
    over = fits + "0"
    errs = check(over)
    assert [(e.code, e.line, e.column) for e in errs] == [(11, 1, 80)]
    assert len(parse(over)) == 1                      # a file may hold it; streaming may not
    spaced = "G1 F100  X111111." + "0" * 65 + " (" + "c" * 5000 + ") ; " + "d" * 5000
    assert check(spaced) == []                        # spaces and comments do not count
    assert check(over, dialect="marlin") == []        # no line buffer stated for marlin


# ---- work bombs and files that are not files ----------------------------------------------

def test_multi_megabyte_comment_lines_parse_in_linear_time(tmp_path, run_labkit):
    f = tmp_path / "b64.nc"
    blob = "A" * 8_000_000
    f.write_text(f"G21\n; data:image/png;base64,{blob}\n({blob})\nG1 X1 F100\n")
    r = run_labkit(["check", f], time_s=30, memory_mb=400)
    assert r.code == 0 and "ok, 4 lines, 1 moves" in r.stderr


def test_check_of_ten_million_bad_lines_keeps_memory_bounded(tmp_path, run_labkit):
    f = tmp_path / "bad.nc"
    with open(f, "wb") as fh:
        fh.write(b"G1 X\n" * 10_000_000)
    r = run_labkit(["check", f], time_s=120, memory_mb=700)
    assert r.code == 1
    out = r.stdout.splitlines()
    assert len(out) == 10_000
    assert out[0] == f"{f}:1:4: error 2: the word has no number (got 'X'; expected a number " \
                     "like 12, -0.5 or +3.25 after the letter)"
    assert (f"{f}: 10000000 error(s) in 10000000 lines (9990000 more not shown: "
            "the diagnostics budget keeps 10000)") in r.stderr


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs on this OS")
@pytest.mark.parametrize("command", [["check"], ["info"], ["preview", "-o", "x.png"]])
def test_a_fifo_is_refused_not_waited_on(tmp_path, run_labkit, command):
    fifo = tmp_path / "pipe.nc"
    os.mkfifo(fifo)
    r = run_labkit([command[0], fifo, *command[1:]], time_s=30, cwd=tmp_path)
    assert r.code == 1
    assert f"{fifo}: not a regular file (a FIFO (named pipe)); expected a G-code file" in r.stderr


@pytest.mark.parametrize("value", ["0x0", "nanxnan", "infx10", "10", "-5x5", "axb"])
def test_bad_envelopes_are_named(tmp_path, run_labkit, value):
    f = tmp_path / "ok.nc"
    f.write_text("G0 X1\n")
    r = run_labkit(["check", f, f"--envelope={value}"], time_s=30)
    assert r.code == 1 and r.stderr.startswith("labkit check: --envelope")


def test_preview_of_a_non_finite_program_is_an_error(tmp_path):
    from labkit.errors import InputError
    from labkit.toolpath import Moves
    from labkit.viz.gcode import save_preview

    m = Moves(kind=[MoveKind.RAPID, MoveKind.LINE], start=[[0, 0, 0], [1, 0, 0]],
              end=[[1, 0, 0], [math.inf, 0, 0]], feed_mm_min=[math.nan, 100], line=[1, 2])
    with pytest.raises(InputError, match=r"move 1 \(line 2\) has a position that is not finite"):
        save_preview(m, tmp_path / "p.png")
