"""labkit._jit: kernels run as Python below a size give the compiled results, and a
small job from the command line imports neither numba nor scipy."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from labkit import _jit
from labkit.gcode import _kernel as K
from labkit.gcode import emit, parse

ROOT = Path(__file__).resolve().parents[1]
CORPUS = sorted(p for p in (ROOT / "data" / "gcode").rglob("*.gcode") if p.stat().st_size < 100_000)

# Lines that reach the corners of the scanner and the checks: long and odd numbers,
# comments, checksums, every rejection the kernel knows of, arcs by R and by I J.
TRICKY = b"""G21 G90 G17
N10 G0 X1.5 Y-2.25 (comment) ; rest
G1 X123456789012345678 Y0 F100
G1 X12345678901234567890 Y1
G1 X0.000000000000000000000001 Y2 F1200 S200
G1 X1..2
G1 X5x
G1 Q5
G2 X10 Y0 R5
G2 X10 Y0 I5 J0
G3 X0 Y0 R-5
G2 X0 Y0 R0
G4 P-1
M3 S255
N5 G1 X1 Y1*99
G1 X1 Y1*
G12
M99
$H
%
(unclosed
G1 X3 Y3 G0
G1 X-0 Y+0
/G1 X4 Y4
M5
M2
"""


def _both(fn, *args, **kwargs):
    with _jit.forced("python"):
        as_python = fn(*args, **kwargs)
    with _jit.forced("compiled"):
        compiled = fn(*args, **kwargs)
    return as_python, compiled


def _same_moves(a, b):
    assert len(a) == len(b)
    for name in a.column_names():
        x, y = np.asarray(getattr(a, name)), np.asarray(getattr(b, name))
        assert np.array_equal(x, y, equal_nan=x.dtype.kind == "f"), name
    assert [e.format() for e in a.diagnostics] == [e.format() for e in b.diagnostics]
    assert repr(a.records) == repr(b.records)


@pytest.mark.parametrize("path", CORPUS, ids=lambda p: p.name)
def test_parse_as_python_equals_compiled_on_the_corpus(path):
    data = path.read_bytes()
    a, b = _both(parse, data, lenient=True, streaming=True)
    _same_moves(a, b)
    text_a, text_b = _both(emit, a)
    assert text_a == text_b


@pytest.mark.parametrize("dialect", ["grbl", "marlin"])
def test_parse_as_python_equals_compiled_on_tricky_lines(dialect):
    a, b = _both(parse, TRICKY, dialect=dialect, lenient=True)
    assert a.diagnostics, "the tricky lines must be rejected somewhere"
    _same_moves(a, b)
    assert _both(emit, a, arcs="r")[0] == _both(emit, a, arcs="r")[1]


def test_auto_mode_runs_small_inputs_as_python_and_large_ones_compiled(monkeypatch):
    calls = []

    @_jit.jit(python_below=100)
    def total(a):
        s = 0.0
        for v in a:
            s += v
        return s

    monkeypatch.setattr(_jit, "DEFAULT_MODE", "auto")
    monkeypatch.delenv("LABKIT_JIT", raising=False)
    original = total.run_python
    monkeypatch.setattr(total, "run_python", lambda *a: calls.append(len(a[0])) or original(*a))
    assert total(np.arange(10.0)) == 45.0
    assert calls == [10] and total.dispatcher is None
    assert total(np.arange(1000.0)) == 499500.0
    assert calls == [10] and total.dispatcher is not None


def test_once_numba_is_loaded_only_tiny_inputs_run_as_python(monkeypatch):
    @_jit.jit(python_below=100_000)
    def count(a):
        return a.shape[0]

    monkeypatch.setattr(_jit, "DEFAULT_MODE", "auto")
    monkeypatch.delenv("LABKIT_JIT", raising=False)
    monkeypatch.setattr(_jit, "_numba_loaded", [False])
    assert count(np.zeros(50_000)) == 50_000 and count.dispatcher is None
    monkeypatch.setattr(_jit, "_numba_loaded", [True])
    assert count(np.zeros(10)) == 10 and count.dispatcher is None
    assert count(np.zeros(50_000)) == 50_000 and count.dispatcher is not None


def test_kernels_call_kernels_in_both_modes():
    @_jit.jit
    def twice(x):
        return 2 * x

    @_jit.jit
    def apply(a):
        out = np.empty_like(a)
        for i in range(a.shape[0]):
            out[i] = twice(a[i])
        return out

    a = np.arange(5.0)
    with _jit.forced("python"):
        assert apply(a).tolist() == [0, 2, 4, 6, 8]
        assert apply.dispatcher is None
    with _jit.forced("compiled"):
        assert apply(a).tolist() == [0, 2, 4, 6, 8]
    assert apply.dispatcher is not None and twice.dispatcher is not None


def test_bad_mode_is_a_clear_error(monkeypatch):
    monkeypatch.setenv("LABKIT_JIT", "fast")
    with pytest.raises(ValueError, match="LABKIT_JIT='fast'"):
        _jit.mode()


def _run_labkit(*args, code=None):
    env = {k: v for k, v in os.environ.items() if k not in ("LABKIT_JIT", "NUMBA_DISABLE_JIT")}
    env["PYTHONPATH"] = str(ROOT)
    probe = ("import sys, runpy; sys.argv = ['labkit', *sys.argv[1:]]\n"
             "try:\n    runpy.run_module('labkit', run_name='__main__')\n"
             "except SystemExit as e:\n    code = e.code\n"
             "print(sorted(m for m in ('numba', 'scipy', 'skimage', 'matplotlib', 'llvmlite')"
             " if m in sys.modules), file=sys.stderr)\n")
    return subprocess.run([sys.executable, "-c", code or probe, *args], capture_output=True,
                          text=True, env=env, cwd=ROOT, timeout=300)


def test_check_and_info_on_a_small_file_import_no_compiler():
    small = ROOT / "data" / "gcode" / "cncjs" / "jsdc-laser.gcode"
    for command in ("check", "info"):
        out = _run_labkit(command, str(small))
        assert "ok, 2418 lines" in out.stderr or "moves" in out.stdout, out.stderr
        assert out.stderr.strip().splitlines()[-1] == "[]", out.stderr


def test_importing_the_package_and_gcode_loads_no_compiler():
    out = _run_labkit(code="import sys, labkit, labkit.gcode, labkit.raster, labkit.cli\n"
                           "print(sorted(m for m in ('numba', 'scipy', 'skimage', 'matplotlib')"
                           " if m in sys.modules))")
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"


def test_svg2gcode_on_a_small_drawing_imports_no_compiler_and_writes_the_compiled_result(tmp_path):
    """A 578-segment drawing runs its geometry kernels (flattening, deviation, ordering, 2-opt,
    emission) as Python — no numba, no scipy — and writes byte for byte what the compiled
    kernels write."""
    svg = ROOT / "data" / "svg" / "cncjs" / "jsdc.svg"
    out = _run_labkit("svg2gcode", str(svg), "-o", str(tmp_path / "py.gcode"))
    assert out.returncode == 0, out.stderr
    assert out.stderr.strip().splitlines()[-1] == "[]", out.stderr
    env = dict(os.environ, PYTHONPATH=str(ROOT), LABKIT_JIT="compiled")
    done = subprocess.run([sys.executable, "-m", "labkit", "svg2gcode", str(svg), "-o", str(tmp_path / "nb.gcode")],
                          capture_output=True, text=True, env=env, cwd=ROOT, timeout=600)
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "py.gcode").read_bytes() == (tmp_path / "nb.gcode").read_bytes()
