"""The stall predictor (labkit.motion.stall) against hand-worked streams, and the link fields.

The paced firmware simulator checks the predictor on real jobs (tests/firmware/test_paced_link.py);
here every figure is worked by hand from the link's byte time, GRBL's character counting and
the blocks' cruise times.
"""
from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from labkit.cli import main
from labkit.errors import MotionError
from labkit.motion import CBR40, load_machine
from labkit.gcode import grbl_sync_lines
from labkit.motion.stall import (predict_stalls, program_feeds, read_starvation_log, sent_line_bytes,
                                 short_queues, stall_free_feed, with_feed)

ROOT = Path(__file__).resolve().parents[2]
#: 0.1 mm cuts along X at 600 mm/min: 10 ms each at cruise (the look-ahead sees more of them).
SHORT_CUTS = ["G21G90", "G1X1F600"] + [f"X{1 + 0.1 * k:.2f}" for k in range(1, 60)]


def _job(lines):
    return "\n".join(lines) + "\n"


def _c_define(path: str, name: str) -> int:
    text = (ROOT / path).read_text()
    return int(re.search(rf"#define {name}\s+(\d+)", text).group(1))


def test_the_labkit_firmware_description_holds_the_firmwares_sizes():
    assert CBR40.planner_blocks == _c_define("firmware/src/config.h", "PLAN_BUFFER_SIZE")
    assert CBR40.rx_buffer_bytes == _c_define("firmware/src/serial.h", "SERIAL_RX_SIZE")
    assert CBR40.buffer_blocks == _c_define("firmware/src/defaults.h", "DEFAULT_BUFFER_BLOCKS")
    assert CBR40.waits_for_lookahead
    grbl = load_machine("grbl-diode")
    assert (grbl.rx_buffer_bytes, grbl.planner_blocks, grbl.waits_for_lookahead) == (128, 15, False)
    assert grbl.link_bytes_per_s == 11_520.0                       # 115200 8N1
    # grbl-diode's belts on the labkit firmware: the firmware's link and buffers, its deepest
    # look-ahead ($207 takes at most PLAN_MAX_DEPTH = PLAN_BUFFER_SIZE - 2) and its 48 MHz timer
    belts = load_machine("labkit-diode")
    link = ("link_baud", "link_bits_per_byte", "rx_buffer_bytes", "planner_blocks", "block_parse_s",
            "waits_for_lookahead")
    assert [getattr(belts, f) for f in link] == [getattr(CBR40, f) for f in link]
    assert belts.buffer_blocks == _c_define("firmware/src/config.h", "PLAN_BUFFER_SIZE") - 2
    assert belts.timer_clock_hz == _c_define("firmware/src/defaults.h", "DEFAULT_TIMER_CLOCK_HZ")
    assert belts.max_rate_mm_min[:2] == grbl.max_rate_mm_min[:2] == (6000.0, 6000.0)


@pytest.mark.parametrize("field,value,message", [
    ("link_baud", 0, "link_baud must be >= 1 baud"),
    ("link_bits_per_byte", 20, "link_bits_per_byte must be 7…12 bits"),
    ("rx_buffer_bytes", 64, "rx_buffer_bytes must be >= 82 bytes"),
    ("planner_blocks", 0, "planner_blocks must be >= 1 block"),
    ("block_parse_s", -1e-3, "block_parse_s must be >= 0 s"),
    ("block_parse_s", float("nan"), "block_parse_s must be >= 0 s"),
    ("link_baud", 9600.5, "link_baud must be an integer"),
    ("waits_for_lookahead", "yes", "waits_for_lookahead must be true or false"),
    ("laser_change_syncs", 1, "laser_change_syncs must be true or false"),
])
def test_bad_link_fields_are_refused(field, value, message):
    with pytest.raises(MotionError, match=message):
        CBR40.replace(**{field: value})


#: Relative 0.1 mm cuts along X at 600 mm/min: line 1 is 16 bytes, every further line 'X.1'
#: 4 bytes (33.3 ms at 1200 baud); a cut takes 10 ms at cruise (the first one 20 ms: it
#: reaches 10 mm/s at its end at 500 mm/s²). A cut is 213 or 214 steps (0.1 mm at 2133.3
#: steps/mm, rounded where it ends): its time is within one step, 47 µs, of 10 ms.
STEP_S = 1 / (10 * 6400 / 3)
RELATIVE_CUTS = ["G21G91G1X.1F600"] + ["X.1"] * 200


