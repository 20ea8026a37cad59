"""The G-code modal state's one home: :class:`ModalState` and :func:`restate`.

The compiled interpreter (:mod:`labkit.gcode._kernel`) keeps the state a controller
keeps between lines — units, distance mode, plane, arc-centre mode, feed mode, the
coordinate system and its G10 origins, the G92 offset, the tool length offset, the
G28.1/G30.1 positions, F, S, the laser mode, coolant and the position — and writes it
after every line as one record (its trace row, :data:`~labkit.gcode._kernel.TRACE_ROW`).
:class:`ModalState` is that record read once, with names; the interpreter starts from
one and ends in one (:class:`labkit.gcode.reader.Interpreter`).

:func:`restate` writes the state back as G-code: the preamble every restart needs, so
that the lines after it run as they would have run after the whole program — a part of
a split program on a fresh controller (:mod:`labkit.gcode.split`), a job resumed after
a fault on the controller that ran it (:mod:`labkit.machine.resume`).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from labkit.errors import InputError
from labkit.gcode import _kernel as K

__all__ = ["ModalState", "restate", "line_states", "axis_words", "grbl_sync_reasons", "grbl_words",
           "is_motion_line"]

#: The laser words by the interpreter's laser mode (labkit.toolpath.LaserMode's values).
_LASER_WORDS = {K.LASER_OFF: 5, K.LASER_CONSTANT: 3, K.LASER_DYNAMIC: 4}


def _triple(v) -> tuple:
    return tuple(float(c) for c in v)


@dataclass(frozen=True)
class ModalState:
    """What a controller holds between lines, and where the head is.

    Attributes
    ----------
    position : tuple of 3 float
        Machine position, mm (the controller's G54–G59 origins as the program set them,
        zero at power-on).
    motion : float
        Motion mode: 0, 1, 2, 3, 80, or 382–385 for G38.2–G38.5.
    plane, units, distance : int
        17/18/19, 20 (inch) or 21 (mm), 90 or 91.
    arc_centres : float
        90.1 (absolute I J K) or 91.1 (incremental).
    feed_mode : int
        94 (units per minute) or 93 (inverse time).
    coord_system : int
        54–59.
    coord_origins : tuple of 6 tuples of 3 float
        G54–G59 origins, machine mm (G10 L2/L20).
    g92 : tuple of 3 float
        G92 offset, mm.
    tool_offset : float
        G43.1 tool length offset on Z, mm.
    home28, home30 : tuple of 3 float
        Positions stored by G28.1 and G30.1, machine mm.
    feed_mm_min : float
        F in mm/min; NaN while undefined (and in G93, where F is per move).
    s_word : float
        S as written (laser power in the controller's S units).
    laser : int
        3 (M3, constant power), 4 (M4, dynamic power) or 5 (M5, off).
    coolant : tuple of int
        Coolant/air-assist words on: ``()``, ``(7,)``, ``(8,)`` or ``(7, 8)``.
    syncing : bool
        The line that led to this state waits for the planner to empty before it runs
        (on GRBL: a dwell, G10, G28, G30, G92, a program stop or end, a laser or coolant M
        word), so a controller may take it and answer only later.
    """

    position: tuple = (0.0, 0.0, 0.0)
    motion: float = 0
    plane: int = 17
    units: int = 21
    distance: int = 90
    arc_centres: float = 91.1
    feed_mode: int = 94
    coord_system: int = 54
    coord_origins: tuple = ((0.0, 0.0, 0.0),) * 6
    g92: tuple = (0.0, 0.0, 0.0)
    tool_offset: float = 0.0
    home28: tuple = (0.0, 0.0, 0.0)
    home30: tuple = (0.0, 0.0, 0.0)
    feed_mm_min: float = math.nan
    s_word: float = 0.0
    laser: int = 5
    coolant: tuple = ()
    syncing: bool = False

    @classmethod
    def at(cls, trace, row: int) -> "ModalState":
        """The state in row ``row`` of an interpreter trace (the state after line ``row + 1``);
        row -1 is GRBL's power-on state.

        >>> from labkit.gcode.state import line_states
        >>> trace, _ = line_states("G20 G91\\nM8 M4 S300\\nG1 X1 F10\\n")
        >>> st = ModalState.at(trace, 2)
        >>> st.units, st.distance, st.laser, st.coolant, st.feed_mm_min, st.position[0]
        (20, 91, 4, (8,), 254.0, 25.4)
        >>> ModalState.at(trace, -1) == ModalState()
        True
        """
        if row < 0:
            return cls()
        t = trace[row]
        cool = int(t["coolant"])
        return cls(position=_triple(t["position"]), motion=_number(t["motion"]),
                   plane=int(t["plane"]), units=int(t["units"]), distance=int(t["distance"]),
                   arc_centres=float(t["arc_distance"]), feed_mode=int(t["feed_mode"]),
                   coord_system=int(t["coord_system"]),
                   coord_origins=tuple(_triple(o) for o in t["coord_origins"]),
                   g92=_triple(t["g92"]), tool_offset=float(t["tool_offset"]),
                   home28=_triple(t["home28"]), home30=_triple(t["home30"]),
                   feed_mm_min=float(t["feed_mm_min"]), s_word=float(t["s_word"]),
                   laser=_LASER_WORDS[int(t["laser"])],
                   coolant=tuple(m for m in (7, 8) if cool & (1 << (m - 7))),
                   syncing=bool(t["syncing"]))

    def record(self) -> np.ndarray:
        """The state as the interpreter's one-row trace record (where it starts from)."""
        st = K.initial_state()
        t = st[0]
        t["position"], t["motion"], t["plane"] = self.position, self.motion, self.plane
        t["units"], t["distance"], t["arc_distance"] = self.units, self.distance, self.arc_centres
        t["feed_mode"], t["coord_system"] = self.feed_mode, self.coord_system
        t["coord_origins"], t["g92"], t["tool_offset"] = self.coord_origins, self.g92, self.tool_offset
        t["home28"], t["home30"], t["feed_mm_min"] = self.home28, self.home30, self.feed_mm_min
        t["s_word"] = self.s_word
        t["laser"] = {v: k for k, v in _LASER_WORDS.items()}[self.laser]
        t["coolant"] = sum(1 << (m - 7) for m in self.coolant)
        t["syncing"] = self.syncing
        return st

    @property
    def work_offset(self) -> np.ndarray:
        """Machine position minus work position, mm: the system's origin, G92, and the tool
        offset on Z (GRBL's WCO)."""
        w = np.array(self.coord_origins[self.coord_system - 54], float) + np.array(self.g92, float)
        w[2] += self.tool_offset
        return w

    @property
    def work_position(self) -> np.ndarray:
        """Where the head is in the coordinates the program's X Y Z words mean, mm."""
        return np.array(self.position, float) - self.work_offset


def _number(v) -> float:
    v = float(v)
    return int(v) if v == int(v) else v


def line_states(text, *, dialect="grbl", state: ModalState | None = None):
    """The interpreter's state after every line of ``text`` (rejected lines keep the state
    before them), and the lines.

    Parameters
    ----------
    text : str or bytes
    dialect : str or Dialect
    state : ModalState, optional
        The state the first line starts from (default: GRBL's power-on state at the
        machine origin).

    Returns
    -------
    trace : ndarray of :data:`~labkit.gcode._kernel.TRACE_ROW`
        One row per line; :meth:`ModalState.at` reads a row.
    lines : list of str
        The lines as read (line ends removed).
    """
    from labkit.gcode.dialects import get_dialect
    from labkit.gcode.reader import _as_bytes, _run, _text_lines

    data = _as_bytes(text)
    lines = _text_lines(data)
    start = None if state is None else state.record()
    return _run(data, get_dialect(dialect), lenient=True, trace=True,
                start=start).trace[:len(lines)], lines


def _shortest(value: float) -> str:
    """Shortest decimal that reads back as the same double, never in exponent form."""
    if value == 0:
        return "0"
    return np.format_float_positional(float(value), unique=True, trim="-")


def axis_words(point, decimals: int | None = None) -> str:
    """``X… Y… Z…`` for a point in mm: the shortest decimal that reads back as the same
    double (``decimals`` None), or rounded to ``decimals`` places without trailing zeros.

    >>> axis_words((10.0, 2.5, 0.0)), axis_words((1 / 3, -0.00001, 25.4), 4)
    ('X10 Y2.5 Z0', 'X0.3333 Y0 Z25.4')
    """
    from labkit.gcode.writer import format_number

    if decimals is None:
        return " ".join(f"{a}{_shortest(v)}" for a, v in zip("XYZ", point))
    return " ".join(f"{a}{format_number(float(v), decimals)}" for a, v in zip("XYZ", point))


def restate(state: ModalState, dialect, position=None, *, origins_kept: bool = False,
            then=()) -> list[str]:
    """The G-code that brings a controller to ``state`` with the beam off, the head at
    ``position``.

    Parameters
    ----------
    state : ModalState
    dialect : str or Dialect
    position : sequence of 3 float, optional
        Where the head goes, in the state's work coordinates (what the program's X Y Z
        words mean there), mm. None: the state's own position.
    origins_kept : bool
        False: the controller is fresh as the parser models it (every origin zero, so
        the work offset in effect is restated with G92, positions are exact decimals) —
        a part of a split program. True: the controller that ran the program, after a
        soft reset (its G54–G59 origins are kept, as GRBL keeps them in EEPROM; the
        program's own G92 and tool offsets are cleared, so they are restated; positions
        in work coordinates to 0.1 µm) — a resumed job.
    then : sequence of str
        Lines to run in mm and absolute distance mode before the program's own units
        and distance mode return (the rest of an interrupted line).

    Returns
    -------
    list of str
        G-code lines (no newlines).

    Raises
    ------
    InputError
        A work offset is in effect and the dialect has no G92 to restate it.

    Examples
    --------
    >>> st = ModalState(position=(10.0, 2.5, 0.0), motion=1, feed_mm_min=600.0, s_word=800.0,
    ...                 laser=3)
    >>> restate(st, "grbl")
    ['G92.1 G49 G54', 'G21 G90 M5', 'G0 X10 Y2.5 Z0', 'F600', 'G1 X10 Y2.5 Z0', 'G17', 'S800 M3']
    >>> restate(st, "grbl", origins_kept=True)
    ['M5 S0', 'G21 G90 G91.1 G17 G54', 'G0 X10 Y2.5 Z0', 'G1 F600 S800', 'M3']
    """
    from labkit.gcode.dialects import get_dialect

    d = get_dialect(dialect)
    off = f"M{d.laser_off_codes[0]}"
    w = state.work_offset
    if origins_kept:
        out = [f"{off} S0", f"G21 G90 G{_shortest(state.arc_centres)} G{state.plane} G{state.coord_system}"]
        here = state.work_position if position is None else np.asarray(position, float)
        g92 = np.array(state.g92, float)
        if np.any(g92 != 0) or state.tool_offset:
            # from the bare origin (G92.1; the tool offset restated), the move, then G92 so
            # that the point reads `here` again
            out.append("G92.1")
            if state.tool_offset:
                out.append(f"G43.1 Z{state.tool_offset:g}")
            out.append("G0 " + axis_words(here + g92, 4))
            if np.any(g92 != 0):
                out.append("G92 " + axis_words(here, 4))
        else:
            out.append("G0 " + axis_words(here, 4))
        words = [f"F{state.feed_mm_min:g}"] if math.isfinite(state.feed_mm_min) else []
        out.append("G1 " + " ".join(words + [f"S{state.s_word:g}"]))
        if state.motion in (0, 80):
            out.append(f"G{state.motion}")
        if state.feed_mode == 93:
            out.append("G93")
        out += [f"M{m}" for m in state.coolant]
        if state.laser != 5:
            out.append(f"M{state.laser}")
    else:
        g_ok = set(round(g, 1) for g in d.g_codes)
        out = []
        reset = [w_ for w_, g in (("G92.1", 92.1), ("G49", 49.0), ("G54", 54.0)) if g in g_ok]
        if reset:
            out.append(" ".join(reset))
        out.append(f"G21 G90 {off}")
        p = list(state.position) if position is None else list(np.asarray(position, float) + w)
        xyz = axis_words(p)
        out.append(f"G0 {xyz}")
        if math.isfinite(state.feed_mm_min):
            out.append(f"F{_shortest(d.feed_from_mm_min(state.feed_mm_min))}")
        if state.motion == 1:
            out.append(f"G1 {xyz}")                            # zero length, beam off: sets G1
        elif state.motion == 80:
            out.append("G80")
        out.append(f"G{state.plane}")
        if state.feed_mode == 93:
            out.append("G93")
        if state.arc_centres == 90.1:
            out.append("G90.1")
        if state.coord_system != 54:
            out.append(f"G{state.coord_system}")
        if any(w):
            if 92.0 not in g_ok:
                raise InputError(f"a work offset ({', '.join(_shortest(v) for v in w)}) mm is in "
                                 f"effect and the {d.name} dialect has no G92 to restate it")
            out.append("G92 " + axis_words([pa - wa for pa, wa in zip(p, w)]))
        out += [f"M{m}" for m in state.coolant]
        out.append(f"S{_shortest(state.s_word)} {off if state.laser == 5 else f'M{state.laser}'}")
    out += list(then)
    if origins_kept and (state.units != 21 or state.distance != 90):
        out.append(f"G{state.units} G{state.distance}")
    elif not origins_kept:
        out += ["G20"] * (state.units == 20) + ["G91"] * (state.distance == 91)
    return out


#: G words whose axis words are not a motion's (GRBL's non-modal axis commands and G43.1).
_AXIS_NOT_MOTION = frozenset({10.0, 28.0, 28.1, 30.0, 30.1, 92.0, 92.1, 43.1})
_GRBL_WORD = re.compile(r"([A-Z])([-+]?[0-9.]*)")


def grbl_words(line: str) -> dict | None:
    """The words of a line as GRBL's reader keeps it (upper case, no spaces or comments):
    letter -> its values in order; ``None`` when a number does not read (GRBL refuses it).

    Examples
    --------
    >>> grbl_words("G1G91X.5S300")
    {'G': [1.0, 91.0], 'X': [0.5], 'S': [300.0]}
    """
    values: dict = {}
    for letter, v in _GRBL_WORD.findall(line):
        try:
            values.setdefault(letter, []).append(float(v))
        except ValueError:
            return None
    return values


def is_motion_line(values: dict) -> bool:
    """Whether a line's axis words make a motion (:func:`grbl_words`'s ``values``): X, Y or Z
    with no G word that takes them for itself (G10, G28, G30, G92, G43.1 and their kin)."""
    return (not (set(values.get("G", ())) & _AXIS_NOT_MOTION)
            and any(a in values for a in "XYZ"))


def grbl_sync_reasons(line: str, state: ModalState, *, laser_mode: bool = True) -> set:
    """Why GRBL 1.1 runs ``line`` only once the moves before it have ended (its planner
    synchronisation in gcode.c, as the recorded transcripts show it), from the modal state
    ``state`` before the line; empty: it does not wait.

    The reasons: ``"spindle"`` (a new M3/M4/M5; with the laser or spindle on, a new S, except
    on a motion line in laser mode, whose power rides with its move; in laser mode M3's switch
    between a G1-G3 mode and another on a line without motion), ``"coolant"`` (a new M8 or
    M9), ``"eeprom"`` (G10, G28.1, G30.1), ``"wco"`` (G92, G92.1, a new coordinate system, a
    new tool length offset) and ``"probe"`` (G38.2-G38.5). G4, M0, M2 and M30 wait too, as
    blocks of their own (not listed here). Whether GRBL accepts the line is not checked: a
    refused line waits for nothing.

    Parameters
    ----------
    line : str
        The line as GRBL's reader keeps it: upper case, no spaces or comments.
    state : ModalState
        The modal state before the line.
    laser_mode : bool
        GRBL's ``$32`` (labkit's grbl dialect: on).

    Returns
    -------
    set of str

    Examples
    --------
    >>> on = ModalState(laser=3, s_word=100.0, motion=1)
    >>> sorted(grbl_sync_reasons("S300", on)), sorted(grbl_sync_reasons("G1X5S300", on))
    (['spindle'], [])
    >>> sorted(grbl_sync_reasons("M8G92X0", ModalState()))
    ['coolant', 'wco']
    """
    values = grbl_words(line)
    if values is None:
        return set()                         # a bad number: GRBL refuses the line
    st = state
    g = set(values.get("G", ()))
    m = set(values.get("M", ()))
    out = set()
    if g & {10.0, 28.1, 30.1}:
        out.add("eeprom")
    if g & {38.2, 38.3, 38.4, 38.5}:
        out.add("probe")
    if g & {92.0, 92.1}:
        out.add("wco")
    if any(54.0 <= w <= 59.0 and w == int(w) and int(w) != st.coord_system for w in g):
        out.add("wco")
    if 49.0 in g and st.tool_offset != 0.0:
        out.add("wco")
    if 43.1 in g:
        inches = 20.0 in g or (st.units == 20 and 21.0 not in g)
        z = values.get("Z", [0.0])[0] * (25.4 if inches else 1.0)
        if abs(z - st.tool_offset) > 1e-9:
            out.add("wco")
    spindle = {3.0: 3, 4.0: 4, 5.0: 5}
    new_laser = next((spindle[w] for w in m if w in spindle), st.laser)
    if new_laser != st.laser:
        out.add("spindle")
    if m & {8.0, 9.0} and ((8.0 in m) != (8 in st.coolant) or 9.0 in m and st.coolant):
        out.add("coolant")
    if st.laser == 5:
        return out
    if laser_mode and is_motion_line(values):
        return out
    new_s = values.get("S", [st.s_word])[0]
    modes = [w for w in g if w in (0.0, 1.0, 2.0, 3.0, 38.2, 38.3, 38.4, 38.5, 80.0)]
    new_motion = modes[0] if modes else st.motion
    cutting = (1, 2, 3)
    force = (laser_mode and st.laser == 3
             and (st.motion in cutting) != (new_motion in cutting))
    if new_s != st.s_word or force:
        out.add("spindle")
    return out
