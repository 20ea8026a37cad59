"""Hypothesis fuzz (issue 9): every reader and every numeric option of every file command,
driven with non-finite, negative, zero, tiny and huge values. The outcome is always one
of two: a LabkitError (or argparse's exit 2) with a message, or a result that holds only
finite numbers — and a G-code file written with exit 0 is one labkit itself accepts,
with S never above --s-max."""

from __future__ import annotations

import argparse
import contextlib
import io
import math
import os
import tempfile

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from labkit import cli
from labkit.errors import LabkitError
from labkit.gcode import check, parse
from labkit.raster.io import read_image
from labkit.toolpath import MoveKind
from labkit.vector import read_dxf, read_svg

from .test_vector_files import dxf_text, svg

HOSTILE_TEXT = ["nan", "NaN", "inf", "-inf", "Infinity", "1e400", "-1e400", "1e308", "-1e308",
                "0", "-0", "1e-320", "-1", "1e20", "-1e20", "1" + "0" * 400, "", "x", "1e", "--1"]
numbers = st.one_of(st.sampled_from(HOSTILE_TEXT),
                    st.floats(allow_nan=True, allow_infinity=True).map(repr),
                    st.integers(-10**30, 10**30).map(str))
FUZZ = settings(max_examples=40, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])


def all_finite(*arrays) -> bool:
    return all(np.isfinite(np.asarray(a, float)).all() for a in arrays)


# --- readers ---------------------------------------------------------------------------------

@FUZZ
@given(st.lists(st.tuples(st.sampled_from(["G0", "G1", "G2", "G3", "G4", "G92", "M3", "M4", "S",
                                           "F", "G20", "G91"]),
                          st.lists(st.tuples(st.sampled_from("XYZIJKRFSP"), numbers), max_size=4)),
                min_size=1, max_size=6))
def test_gcode_reader(lines):
    text = "\n".join(cmd + " " + " ".join(w + v for w, v in words) for cmd, words in lines) + "\n"
    for diag in check(text):                                    # diagnostics, never an exception
        assert isinstance(diag, LabkitError) and diag.line >= 1
    try:
        moves = parse(text)
    except LabkitError:
        return
    assert all_finite(moves.start, moves.end, moves.s_word)


SHAPES = ['<rect x="{0}" y="{1}" width="{2}" height="{3}" stroke="#000"/>',
          '<circle cx="{0}" cy="{1}" r="{2}" stroke="#000"/>',
          '<ellipse cx="{0}" cy="{1}" rx="{2}" ry="{3}" stroke="#000"/>',
          '<line x1="{0}" y1="{1}" x2="{2}" y2="{3}" stroke="#000"/>',
          '<path d="M {0} {1} C {2} {3} {1} {0} {3} {2} A {2} {3} {0} 0 1 {1} {0} Z" stroke="#000"/>',
          '<polyline points="{0},{1} {2},{3} {1},{0}" stroke="#000"/>',
          '<g transform="matrix({0} {1} {2} {3} 0 0)"><rect width="3" height="4" stroke="#000"/></g>',
          '<g transform="rotate({0}) scale({1} {2})"><circle r="{3}" stroke="#000"/></g>']


@FUZZ
@given(st.lists(st.tuples(st.sampled_from(SHAPES), st.lists(numbers, min_size=4, max_size=4)),
                min_size=1, max_size=4),
       st.sampled_from(['', ' viewBox="0 0 40 40"', ' viewBox="{0} {1} {2} {3}"']))
def test_svg_reader(shapes, view):
    body = "".join(tpl.format(*vals) for tpl, vals in shapes)
    try:
        d = read_svg(svg(body, view.format(*shapes[0][1])), warn=False)
    except LabkitError:
        return
    for p in d.paths:
        assert all_finite(p.vertices, p.sweeps)


DXF_ENTITIES = [
    lambda a, b, c, d: [(0, "LINE"), (8, "0"), (10, a), (20, b), (11, c), (21, d)],
    lambda a, b, c, d: [(0, "CIRCLE"), (8, "0"), (10, a), (20, b), (40, c)],
    lambda a, b, c, d: [(0, "ARC"), (8, "0"), (10, a), (20, b), (40, c), (50, d), (51, a)],
    lambda a, b, c, d: [(0, "ELLIPSE"), (8, "0"), (10, a), (20, b), (11, c), (21, d), (40, a),
                        (41, b), (42, c)],
    lambda a, b, c, d: [(0, "INSERT"), (8, "0"), (2, "B"), (10, a), (20, b), (41, c), (42, d),
                        (50, a)],
]


@FUZZ
@given(st.lists(st.tuples(st.sampled_from(range(len(DXF_ENTITIES))),
                          st.lists(numbers, min_size=4, max_size=4)), min_size=1, max_size=3))
def test_dxf_reader(entities):
    text = dxf_text([DXF_ENTITIES[i](*v) for i, v in entities],
                    {"B": [[(0, "LINE"), (8, "0"), (10, 0), (20, 0), (11, 10), (21, 0)]]})
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "f.dxf")
        with open(path, "w") as f:
            f.write(text)
        try:
            d = read_dxf(path, warn=False)
        except LabkitError:
            return
    for p in d.paths:
        assert all_finite(p.vertices, p.sweeps)


