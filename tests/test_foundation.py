"""errors, units and the status-code table."""

import pickle

import numpy as np
import pytest

from labkit import units
from labkit.errors import STATUS_CODES, GcodeError, status_code


def test_status_table_is_consistent():
    numbers = [s.code for s in STATUS_CODES.values()]
    assert len(numbers) == len(set(numbers))
    assert status_code("ok").code == 0
    # GRBL's own numbers where GRBL has the error.
    assert status_code("modal_group_violation").code == 21
    assert status_code("invalid_arc").code == 33
    with pytest.raises(KeyError, match="unknown status code 999"):
        status_code(999)


def test_gcode_error_carries_its_place_and_pickles():
    err = GcodeError("bad", filename="a.nc", line=3, column=7, text="X1.2.3", expected="a number",
                     code="bad_number", source_line="G1 X1.2.3")
    assert str(err) == "a.nc:3:7: error 2: bad (got 'X1.2.3'; expected a number)"
    back = pickle.loads(pickle.dumps(err))
    assert str(back) == str(err) and back.column == 7 and back.code == 2


def test_unit_conversions():
    assert units.inch_to_mm(2.0) == 50.8
    assert units.mm_to_inch(25.4) == 1.0
    assert units.mm_s_to_mm_min(units.mm_min_to_mm_s(1234.0)) == pytest.approx(1234.0)
    assert units.s_to_percent(255, s_max=255) == 100.0           # seed 003: S' = S·100/255
    assert units.s_to_percent(51, s_max=255) == pytest.approx(20.0)
    np.testing.assert_allclose(units.s_to_mw(np.array([0, 500, 2000]), max_power_mw=2500),
                               [0, 1250, 2500])
    assert units.mw_to_s(1250.0, max_power_mw=2500) == pytest.approx(500.0)
    with pytest.raises(ValueError, match="s_max must be > 0"):
        units.s_to_duty(1, s_max=0)
    with pytest.raises(ValueError, match="max_power_mw must be > 0"):
        units.mw_to_s(1, max_power_mw=0)


def test_kernel_cache_folder_follows_the_kernels_sources_only(tmp_path):
    import os
    import time

    import labkit

    src = tmp_path / "pkg"
    (src / "sub").mkdir(parents=True)
    (src / "a.py").write_text("from pkg.sub import b\n\n\n@jit\ndef f(x):\n    return x + b.y\n")
    (src / "sub" / "b.py").write_text("y = 2\n")
    (src / "c.py").write_text("z = 1\n")                      # no kernel uses it
    cache = tmp_path / "cache"

    def touch(path, text, k):
        path.write_text(text)
        os.utime(path, ns=(time.time_ns(), time.time_ns() + k * 10**9))

    assert {p.name for p in labkit._kernel_sources(src)} == {"a.py", "b.py"}
    first = labkit._numba_cache_dir(src, cache)
    assert first == labkit._numba_cache_dir(src, cache) and first.is_dir()
    # an edit in a module a kernel only imports gives a new folder ...
    touch(src / "sub" / "b.py", "y = 3\n", 1)
    second = labkit._numba_cache_dir(src, cache)
    assert second != first
    # ... an edit in a module no kernel depends on keeps the compiled kernels
    touch(src / "c.py", "z = 2\n", 2)
    assert labkit._numba_cache_dir(src, cache) == second
    for k in range(6):                      # old folders are pruned to the last few
        touch(src / "a.py", f"@jit\ndef f(x):\n    return x + {k}\n", k + 3)
        labkit._numba_cache_dir(src, cache)
    assert len(list(cache.iterdir())) <= 4
