"""Restart text for a job: resume after a fault, and the frame trace before a burn.

:func:`resume_text` rebuilds the modal state in effect at a line (units,
distance mode, arc-centre mode, plane, coordinate system, the job's own G92 and
tool offsets, feed, laser mode and power) from the parse, moves to the stop
point with the beam off, finishes the interrupted line from there, and
continues with the next lines — so every line runs exactly once.
:func:`frame_text` traces a job's bounding box with the beam off or at a
visible power. The job runner (:mod:`labkit.machine.stream`) sends both.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from labkit.errors import InputError
from labkit.gcode.state import ModalState, axis_words, line_states, restate

if TYPE_CHECKING:                        # the runner imports this module; Job is a type here only
    from labkit.machine.stream import Job

__all__ = ["resume_text", "frame_text"]


def resume_text(job: "Job", line: int, position=None) -> list[str]:
    """Lines that restore the state before ``line``, go there with the beam off, and finish it.

    Everything is said in the job's own coordinates (the work coordinates its X Y Z
    words mean), so a resume lands where the job would have been whatever origin the
    controller holds: G54–G59 origins stay on the controller (GRBL keeps them in
    EEPROM) and the coordinate system in use is restated; a G92 or G43.1 offset the job
    itself set is restated too, since GRBL's reset clears them — G92.1, the move, then
    G92 with the position the job's words give there.

    Parameters
    ----------
    job : Job
    line : int
        First source line to run (1-based).
    position : sequence of 3 floats, optional
        Where the machine stopped inside ``line``, in the job's coordinates (a
        status report's WPos: ``report.stop_position``). The line's remaining
        motion is sent from there instead of the whole line, so nothing is
        burned twice. None: go to the line's start.

    Returns
    -------
    list of str
        The preamble; the job's own lines follow from ``line + 1`` (with a
        position) or from ``line`` (without).

    Examples
    --------
    >>> from labkit.machine.stream import Job
    >>> job = Job.from_text("G21 G90\\nM4 S300 F600\\nG1 X10\\nG1 Y10\\nM5\\n")
    >>> resume_text(job, 4)
    ['M5 S0', 'G21 G90 G91.1 G17 G54', 'G0 X10 Y0 Z0', 'G1 F600 S300', 'M4']
    >>> resume_text(job, 4, position=(10, 4, 0))[-1]
    'G1 X10 Y10 Z0 F600 S300'

    A job that sets its own origin with G92 gets it back:

    >>> job = Job.from_text("G0 X50 Y50\\nG92 X0 Y0\\nM4 S300 F600\\nG1 X10\\nG1 Y10\\nM5\\n")
    >>> resume_text(job, 5)[1:5]
    ['G21 G90 G91.1 G17 G54', 'G92.1', 'G0 X60 Y50 Z0', 'G92 X10 Y0 Z0']
    """
    if not 1 <= line <= len(job.source_lines):
        raise InputError(f"resume line {line} is outside the file (1–{len(job.source_lines)})")
    prefix = "\n".join(job.source_lines[:line])
    trace, _ = line_states(prefix, dialect=job.dialect)
    before = ModalState.at(trace, line - 2)            # the state the line starts from
    _refuse_unknown_origin(prefix, job.dialect, trace, line)
    here = before.work_position if position is None else np.asarray(position, float)
    finish = []
    if position is not None:
        m = job.moves
        rows = np.flatnonzero(m.line == line)
        if len(rows) == 0:
            raise InputError(f"line {line} has no motion to finish")
        r = rows[-1]
        kind = int(m.kind[r])
        offset = m.work_offset[r]                    # Moves are machine coordinates
        end = m.end[r] - offset
        # the rest of the line burns with the line's own F, S and M3/M4 (its words may set them)
        own = ModalState.at(trace, line - 1)
        if own.laser != before.laser:
            finish.append(f"M{own.laser}")
        words = (f" F{own.feed_mm_min:g}" if math.isfinite(own.feed_mm_min) else "") + f" S{own.s_word:g}"
        xyz = axis_words(end, 4)
        if kind in (2, 3):
            c = m.centre[r] - offset - here
            finish.append(f"G{kind} {xyz} I{c[0]:.4f} J{c[1]:.4f}{words}")
        else:
            finish.append(f"G{kind} {xyz}{words}")
    return restate(before, job.dialect, here, origins_kept=True, then=finish)


#: A start position no program assumes (Z left at 0: a flat job that never names Z).
_PROBE_START_MM = (1234.5, -678.25, 0.0)


def _refuse_unknown_origin(prefix: str, dialect, trace, line: int) -> None:
    """Raise when the G92 offset in effect before ``line`` was taken wherever the head stood
    when the job began (``G92 X0 Y0`` as a job's first line: a job placed at the current
    position, LightBurn's "Current Position"). GRBL clears G92 on a reset and the program
    alone cannot say where the head was, so a resume would burn in the wrong place. (A job
    with no such G92 is resumed, as it is run, in the work coordinates.)"""
    if line < 2:
        return
    here = ModalState.at(trace, line - 2)
    elsewhere, _ = line_states(prefix, dialect=dialect, state=ModalState(position=_PROBE_START_MM))
    there = ModalState.at(elsewhere, line - 2)
    if np.allclose(here.g92, there.g92, atol=1e-9):
        return
    raise InputError(
        f"the G92 offset in effect at line {line} was taken wherever the head stood when the "
        f"job began (a job placed at the current position); a reset has cleared it and the "
        f"program does not say where that was, so resuming at line {line} would burn in the "
        f"wrong place. Run the job again from its start point, or make the remaining lines a "
        f"job of their own placed where they belong")


def frame_text(job: "Job", *, s_word: float = 0.0, feed_mm_min: float = 3000.0) -> list[str]:
    """Trace the job's bounding box with the beam off (or at a low visible power).

    Parameters
    ----------
    s_word : float
        0 (default): beam off. A small S (about 1 % of ``$30``) shows the
        frame on the work without marking it.
    feed_mm_min : float
        Speed of the trace.

    Examples
    --------
    >>> from labkit.machine.stream import Job
    >>> job = Job.from_text("G0 X5 Y5\\nM3 S500\\nG1 X15 Y8 F600\\nM5\\n")
    >>> frame_text(job)[2:5]
    ['G0 X5.000 Y5.000', 'M5 S0', 'G0 X15.000 Y5.000 F3000']
    """
    box = job.moves.bounds(job.moves.laser_on)
    if np.isnan(box).any():
        box = job.moves.bounds()
    if np.isnan(box).any():
        raise InputError("the job has no motion to frame")
    (x0, y0), (x1, y1) = box[0, :2], box[1, :2]
    beam = ["M5 S0"] if s_word <= 0 else [f"M3 S{s_word:g}"]
    cmd = "G1" if s_word > 0 else "G0"
    return (["G21 G90", "M5 S0", f"G0 X{x0:.3f} Y{y0:.3f}"] + beam +
            [f"{cmd} X{x1:.3f} Y{y0:.3f} F{feed_mm_min:g}", f"{cmd} X{x1:.3f} Y{y1:.3f}",
             f"{cmd} X{x0:.3f} Y{y1:.3f}", f"{cmd} X{x0:.3f} Y{y0:.3f}", "M5 S0"])
