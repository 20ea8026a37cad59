"""summarize works in blocks of rows (issue 27's memory): the same summary whatever the block."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from labkit.gcode import parse, simulate

GCODE = Path(__file__).resolve().parents[2] / "data" / "gcode" / "cncjs"


@pytest.mark.parametrize("name", ["Circle_Diamond_Square_Calibration.gcode", "jsdc-laser.gcode"])
def test_blocks_of_seven_rows_give_the_one_block_summary(name, monkeypatch):
    """Real programs (75 arcs; 2,360 cuts); blocks of 7 rows split arcs, cuts and dwells
    from their neighbours: every figure as one block gives it (sums to 1e-12)."""
    moves = parse((GCODE / name).read_bytes(), lenient=True)
    monkeypatch.setattr(simulate, "SUMMARY_ROWS", len(moves) + 1)
    whole = simulate.summarize(moves).to_dict()
    monkeypatch.setattr(simulate, "SUMMARY_ROWS", 7)
    blocks = simulate.summarize(moves).to_dict()
    assert blocks.keys() == whole.keys()
    for key, value in whole.items():
        if isinstance(value, float):
            assert blocks[key] == pytest.approx(value, rel=1e-12, abs=1e-12), key
        elif key.endswith("bounds"):
            np.testing.assert_array_equal(blocks[key], value)
        else:
            assert blocks[key] == value, key
    lengths = moves.lengths_mm()                               # by hand: the cut length
    assert whole["cut_length_mm"] == pytest.approx(float(lengths[moves.laser_on].sum()), rel=1e-12)
