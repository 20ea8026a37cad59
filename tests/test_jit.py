"""labkit._jit: kernels run as Python below a size give the compiled results, and a
small job from the command line imports neither numba nor scipy."""

import os
import subprocess
import sys
import threading
import time
import types
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


@pytest.mark.parametrize("path", CORPUS[:6], ids=lambda p: p.name)
def test_the_writer_as_python_equals_compiled_with_line_numbers_checksums_and_compact_words(path):
    """The writer's Python twins (numbers by ``str``, lines moved by slices) against the
    compiled writer, digit by digit: Marlin's N words and ``*`` checksums, GRBL's compact
    words and G90/G91 choice."""
    moves = parse(path.read_bytes(), lenient=True)
    for options in ({"dialect": "marlin"}, {"compact": True}, {"arcs": "r", "tol_mm": 0.01}):
        text_a, text_b = _both(emit, moves, **options)
        assert text_a == text_b and len(text_a) > 100


@pytest.mark.parametrize("dialect", ["grbl", "marlin"])
def test_parse_as_python_equals_compiled_on_tricky_lines(dialect):
    a, b = _both(parse, TRICKY, dialect=dialect, lenient=True)
    assert a.diagnostics, "the tricky lines must be rejected somewhere"
    _same_moves(a, b)
    assert _both(emit, a, arcs="r")[0] == _both(emit, a, arcs="r")[1]


@pytest.fixture
def fresh_process(monkeypatch):
    """Auto mode as in a new process: numba not loaded, no Python time spent yet, a CPU
    clock that the test moves (each kernel run as Python costs ``clock.step`` seconds)."""
    clock = types.SimpleNamespace(now=0.0, step=0.0)

    def read():
        clock.now += clock.step               # read at a run's start and end: a run takes step
        return clock.now

    monkeypatch.setattr(_jit, "DEFAULT_MODE", "auto")
    monkeypatch.delenv("LABKIT_JIT", raising=False)
    monkeypatch.delenv("NUMBA_DISABLE_JIT", raising=False)
    monkeypatch.setattr(_jit, "_numba_loaded", [False])
    monkeypatch.setattr(_jit, "_spent", [0.0])
    monkeypatch.setattr(_jit, "_jobs", [])
    monkeypatch.setattr(_jit, "_ahead", [])
    monkeypatch.setattr(_jit, "_after", [])
    monkeypatch.setattr(_jit, "_cpu_clock", read)
    return clock


def _recording_kernel(monkeypatch, python_below):
    """A kernel whose calls are recorded as "py" or "nb"; its compiled path is a stand-in
    that marks numba as loaded, as the real one does (no compiling in these tests)."""
    calls = []

    @_jit.jit(python_below=python_below)
    def total(a):
        s = 0.0
        for v in a:
            s += v
        return s

    original = total.run_python

    def compiled_stand_in(*args):
        calls.append("nb")
        return float(np.sum(args[0]))

    def load():
        _jit._numba_loaded[0] = True
        return compiled_stand_in

    monkeypatch.setattr(total, "run_python", lambda *a, **k: calls.append("py") or original(*a, **k))
    monkeypatch.setattr(total, "compiled", load)
    return total, calls


def test_auto_mode_runs_small_inputs_as_python_and_large_ones_compiled(fresh_process, monkeypatch):
    total, calls = _recording_kernel(monkeypatch, python_below=100)
    assert total(np.arange(10.0)) == 45.0
    assert total(np.arange(1000.0)) == 499500.0
    assert calls == ["py", "nb"]


def test_a_kernel_whose_machine_code_is_loaded_runs_compiled_at_once(fresh_process, monkeypatch):
    """Once a kernel's machine code is in the process (its dispatcher made: compiled, or loaded
    from the cache), loading it costs nothing more, so every call runs it compiled at once —
    the tiniest input and with nothing spent as Python, where a kernel not loaded yet runs such
    an input as Python (issue 29: a process converting many small drawings after the first)."""
    fresh_process.step = 0.01
    total, calls = _recording_kernel(monkeypatch, python_below=10**9)
    total(np.ones(3))
    assert calls == ["py"] and _jit._spent[0] == pytest.approx(0.01)
    monkeypatch.setattr(total, "dispatcher", lambda *a: calls.append("nb") or float(np.sum(a[0])))
    monkeypatch.setattr(_jit, "_spent", [0.0])
    assert total(np.ones(1)) == 1.0 and total(np.ones(4)) == 4.0
    assert calls == ["py", "nb", "nb"]


