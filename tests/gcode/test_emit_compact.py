"""Compact G-code (issue 30 §3): fewer bytes, the same program.

The checks are independent of the writer's own choice: every assignment of G90/G91 to the lines
of small programs is written and measured (the chosen one must be the shortest), and the text is
read back by the parser and compared with the spaced, absolute text of the same Moves.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from labkit.gcode import _emit_kernel as EK, emit, parse, writer
from labkit.toolpath import LaserMode, MovesBuilder


def _scan(xs, ss, y=0.05, feed=1000):
    """A raster row: a rapid to its start, then lines at power S (hand-made, like a gray row)."""
    b = MovesBuilder(feed_mm_min=feed, s_word=0, laser=LaserMode.DYNAMIC)
    b.rapid(x=xs[0], y=y)
    for x, s in zip(xs[1:], ss):
        b.line(x=x, s_word=s)
    return b.build()


def test_hand_worked_row():
    m = _scan([10.0, 10.1, 10.3, 10.2, 9.9, 10.0, 10.1, 10.2], [868, 5, 0, 1000, 1, 2, 3])
    text = emit(m, header=False, footer=False, compact=True)
    # By hand: absolute X words X10.1 … X10.2 take 32 characters, relative ones 23, plus 3 for
    # G91 and 4 for the closing G90 line: 30. From the origin a relative rapid reads the same
    # as an absolute one, so the switch goes on the first line.
    assert text == ("M4S0\nG91G0X10Y.05\nG1X.1F1000S868\nX.2S5\nX-.1S0\nX-.3S1000\nX.1S1\nX.1S2\n"
                    "X.1S3\nG90\n")
    assert len(emit(m, header=False, footer=False, compact=True)) < len(
        emit(m, header=False, footer=False).replace(" ", ""))     # spaces alone are not the gain
    back = parse(text)
    np.testing.assert_allclose(back.end, m.end, atol=1e-9)
    np.testing.assert_array_equal(back.s_word, m.s_word)


def test_marlin_is_refused():
    with pytest.raises(ValueError, match="not marlin"):
        emit(_scan([0.0, 1.0], [5]), dialect="marlin", compact=True)


def _lines_program(data):
    b = MovesBuilder(feed_mm_min=600, s_word=0, laser=LaserMode.CONSTANT)
    for kind, x, y in data:
        (b.rapid if kind == 0 else b.line)(x=x / 20, y=y / 20)
    return b.build()


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 1), st.integers(-4000, 4000), st.integers(-40, 40)),
                min_size=1, max_size=7))
def test_the_chosen_distance_modes_give_the_shortest_text(data):
    m = _lines_program(data)
    chosen = emit(m, header=False, compact=True)
    lengths = []
    real = EK.choose_relative
    try:
        for modes in itertools.product((0, 1), repeat=len(m)):
            EK.choose_relative = lambda *args, modes=modes: np.array(modes, np.int8)
            lengths.append(len(emit(m, header=False, compact=True)))
    finally:
        EK.choose_relative = real
    assert len(chosen) == min(lengths)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 1), st.integers(-4000, 4000), st.integers(-40, 40)),
                min_size=1, max_size=40), st.sampled_from(["grbl", "labkit-fw"]))
def test_compact_reads_back_as_the_spaced_text_and_is_never_longer(data, dialect):
    m = _lines_program(data)
    spaced = emit(m, dialect=dialect)
    compact = emit(m, dialect=dialect, compact=True)
    assert len(compact) <= len(spaced)
    a, b = parse(spaced, dialect=dialect), parse(compact, dialect=dialect)
    assert a.diagnostics == () and b.diagnostics == ()
    np.testing.assert_array_equal(a.kind, b.kind)
    np.testing.assert_allclose(a.end, b.end, atol=1e-9)
    np.testing.assert_array_equal(a.s_word, b.s_word)
    np.testing.assert_array_equal(a.feed_mm_min, b.feed_mm_min)


def test_blocks_of_any_size_write_the_same_program(monkeypatch):
    rng = np.random.default_rng(3)
    xs = np.round(np.cumsum(rng.choice([-0.3, -0.1, 0.1, 0.2, 5.0], 300)), 1) + 50
    m = _scan(list(xs), list(rng.integers(0, 1000, 299)))
    whole = parse(emit(m, compact=True))
    for rows in (1, 2, 7):
        monkeypatch.setattr(writer, "EMIT_ROWS", rows)
        back = parse(emit(m, compact=True))
        np.testing.assert_allclose(back.end, whole.end, atol=1e-9)
        np.testing.assert_array_equal(back.s_word, whole.s_word)


def _random_block(rng, n, scale):
    """Rows of every kind (dwells and arcs among straight moves), with repeats of a position."""
    kind = rng.choice([EK.RAPID, EK.LINE, EK.LINE, EK.ARC_CW, EK.ARC_CCW, EK.DWELL], n).astype(np.int64)
    end = (rng.integers(-5, 6, (n, 3)) * scale + rng.integers(-3, 4, (n, 3))).astype(np.int64)
    if n > 1:
        end[rng.integers(0, n, n // 2)] = end[0]                 # lines that do not move
    return kind, end


@pytest.mark.parametrize("seed", range(4))
def test_choose_relative_as_python_equals_the_kernel(seed):
    """The numpy twin that runs below python_below (so a small job does not load numba for
    its G90/G91 choice) picks the kernel's modes, tie for tie: against the kernel's own code
    as Python and compiled, on random blocks of every move kind, scale and mode before."""
    from labkit import _jit

    rng = np.random.default_rng(seed)
    for _ in range(200):
        n = int(rng.integers(0, 60))
        decimals = int(rng.integers(0, 6))
        kind, end = _random_block(rng, n, int(rng.choice([1, 10, 1000, 10 ** decimals, 10 ** 7])))
        cur0 = rng.integers(-20, 20, 3).astype(np.int64) * 1000
        relative0, last = int(rng.integers(0, 2)), bool(rng.integers(0, 2))
        twin = EK._choose_relative_numpy(kind, end, cur0, relative0, decimals, last)
        assert np.array_equal(twin, EK.choose_relative.py_func(kind, end, cur0, relative0, decimals, last))
        with _jit.forced("compiled"):
            assert np.array_equal(twin, EK.choose_relative(kind, end, cur0, relative0, decimals, last))


def test_a_zigzag_job_writes_compact_gcode_without_loading_numba(tmp_path):
    """Issue 29's regression: the G90/G91 choice had no Python path, so the 4096² zig-zag's
    10,076 moves loaded numba (about 1 s) to write what Python writes in 0.08 s. A job of that
    size now writes compact G-code as Python by the rule, the same text as compiled."""
    import subprocess
    import sys

    script = (
        "import sys, numpy as np\n"
        "from labkit.toolpath import LaserMode, MovesBuilder\n"
        "from labkit.gcode import emit\n"
        "b = MovesBuilder(feed_mm_min=1000, s_word=1000, laser=LaserMode.CONSTANT)\n"
        "rng = np.random.default_rng(0)\n"
        "for r in range(2519):\n"
        "    x0, x1 = sorted(rng.integers(0, 4096, 2) / 10)\n"
        "    b.rapid(x=x0 if r % 2 else x1, y=r / 10)\n"
        "    b.line(x=x1 if r % 2 else x0)\n"
        "    b.rapid(x=x1 if r % 2 else x0, y=r / 10 + 0.05)\n"
        "    b.line(x=x0 if r % 2 else x1)\n"
        "sys.stdout.write(emit(b.build(), compact=True))\n"
        "sys.stderr.write(str('numba' in sys.modules))\n")
    env = {k: v for k, v in __import__("os").environ.items() if k != "LABKIT_JIT"}
    auto = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True)
    compiled = subprocess.run([sys.executable, "-c", script], env=dict(env, LABKIT_JIT="compiled"),
                              capture_output=True, text=True)
    assert auto.returncode == 0 and compiled.returncode == 0, auto.stderr + compiled.stderr
    assert auto.stdout.count("\n") > 10_000
    assert auto.stderr == "False" and compiled.stderr == "True"
    assert auto.stdout == compiled.stdout