def test_grbl_starves_by_wire_time_less_block_time():
    """GRBL runs a block as soon as it is in the planner. Each line after the first arrives
    33.3 ms after the one before, and is parsed 1 ms later; its block needs 10 ms: from line
    3 on the motors stand 23.3 ms before every block, each block starting as its line is
    parsed. Line 2 waits less (the first cut took 20 ms)."""
    m = CBR40.replace(link_baud=1200, waits_for_lookahead=False, block_parse_s=0.001)
    p = predict_stalls(_job(RELATIVE_CUTS), m)
    tau = 10 / 1200
    np.testing.assert_allclose(p.arrived_s, np.cumsum([len(x) + 1 for x in RELATIVE_CUTS]) * tau)
    np.testing.assert_allclose(p.parsed_s, p.arrived_s + 0.001)
    assert [s.line for s in p.stalls] == list(range(2, 202))
    assert p.stalls[0].duration_s == pytest.approx(16 * tau + 4 * tau + 0.001 - (16 * tau + 0.001 + 0.020),
                                                   abs=2e-3)
    for s in p.stalls[1:]:
        assert s.duration_s == pytest.approx(4 * tau - 0.010, abs=STEP_S)
    np.testing.assert_allclose(p.block_start_s[1:], p.parsed_s[1:])


def test_the_labkit_firmware_waits_for_its_window():
    """With a look-ahead of 16 blocks, block k starts when the line of block k + 16 is in:
    the first cut when line 17 has arrived; then each block waits 33.3 - 10 ms for the line
    16 further on. The last 16 blocks wait for the quiet-input flush (no line left: no
    starvation)."""
    m = CBR40.replace(link_baud=1200, block_parse_s=0.0)
    p = predict_stalls(_job(RELATIVE_CUTS), m)
    assert p.block_start_s[0] == pytest.approx(p.parsed_s[16])
    lines = [s.line for s in p.stalls]
    assert lines == list(range(lines[0], 186)) and lines[0] <= 3
    for s in p.stalls[1:]:
        assert s.duration_s == pytest.approx(4 * 10 / 1200 - 0.010, abs=STEP_S)
    # the same cuts in absolute coordinates: the simulator's closed-form case
    assert [s.line for s in predict_stalls(_job(SHORT_CUTS), m).stalls] == list(range(5, 46))


def test_character_counting_and_fill_level():
    """A fast link and slow moves: the sender keeps fewer than 127 characters in flight, the
    planner fills to its 36 blocks and a line waits for a free slot (no starvation)."""
    lines = ["G21G90"] + [f"G1X{k % 2 * 10}Y{k * 0.5:.1f}F600" for k in range(1, 80)]
    p = predict_stalls(_job(lines), CBR40)
    assert not p.stalls
    assert p.fill.max() == CBR40.planner_blocks
    n = p.bytes
    for i in range(len(n)):                                         # in flight when line i went out
        answered_before = p.parsed_s <= p.sent_s[i]
        in_flight = n[: i + 1][~answered_before[: i + 1]].sum()
        assert in_flight < 127, (i, in_flight)
    # the first lines go out at once: 7 + 14 + 14 + … bytes until the next would reach 127
    first = np.flatnonzero(p.sent_s == 0.0)
    assert n[first].sum() < 127 <= n[: len(first) + 1].sum()


def test_a_fast_link_never_starves():
    assert not predict_stalls(_job(SHORT_CUTS), CBR40).stalls      # 115200 baud: 0.5 ms a line


def test_stall_free_feed_brackets_the_first_stall():
    """By hand: a 4-byte line takes 33.3 ms at 1200 baud and a 0.1 mm cut takes as long at
    0.1 mm / 33.3 ms = 180 mm/min; the first cut's ramp gives a few ms of slack, spent
    within a few of the 200 cuts above that feed."""
    m = CBR40.replace(link_baud=1200)
    text = _job(RELATIVE_CUTS)
    found = stall_free_feed(text, m, rel_tol=0.001)
    assert found.limited_by == "link" and found.programmed_mm_min == 600
    assert not predict_stalls(with_feed(text, found.feed_mm_min), m).stalls
    assert predict_stalls(with_feed(text, found.feed_mm_min * 1.002), m).stalls
    assert found.feed_mm_min == pytest.approx(180, rel=0.005)    # cuts of 213 or 214 steps
    assert len(found.stalls) == len(predict_stalls(text, m).stalls) > 150
    assert stall_free_feed(text, CBR40).limited_by == "machine"


