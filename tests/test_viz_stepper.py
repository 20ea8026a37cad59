"""The step-through simulator shows, at each line, the state a controller would be in."""

import re

from labkit.viz.stepper import gcode_stepper

PROGRAM = "G21 G90\nM3 S600\nG0 X10 Y5\nG1 X35 F1200\nG91 Y25\nG90 G1 X10\nM5\n"
# worked by hand: (motion, distance, feed, X, Y) after each line
EXPECTED = {1: ("G0", "G90", "not set", "0", "0"), 3: ("G0", "G90", "not set", "10", "5"),
            4: ("G1", "G90", "1200", "35", "5"), 5: ("G1", "G91", "1200", "35", "30"),
            6: ("G1", "G90", "1200", "10", "30"), 7: ("G1", "G90", "1200", "10", "30")}


def _state(widget):
    html = widget.children[1].children[1].value
    return dict(re.findall(r"<td[^>]*>([^<]+)</td><td><b>([^<]*)</b>", html))


def test_stepping_shows_the_state_after_each_line():
    widget = gcode_stepper(PROGRAM)
    for line, (motion, distance, feed, x, y) in EXPECTED.items():
        widget.controls["line"].value = line
        state = _state(widget)
        assert (state["motion"], state["distance"], state["feed (mm/min)"], state["X (mm)"], state["Y (mm)"]) == \
            (motion, distance, feed, x, y), line
        listing = widget.children[1].children[0].value
        highlighted = re.search(r'<span style="background[^>]*>\s*(\d+)', listing).group(1)
        assert int(highlighted) == line
        assert widget.children[-1].outputs, "the picture is drawn"


def test_laser_state_follows_m3_and_m5():
    widget = gcode_stepper(PROGRAM)
    widget.controls["line"].value = 2
    assert _state(widget)["laser"] == "M3"
    widget.controls["line"].value = 7
    assert _state(widget)["laser"] == "M5"


def test_a_rejected_line_is_flagged_not_fatal():
    widget = gcode_stepper("G21 G90\nG1 X10\nG1 X20 F600\n")
    widget.controls["line"].value = 2
    assert "error 22" in widget.children[1].children[1].value