def test_rule_state_changes_until_the_work_neither_loads_code_nor_runs_as_python(fresh_process, monkeypatch):
    """What benchmarks wait for before timing a warm process: the state moves while the rule
    still runs a kernel as Python or loads one, and holds once every call runs compiled."""
    fresh_process.step = 0.01
    total, calls = _recording_kernel(monkeypatch, python_below=10**9)
    start = _jit.rule_state()
    total(np.ones(3))                                   # as Python: the tally moves
    after_python = _jit.rule_state()
    assert after_python != start and after_python[2] == pytest.approx(start[2] + 0.01)
    _jit._numba_loaded[0] = True                        # its machine code loaded
    monkeypatch.setattr(total, "dispatcher", lambda *a: calls.append("nb") or float(np.sum(a[0])))
    loaded = _jit.rule_state()
    assert loaded[0] and total.name in loaded[1] and loaded != after_python
    total(np.ones(3))
    assert calls == ["py", "nb"] and _jit.rule_state() == loaded


def test_a_kernel_sized_by_its_work_decides_by_that_work(fresh_process):
    """``work=``: a call's size for the rule from its arguments (a traced parse costs six times
    a plain one as Python), not its array elements alone."""
    calls = []

    @_jit.jit(python_below=100, work=lambda a, heavy: len(a) * (6 if heavy else 1))
    def total(a, heavy):
        return float(np.sum(a))

    total.run_python = lambda *a, **k: calls.append("py") or 0.0
    total.compiled = lambda: _jit._numba_loaded.__setitem__(0, True) or (lambda *a: calls.append("nb") or 0.0)
    total(np.ones(50), False)                      # 50 < 100: Python
    assert calls == ["py"]
    total(np.ones(50), True)                       # 300 ≥ 100: compiled
    assert calls == ["py", "nb"]


def test_the_parse_counts_a_traced_reading_as_six_plain_ones():
    from labkit.gcode import _kernel as K

    buf = np.zeros(1000, np.uint8)
    assert K.interpret.work(buf, None, False, 1, False) == 1000
    assert K.interpret.work(buf, None, False, 1, True) == 6000


def test_once_numba_is_loaded_only_tiny_inputs_run_as_python(fresh_process, monkeypatch):
    count, calls = _recording_kernel(monkeypatch, python_below=100_000)
    count(np.zeros(50_000))
    assert calls == ["py"]
    _jit._numba_loaded[0] = True
    count(np.zeros(10))
    count(np.zeros(50_000))
    assert calls == ["py", "py", "nb"]


def test_the_tally_goes_compiled_once_python_time_would_have_paid_for_numba(fresh_process, monkeypatch):
    """Many small calls (each far below python_below): Python until the CPU time they took
    reaches LOAD_COST_S, then compiled for the rest of the process."""
    monkeypatch.setattr(_jit, "LOAD_COST_S", 1.0)
    fresh_process.step = 0.3
    total, calls = _recording_kernel(monkeypatch, python_below=10**9)
    for _ in range(6):
        total(np.ones(5000))
    # after 3 runs 0.9 s is spent (< 1 s): a 4th runs as Python; after it 1.2 s ≥ 1 s
    assert calls == ["py"] * 4 + ["nb"] * 2
    assert _jit._spent[0] == pytest.approx(1.2)