def test_a_raster_jobs_rows_get_their_own_feed(tmp_path):
    from PIL import Image

    img = np.full((6, 100), 255, np.uint8)
    img[1, :] = np.arange(100) * 2                                  # a busy row: S changes every pixel
    img[4, 5:95] = 0                                                # a calm row: one cut
    Image.fromarray(img).save(tmp_path / "rows.png", dpi=(254, 254))
    out = tmp_path / "rows.gcode"
    assert main(["img2gcode", str(tmp_path / "rows.png"), "-o", str(out), "--mode", "gray",
                 "--beam", "0.1", "--width", "10", "--preview", "none", "--feed", "1500"]) == 0
    found = stall_free_feed(out.read_text(), CBR40.replace(link_baud=2400))
    assert found.limited_by == "link"
    busy = [r for r in found.rows if r["bytes"] > 150]
    calm = [r for r in found.rows if r["bytes"] <= 150]
    assert busy and calm
    assert max(r["feed_mm_min"] for r in busy) < min(r["feed_mm_min"] for r in calm)
    assert min(r["feed_mm_min"] for r in found.rows) == pytest.approx(found.feed_mm_min)


def test_helpers_and_their_errors(tmp_path):
    assert program_feeds("G1 X1 (F9) F100\nX2 ; F7\n") == [100.0]
    assert with_feed("G1X1F100\nX2\n", 250) == "G1X1F250\nX2\n"
    with pytest.raises(MotionError, match="no F word"):
        with_feed("G0 X1\n", 100)
    with pytest.raises(MotionError, match="no F word"):
        stall_free_feed("G0 X1\n", CBR40)
    with pytest.raises(MotionError, match="line 2: 130 bytes"):
        predict_stalls("G21\nG1X1F100\n", CBR40, line_bytes=[4, 130])
    with pytest.raises(MotionError, match="gives 1 counts for 2 lines"):
        predict_stalls("G21\nG1X1F100\n", CBR40, line_bytes=[4])
    with pytest.raises(MotionError, match="line 2 makes a block but sends nothing"):
        predict_stalls("G21\nG1X1F100\n", CBR40, line_bytes=[4, 0])
    assert sent_line_bytes("(only a comment)\n  G1 X1\n").tolist() == [0, 5]
    log = tmp_path / "s.csv"
    log.write_text("time_s,line,duration_s\n0.5,12,0.004\n")
    assert [(s.line, s.duration_s) for s in read_starvation_log(log)] == [(12, 0.004)]
    log.write_text("t,l,d\n")
    with pytest.raises(MotionError, match="line 1: expected the header"):
        read_starvation_log(log)
    log.write_text("time_s,line,duration_s\n0.5,x,1\n")
    with pytest.raises(MotionError, match="line 2: expected time_s,line,duration_s"):
        read_starvation_log(log)


