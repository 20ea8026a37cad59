"""Every line labkit writes fits GRBL's line buffer, comments included (issue 26).

The limit is read from the conversation recorded from GRBL 1.1h itself
(tests/vectors/grbl/line_length.json), not from labkit: the longest line GRBL
answered ``ok`` and the shortest it answered ``error:11``. A comment line is
held to the same length as sent, because a character-counting sender (GRBL's
stream.py) counts it against the controller's 128-byte receive buffer.
"""

import json
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from labkit.cli import main
from labkit.errors import InputError
from labkit.gcode import parse
from labkit.gcode.writer import comment_lines
from labkit.machine.stream import Job, strip_line

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "data"
TRANSCRIPT = json.loads((ROOT / "tests/vectors/grbl/line_length.json").read_text())


def _grbl_verdicts():
    """(line, GRBL's reply) for every plain G-code line of the recorded transcript."""
    out = []
    for ex in TRANSCRIPT["exchanges"]:
        line = ex["send"].rstrip("\n")
        if ex["send"].endswith("\n") and line.startswith("G0") and len(ex["replies"]) == 1:
            out.append((line, ex["replies"][0]))
    return out


VERDICTS = _grbl_verdicts()
#: GRBL's limit, as recorded: the longest G-code line (spaces and comments removed) it accepted.
GRBL_MAX = max(len(strip_line(line)) for line, reply in VERDICTS if reply == "ok")


def test_the_transcript_fixes_grbl_limit_at_79():
    refused = [len(strip_line(line)) for line, reply in VERDICTS if reply == "error:11"]
    assert GRBL_MAX == 79 and min(refused) == 80
    # spaces and comments do not count: GRBL accepted lines far longer than 80 as sent
    assert max(len(line) for line, reply in VERDICTS if reply == "ok") > 100


def _check_program(path: Path):
    lines = path.read_text().splitlines()
    assert lines, f"{path.name} is empty"
    too_long = [(k, len(t)) for k, t in enumerate(lines, 1) if len(t) > GRBL_MAX]
    assert not too_long, f"{path.name}: lines longer than {GRBL_MAX} characters (line, length): {too_long[:5]}"
    parse(path.read_text(), filename=path.name)    # and it is still a program that reads back


@pytest.fixture(scope="module")
def image(tmp_path_factory):
    """A 60 x 40 px disc with a gray ramp (drawn here), so every img2gcode mode has content."""
    yy, xx = np.mgrid[0:40, 0:60]
    gray = np.clip(xx * 4, 0, 255).astype(np.uint8)
    gray[(xx - 30) ** 2 + (yy - 20) ** 2 < 150] = 0
    # a long name: the header names the file, and a long name must wrap too
    path = tmp_path_factory.mktemp("img") / ("a-very-long-image-file-name-" * 4 + "disc.png")
    Image.fromarray(gray).save(path, dpi=(254, 254))
    return path


@pytest.mark.parametrize("mode", ["zigzag", "spiral", "edges", "gray", "dither"])
@pytest.mark.parametrize("travel", [[], ["--travel-beam-off"]])
def test_img2gcode_every_mode(image, tmp_path, capsys, mode, travel):
    out = tmp_path / f"{mode}.gcode"
    assert main(["img2gcode", str(image), "-o", str(out), "--mode", mode, "--beam", "0.5",
                 "--width", "15", "--preview", "none", *travel]) == 0
    _check_program(out)
    if not travel:   # the GRBL travel warning is in the header, wrapped, not dropped
        assert "every rapid burns" in out.read_text()


@pytest.mark.parametrize("dialect", ["grbl", "labkit-fw", "marlin"])
def test_svg2gcode(tmp_path, capsys, dialect):
    out = tmp_path / "jsdc.gcode"
    assert main(["svg2gcode", str(DATA / "svg/cncjs/jsdc_mm.svg"), "-o", str(out),
                 "--dialect", dialect]) == 0
    _check_program(out)


def test_dxf2gcode(tmp_path, capsys):
    out = tmp_path / "parts.gcode"
    assert main(["dxf2gcode", str(DATA / "dxf/parts_mm.dxf"), "-o", str(out), "--arcs"]) == 0
    _check_program(out)


