"""The shared motion vectors: still what the reference makes, and consistent with the README's
integer semantics re-implemented here in plain Python integers (as the firmware will)."""

import json
import math
import sys
from pathlib import Path

import pytest

VECTORS = Path(__file__).resolve().parents[1] / "vectors" / "motion"
sys.path.insert(0, str(VECTORS))
import generate  # noqa: E402

FILES = sorted(VECTORS.glob("*.json"))


def test_every_case_has_a_file():
    assert {p.stem for p in FILES} == set(generate.CASES)


@pytest.mark.parametrize("name", sorted(generate.CASES))
def test_vectors_match_the_reference(name):
    assert generate.check(name) is None


def _rate(b, k, law):
    n = b["ticks"]
    if law == "linear":
        rise = b["f_entry"] + b["up"] * k
        fall = b["f_exit"] + b["down"] * (n - 1 - k)
    else:
        rise = math.isqrt(b["f_entry"] ** 2 + 2 * b["up"] * k)
        fall = math.isqrt(b["f_exit"] ** 2 + 2 * b["down"] * (n - 1 - k))
    return max(b["f_min"], min(rise, b["f_peak"], fall))


def _bresenham(delta):
    n = max(abs(d) for d in delta)
    err = [2 * abs(d) - n for d in delta]
    out = []
    for _ in range(n):
        tick = []
        for i, d in enumerate(delta):
            s = 0
            if err[i] >= 0:
                s = 1 if d > 0 else -1
                err[i] -= 2 * n
            err[i] += 2 * abs(d)
            tick.append(s)
        out.append(tick)
    return out


@pytest.mark.parametrize("path", FILES, ids=[p.stem for p in FILES])
def test_vectors_follow_the_readme_semantics(path):
    v = json.loads(path.read_text())
    m = v["machine"]
    clk, psc = m["timer_clock_hz"], m["prescaler"]
    cycles = 0
    pos = None
    for b in v["blocks"]:
        if b["kind"] == "DWELL":
            cycles += b["dwell_cycles"]
            continue
        if pos is not None:
            assert b["start_steps"] == pos
        n = b["ticks"]
        rates = [_rate(b, k, v["law"]) for k in range(n)]
        periods = [-(-clk // (f * (psc + 1))) - 1 for f in rates]
        assert periods == b["tick_periods"]
        assert (periods[0], min(periods), periods[-1]) == (b["period_entry"], b["period_peak"], b["period_exit"])
        cycles += sum((p + 1) * (psc + 1) for p in periods)
        assert cycles == b["cycles_end"]
        assert all(p < 2 ** m["timer_bits"] for p in periods)
        steps = b["tick_steps"]
        assert len(steps) == n and all(all(abs(s) <= 1 for s in t) for t in steps)
        total = [sum(t[i] for t in steps) for i in range(3)]
        assert [s + d for s, d in zip(b["start_steps"], total)] == b["end_steps"]
        if b["kind"] in ("LINE", "RAPID"):
            delta = [e - s for s, e in zip(b["start_steps"], b["end_steps"])]
            assert steps == _bresenham(delta)
            assert b["steps_per_axis"] == [abs(d) for d in delta]
        for f, pw in zip(rates, b["tick_power_mw"]):
            if b["laser"] == 4:
                want = min(m["laser_max_power_mw"], b["power_mw"] * f / b["f_feed"])
            else:
                want = b["power_mw"] if b["laser"] == 3 else 0.0
            assert pw == pytest.approx(want, rel=1e-15, abs=0)
        pos = b["end_steps"]
    assert cycles == v["summary"]["cycles_total"]
    assert pos == v["summary"]["final_steps"]