def test_labkit_plan_prints_and_writes_the_stall_prediction(tmp_path, capsys):
    job = tmp_path / "cuts.gcode"
    job.write_text(_job(SHORT_CUTS))
    assert main(["plan", str(job), "--baud", "1200", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["link_baud"] == 1200
    assert [s["line"] for s in out["stalls"]] == list(range(5, 46))
    # above 6 bytes / 50 ms per 0.1 mm (120 mm/min): the first, 1 mm cut gives slack
    assert 120 <= out["stall_free_feed_mm_min"] <= 160
    assert out["stall_free_limited_by"] == "link"
    fill = tmp_path / "fill.csv"
    assert main(["plan", str(job), "--baud", "1200", "--fill", str(fill)]) == 0
    text = capsys.readouterr().out
    assert "stalls                      41, standing" in text and "stall-free feed" in text
    rows = fill.read_text().splitlines()
    assert rows[0] == "line,bytes,sent_s,arrived_s,parsed_s,fill_blocks" and len(rows) == 62
    assert main(["plan", str(job), "--json", "--no-link"]) == 0
    assert "stalls" not in json.loads(capsys.readouterr().out)


#: A hand-written program with what the fast path must read as the text path does: inches
#: (G20: F × 25.4), inverse time (G93: F × length), an F after an inline comment (left as it
#: is by with_feed), a jog, lower-case f, comments holding F words and CRLF line ends.
ODD_FEEDS = ("G21 G90\r\nG1 X1 F600 ; F9\r\nX2 (F7) F300\r\nG20 G1 X0.2 Y0.05 f24.5\r\nX0.25\r\n"
             "G21 G93 G1 X8 Y2 F90\r\nX9 F120\r\nG94 G1 X10 F450.123456789\r\nX11\r\n"
             "$J=G91 X1 F700\r\nG1 X13 F555\r\n")


def _scaled_jobs(tmp_path):
    from PIL import Image

    img = np.full((5, 60), 255, np.uint8)
    img[1, :] = np.arange(60) * 4
    img[3, 10:50] = 0
    Image.fromarray(img).save(tmp_path / "rows.png", dpi=(254, 254))
    out = tmp_path / "rows.gcode"
    assert main(["img2gcode", str(tmp_path / "rows.png"), "-o", str(out), "--mode", "gray",
                 "--beam", "0.1", "--preview", "none", "--feed", "1500"]) == 0
    return [(_job(RELATIVE_CUTS), CBR40.replace(link_baud=1200)),
            (_job(SHORT_CUTS), CBR40.replace(link_baud=1200, waits_for_lookahead=False)),
            (out.read_text(), CBR40.replace(link_baud=2400)),
            (out.read_text(), load_machine("grbl-diode").replace(link_baud=9600)),
            ("".join((ROOT / "data/gcode/cncjs/jsdc-laser.gcode").open().readlines()[:400]),
             CBR40.replace(link_baud=4800)),
            (ODD_FEEDS, CBR40.replace(link_baud=300, buffer_blocks=2))]


def test_scaling_the_parsed_program_predicts_what_rewriting_its_text_does(tmp_path):
    """stall_free_feed scales the feeds of the parsed moves and the bytes of the lines; the
    text path (with_feed, then parse, plan and predict: what a sender-supplied line_bytes
    still takes) must come out the same, stall for stall and row for row, to the last bit."""
    from labkit.motion.stall import _FeedScaled

    for text, m in _scaled_jobs(tmp_path):
        scaled = _FeedScaled(text, m, "grbl")
        assert scaled.ok
        top = float(min(m.max_rate_mm_min[:2]))
        for feed in (top * 1e-3, 97.3, 180.0, 333.3, 611.0, 1200.0, top):
            assert scaled.stalls_at(feed) == predict_stalls(with_feed(text, feed), m).stalls, feed
            nbytes, moves, _ = scaled.at(feed)
            np.testing.assert_array_equal(nbytes, sent_line_bytes(with_feed(text, feed)))
            from labkit.gcode import parse
            np.testing.assert_array_equal(moves.feed_mm_min, parse(with_feed(text, feed)).feed_mm_min)
        fast = stall_free_feed(text, m)
        by_text = stall_free_feed(text, m, line_bytes=sent_line_bytes)     # the text path
        assert fast == by_text
        from labkit.gcode import parse
        from labkit.motion import plan

        moves = parse(text)                                     # as labkit plan hands them over
        assert stall_free_feed(text, m, moves=moves, plan=plan(moves, m, planner="junction")) == by_text
    # the odd program's feeds really moved (inches, inverse time, the jog) and one stayed
    nbytes, moves, _ = _FeedScaled(ODD_FEEDS, CBR40, "grbl").at(2 * 700)
    from labkit.gcode import parse
    before = parse(ODD_FEEDS).feed_mm_min
    changed = ~np.isclose(moves.feed_mm_min, before, equal_nan=True)
    assert changed.sum() >= 6 and (~changed).sum() >= 1


def test_the_stream_kernel_as_python_equals_compiled(tmp_path):
    """labkit.motion._stall.stream_lines runs as Python below 20,000 lines and compiled above
    (labkit._jit's rule): both give the same times to the bit."""
    from labkit._jit import forced

    for text, m in _scaled_jobs(tmp_path):
        with forced("python"):
            a = predict_stalls(text, m)
        with forced("compiled"):
            b = predict_stalls(text, m)
        assert a.stalls == b.stalls
        for name in ("sent_s", "arrived_s", "parsed_s", "fill", "block_start_s", "block_end_s"):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name))


