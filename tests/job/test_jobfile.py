"""labkit job: a job file's layers composed into one program, checked against hand-worked cases
(the burning order, each layer's S from its mW, the placement, a kerf, typed values over the
library) and bad job files as one-line errors."""

import numpy as np
import pytest
from PIL import Image

from labkit.cli import main
from labkit.errors import InputError
from labkit.gcode.reader import parse
from labkit.jobfile import compose_job, read_job

# written by hand: an outline with a hole (both cut), and a fold line (score) in red
SVG = """<svg xmlns="http://www.w3.org/2000/svg" width="60mm" height="40mm" viewBox="0 0 60 40">
<rect id="outline" x="10" y="10" width="40" height="20" fill="none" stroke="#000000"/>
<rect id="hole" x="20" y="15" width="5" height="5" fill="none" stroke="#000000"/>
<path id="fold" d="M 30 12 L 30 28" fill="none" stroke="#ff0000"/>
</svg>"""

LIBRARY = """format = "labkit-materials"
version = 1
machine = "cbr40-laser"
[material.card.cut]
origin = "typed"
power_mw = 2000.0
speed_mm_min = 300.0
passes = 2
kerf_mm = 0.2
[material.card.score]
origin = "typed"
power_mw = 500.0
speed_mm_min = 1000.0
[material.card.image]
origin = "typed"
power_mw = 1000.0
speed_mm_min = 1200.0
line_interval_mm = 0.5
"""

JOB = """format = "labkit-job"
version = 1
machine = "cbr40-laser"
material = "card"
library = "lib.toml"
{placement}
[[layer]]
source = "part.svg"
operation = "cut"
select = ["#000000"]
kerf_mm = {kerf}

[[layer]]
source = "part.svg"
operation = "score"
select = ["#ff0000"]
speed_mm_min = 800.0

[[layer]]
source = "half.png"
operation = "image"
width_mm = 10.0
at_mm = [35.0, 15.0]
mode = "zigzag"
"""


@pytest.fixture
def folder(tmp_path):
    (tmp_path / "part.svg").write_text(SVG)
    (tmp_path / "lib.toml").write_text(LIBRARY)
    pixels = np.full((10, 20), 255, np.uint8)
    pixels[:, :10] = 0                                   # the left half black: 5 × 5 mm at 10 mm wide
    Image.fromarray(pixels).save(tmp_path / "half.png")
    return tmp_path


def _job(folder, placement="", kerf=0.0, name="job.toml"):
    p = folder / name
    p.write_text(JOB.format(placement=placement, kerf=kerf))
    return p


def _burns(moves):
    """(first row, last row, S, feed) of each run of burning moves with one S."""
    on = np.flatnonzero(moves.laser_on)
    runs, start = [], on[0]
    for a, b in zip(on, on[1:]):
        if moves.s_word[b] != moves.s_word[a]:
            runs.append((start, a, float(moves.s_word[a]), float(moves.feed_mm_min[a])))
            start = b
    runs.append((start, on[-1], float(moves.s_word[on[-1]]), float(moves.feed_mm_min[on[-1]])))
    return runs


def test_engrave_before_score_before_cut_each_at_its_power(folder):
    composed = compose_job(read_job(_job(folder)))
    runs = _burns(composed.moves)
    # 1000, 500, 2000 mW of the CBR-40's 2500 mW at S max 1000: S400, S200, S800
    assert [(s, f) for _, _, s, f in runs] == [(400.0, 1200.0), (200.0, 800.0), (800.0, 300.0)]
    assert [d["operation"] for d in composed.layers] == ["image", "score", "cut"]
    assert composed.layers[1]["from_library"] == ["power_mw", "passes"]       # speed typed in the layer
    assert "kerf_mm" not in composed.layers[2]["from_library"]


def test_inner_shape_before_its_container_in_every_pass(folder):
    m = compose_job(read_job(_job(folder))).moves
    first, last, _, _ = _burns(m)[2]
    cut = m[first:last + 1]
    burn = cut[cut.laser_on]
    xs = np.c_[burn.start[:, 0], burn.end[:, 0]]
    inside = (xs.min(axis=1) > 20 - 1e-3) & (xs.max(axis=1) < 25 + 1e-3)     # the hole spans x 20…25
    # each pass cuts the hole's four sides, then the outline's four: the hole never after its container
    assert "".join("h" if i else "o" for i in inside) == "hhhhoooo" * 2
    length = float(burn.lengths_mm().sum())
    assert length == pytest.approx(2 * (120 + 20), abs=1e-3)        # two passes of 120 + 20 mm


def test_image_and_placement(folder):
    m = compose_job(read_job(_job(folder))).moves
    first, last, _, _ = _burns(m)[0]
    img = m[first:last + 1]
    on = img.laser_on
    # the black half: 5 mm wide at x 35…40, ten lines 0.5 mm apart from y 15.25
    assert img.start[on, 0].min() == pytest.approx(35.0) and img.end[on, 0].max() == pytest.approx(40.0)
    assert np.allclose(sorted(set(np.round(img.end[on, 1], 6))), 15.25 + 0.5 * np.arange(10))
    placed = compose_job(read_job(_job(folder, '[placement]\nstart_from = "origin"\noffset_mm = [5.0, 5.0]\n',
                                       name="placed.toml"))).moves
    lows = placed.bounds(placed.laser_on)[0]
    assert lows[:2] == pytest.approx([5.0, 5.0])
    # everything moved by the same (5 − 10, 5 − 10): the image's corner from (35, 15) to (30, 10)
    first, last, _, _ = _burns(placed)[0]
    assert placed[first:last + 1].start[placed[first:last + 1].laser_on, 0].min() == pytest.approx(30.0)
    assert placed.start[0].tolist() == [0.0, 0.0, 0.0]           # the program leaves from the origin


