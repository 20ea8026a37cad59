"""The firmware simulator's paced link (``--baud``) against closed forms and the stall predictor (issue 30 §1–2).

The simulator runs on a pty in the grbl dialect with ``--baud N --starvation-log FILE``;
GRBL's stream.py (re-implemented in test_real_senders.py from its documented behaviour:
character counting against the 128-byte buffer, ``?`` once a second) streams the job.
``labkit.motion.stall`` predicts the same stream from the machine description (CBR-40, the
firmware's defaults) with the link's baud rate. Checked:

* a hand-worked case through stdin: equal short cuts at cruise speed, each line slower on
  the wire than its block on the motors, starve by exactly the difference;
* on eleven jobs (photos and a gray card from ``img2gcode`` in gray, dither and zig-zag at
  several pixel pitches and baud rates; vector jobs with many short segments from
  ``svg2gcode``; the photo as LaserGRBL writes it, at 57600 baud on ``labkit-diode``, the
  firmware's settings sent first): every starvation the simulator logs is predicted at the
  same line, but for those stream.py's once-a-second ``?`` causes (one byte on the wire at a wall-clock
  moment: at most one byte time long, at most one a second); the predicted stall-free feed
  F* is within 5 % of the simulated one (none at 0.95 F*, some at 1.05 F*);
* that the firmware stops at a change of M3/M4/M5 exactly when
  ``labkit.motion.spec.FIRMWARE_LASER_CHANGE_SYNCS`` says it does (GRBL does; the predictor
  reads the flag through the machine description).
"""
from __future__ import annotations

import importlib.util
import subprocess
from pathlib import Path

import numpy as np
import pytest

from labkit.cli import main
from labkit.machine.safety import end_process
from labkit.motion import load_machine
from labkit.motion.spec import CBR40
from labkit.motion.stall import predict_stalls, read_starvation_log, stall_free_feed, with_feed
import paced_stream
from paced_stream import REAL_SENDERS, WAKE_UP_LINES, paced_sim, poll_shadows, sim_complaints, stream_py_bytes

ROOT = Path(__file__).resolve().parents[2]
sim = REAL_SENDERS.sim          # the fixture that builds the simulator (make -C firmware sim)


def stream_paced(sim: str, text: str, machine, tmp: Path):
    """Stream ``text`` with stream.py through the simulator paced as ``machine``'s link says.

    Returns its starvations (numbered by the job's lines) and the seconds the stream took
    (stream.py's ``?`` goes out once a second). The simulator is told what stream.py will
    write (``--expect``), so however late a loaded machine makes the sender, the simulated
    clock waits for it: the sender must never have been late by the simulator's measure.
    """
    cmd, log = paced_sim(sim, machine, text, tmp)
    proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            text=True)
    try:
        line = proc.stderr.readline()
        assert "pty " in line, f"simulator did not announce its pty: {line!r}"
        tally = REAL_SENDERS.stream_py(line.split("pty ", 1)[1].strip(), text, counting=True)
        proc.terminate()
        err = proc.communicate(timeout=30)[1]
    finally:
        end_process(proc)
    assert sim_complaints(err) == (0, ""), err
    assert len(tally["answers"]) == len(text.splitlines())
    assert all(a == "ok" for a in tally["answers"]), [a for a in tally["answers"] if a != "ok"][:3]
    stalls = [s.__class__(s.time_s, s.line - WAKE_UP_LINES, s.duration_s) for s in read_starvation_log(log)]
    return stalls, tally["seconds"]


# ---------------------------------------------------------------- closed form