def test_which_programs_skip_the_tagged_parse():
    """A program whose F words are all scaled ones, without jogs or G93, is read without a
    tagged parse; the odd one is not."""
    from labkit.motion.stall import _FeedScaled, _plainly_modal

    assert _plainly_modal(_job(RELATIVE_CUTS), 1)
    assert not _plainly_modal(ODD_FEEDS, 10)                   # CRLF, an F after a comment, G93
    assert not _plainly_modal("G1X1F100\nX2 (c) F200\n", 1)
    assert not _plainly_modal("G1X1F100\n$J=X2F50\n", 2)
    assert not _plainly_modal("G93 G1X1F2\n", 1)
    assert _FeedScaled(_job(RELATIVE_CUTS), CBR40, "grbl").ok


def _cheap_condition(text, m):
    """may_starve on a parsed program: its blocks' lines and their times' lower bounds."""
    from labkit.gcode import parse
    from labkit.motion.stall import block_time_bounds, may_starve

    moves = parse(text)
    bounds = block_time_bounds(moves, m)
    if bounds is None:
        return None
    rows, low = bounds
    return may_starve(sent_line_bytes(text), np.asarray(moves.line)[rows], low, m)


def test_the_cheap_condition_never_misses_a_stall(tmp_path):
    """may_starve is a necessary condition: wherever the predictor finds a starvation it holds,
    on the jobs above at several feeds and baud rates; and it is not always true (a fast link
    under slow moves proves there is none). Its blocks and lower bounds are the plan's: one a
    line, each below the block's planned time."""
    from labkit.gcode import parse
    from labkit.motion import plan
    from labkit.motion.stall import block_time_bounds

    checked = stalled = cleared = 0
    for text, m in _scaled_jobs(tmp_path) + [(_job(lines), CBR40) for lines in (SHORT_CUTS, RELATIVE_CUTS)]:
        moves = parse(text)
        bounds = block_time_bounds(moves, m)
        if bounds is None:                                  # arcs: the predictor itself decides
            continue
        p = plan(moves, m, planner="junction")
        rows, low = bounds
        np.testing.assert_array_equal(np.asarray(moves.line)[rows], p.blocks.line)
        assert np.all(low <= np.asarray(p.block_time_s) * (1 + 1e-9))
        for baud in (m.link_baud, 1200, 9600, 115200):
            for feed in (120.0, 600.0, 1500.0, 6000.0):
                mb = m.replace(link_baud=baud)
                t = with_feed(text, feed)
                stalls = predict_stalls(t, mb).stalls
                cheap = _cheap_condition(t, mb)
                assert cheap or not stalls, (baud, feed, stalls[:2])
                checked += 1
                stalled += bool(stalls)
                cleared += not cheap
    assert checked >= 60 and stalled >= 10 and cleared >= 10


def test_the_numpy_line_bytes_equal_the_line_by_line_ones(monkeypatch):
    """sent_line_bytes counts a plainly written program (whole-line ; comments) with numpy; on
    random texts of G-code words, spaces, tabs, comments and empty lines it gives what the
    comment-stripping path gives, and leaves every other text to that path."""
    import random

    import labkit.motion.stall as stall

    random.seed(30)
    words = ["G1", "X1.5", " ", "\t", "S100", ";c", "\n", "\n", "F300", "y2", "(a)", ";(", "\n;x(y)", "\r\n"]
    fast = 0
    for _ in range(3000):
        text = "".join(random.choice(words) for _ in range(random.randint(0, 30)))
        got = stall._plain_line_bytes(text)
        with monkeypatch.context() as mp:
            mp.setattr(stall, "_plain_line_bytes", lambda t: None)
            expected = sent_line_bytes(text)
        if got is not None:
            fast += 1
            np.testing.assert_array_equal(got, expected, err_msg=repr(text))
        np.testing.assert_array_equal(sent_line_bytes(text), expected, err_msg=repr(text))
    assert 500 < fast < 3000


# ---------------------------------------------------------------- GRBL's stop at a laser change

