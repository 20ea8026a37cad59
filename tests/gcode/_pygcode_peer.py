"""Run a program through pygcode's interpreter, the independent peer of our parser."""

import numpy as np
from pygcode import Line, Machine
from pygcode.gcodes import GCodeArcMove


def positions_by_line(text):
    """Position (X, Y, Z) in mm after every line, and the I J K words of each arc line."""
    machine = Machine()
    positions, arc_words = [], {}
    for lineno, raw in enumerate(text.splitlines(), start=1):
        line = Line(raw)
        for g in line.block.gcodes:
            if isinstance(g, GCodeArcMove):
                arc_words[lineno] = {k: float(w.value) for k, w in g.params.items()}
        machine.process_block(line.block)
        pos = machine.pos.values
        positions.append([float(pos.get(a, 0.0)) for a in "XYZ"])
    return np.array(positions), arc_words