@FUZZ
@given(st.binary(max_size=300), st.sampled_from([b"", b"\x89PNG\r\n\x1a\n", b"BM", b"\xff\xd8\xff"]))
def test_image_reader(data, magic):
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "f.img")
        with open(path, "wb") as f:
            f.write(magic + data)
        try:
            img = read_image(path)
        except LabkitError:
            return
    assert np.isfinite(np.asarray(img.pixels, float)).all()


# --- numeric options of every file command ---------------------------------------------------

def numeric_options(command):
    """(flag, action) for every option of ``command`` whose value is a number."""
    add, _ = cli.command_entry(command)
    parser = argparse.ArgumentParser()
    add(parser)
    out = []
    for action in parser._actions:
        if not action.option_strings or action.nargs == 0 or action.type in (None, str):
            continue
        if action.type in (int, float) or getattr(action.type, "__module__", "").startswith("labkit"):
            out.append(action.option_strings[-1])
    return out


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    d = tmp_path_factory.mktemp("fuzz")
    (d / "job.gcode").write_text("G21 G90\nG0 X1 Y1\nM3 S500\nG1 X5 Y1 F600\nG2 X5 Y5 I0 J2\nM5\n")
    (d / "art.svg").write_text(svg('<circle cx="20" cy="20" r="8" stroke="#000" fill="none"/>',
                                   ' viewBox="0 0 40 40"'))
    (d / "art.dxf").write_text(dxf_text([[(0, "CIRCLE"), (8, "0"), (10, 5), (20, 5), (40, 4)]]))
    from PIL import Image
    Image.fromarray(np.tile(np.linspace(0, 255, 16, dtype=np.uint8), (8, 1))).save(d / "img.png", dpi=(254, 254))
    return d


COMMANDS = {  # command → (input, output option or None)
    "check": ("job.gcode", None), "info": ("job.gcode", None), "preview": ("job.gcode", "-o"),
    "plan": ("job.gcode", None), "steps": ("job.gcode", "-o"),
    "svg2gcode": ("art.svg", "-o"), "dxf2gcode": ("art.dxf", "-o"), "img2gcode": ("img.png", "-o"),
}
#: options whose value is a string of numbers: fuzzed as "vxv"
SIZE_OPTIONS = [("check", "--envelope")]
CASES = [(c, o) for c in COMMANDS for o in numeric_options(c)] + SIZE_OPTIONS


def test_every_numeric_option_is_fuzzed():
    """The list is derived from the parsers, so a new numeric option is fuzzed too."""
    flags = {c: {o for cc, o in CASES if cc == c} for c in COMMANDS}
    assert {"--tol", "--power", "--s-max", "--passes", "--fill-spacing", "--kerf"} <= flags["svg2gcode"]
    assert {"--width", "--beam", "--threshold", "--gamma"} <= flags["img2gcode"]
    assert {"--buffer", "--arc-tol"} <= flags["plan"] and "--envelope" in flags["check"]


@pytest.mark.parametrize("command,option", CASES, ids=[f"{c} {o}" for c, o in CASES])
def test_numeric_option(inputs, tmp_path, command, option):
    src, out_flag = COMMANDS[command]

    @settings(max_examples=8, deadline=None, derandomize=True,
              suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
    @given(st.one_of(st.sampled_from(HOSTILE_TEXT + ["1e9", "1e-9", "3", "0.5"]),
                     st.floats(allow_nan=False, allow_infinity=False, width=32).map(repr)))
    def one(value):
        out = tmp_path / f"out-{command}.{'png' if command == 'preview' else 'csv' if command == 'steps' else 'gcode'}"
        with contextlib.suppress(FileNotFoundError):
            out.unlink()
        if (command, option) in SIZE_OPTIONS:
            value = f"{value}x{value}"
        argv = [command, str(inputs / src), f"{option}={value}"] + ([out_flag, str(out)] if out_flag else [])
        err = io.StringIO()
        try:
            with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
                code = cli.main(argv)
        except SystemExit as exc:                 # argparse: a usage error names the option
            assert exc.code == 2 and option in err.getvalue(), err.getvalue()
            return
        assert code in (0, 1), (code, err.getvalue())
        if code == 1:
            said = err.getvalue()           # check reports a job outside the envelope as diagnostics
            assert said.startswith(f"labkit {command}: ") or (command == "check" and "error(s)" in said), said
            assert not out.exists() or command in ("preview", "steps")
        elif out_flag and out.suffix == ".gcode":
            text = out.read_text()
            assert check(text) == [], (argv, check(text)[:3])
            moves = parse(text)
            cutting = moves.kind != MoveKind.RAPID            # a rapid has no feed (NaN)
            assert all_finite(moves.start, moves.end, moves.feed_mm_min[cutting], moves.s_word)
            s_values = [float(w[1:]) for w in text.split() if w[:1] == "S" and w[1:2].isdigit()]
            assert all(0 <= s <= 1000 or option == "--s-max" for s in s_values)
    one()