def test_library_kerf_grows_a_single_outline(folder):
    (folder / "part.svg").write_text(SVG.replace('<rect id="hole" x="20" y="15" width="5" height="5" '
                                                 'fill="none" stroke="#000000"/>', ""))
    job = read_job(_job(folder).parent / "job.toml")
    job.layers[0].overrides.pop("kerf_mm")                    # the library's 0.2 mm
    m = compose_job(job).moves
    first, last, _, _ = _burns(m)[2]
    box = m[first:last + 1].bounds(m[first:last + 1].laser_on)
    assert (box[1] - box[0])[:2] == pytest.approx([40.2, 20.2], abs=0.02)   # flattening within tol 0.01 a side


def test_command_writes_program_and_record(folder, capsys):
    out = folder / "out.gcode"
    assert main(["job", str(_job(folder)), "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "layer 3 image half.png: 1000 mW = S400" in text and "record" in text
    program = out.read_text()
    assert parse(program).laser_on.any() and "material card:cut" in program
    assert max(len(line) for line in program.splitlines()) <= 79          # GRBL's line buffer, header included
    from labkit.record import read_record

    rec = read_record(folder / "out.gcode.record.json")
    assert rec["command"] == "job" and [i["role"] for i in rec["inputs"]] == ["job", "layer 1", "layer 2", "layer 3"]
    assert [d["operation"] for d in rec["layers"]] == ["image", "score", "cut"]
    assert main(["job", str(_job(folder)), "-o", str(folder / "o2.gcode"), "--no-record"]) == 0
    assert not (folder / "o2.gcode.record.json").exists()


@pytest.mark.parametrize("edit, match", [
    (lambda t: t.replace("version = 1", "version = 3"), "version = 3; this labkit reads version 1"),
    (lambda t: t.replace('operation = "cut"', 'operation = "weld"'), r"layer 1: operation = 'weld'"),
    (lambda t: t.replace('source = "half.png"', 'source = "missing.png"'), r"layer 3: source 'missing.png' is not"),
    (lambda t: t.replace('operation = "score"', 'operation = "image"'),
     r"layer 2: part.svg embeds no bitmap named \['#ff0000'\]"),
    (lambda t: t.replace('operation = "image"', 'operation = "cut"'), r"layer 3: operation 'cut' on half.png"),
    (lambda t: t.replace('select = ["#ff0000"]', 'select = ["#00ff00"]'),
     r"layer 2: nothing to score in part.svg with select \['#00ff00'\] \(its layers: #000000, #ff0000\)"),
    (lambda t: t.replace('speed_mm_min = 800.0', 'speed = 800.0'), r"layer 2: unknown key\(s\) speed"),
    (lambda t: t.replace('material = "card"\n', 'material = "wood"\n'), "no material 'wood'"),
    (lambda t: t.replace('machine = "cbr40-laser"\n', ""), "machine is missing"),
    (lambda t: t + "[[layer\n", r"not valid TOML: .*line \d+, column"),
])
def test_bad_job_files(folder, edit, match):
    p = folder / "bad.toml"
    p.write_text(edit(JOB.format(placement="", kerf=0.0)))
    with pytest.raises(InputError, match=match):
        compose_job(read_job(p))


def test_what_a_reader_could_not_cut_is_said_once(tmp_path, capsys):
    """A job is not quieter than svg2gcode: a mask it cannot apply and characters it cuts upright
    are named (once, though two layers read the file); bitmaps an image layer of the same job
    engraves are not reported as left out."""
    import base64
    import io

    buf = io.BytesIO()
    Image.fromarray(np.zeros((4, 4), np.uint8)).save(buf, format="PNG")
    uri = "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode()
    (tmp_path / "t.svg").write_text(      # written by hand
        '<svg xmlns="http://www.w3.org/2000/svg" xmlns:xlink="http://www.w3.org/1999/xlink" width="40mm" '
        'height="30mm" viewBox="0 0 40 30"><rect x="5" y="5" width="30" height="20" fill="none" stroke="#000"/>'
        '<text x="5" y="20" rotate="30" font-size="8" fill="#000">Hi</text><g mask="url(#m)"><rect x="1" '
        'y="1" width="3" height="3" fill="#000"/></g><mask id="m"><rect width="40" height="30" fill="#888"/>'
        f'</mask><image id="pic" x="30" y="1" width="4" height="4" xlink:href="{uri}"/></svg>')
    layer = '[[layer]]\nsource = "t.svg"\noperation = "{op}"\npower_mw = 500.0\nspeed_mm_min = 600.0\n'
    head = 'format = "labkit-job"\nversion = 1\nmachine = "cbr40-laser"\n'
    (tmp_path / "two.toml").write_text(head + layer.format(op="cut") + layer.format(op="score"))
    warned = compose_job(read_job(tmp_path / "two.toml")).warnings
    assert len(warned) == 3, warned
    assert sum("rotate='30'" in w for w in warned) == 1 and sum("mask is not applied" in w for w in warned) == 1
    assert sum("image#pic" in w for w in warned) == 1        # the bitmap: no image layer takes it
    (tmp_path / "img.toml").write_text(head + layer.format(op="cut") + layer.format(op="image")
                                       + 'select = ["pic"]\nline_interval_mm = 0.5\n')
    warned = compose_job(read_job(tmp_path / "img.toml")).warnings
    assert len(warned) == 2 and not any("image#pic" in w for w in warned), warned
    assert main(["job", str(tmp_path / "two.toml"), "-o", str(tmp_path / "two.gcode"), "--no-record"]) == 0
    err = capsys.readouterr().err
    assert err.count("warning: ") == 3 and "mask is not applied" in err
