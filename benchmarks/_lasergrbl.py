"""A LaserGRBL-style line-to-line program of an S map, and the bytes LaserGRBL's sender sends.

Written here from how LaserGRBL (github.com/arkypita/LaserGRBL, GPLv3) builds a grayscale
"line to line tracing" job, read in its ``GrblFile.cs`` (``LoadImageL2L``, ``ImageLine2Line``,
``OptimizeLine2Line``, ``GetSegments``) and ``GrblCommand.cs`` (``SerialData``) at b81845c; no
line of it is copied. What it writes, for a horizontal scan with PWM:

* the header ``G90`` (its default custom header, a comment after it), a move to the offset
  ``G0 X<oX> Y<oY> F<mark speed>`` and ``M3 S0`` or ``M4 S0`` (its "laser on" choice);
* every image row, bottom row first, scanned over the whole width, even rows left to right
  and odd rows right to left (bidirectional unless "Unidirectional Engraving" is set);
* each run of equal power as ``X<end> S<power>``: absolute X, words separated by a space,
  numbers rounded to three decimals and written shortest (``12.3``, ``0.05``, ``7``), one S
  on every line; ``G1 `` before the first burning run after a white one;
* white (power 0) runs and the step to the next row are not written as moves: they are
  gathered and replaced, before the next burning run, by one ``G0 X<x> Y<y> S0`` to where
  it starts; a row that ends burning gets a lone ``S0`` line first;
* ``M5``, then its default footer ``G0 X0 Y0 Z0``.

Its sender strips the spaces (``GrblCommand.SerialData``: ``Replace(" ", "")``) and comments
and ends each line with ``\\n``, so on the link a line is its words only.

The S map is the burn labkit plans (its power per pixel); LaserGRBL would reach it from an
8-bit gray image through its power range. Rows are put at pixel centres with LaserGRBL's own
offset setting (``oY`` = half a pixel), so that its burn can be compared pixel for pixel.
"""

from __future__ import annotations

import numpy as np


def lasergrbl_number(value: float) -> str:
    """A coordinate as LaserGRBL writes it: rounded to three decimals (half to even, as .NET's
    ``Math.Round``), shortest text, a leading 0 kept.

    >>> [lasergrbl_number(v) for v in (12.3, 0.05, 7.0, 1.23456, -0.0)]
    ['12.3', '0.05', '7', '1.235', '0']
    """
    text = repr(round(float(value), 3) + 0.0)
    if text.endswith(".0"):
        text = text[:-2]
    return "0" if text == "-0" else text


def _row_runs(row: np.ndarray):
    """(lengths, powers) of the runs of equal power over a whole row, left to right."""
    cut = np.flatnonzero(np.diff(row)) + 1
    starts = np.r_[0, cut]
    ends = np.r_[cut, len(row)]
    return (ends - starts).tolist(), row[starts].tolist()


def lasergrbl_line_to_line(power: np.ndarray, pitch_mm: float, feed_mm_min: float, *,
                           laser_on: str = "M4") -> str:
    """The S map ``power`` (rows top first, 0 = not burned) as LaserGRBL's line-to-line job.

    Parameters
    ----------
    power : ndarray of int, (rows, columns)
        S of each pixel.
    pitch_mm : float
        Pixel size, mm (LaserGRBL's resolution is its inverse, lines per mm).
    feed_mm_min : float
        LaserGRBL's "mark speed", mm/min.
    laser_on : {"M3", "M4"}
        LaserGRBL's "laser on" command.

    Returns
    -------
    str
    """
    rows, cols = power.shape
    num = lasergrbl_number
    oy = pitch_mm / 2
    out = ["G90 (use absolute coordinates)", f"G0 X0 Y{num(oy)} F{num(feed_mm_min)}", f"{laser_on} S0"]
    x = 0                       # pixels from the left edge
    gathering = False           # white moves gathered, to be replaced by one G0
    burning = False             # the last run written burned (the next burning one needs no G1)
    for i in range(rows):
        row = power[rows - 1 - i]
        y = num(i * pitch_mm + oy)
        if i:                   # the step to the next row (a white move)
            if burning:
                out.append("S0")
            burning, gathering = False, True
        lengths, values = _row_runs(row)
        forward = i % 2 == 0
        if not forward:
            lengths, values = lengths[::-1], values[::-1]
        for n, s in zip(lengths, values):
            start = x
            x += n if forward else -n
            if s == 0:
                burning, gathering = False, True
                continue
            if gathering:
                out.append(f"G0 X{num(start * pitch_mm)} Y{y} S0")
                gathering = False
            out.append(f"{'' if burning else 'G1 '}X{num(x * pitch_mm)} S{int(s)}")
            burning = True
    out += ["M5", "G0 X0 Y0 Z0 (move back to origin)"]
    return "\n".join(out) + "\n"


def lasergrbl_sent_bytes(text: str) -> int:
    """Bytes LaserGRBL's sender puts on the link for ``text``: each line without its comments
    and spaces, and a ``\\n``; empty lines are not sent.

    >>> lasergrbl_sent_bytes("G90 (use absolute coordinates)\\nG1 X12.3 S500\\n\\n")
    16
    """
    total = 0
    for line in text.splitlines():
        code = line.split(";", 1)[0]
        while "(" in code:
            a = code.index("(")
            b = code.find(")", a)
            code = code[:a] + (code[b + 1:] if b >= 0 else "")
        code = code.replace(" ", "").strip()
        if code:
            total += len(code) + 1
    return total