def test_grbl_stops_at_a_laser_change_and_parses_the_next_line_after_it():
    """Hand-worked, grbl-diode (1000 mm/s², GRBL's planner rests at 0, 3.7 ms a line, 115200
    baud): 'M3S100', a 10 mm cut at 600 mm/min, 'M5', a 10 mm move. GRBL syncs at M3 (nothing
    to wait for) and at M5: the cut runs alone from rest to rest, 10 / 1000 = 10 ms a ramp over
    10² / 2000 = 0.05 mm, 9.9 mm at 10 mm/s between: 1.01 s. The M5 is answered when the cut ends; the next line is
    parsed 3.7 ms later and its move starts then. That stop is the program's, not a
    starvation, and the move after it is no short queue (nothing could be behind it). A GRBL
    described without the sync runs the two moves as one stream; the labkit firmware
    (``FIRMWARE_LASER_CHANGE_SYNCS``: its grbl dialect syncs as GRBL) stops there too."""
    from labkit.motion.spec import FIRMWARE_LASER_CHANGE_SYNCS

    grbl = load_machine("grbl-diode")
    assert grbl.laser_change_syncs and not grbl.waits_for_lookahead
    job = "M3S100\nG1X10F600\nM5\nG1X20\n"
    assert grbl_sync_lines(job) == [1, 3]
    p = predict_stalls(job, grbl)
    a, b = 0, 1
    assert p.block_end_s[a] - p.block_start_s[a] == pytest.approx(2 * 0.01 + (10 - 2 * 0.05) / 10, abs=1e-9)
    assert p.block_exit_mm_s[a] == 0.0
    assert p.parsed_s[2] == pytest.approx(p.block_end_s[a])            # M5 answered as the cut ends
    assert p.block_start_s[b] == pytest.approx(p.block_end_s[a] + 0.0037)
    assert p.stalls == [] and short_queues(p) == []
    q = predict_stalls(job, grbl.replace(laser_change_syncs=False))
    assert q.block_start_s[b] == pytest.approx(q.block_end_s[a])        # one stream: no stop
    assert q.block_exit_mm_s[a] > 1.0
    fw = predict_stalls(job, load_machine("labkit-diode").replace(waits_for_lookahead=False))
    assert fw.block_exit_mm_s[a] <= fw.block_floor_mm_s[a] * (1 + 1e-9)  # stops at the M5
    assert fw.block_start_s[b] > fw.block_end_s[a]                      # the M5's answer first
    assert load_machine("labkit-diode").laser_change_syncs == CBR40.laser_change_syncs == FIRMWARE_LASER_CHANGE_SYNCS
    assert FIRMWARE_LASER_CHANGE_SYNCS


def test_grbl_sync_lines_follow_the_modal_state():
    """A change of M3/M4/M5 syncs, a repeat does not; M2/M30 end in M5; comments and M30's
    digits are not an M3."""
    text = "M5\nM3 S10\nM03\nG1X1 (M5 here is a comment)\nM4\n; M5\nM30\nM5\nM3\nM3.5\n"
    assert grbl_sync_lines(text) == [2, 5, 9]


def test_plan_reads_a_programs_sync_lines_once(tmp_path, monkeypatch, capsys):
    """``labkit plan`` asks for the controller's sync lines in the plan, the link's prediction
    and the stall-free feed (five asks); the program is interpreted for them once (each
    interpretation with a trace cost as much as the whole plan, as Python)."""
    import labkit.gcode.reader as reader

    calls = []
    real = reader._grbl_sync_lines
    monkeypatch.setattr(reader, "_grbl_sync_lines", lambda data, d, *trace: calls.append(len(data)) or real(data, d, *trace))
    job = tmp_path / "job.gcode"
    job.write_text("G21 G90\nM3 S200\nG1 X10 F600\nM5\nG0 X0\nM3 S400\nG1 Y10\nM5\n")
    assert main(["plan", str(job), "--machine", "grbl-diode"]) == 0
    assert "stall-free feed" in capsys.readouterr().out
    assert calls == [job.stat().st_size]
    # another program, or the same text in another dialect, is read again
    assert grbl_sync_lines(job.read_text() + "M3 S100\n") == [2, 4, 6, 8, 9]
    assert len(calls) == 2
