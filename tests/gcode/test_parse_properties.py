"""Property tests: random programs against pygcode, random text never crashes the parser."""

import math

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from labkit.errors import GcodeError
from labkit.gcode import parse

from ._pygcode_peer import positions_by_line

coord = st.floats(min_value=-500, max_value=500, allow_nan=False).map(lambda v: round(v, 4))


@st.composite
def programs(draw):
    """Random G90/G91 programs of G0, G1 and consistent G2/G3 (I J) moves, 4 decimals."""
    lines = ["G21 G90 G17 F600"]
    x = y = 0.0
    absolute = True
    motion = "G0"
    for _ in range(draw(st.integers(1, 25))):
        op = draw(st.sampled_from(["G0", "G1", "G2", "G3", "G90", "G91", "modal"]))
        if op in ("G90", "G91"):
            absolute = op == "G90"
            lines.append(op)
        elif op in ("G0", "G1", "modal"):
            if op == "modal" and motion not in ("G0", "G1"):
                op = "G1"          # a bare X Y after G2/G3 would be an arc without I J
            if op != "modal":
                motion = op
            nx, ny = draw(coord), draw(coord)
            if absolute:
                text = f"X{nx:.4f} Y{ny:.4f}"
                x, y = nx, ny
            else:
                text = f"X{nx:.4f} Y{ny:.4f}"
                x, y = x + nx, y + ny
            lines.append(text if op == "modal" else f"{op} {text}")
        else:
            motion = op
            r = draw(st.floats(1.0, 100.0))
            a0 = draw(st.floats(0, 2 * math.pi))
            turn = draw(st.floats(0.1, 6.0))
            ccw = op == "G3"
            cx, cy = x - r * math.cos(a0), y - r * math.sin(a0)
            a1 = a0 + (turn if ccw else -turn)
            ex, ey = round(cx + r * math.cos(a1), 4), round(cy + r * math.sin(a1), 4)
            i, j = round(cx - x, 4), round(cy - y, 4)
            words = f"X{ex:.4f} Y{ey:.4f}" if absolute else f"X{ex - x:.4f} Y{ey - y:.4f}"
            lines.append(f"{op} {words} I{i:.4f} J{j:.4f}")
            x, y = (ex, ey) if absolute else (x + round(ex - x, 4), y + round(ey - y, 4))
    return "\n".join(lines)


@given(programs())
def test_random_programs_end_where_pygcode_ends(text):
    expected, arc_words = positions_by_line(text)
    m = parse(text)
    last = np.searchsorted(m.line, np.arange(1, len(expected) + 1), side="right") - 1
    ends = np.vstack([np.zeros((1, 3)), m.end])          # row 0: the origin, before any move
    ours = ends[last + 1]
    np.testing.assert_allclose(ours, expected, atol=1e-9)
    for i in np.flatnonzero(m.is_arc):
        words = arc_words[int(m.line[i])]
        np.testing.assert_allclose(m.centre[i, :2] - m.start[i, :2], [words["I"], words["J"]],
                                   atol=1e-9)


@given(st.text(alphabet="GMXYZIJKRFSPN0123456789.-+ ;()*%$\n\tabc#", max_size=200))
def test_arbitrary_text_is_either_accepted_or_rejected_with_a_gcode_error(text):
    m = parse(text, lenient=True)
    for err in m.diagnostics:
        assert isinstance(err, GcodeError)
        assert 1 <= err.line <= text.count("\n") + 1
        assert err.column >= 1
    try:
        strict = parse(text)
    except GcodeError as exc:
        assert m.diagnostics and exc.line == m.diagnostics[0].line
    else:
        assert not m.diagnostics and len(strict) == len(m)


@given(st.floats(min_value=-1e6, max_value=1e6, allow_nan=False), st.integers(0, 6))
def test_numbers_read_back_exactly(value, decimals):
    text = f"{value:.{decimals}f}"
    assert parse(f"G0 X{text}").end[0, 0] == float(text)
