"""The G-code splitter ([MicroCAM] §6.2.1): parts within the limit that, parsed alone or in turn,
give exactly the original program's moves."""

from pathlib import Path

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from labkit.cli import main
from labkit.errors import GcodeError, InputError
from labkit.gcode import parse
from labkit.gcode.split import POSITION_ATOL_MM, split_program, verify_parts

DATA = Path(__file__).parents[2] / "data" / "gcode" / "cncjs"


def _in_sequence(text, parts, dialect="grbl"):
    """Parse the parts as one stream (the controller keeps its state between them) and drop
    the moves of the added lines: what running the parts in turn does."""
    joined = "".join(p.text for p in parts)
    m = parse(joined, dialect=dialect)
    keep = np.zeros(len(m), bool)
    line0 = 0
    for p in parts:
        first = line0 + p.preamble_lines + 1
        last = first + p.last_line - p.first_line
        keep |= (m.line >= first) & (m.line <= last)
        line0 += p.n_lines
    return m[keep]


def _same_motion(a, b):
    assert len(a) == len(b)
    assert np.array_equal(a.kind, b.kind)
    for col in ("start", "end", "centre", "work_offset"):
        assert np.allclose(getattr(a, col), getattr(b, col), atol=POSITION_ATOL_MM, rtol=0, equal_nan=True)
    for col in ("feed_mm_min", "s_word", "laser", "plane", "dwell_s"):
        assert np.array_equal(getattr(a, col), getattr(b, col), equal_nan=True), col


@pytest.mark.parametrize("name,limit", [
    ("jsdc-laser.gcode", dict(max_lines=200)),
    ("jsdc-laser.gcode", dict(max_bytes=4096)),
    ("tball-engrave-laser.gcode", dict(max_lines=500, max_bytes=8000)),
    ("Circle_Diamond_Square_Calibration.gcode", dict(max_lines=60)),
])
def test_real_jobs_split_within_the_limit_and_reproduce_the_moves(name, limit):
    text = (DATA / name).read_text()
    if name.startswith("Circle"):      # N1-N620: N624's arc is off its circle (error 33, tests/gcode)
        text = "\n".join(text.splitlines()[:620]) + "\n"
    whole = parse(text)
    res = split_program(text, **limit)                       # verifies each part alone
    assert len(res.parts) > 2
    for p in res.parts:
        assert p.n_lines <= limit.get("max_lines", np.inf)
        assert p.n_bytes <= limit.get("max_bytes", np.inf)
    # the original lines, in order, each exactly once
    body = [ln for p in res.parts for ln in p.text.splitlines()[p.preamble_lines:p.n_lines - p.trailer_lines]]
    assert body == text.splitlines()
    # alone: the independent re-parse inside split_program; again here, and in turn
    _same_motion(whole, verify_parts(text, res.parts))
    _same_motion(whole, _in_sequence(text, res.parts))


def test_parts_end_where_the_beam_is_not_cutting():
    text = (DATA / "tball-engrave-laser.gcode").read_text()      # short paths, M5 between
    whole = parse(text)
    res = split_program(text, max_lines=150)
    assert res.inside_cuts == 0 and all(p.safe for p in res.parts)
    for p in res.parts[:-1]:
        before = whole[whole.line <= p.last_line]
        after = whole[whole.line > p.last_line]
        last_burn = before.laser_on[before.is_motion][-1]
        next_burn = after.laser_on[after.is_motion][0]
        assert not (last_burn and next_burn)


def test_a_cut_longer_than_a_part_is_split_inside_and_counted():
    text = "G21 G90\nM3 S500\nG1 F900\n" + "".join(f"X{i} Y{i % 2}\n" for i in range(1, 60)) + "M5\n"
    res = split_program(text, max_lines=25)
    assert res.inside_cuts >= 2
    assert not all(p.safe for p in res.parts)
    _same_motion(parse(text), verify_parts(text, res.parts))


def test_incremental_inch_offsets_and_coolant_are_restated():
    text = ("G20 G91 G17\nG92 X1 Y2\nM8\nM4 S300\nG1 F20 X0.1\n"
            + "X0.01 Y0.02\n" * 30 + "G0 X1\nG1 Y-0.5\n" * 5 + "M9 M5\n")
    res = split_program(text, max_lines=20)
    assert len(res.parts) >= 3
    later = res.parts[1].text
    for word in ("G92 ", "M8", "M4", "G20", "G91"):
        assert word in later
    _same_motion(parse(text), _in_sequence(text, res.parts))


