"""labkit.toolpath.job: the vector pipeline the commands call, and Moves.motion_lines."""

from __future__ import annotations

import re
import warnings
from pathlib import Path as FilePath

import numpy as np
import pytest

from labkit.errors import GeometryError
from labkit.gcode import parse
from labkit.geometry import Path
from labkit.geometry.arcfit import tolerance_budget
from labkit.toolpath.build import LayerSettings
from labkit.toolpath.job import vector_job
from labkit.vector import read_dxf, read_svg

DATA = FilePath(__file__).resolve().parents[2] / "data"
SVGS = sorted((DATA / "svg").glob("*/*.svg"))[::3]


def regex_motion_lines(text: str) -> int:
    """Motion lines by reading the text: G0–G3, or a line opening with an axis word."""
    first = re.compile(r"^\s*(?:N\d+\s*)?([A-Z])\s*([-+]?\d*\.?\d*)", re.IGNORECASE)
    count = 0
    for line in text.splitlines():
        m = first.match(line)
        if m and (m.group(1).upper() in "XYZIJ" or (m.group(1).upper() == "G" and m.group(2)
                                                     and float(m.group(2)) in (0, 1, 2, 3))):
            count += 1
    return count


@pytest.mark.parametrize("path", SVGS, ids=[p.name for p in SVGS])
@pytest.mark.parametrize("arcs", [True, False])
def test_motion_lines_from_moves_equal_the_written_program(path, arcs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            d = read_svg(path, arcs=arcs, tol_mm=0.05)
        except Exception:           # noqa: BLE001 - refusals are another test's business
            return
    if not d.paths:
        return
    job = vector_job(d.paths, tol_mm=0.05, arcs=arcs)
    text = job.gcode()
    assert job.moves.motion_lines == regex_motion_lines(text) == parse(text).motion_lines


def test_written_resolution_follows_the_tolerance():
    """A 0.01 mm job is written to 1 µm (3 decimals), a 0.002 mm one to 0.2 µm (4 decimals);
    a coarse tolerance still writes 1 µm (finer than any laser machine, and free)."""
    square = [Path.rectangle(0.12345, 0, 10.98765 - 0.12345, 5)]
    fine = vector_job(square, tol_mm=0.01).gcode()
    finer = vector_job(square, tol_mm=0.002).gcode()
    coarse = vector_job(square, tol_mm=0.5).gcode()
    assert "X0.123\n" in fine and "X10.988 " in fine and "X0.123\n" in coarse
    assert re.search(r"X0\.123\d\n", finer) and re.search(r"X10\.987\d ", finer)
    for text, tol in ((fine, 0.01), (finer, 0.002), (coarse, 0.5)):
        end = parse(text).end[-4:, :2]
        exact = np.array([[10.98765, 0], [10.98765, 5], [0.12345, 5], [0.12345, 0]])
        assert np.abs(np.sort(end, axis=0) - np.sort(exact, axis=0)).max() <= tolerance_budget(tol).emit_mm


def test_dxf_without_arcs_stays_within_the_tolerance():
    """read_dxf(arcs=False) reads at half the tolerance and chords at the other half: the cut
    lies within the tolerance of the arcs of parts_mm.dxf, with no arc left."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        exact = read_dxf(DATA / "dxf" / "parts_mm.dxf", tol_mm=0.001)
        lines = read_dxf(DATA / "dxf" / "parts_mm.dxf", tol_mm=0.02, arcs=False)
    assert not any(p.is_arc.any() for p in lines.paths)
    from labkit.geometry import hausdorff

    for a, b in zip(exact.paths, lines.paths):
        assert hausdorff([a], [b]) <= 0.02 + 0.001
    assert max(p.deviation_mm for p in lines.paths) <= 0.02


def test_errors_name_what_is_wrong():
    sq = [Path.rectangle(0, 0, 5, 5)]
    with pytest.raises(GeometryError, match=r"power S1200 is above s_max 1000"):
        vector_job(sq, default=LayerSettings(600, 1200))
    with pytest.raises(GeometryError, match=r"arcs=False but the paths hold arcs"):
        vector_job([Path.circle((0, 0), 3)], arcs=False)
    with pytest.raises(GeometryError, match=r"tol_mm must be a finite number > 0 mm"):
        vector_job(sq, tol_mm=float("nan"))