def test_equal_short_cuts_starve_by_wire_time_less_block_time(sim, tmp_path):
    """Hand-worked: line 2 cuts 1 mm, lines 3-61 cut 0.1 mm each along X at 600 mm/min
    (10 ms each at cruise: the look-ahead always sees more collinear cuts); each such
    line, 'X1.23\\n', is 6 bytes, 50 ms at 1200 baud. A block runs once the line of the
    block 16 ahead (its window) has arrived, so from line 6 on every block waits for a
    line that arrives 50 ms after the one before while the block before it took 10 ms:
    the motors stand 40 ms. The blocks of lines 46-61 wait for the quiet-input flush
    after the last line instead: no line is left to come, so no starvation."""
    lines = ["G21G90", "G1X1F600"] + [f"X{1 + 0.1 * k:.2f}" for k in range(1, 60)]
    job = "\n".join(lines) + "\n"
    log = tmp_path / "st.csv"
    run = subprocess.run([sim, "--dialect", "grbl", "--baud", "1200", "--starvation-log", str(log)],
                         input=job, capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    stalls = read_starvation_log(log)
    assert [s.line for s in stalls] == list(range(5, 46)), stalls
    steady = [s for s in stalls if s.line >= 6]
    for s in steady:
        assert s.duration_s == pytest.approx(0.040, abs=2e-4), s
    gaps = np.diff([s.time_s for s in steady])
    np.testing.assert_allclose(gaps, 0.050, atol=2e-4)     # one line per 50 ms
    # the predictor, from the machine description, says the same
    pred = predict_stalls(job, CBR40.replace(link_baud=1200, block_parse_s=0.0),
                          line_bytes=[len(x) + 1 for x in lines])
    by_line = {s.line: s for s in pred.stalls}
    for s in steady:
        assert by_line[s.line].duration_s == pytest.approx(s.duration_s, abs=2e-4)


def test_the_firmware_stops_at_a_laser_change_as_its_description_says(sim, tmp_path):
    """Whether the labkit firmware waits for its planner to empty at a change of M3/M4/M5 is
    said in one place, ``labkit.motion.spec.FIRMWARE_LASER_CHANGE_SYNCS`` (the firmware's
    descriptions take it as their default); this holds the firmware to it. Two 2 mm cuts
    along X at 1200 mm/min with M5 between and M3 before a third: stopping there, the last
    step before the next line's first comes at the start rate's pace (1 kHz on CBR-40), not
    at cruise (42,667 steps/s, 23.4 µs); the predictor's plan on CBR-40 agrees."""
    from labkit.motion.spec import FIRMWARE_LASER_CHANGE_SYNCS

    job = "G21G90\nM3S500\nG1X2F1200\nM5\nG1X4\nM3\nG1X6\nM5\n"
    trace = tmp_path / "trace.csv"
    run = subprocess.run([sim, "--dialect", "grbl", "--trace", str(trace)], input=job, capture_output=True,
                         text=True, timeout=60)
    assert run.returncode == 0, run.stderr
    rows = np.loadtxt(trace, delimiter=",", skiprows=1, usecols=(0, 3, 4))
    rows = rows[rows[:, 2] != 0]                                # ticks that step X
    t, line = rows[:, 0], rows[:, 1]
    cruise = 1 / (1200 / 60 * CBR40.steps_per_mm[0])
    pred = predict_stalls(job, CBR40)
    assert CBR40.laser_change_syncs == FIRMWARE_LASER_CHANGE_SYNCS
    for k, (a, b) in enumerate(((3, 5), (5, 7))):
        i = int(np.flatnonzero((line[:-1] == a) & (line[1:] == b))[0])
        stopped = t[i + 1] - t[i] > 10 * cruise
        assert stopped == FIRMWARE_LASER_CHANGE_SYNCS, (a, b, t[i + 1] - t[i])
        # the plan: the cut leaves at its rest speed where the firmware stops
        assert (pred.block_exit_mm_s[k] <= pred.block_floor_mm_s[k] * (1 + 1e-9)) == stopped


def test_paced_options_are_checked(sim, tmp_path):
    for args, expected in ((["--baud", "12x"], "--baud: expected a whole number"),
                           (["--baud", "100"], "300 to 10000000"),
                           (["--starvation-log", str(tmp_path / "s.csv")], "need --baud"),
                           (["--baud", "9600", "--parse-us", "-1"], "--parse-us: expected"),
                           (["--baud", "9600", "--realtime"], "leave out --realtime")):
        run = subprocess.run([sim, *args], input="", capture_output=True, text=True, timeout=30)
        assert run.returncode == 2 and expected in run.stderr, (args, run.stderr)


# ---------------------------------------------------------------- predictor against the simulator

def _image_job(tmp: Path, image: str, mode: str, pitch: float, width_mm: float, feed: float) -> str:
    out = tmp / f"{Path(image).stem}-{mode}-{pitch}.gcode"
    assert main(["img2gcode", str(ROOT / "data/images" / image), "-o", str(out), "--mode", mode,
                 "--beam", str(pitch), "--width", str(width_mm), "--feed", str(feed),
                 "--preview", "none", "--dialect", "grbl"]) == 0
    return out.read_text("ascii")


def _svg_job(tmp: Path, svg: str, tol: float, feed: float) -> str:
    out = tmp / f"{Path(svg).stem}-{tol}.gcode"
    assert main(["svg2gcode", str(ROOT / "data/svg" / svg), "-o", str(out), "--tol", str(tol),
                 "--feed", str(feed), "--dialect", "grbl"]) == 0
    return out.read_text("ascii")


def _lasergrbl_photo_job(tmp: Path) -> str:
    """The photo in gray at 0.1 mm pixels, 20 mm wide, as LaserGRBL writes a line-to-line job
    (``benchmarks/_lasergrbl.py``): the stall-free feed table of README.md's raster section."""
    from labkit.raster.engrave import RasterSettings, image_to_job
    from labkit.raster.io import read_image

    spec = importlib.util.spec_from_file_location("_lasergrbl", ROOT / "benchmarks" / "_lasergrbl.py")
    lasergrbl = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(lasergrbl)
    job = image_to_job(read_image(ROOT / "data/images/photo_500x450_72dpi.jpg"),
                       RasterSettings(mode="gray", beam_mm=0.1, feed_mm_min=6000.0, width_mm=20.0))
    return lasergrbl.lasergrbl_line_to_line(job.target, 0.1, 6000.0)


#: The labkit firmware with grbl-diode's belts (its settings sent ahead of the job).
LABKIT_DIODE = load_machine("labkit-diode")

#: (name, how the job is made, baud[, machine]): real images and drawings, the pitch and the
#: baud rate chosen so that the link, not the machine's top speed (CBR-40's 1546 mm/min unless
#: another machine is named), limits the feed.
JOBS = [
    ("photo gray 0.1 mm @ 4800", lambda t: _image_job(t, "photo_500x450_72dpi.jpg", "gray", 0.1, 4.0, 1500), 4800),
    ("photo gray 0.05 mm @ 9600", lambda t: _image_job(t, "photo_500x450_72dpi.jpg", "gray", 0.05, 2.0, 1500), 9600),
    ("photo gray 0.05 mm @ 4800", lambda t: _image_job(t, "photo_500x450_72dpi.jpg", "gray", 0.05, 2.0, 300), 4800),
    ("photo dither 0.1 mm @ 4800", lambda t: _image_job(t, "photo_500x450_72dpi.jpg", "dither", 0.1, 4.0, 1500), 4800),
    ("gray card dither 0.05 mm @ 4800", lambda t: _image_job(t, "gray_card.png", "dither", 0.05, 3.0, 600), 4800),
    ("gray card gray 0.1 mm @ 9600", lambda t: _image_job(t, "gray_card.png", "gray", 0.1, 6.0, 1500), 9600),
    ("waves zigzag 0.05 mm @ 2400", lambda t: _image_job(t, "waves.png", "zigzag", 0.05, 3.0, 100), 2400),
    ("waves zigzag 0.02 mm @ 9600", lambda t: _image_job(t, "waves.png", "zigzag", 0.02, 1.2, 1000), 9600),
    ("shapes 0.0005 mm @ 9600", lambda t: _svg_job(t, "svg2gcode/shapes.svg", 0.0005, 1500), 9600),
    ("jsdc 0.001 mm @ 19200", lambda t: _svg_job(t, "cncjs/jsdc.svg", 0.001, 1500), 19200),
    ("photo LaserGRBL-style 0.1 mm @ 57600", _lasergrbl_photo_job, 57600, LABKIT_DIODE),
]


def job_machine(job):
    """The machine description a ``JOBS`` entry streams on, with its baud rate."""
    return (job[3] if len(job) > 3 else CBR40).replace(link_baud=job[2])


def stream_job(sim: str, text: str, machine, tmp: Path):
    """(starvations, seconds) of ``text`` streamed on ``machine``: CBR-40 is the firmware's
    defaults; another machine gets its settings sent first (``paced_stream.stream_paced``)."""
    if machine.name == CBR40.name:
        return stream_paced(sim, text, machine, tmp)
    run = paced_stream.stream_paced(sim, text, machine, tmp)
    assert not run.host_late, f"the sender was late {run.host_late} times"
    return run.stalls, run.seconds


@pytest.mark.parametrize("job", JOBS, ids=[j[0] for j in JOBS])
def test_predicted_stalls_and_stall_free_feed_match_the_simulator(sim, tmp_path, job, capsys):
    name, make, baud = job[:3]
    text = make(tmp_path)
    machine = job_machine(job)
    found = stall_free_feed(text, machine, line_bytes=stream_py_bytes, rel_tol=0.005, rows=False)
    f_star = found.feed_mm_min
    assert found.limited_by == "link", f"{name}: the link never limits this job (F* = {f_star:.0f})"
    report = [f"{name}: predicted stall-free feed {f_star:.1f} mm/min"]
    for factor, must_stall in ((0.95, False), (1.05, True), (1.4, True)):
        feed = min(f_star * factor, float(machine.max_rate_mm_min[0]))
        job = with_feed(text, feed)
        simulated, seconds = stream_job(sim, job, machine, tmp_path)
        predicted = predict_stalls(job, machine, line_bytes=stream_py_bytes(job)).stalls
        shadows, missed = poll_shadows(simulated, predicted, baud, seconds)
        assert not missed, f"{name} at {feed:.0f} mm/min: simulated starvations not predicted: {missed[:5]}"
        real = [s for s in simulated if s not in shadows]
        if must_stall:
            assert real, f"{name}: no starvation simulated at {feed:.0f} mm/min ({factor} F*)"
        else:
            assert not real, f"{name}: starvations simulated at {feed:.0f} mm/min ({factor} F*): {real[:5]}"
        report.append(f"  {factor:.2f} F*: simulated {len(simulated)} ({len(shadows)} behind a '?'), "
                      f"predicted {len(predicted)} ({sum(s.duration_s for s in simulated):.4f} s vs "
                      f"{sum(s.duration_s for s in predicted):.4f} s standing)")
    with capsys.disabled():
        print("\n" + "\n".join(report))