@pytest.mark.parametrize("units", range(1, 31))
def test_a_job_is_decided_from_its_first_unit_and_costs_at_most_a_fifth_more_than_the_better_path(
        fresh_process, monkeypatch, units):
    """The rule at the crossover. A job of ``units`` units, each a kernel call taking 0.1 s
    as Python and 0.1 × 0.05 s compiled, with LOAD_COST_S = 1 s: the crossover is at 10
    units (1 s as Python against 1 s to load). Below it every unit runs as Python; at and
    above it the first unit runs as Python and the rest compiled. What the job then costs
    (in this model of the two paths) is within 20 % of the better of all-Python and
    all-compiled at every size — the first unit (here 10 % of the crossover) is the price."""
    load, per_unit, speedup = 1.0, 0.1, 0.05
    monkeypatch.setattr(_jit, "LOAD_COST_S", load)
    fresh_process.step = per_unit
    total, calls = _recording_kernel(monkeypatch, python_below=10**9)
    for _ in _jit.job_units(range(units)):
        total(np.ones(5000))
    crossover = round(load / per_unit)
    if units < crossover:
        assert calls == ["py"] * units
    else:
        assert calls == ["py"] + ["nb"] * (units - 1)
    cost = (calls.count("py") * per_unit + calls.count("nb") * per_unit * speedup
            + (load if "nb" in calls else 0.0))
    better = min(units * per_unit, load + units * per_unit * speedup)
    assert cost <= 1.2 * better + 1e-12
    assert _jit._jobs == []


def test_the_tally_carries_over_from_one_job_to_the_next(fresh_process, monkeypatch):
    """Ten jobs of 4 units (0.4 s as Python each, below the 1 s load) in one process: the
    third job goes compiled once Python time spent plus its projection reaches the load."""
    monkeypatch.setattr(_jit, "LOAD_COST_S", 1.0)
    fresh_process.step = 0.1
    total, calls = _recording_kernel(monkeypatch, python_below=10**9)
    per_job = []
    for _ in range(10):
        before = len(calls)
        for _ in _jit.job_units(range(4)):
            total(np.ones(5000))
        per_job.append(calls[before:])
    assert per_job[0] == per_job[1] == ["py"] * 4
    # job 3: 0.8 s spent; after its first unit 0.9 s + 3 units × 0.1 s projected ≥ 1 s
    assert per_job[2] == ["py"] + ["nb"] * 3
    assert all(j == ["nb"] * 4 for j in per_job[3:])


@pytest.mark.parametrize("later_units", range(0, 31))
def test_work_declared_ahead_decides_the_first_kernel_for_the_whole_job(fresh_process, monkeypatch,
                                                                        later_units):
    """A job that runs kernel A (3,000 elements, 0.3 s as Python) and then kernel B on
    ``later_units`` units (1,000 elements and 0.1 s as Python each); both declare
    python_below 10,000 (what their elements cost), LOAD_COST_S = 1 s, compiled runs take 5 %
    of Python's time. With B's work declared while A runs, A runs compiled exactly when the
    whole job would pay for numba (0.3 s + B's units ≥ 1 s: from 7 units on), and the job
    costs within 20 % of the better of all-Python and all-compiled at every size;
    undeclared, A runs as Python and B then loads numba anyway: more than 1.2 × the better
    path from 7 units on."""
    load, a_s, b_s, fast = 1.0, 0.3, 0.1, 0.05
    monkeypatch.setattr(_jit, "LOAD_COST_S", load)
    costs = {}
    for declared in (True, False):
        monkeypatch.setattr(_jit, "_numba_loaded", [False])
        monkeypatch.setattr(_jit, "_spent", [0.0])
        a, a_calls = _recording_kernel(monkeypatch, python_below=10_000)
        b, b_calls = _recording_kernel(monkeypatch, python_below=10_000)
        fresh_process.step = a_s                     # what a run as Python takes
        with _jit.expecting({b: 1000 * later_units} if declared else {}):
            a(np.ones(3000))
        assert _jit._ahead == []                    # the declaration ends with its block
        fresh_process.step = b_s * later_units
        if later_units:
            b(np.ones(1000 * later_units))
        cost = sum(t * (fast if c == "nb" else 1.0) for t, calls in ((a_s, a_calls), (b_s * later_units, b_calls))
                   for c in calls) + (load if "nb" in a_calls + b_calls else 0.0)
        costs[declared] = cost
        whole = 3000 / 10_000 * load + 1000 * later_units / 10_000 * load     # the job's Python, projected
        if declared:
            assert a_calls == (["nb"] if whole >= load else ["py"])
            assert b_calls == (["nb"] if whole >= load else ["py"]) if later_units else b_calls == []
    better = min(a_s + b_s * later_units, load + fast * (a_s + b_s * later_units))
    assert costs[True] <= 1.2 * better + 1e-12
    if later_units >= 7:
        assert costs[False] > 1.2 * better