def test_modal_arcs_are_not_split_where_the_mode_cannot_be_restated():
    # G2 stays modal: the bare lines after it rely on it; a G2 cannot be restated alone
    arcs = "".join(f"X{2 * k + 2} Y0 I1 J0\n" for k in range(20))
    text = "G21 G90 G0 X0 Y0\nM3 S100\nG2 X2 Y0 I1 J0 F500\n" + arcs + "M5\n"
    with pytest.raises(InputError, match="cannot start a part"):
        split_program(text, max_lines=15)
    text2 = text.replace("\nX", "\nG2 X")                     # every arc states its G2
    res = split_program(text2, max_lines=15)
    _same_motion(parse(text2), verify_parts(text2, res.parts))


@pytest.mark.parametrize("dialect", ["labkit-fw", "marlin"])
def test_other_dialects(dialect):
    text = "G21 G90\nM3 S100\n" + "".join(f"G1 X{i} Y{i % 3} F30\nG0 X{i} Y5\n" for i in range(40)) + "M5\n"
    res = split_program(text, max_lines=20, dialect=dialect)
    _same_motion(parse(text, dialect=dialect), verify_parts(text, res.parts, dialect=dialect))
    assert "F30" in res.parts[1].text or "F" in res.parts[1].text


def test_errors_name_what_is_wrong():
    with pytest.raises(InputError, match="max_lines or max_bytes"):
        split_program("G0 X1\n")
    with pytest.raises(InputError, match="max_lines must be a whole number"):
        split_program("G0 X1\n", max_lines=0)
    with pytest.raises(GcodeError, match=r"job.nc:2:7: error 25"):
        split_program("G0 X1\nG1 X1 X2\n", max_lines=10, filename="job.nc")
    with pytest.raises(InputError, match="raise the limit"):
        split_program("G0 X1\n" * 50 + "G1 X2 F10\n" * 50, max_lines=5)


def test_whole_program_within_the_limit_is_one_part_unchanged():
    text = "G21\nG0 X1\nM3 S10\nG1 X2 F100\nM5\n"
    res = split_program(text, max_lines=6)
    assert len(res.parts) == 1 and res.parts[0].text.split("\n", 1)[1] == text


# random programs: absolute and incremental, mm and inch, arcs, laser on/off, dwell
_line = st.one_of(
    st.builds(lambda x, y: f"G1 X{x} Y{y}", st.integers(-50, 50), st.integers(-50, 50)),
    st.builds(lambda x: f"G0 X{x}", st.integers(-50, 50)),
    st.builds(lambda x, y: f"X{x} Y{y}", st.integers(-5, 5), st.integers(-5, 5)),
    st.builds(lambda g, x, y: f"G{g} X{x} Y{y} R{'-' if g == 3 else ''}900", st.sampled_from([2, 3]),
              st.integers(-50, 50), st.integers(-50, 50)),
    st.sampled_from(["G90", "G91", "G20", "G21", "M5", "M3 S200", "M4 S900", "F300", "G4 P0.1",
                     "G17", "M8", "M9", "(comment)", ""]),
)


@settings(max_examples=60, deadline=None)
@given(st.lists(_line, min_size=5, max_size=80), st.integers(18, 40))
def test_random_programs_reproduce_their_moves(lines, limit):
    text = "F100\n" + "\n".join(lines) + "\n"
    try:
        whole = parse(text)
    except GcodeError:                    # rare: an R arc that ends where it starts
        assume(False)
    res = split_program(text, max_lines=limit)
    assert all(p.n_lines <= limit for p in res.parts)
    _same_motion(whole, verify_parts(text, res.parts))
    _same_motion(whole, _in_sequence(text, res.parts))


def test_command_writes_the_parts(tmp_path, capsys):
    src = tmp_path / "job.gcode"
    src.write_text((DATA / "jsdc-laser.gcode").read_text())
    assert main(["split", str(src), "--max-lines", "300", "-o", str(tmp_path / "out")]) == 0
    files = sorted((tmp_path / "out").glob("job.part*.gcode"))
    assert len(files) >= 3
    out = capsys.readouterr().out
    assert f"{len(files)} parts" in out and "verified" in out
    _same_motion(parse(src.read_text()),
                 _in_sequence(src.read_text(), split_program(src.read_text(), max_lines=300).parts))
    assert main(["split", str(src), "--max-lines", "2"]) == 1
    assert "raise the limit" in capsys.readouterr().err
