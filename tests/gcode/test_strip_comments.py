"""One home for G-code comments (issue 28): :func:`labkit.gcode.reader.strip_comments` cuts
them as GRBL 1.1's serial reader drops characters (worked by hand from its protocol: after
``(`` every character is dropped up to ``)`` or the line's end; after ``;`` up to the line's
end), and both the streamer's :func:`~labkit.machine.stream.strip_line` and the ``$``-line
verdicts read lines through it."""
import pytest

from labkit.gcode.reader import grbl_system_verdict, strip_comments
from labkit.machine.stream import strip_line


@pytest.mark.parametrize("line, without", [
    ("G1 X10 (cut) Y5", "G1 X10  Y5"),
    ("G1 X10 ; to the corner (not a comment start)", "G1 X10 "),
    ("(a)(b)G0 X1(c)", "G0 X1"),
    ("G0 X1 (never closed Y2", "G0 X1 "),      # GRBL drops up to the line's end
    ("G0 X1 (a ; b) Y2", "G0 X1  Y2"),         # ';' inside parentheses does not end the line
    ("G0 X1 ) Y2", "G0 X1 ) Y2"),              # a lone ')' is text (the parser refuses it)
    ("", ""),
])
def test_comments_cut_as_grbl_reads_them(line, without):
    assert strip_comments(line) == without


def test_the_streamer_and_the_verdicts_cut_the_same_comments():
    # an unclosed comment after a setting: GRBL reads "$10=1" and accepts it
    assert strip_line("$10 = 1 (status mask") == "$10=1"
    assert grbl_system_verdict("$10 = 1 (status mask") is None
    # the comment hides the words that would make it invalid
    assert strip_line("$$ (list ; the settings)") == "$$"
    assert grbl_system_verdict("$$ (list ; the settings)") is None
    assert grbl_system_verdict("$$ x") == ("invalid_statement", "$$ takes nothing after it")