def test_a_declaration_ends_when_its_kernel_runs(fresh_process, monkeypatch):
    """Declared work stands for calls not made yet: once the kernel runs, its calls count
    themselves (a small first part no longer carries the whole declaration)."""
    b, calls = _recording_kernel(monkeypatch, python_below=10_000)
    with _jit.expecting({b: 50_000}):
        assert _jit._ahead == [{b: 50_000}]
        b(np.ones(10))                               # its own 10 elements: Python
        assert _jit._ahead == [{}]
        b(np.ones(10))
    assert calls == ["py", "py"] and _jit._ahead == []


@pytest.mark.parametrize("units", [5, 30])
def test_a_job_advanced_as_its_units_end_projects_like_a_loop_over_them(fresh_process, monkeypatch, units):
    """job(): a stream's lines end when the controller answers them, not in a loop over them,
    and the virtual machine runs their kernels in another thread. 0.1 s a unit as Python
    against a 1 s load: 5 units stay Python; of 30, the first runs as Python and the
    projection (0.1 s + 29 × 0.1 s) sends the rest compiled."""
    monkeypatch.setattr(_jit, "LOAD_COST_S", 1.0)
    fresh_process.step = 0.1
    total, calls = _recording_kernel(monkeypatch, python_below=10**9)
    with _jit.job(units) as lines:
        for _ in range(units):
            worker = threading.Thread(target=total, args=(np.ones(5000),))
            worker.start()
            worker.join()
            lines.advance()
    assert calls == (["py"] * units if units < 10 else ["py"] + ["nb"] * (units - 1))
    assert _jit._jobs == []


def test_the_tally_counts_the_kernels_own_thread_not_the_process(monkeypatch):
    """A kernel run as Python while another thread works (a stream's sender polling beside
    the virtual machine) adds its own CPU time to the tally, not the other thread's."""
    monkeypatch.setattr(_jit, "_spent", [0.0])

    @_jit.jit(python_below=10**9, cache=False)
    def spin(n):
        s = 0
        for i in range(n):
            s += i
        return s

    stop = threading.Event()

    def busy():
        while not stop.is_set():
            sum(range(1000))

    other = threading.Thread(target=busy)
    other.start()
    try:
        process_before = time.process_time()
        spin.run_python(3_000_000, tally=True)
        process_used = time.process_time() - process_before
    finally:
        stop.set()
        other.join()
    assert 0 < _jit._spent[0] < 0.75 * process_used


@pytest.mark.parametrize("declared, expected", [(5_000, "py"), (50_000, "nb")])
def test_work_declared_to_begin_after_the_block_stands_through_calls_inside_it(fresh_process, monkeypatch,
                                                                                declared, expected):
    """expecting(later=True): a stream reads its file with the kernel the virtual machine will
    call again for every line. That reading is other work: the declaration stands through
    it (half a load: the reading runs as Python; five loads: compiled) and ends with the block."""
    b, calls = _recording_kernel(monkeypatch, python_below=10_000)
    with _jit.expecting({b: declared}, later=True):
        b(np.ones(10))
        assert _jit._after == [{b: declared}] and _jit._ahead == []
    assert _jit._after == []
    assert calls == [expected]


