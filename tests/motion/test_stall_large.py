"""img2gcode's link check at the size it was made lean for (issue 30: a photo's millions of moves).

The cheap condition (``may_starve`` over ``block_time_bounds``, the lines found by
``motion_line_numbers``) works a chunk of rows at a time and stops at the first block that may
starve; here it is held to the whole-array formula it replaced (written out below, as it was
committed before) on random programs and on the 2.26 M-move gray photo of ``data/images``,
and to the predictor: wherever the predictor finds a starvation, the condition holds.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from labkit import _jit
from labkit.motion import load_machine
from labkit.motion import stall
from labkit.motion.stall import (FLUSH_QUIET_S, block_time_bounds, may_starve, motion_line_numbers,
                                 predict_stalls, sent_line_bytes)

ROOT = Path(__file__).resolve().parents[2]
PHOTO = ROOT / "data" / "images" / "photo_500x450_72dpi.jpg"


def whole_array_may_starve(line_bytes, block_line, block_min_s, m) -> bool:
    """The condition as one array per quantity, as long as the program (the form before the
    chunks): the reference of the chunked one."""
    nbytes = np.asarray(line_bytes, dtype=np.int64)
    block_line = np.asarray(block_line, dtype=np.int64)
    nb = len(block_line)
    if nb < 2 or not np.any(nbytes > 0):
        return False
    tau = m.link_bits_per_byte / m.link_baud
    p = float(m.block_parse_s)
    sent = nbytes[nbytes > 0]
    side_by_side = len(sent) < 2 or int((sent[1:] + sent[:-1]).max()) < m.rx_buffer_bytes - 1
    link = nbytes * tau
    link = np.maximum(link, p) if side_by_side else link + p
    link[nbytes <= 0] = 0.0
    link = np.cumsum(link)
    motion = np.concatenate([[0.0], np.cumsum(np.asarray(block_min_s, dtype=float))])
    W = m.buffer_blocks if m.waits_for_lookahead else 0
    Q = m.planner_blocks - 1
    wait_line = block_line[np.minimum(np.arange(1 + W, nb + W), nb - 1)] - 1
    ready = link[wait_line] + 2 * p
    if W:
        last = max(nb - 1 - W, 0)
        ready[last:] = link[-1] + 2 * p
        wait_line[last:] = len(nbytes) - 1
    first_block = np.searchsorted(block_line, np.arange(1, len(nbytes) + 1), side="left")
    best = motion[np.maximum(first_block - Q, 0)] - link
    best[first_block < Q] = -np.inf
    best = np.maximum.accumulate(best)
    k0 = block_line[0] - 1
    kw = block_line[min(W, nb - 1)] - 1
    head = nbytes[:kw + 1]
    arrived_lb = tau * np.cumsum(head).astype(float)
    parsed_lb = np.maximum(arrived_lb + p, np.cumsum(head > 0) * p)
    start0 = parsed_lb[kw]
    if W:
        gap = link[k0 + 1:kw + 1] + 2 * p - arrived_lb[k0:kw] >= FLUSH_QUIET_S
        if np.any(gap):
            start0 = max(parsed_lb[k0], min(start0, float(arrived_lb[k0:kw][gap][0]) + FLUSH_QUIET_S))
    ahead = np.maximum(best[wait_line], -start0)
    ready = ready - motion[1:nb] + ahead
    return bool(np.any(ready > 0))


MACHINES = ("cbr40-laser", "grbl-diode")


@pytest.mark.parametrize("chunk", [1, 3, 17, 1 << 16])
def test_the_chunked_condition_is_the_whole_array_formula(monkeypatch, chunk):
    """Random programs (lines of 0-29 bytes, some not sent, blocks on some lines, several on
    one, block times from 0.1 ms to 0.2 s) on both controllers at 300-115200 baud."""
    monkeypatch.setattr(stall, "_STARVE_CHUNK", chunk)
    rng = np.random.default_rng(chunk)
    verdicts = []
    for trial in range(600):
        m = load_machine(MACHINES[trial % 2]).replace(link_baud=int(rng.choice([300, 1200, 4800, 9600, 115200])))
        n_lines = int(rng.integers(1, 300))
        nbytes = rng.integers(0, 30, n_lines) * (rng.random(n_lines) < 0.9)
        block_line = np.sort(rng.choice(np.arange(1, n_lines + 1), size=int(rng.integers(1, n_lines + 1))))
        least = rng.uniform(0, 0.02, len(block_line)) * rng.choice([0.1, 1.0, 10.0])
        got = may_starve(nbytes, block_line, least, m)
        assert got == whole_array_may_starve(nbytes, block_line, least, m), trial
        verdicts.append(got)
    assert 50 < sum(verdicts) < 550


@pytest.fixture(scope="module")
def photo_program():
    """The gray photo at 0.1 mm (1764 × 1587 beam pixels, 2.26 M moves), compact, 3000 mm/min."""
    from labkit.raster import image_to_job, read_image
    from labkit.gcode import emit

    with _jit.forced("compiled"):
        job = image_to_job(read_image(PHOTO), mode="gray", beam_mm=0.1, dpi=72, feed_mm_min=3000)
        text = emit(job.moves, compact=True)
    return job.moves, text


def test_the_lines_and_blocks_of_a_photo_are_found_as_before(photo_program):
    """The motion lines by one pass over the text's bytes: the lines with an X, Y or Z and
    bytes to send, as sent_line_bytes counts them; the blocks' least times as
    block_time_bounds computed them with a whole step conversion of both ends."""
    from labkit.motion.blocks import to_steps

    moves, text = photo_program
    line, nbytes = motion_line_numbers(text, len(moves))
    assert len(moves) > 2_000_000 and line is not None
    np.testing.assert_array_equal(nbytes, sent_line_bytes(text))
    raw = np.frombuffer(text.encode("ascii"), dtype=np.uint8)
    axis_lines = np.unique(np.searchsorted(np.flatnonzero(raw == 10),
                                           np.flatnonzero((raw >= 88) & (raw <= 90))))
    np.testing.assert_array_equal(line, axis_lines[nbytes[axis_lines] > 0] + 1)
    m = load_machine("cbr40-laser")
    rows, least = block_time_bounds(moves, m)
    spm = np.asarray(m.steps_per_mm, dtype=float)
    delta = to_steps(moves.end, spm) - to_steps(moves.start, spm)
    expected_rows = np.flatnonzero(np.any(delta != 0, axis=1))
    np.testing.assert_array_equal(rows, expected_rows)
    length = np.linalg.norm(delta[expected_rows] / spm, axis=1)
    feed = np.asarray(moves.feed_mm_min, dtype=float)[expected_rows]
    top = float(np.linalg.norm(np.asarray(m.max_rate_mm_min, dtype=float)))
    fast = np.where((np.asarray(moves.kind)[expected_rows] == 1) & (feed > 0), np.minimum(feed, top), top)
    np.testing.assert_array_equal(least, length / (fast / 60.0))


def test_the_condition_on_a_photo_is_the_formula_and_never_misses_a_stall(photo_program):
    """On the photo's 2.26 M lines: the chunked condition gives the whole-array verdict on both
    controllers at six baud rates, and holds where the predictor finds starvations (19200
    baud: hundreds of thousands); at 115200 baud it proves there are none, as the predictor
    finds."""
    moves, text = photo_program
    line, nbytes = motion_line_numbers(text, len(moves))
    verdicts = {}
    for name in MACHINES:
        base = load_machine(name)
        rows, least = block_time_bounds(moves, base)
        for baud in (2400, 9600, 19200, 38400, 115200, 250000):
            m = base.replace(link_baud=baud)
            got = may_starve(nbytes, line[rows], least, m)
            assert got == whole_array_may_starve(nbytes, line[rows], least, m), (name, baud)
            verdicts[name, baud] = got
    assert not verdicts["cbr40-laser", 115200] and verdicts["cbr40-laser", 19200]
    with _jit.forced("compiled"):
        for baud in (115200, 19200):
            stalls = predict_stalls(text, load_machine("cbr40-laser").replace(link_baud=baud)).stalls
            assert verdicts["cbr40-laser", baud] or not stalls, baud
            assert bool(stalls) == (baud == 19200), (baud, len(stalls))