PATTERNS = {
    "helix": ["--x", "3", "--radius", "1.5", "--pitch", "0.4", "--turns", "3"],
    "spiral": ["--radius", "4", "--step", "0.3"],
    "square-spiral": ["--size", "3", "--step", "0.5"],
    "zigzag": ["--width", "6", "--height", "4", "--step", "1"],
    "cone": ["--d1", "6", "--d2", "2", "--height", "2", "--levels", "3", "--beam", "0.4"],
}


@pytest.mark.parametrize("name", list(PATTERNS))
def test_pattern(tmp_path, capsys, name):
    out = tmp_path / f"{name}.gcode"
    assert main(["pattern", name, *PATTERNS[name], "-o", str(out)]) == 0
    _check_program(out)


def test_slice(tmp_path, capsys):
    out = tmp_path / "pyramid.gcode"
    assert main(["slice", str(DATA / "stl/stepped_pyramid.stl"), "--step", "1", "--beam", "0.5",
                 "-o", str(out)]) == 0
    _check_program(out)


def test_split(tmp_path, capsys):
    assert main(["split", str(DATA / "gcode/cncjs/jsdc-laser.gcode"), "--max-lines", "300",
                 "-o", str(tmp_path)]) == 0
    parts = sorted(tmp_path.glob("*.gcode"))
    assert len(parts) > 1
    for part in parts:
        _check_program(part)


def test_cutwidth_grid_with_a_long_legend(tmp_path, capsys):
    """Twelve powers and ten speeds: the legend (one comment line each before) wraps."""
    out = tmp_path / "grid.gcode"
    assert main(["cutwidth", "pattern", "--powers", "500:2500:12", "--speeds", "300:1200:10",
                 "-o", str(out)]) == 0
    _check_program(out)
    header = [t for t in out.read_text().splitlines() if t.startswith(";")]
    assert any("12 = 2500 mW" in t for t in header) and any("10 = 1200 mm/min" in t for t in header)


def test_millfeed(tmp_path, capsys):
    from labkit.gcode.writer import emit
    from labkit.toolpath import patterns

    moves, _ = patterns.square_spiral((2, 2), 3.0, 0.5, z_mm=-0.05, feed_mm_min=120, loops=False)
    src = tmp_path / "pocket.gcode"
    src.write_text(emit(moves))
    out = tmp_path / "scheduled.gcode"
    assert main(["millfeed", str(src), "--tool-d", "0.794", "--teeth", "2", "--rpm", "60000",
                 "--ft-min", "0.001", "--ft-max", "0.0015", "--stock", "0", "0", "4", "4",
                 "-o", str(out)]) == 0
    _check_program(out)


def test_comment_lines_wrap_without_losing_a_word():
    text = ("rows (engraved left, bottom to top): " + ", ".join(f"{i} = {i * 250} mW (S{i * 100})"
                                                             for i in range(1, 15)))
    lines = comment_lines(text + "\n\nsecond paragraph")
    assert all(t.startswith(";") and len(t) <= GRBL_MAX for t in lines)
    assert len(lines) > 3
    # the words, in order, are the comment's words: nothing cut, nothing added
    words = " ".join(t[2:] for t in lines).split()
    assert words == (text + " second paragraph").split()
    assert ";" in lines                                       # the blank line kept
    # a word longer than a line is cut, never left over-long
    assert [len(t) for t in comment_lines("x" * 200, width=79)] == [79, 79, 48]
    with pytest.raises(ValueError, match="at least 3"):
        comment_lines("x", width=2)


def test_stream_takes_what_grbl_takes_and_names_the_line_it_refuses():
    for line, reply in VERDICTS:
        text = f"G21 G90\n{line}\n"
        if reply == "ok":
            assert [s for _, s in Job.from_text(text).send][-1] == strip_line(line)
        else:
            n = len(strip_line(line))
            with pytest.raises(InputError, match=rf"^job\.nc:2:1: line 2 \(G0X1\.0+\.\.\.\) has "
                                                 rf"{n} characters .* at most 79"):
                Job.from_text(text, filename="job.nc")