@pytest.mark.parametrize("lines, python", [(300, True), (700, True), (1_500, False), (2_418, False)])
def test_a_stream_to_the_virtual_machine_reads_its_file_as_its_measured_crossover_says(fresh_process,
                                                                                     lines, python):
    """``labkit stream`` of the first N lines of cncjs's tball job (22 bytes a line), CPU s
    Python only / compiled only, measured when the stream's work was declared: 0.63 / 1.13 at
    300 lines, 1.27 / 1.56 at 700, 2.66 / 2.52 at 1,500, 3.99 / 3.49 at jsdc's 2,418. The
    file's traced reading, with the stream's declared work, runs on the better side."""
    from labkit.machine.virtual import stream_work

    buf = np.zeros(22 * lines, np.uint8)
    with _jit.expecting(stream_work(lines), later=True):
        as_python = _jit.runs_as_python(K._interpret_work(buf, None, False, 1, True),
                                        K.interpret.python_below)
    assert as_python == python


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


@pytest.mark.parametrize("planner", ["junction", "fast", "normal", "hq"])
def test_planner_kernels_as_python_equal_compiled(planner):
    """The planner's kernels run as Python for small jobs under the rule (python_below): the
    same junction speeds and super blocks as compiled, on a real job."""
    from labkit.motion import CBR40
    from labkit.motion.pipeline import plan

    moves = parse((ROOT / "data" / "gcode" / "cncjs" / "jsdc-laser.gcode").read_bytes())
    a, b = _both(plan, moves, CBR40, planner=planner)
    assert len(a.lookahead.speed_mm_s) > 1000
    assert np.array_equal(a.lookahead.speed_mm_s, b.lookahead.speed_mm_s)
    assert np.array_equal(a.lookahead.super_block, b.lookahead.super_block)


def test_a_declared_batch_projects_from_part_of_its_first_file(fresh_process, monkeypatch):
    """Ten files of 4 units (0.4 s as Python each) in a declared batch: once the first file
    has spent 0.1 s (a tenth of the load) on its first unit, the batch projects 0.1 s per
    quarter file over 9.75 files, beyond the 1 s load, so the rest runs compiled
    (undeclared, the tally alone waits until the third file)."""
    monkeypatch.setattr(_jit, "LOAD_COST_S", 1.0)
    fresh_process.step = 0.1
    total, calls = _recording_kernel(monkeypatch, python_below=10**9)
    per_file = []
    for _ in _jit.job_units(range(10)):
        before = len(calls)
        for _ in _jit.job_units(range(4)):
            total(np.ones(5000))
        per_file.append(calls[before:])
    assert per_file[0] == ["py"] + ["nb"] * 3
    assert all(f == ["nb"] * 4 for f in per_file[1:])


@pytest.mark.parametrize("files", [10, 20])
def test_a_file_under_way_is_not_counted_as_not_begun(fresh_process, monkeypatch, files):
    """A declared batch whose files each run two kernel calls inside a job of shapes and two
    after it (ordering, G-code), 0.02 s each as Python: 0.08 s a file. Ten files (0.8 s in
    all, below the 1 s load) stay Python: in the second file's calls after its shapes, the
    projection is the first file's 0.08 s for each of the 9 files left less the 0.04 s the
    second has spent (counting that file as not begun projected 0.12 s × 9 and loaded numba
    there). Twenty files (1.6 s) go compiled from the second file's third call on."""
    monkeypatch.setattr(_jit, "LOAD_COST_S", 1.0)
    fresh_process.step = 0.02
    total, calls = _recording_kernel(monkeypatch, python_below=10**9)
    per_file = []
    for _ in _jit.job_units(range(files)):
        before = len(calls)
        for _ in _jit.job_units(range(2)):
            total(np.ones(5000))
        total(np.ones(5000))
        total(np.ones(5000))
        per_file.append(calls[before:])
    assert per_file[0] == ["py"] * 4
    if files == 10:
        assert all(f == ["py"] * 4 for f in per_file)
    else:       # the projection starts once 0.1 s is spent: at the second file's third call
        assert per_file[1] == ["py"] * 2 + ["nb"] * 2
        assert all(f == ["nb"] * 4 for f in per_file[2:])
