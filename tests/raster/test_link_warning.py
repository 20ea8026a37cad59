"""img2gcode warns when the machine's serial link cannot deliver the job at its feed (issue 30 §3).

The warning's feed is the stall predictor's (labkit.motion.stall.stall_free_feed, itself checked
against the paced firmware simulator); the cheap condition that decides whether the predictor
runs at all must never miss a starvation the predictor finds. The images are made here by hand:
a busy gray row (S changes every pixel) and a calm one.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from labkit.cli import main
from labkit.motion import load_machine
from labkit.motion.stall import predict_stalls, stall_free_feed


def _image(tmp_path):
    from PIL import Image

    img = np.full((6, 100), 255, np.uint8)
    img[1, :] = np.arange(100) * 2
    img[4, 5:95] = 0
    path = tmp_path / "rows.png"
    Image.fromarray(img).save(path, dpi=(254, 254))
    return path


def _machine_file(tmp_path, baud, name="grbl-diode"):
    """A shipped machine description with another link speed, as a user would copy and edit it."""
    from labkit.motion.spec import MACHINES_DIR

    text = (MACHINES_DIR / f"{name}.toml").read_text()
    assert "link_baud = 115200" in text
    path = tmp_path / f"{name}-{baud}.toml"
    path.write_text(text.replace("link_baud = 115200", f"link_baud = {baud}")
                    .replace(f'name = "{name}"', f'name = "{name}-{baud}"'))
    assert load_machine(str(path)) == load_machine(name).replace(link_baud=baud, name=f"{name}-{baud}")
    return path


def test_the_warning_names_the_stall_free_feed_and_a_pitch(tmp_path, capsys):
    png, out = _image(tmp_path), tmp_path / "job.gcode"
    machine = _machine_file(tmp_path, 9600)
    assert main(["img2gcode", str(png), "-o", str(out), "--mode", "gray", "--preview", "none",
                 "--feed", "3000", "--machine", str(machine)]) == 0
    err = capsys.readouterr().err
    text = out.read_text()                                       # written anyway
    m = load_machine(str(machine))
    stalls = predict_stalls(text, m).stalls
    free = stall_free_feed(text, m, rows=False)
    assert stalls and free.limited_by == "link" and free.feed_mm_min < 3000
    feed = math.floor(free.feed_mm_min)
    assert err.count("warning:") == 1
    assert "at 9600 baud" in err and f"--feed {feed}," in err
    assert f"{len(stalls)} starvations predicted at the programmed feed 3000 mm/min" in err
    pitch = math.ceil(0.1 * 3000 / free.feed_mm_min * 1000) / 1000
    assert f"pixel pitch of about {pitch:g} mm" in err and "an estimate" in err
    # the proposed feed runs without a starvation, and img2gcode says nothing there
    assert main(["img2gcode", str(png), "-o", str(out), "--mode", "gray", "--preview", "none",
                 "--feed", str(feed), "--machine", str(machine)]) == 0
    assert "warning" not in capsys.readouterr().err
    assert not predict_stalls(out.read_text(), m).stalls
    # the proposed pitch (an estimate) does too at the programmed feed
    assert main(["img2gcode", str(png), "-o", str(out), "--mode", "gray", "--preview", "none",
                 "--feed", "3000", "--beam", f"{pitch:g}", "--machine", str(machine)]) == 0
    assert not predict_stalls(out.read_text(), m).stalls


def test_no_warning_and_no_prediction_when_the_link_keeps_up(tmp_path, capsys, monkeypatch):
    """At 115200 baud the default job cannot starve: the cheap condition says so and the
    predictor never runs (it would fail the test here)."""
    import labkit.motion.stall as stall

    def must_not_run(*a, **k):
        raise AssertionError("the predictor ran")

    monkeypatch.setattr(stall, "predict_stalls", must_not_run)
    png, out = _image(tmp_path), tmp_path / "job.gcode"
    for mode in ("gray", "dither", "zigzag"):
        assert main(["img2gcode", str(png), "-o", str(out), "--mode", mode, "--preview", "none"]) == 0
        assert "warning" not in capsys.readouterr().err


@pytest.mark.parametrize("mode", ["gray", "dither", "zigzag"])
def test_the_cheap_condition_never_misses_a_stall_on_img2gcode_jobs(tmp_path, capsys, monkeypatch, mode):
    """Wherever the predictor finds a starvation, img2gcode's cheap condition holds (the
    predictor is called); at several feeds, baud rates and both controllers."""
    import labkit.motion.stall as stall

    calls = []
    real = stall.predict_stalls

    def counted(*a, **k):
        calls.append(1)
        return real(*a, **k)

    monkeypatch.setattr(stall, "predict_stalls", counted)
    png, out = _image(tmp_path), tmp_path / "job.gcode"
    seen = starved = 0
    for name in ("cbr40-laser", "grbl-diode"):
        for baud in (2400, 9600, 38400, 115200):
            machine = _machine_file(tmp_path, baud, name)
            m = load_machine(str(machine))
            for feed in (600, 3000, 6000):
                calls.clear()
                assert main(["img2gcode", str(png), "-o", str(out), "--mode", mode, "--preview", "none",
                             "--feed", str(feed), "--machine", str(machine)]) == 0
                capsys.readouterr()
                if real(out.read_text(), m).stalls:
                    assert calls, (name, baud, feed)
                    starved += 1
                seen += 1
    assert seen == 24 and starved >= 3
