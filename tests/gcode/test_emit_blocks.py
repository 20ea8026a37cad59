"""emit writes in blocks of rows (issue 27's memory): the text is the one-block text, byte
for byte, wherever the blocks end — modal words, records, numbering and checksums carry over."""

from __future__ import annotations

import warnings
from pathlib import Path

import pytest

from labkit.gcode import emit, parse, writer

ROOT = Path(__file__).resolve().parents[2]


def _programs():
    from labkit.toolpath.build import LayerSettings
    from labkit.toolpath.job import vector_job
    from labkit.vector import read_svg

    gcode = ROOT / "data" / "gcode" / "cncjs"
    yield "jsdc-laser", parse((gcode / "jsdc-laser.gcode").read_bytes(), lenient=True)
    yield "calibration", parse((gcode / "Circle_Diamond_Square_Calibration.gcode").read_bytes(), lenient=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        drawing = read_svg(ROOT / "data" / "svg" / "cncjs" / "jsdc.svg", tol_mm=0.01)
    yield "jsdc.svg arcs", vector_job(drawing.paths, default=LayerSettings(feed_mm_min=900, s_word=700),
                                      arcs=True, tol_mm=0.01).moves
    yield "records", parse("G21 G90\n$H\nM3 S300\nG1 X1 F100\nM0\nG2 X3 I1\nG4 P0.5\nM2\nG0 X0\nM30\n")


@pytest.mark.parametrize("dialect", ["grbl", "labkit-fw", "marlin"])
def test_blocks_of_any_size_write_the_same_text(dialect, monkeypatch):
    for name, moves in _programs():
        for options in ({}, {"arcs": "r"}, {"travel_beam_off": True}):
            monkeypatch.setattr(writer, "EMIT_ROWS", len(moves) + 1)
            whole = emit(moves, dialect=dialect, **options)
            for rows in (1, 2, 7):
                monkeypatch.setattr(writer, "EMIT_ROWS", rows)
                assert emit(moves, dialect=dialect, **options) == whole, (name, options, rows)
    assert "$H" in whole and "M0" in whole and "M30" in whole and "G4 P" in whole
