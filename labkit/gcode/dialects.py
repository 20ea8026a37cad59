"""G-code dialects: where laser controllers disagree on the same words.

A :class:`Dialect` is a small frozen record of settings used by both the
parser (how to read F, P, S; which codes exist) and the emitter (how to write
them). Three are defined:

``grbl``
    GRBL 1.1 in laser mode (``$32=1``): F in mm/min, ``G4 P`` in seconds,
    S 0–1000 (``$30``), M3 constant and M4 dynamic power, arcs by I J K or R;
    an R arc whose chord exceeds its diameter by any amount is rejected
    (GRBL error 33), so is an I J K arc whose radius at start and end differs
    by more than 0.005 mm and by more than 0.1 %.
``labkit-fw``
    The labkit firmware (``firmware/``), which follows [LaserApp] and [CBR40]: F in
    mm/s, ``G4 P`` in milliseconds, S 0–255 (8-bit PWM duty; power in mW is
    S/255 × the laser's maximum), ``G5 P<n>`` sets the look-ahead depth in
    blocks, M3/M4/M5 laser words, and an answer ``ok`` or ``er`` per line.
    An R arc whose radius is short of half the chord by at most 0.0005 mm is
    taken as a half circle (text rounding), a larger shortfall is an error.
``marlin``
    Marlin 2 with its laser feature: F in mm/min, ``G4 P`` in milliseconds,
    S 0–255, M3/M4/M5 plus the fan words M106 S/M107 that [DobotLaser]'s
    Dobot-era tools used for the laser; emitted lines carry N numbers and
    ``*`` checksums as Marlin's host protocol expects.

Examples
--------
>>> get_dialect("grbl").feed_to_mm_min(1500.0)
1500.0
>>> get_dialect("labkit-fw").feed_to_mm_min(25.0)     # F is mm/s there
1500.0
>>> get_dialect("labkit-fw").dwell_to_s(250.0)        # P is ms there
0.25
"""

from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ["Dialect", "DIALECTS", "get_dialect"]


@dataclass(frozen=True)
class Dialect:
    """Settings of one controller's G-code flavour.

    Attributes
    ----------
    name : str
        Key in :data:`DIALECTS`.
    feed_per_second : bool
        F is mm/s (True) or mm/min (False). Moves always hold mm/min.
    dwell_in_ms : bool
        ``G4 P`` counts milliseconds (True) or seconds (False).
    s_max : float
        S value meaning full laser power.
    laser_on_codes, laser_off_codes : tuple of int
        M numbers that switch the beam on (3 = constant, 4 = dynamic,
        106 = fan output used as laser) and off (5, 107).
    lookahead_g5 : bool
        ``G5 P<n>`` sets the look-ahead depth ([LaserApp]) instead of being unsupported.
    arc_r_tol_mm : float
        How far |R| may fall short of half the chord and still be taken as a
        half circle (GRBL: 0, any shortfall is error 33).
    arc_radius_tol_mm, arc_radius_tol_rel : float
        An I J K arc is rejected when the radius at start and at end differ by
        more than both of these (GRBL: 0.005 mm and 0.1 %).
    line_numbers, checksums : bool
        The emitter prefixes ``N<n>`` and suffixes ``*<xor>``.
    inline_power : bool
        S may ride on G1/G2/G3 lines (GRBL); otherwise power changes are
        written as ``M3 S…`` lines.
    rapids_beam_off : bool
        The controller keeps the beam off during G0 by itself (GRBL laser
        mode); otherwise the emitter writes M5 before travel and M3/M4 after.
    modal_motion : bool
        A line of axis words alone continues the last G0–G3 (GRBL, labkit-fw).
        Marlin builds without ``GCODE_MOTION_MODES`` (the default) need the G
        word on every motion line, so the emitter repeats it.
    full_circle_without_axes : bool
        ``G2 I… J…`` with no end-point words is a full circle (GRBL instead
        rejects it: error 32).
    require_axis_words : bool
        An explicit G0/G1 without X Y Z is an error (GRBL ignores it).
    extra_letters : str
        Word letters this dialect accepts beyond the common set.
    g_codes : tuple of float
        G commands the dialect runs (anything else is error 20; ``G1.5`` style
        numbers of a known command are error 23).
    coolant_codes : tuple of int
        M numbers read as coolant/air assist (GRBL's default build: M8 M9; M7
        only when compiled with ``ENABLE_M7``).
    record_m_codes : tuple of int
        M numbers kept as ``"printer"`` records (heaters, fans, extruder modes
        of a printer's file); their S is a temperature, not laser power.
    home_is_origin : bool
        ``G28`` homes (the named axes, or all, end at machine 0: Marlin) instead
        of going to the position stored by ``G28.1`` (GRBL).
    max_tool : int
        Largest T number (GRBL: 255, error 38 above).
    line_buffer_chars : int
        Size of the controller's line buffer in bytes, 0 when unknown (GRBL 1.1:
        ``LINE_BUFFER_SIZE`` 80, holding 79 characters after spaces and comments
        are dropped; a longer streamed line is error 11). Checked by
        :func:`labkit.gcode.check`.
    grbl_verdicts : bool
        Answer each line as GRBL 1.1h does where labkit's firmware answers otherwise: an
        unclosed ``(`` ends at the line end, ``?`` ``~`` ``!`` are real-time characters taken
        out of the line, an R arc whose chord is longer than 2R is error 34, and of several
        faults in a line the first in GRBL's parser order is reported (each word checked as
        it is read, then GRBL's checks of the whole line in its order); a number ends where
        GRBL's reader ends it (``X1.2.3`` is ``X1.2`` and then ``.``, no letter: error 1), N
        and G10's L and P count by their whole part, two axis commands in one line are error
        24 before their modal group, and an I J K circle of radius 0 whose end is within
        0.005 mm of it is a move. Streamed (:func:`labkit.gcode.check`, the virtual
        machine), a ``%`` line and a ``*`` are error 1 (GRBL has no program delimiter and no
        checksum) and ``$`` lines are checked against GRBL's system commands.
    """

    name: str
    feed_per_second: bool = False
    dwell_in_ms: bool = False
    s_max: float = 1000.0
    laser_on_codes: tuple[int, ...] = (3, 4)
    laser_off_codes: tuple[int, ...] = (5,)
    lookahead_g5: bool = False
    arc_r_tol_mm: float = 0.0
    arc_radius_tol_mm: float = 0.005
    arc_radius_tol_rel: float = 0.001
    line_numbers: bool = False
    checksums: bool = False
    extra_letters: str = ""
    inline_power: bool = True
    rapids_beam_off: bool = True
    modal_motion: bool = True
    full_circle_without_axes: bool = True
    require_axis_words: bool = False
    g_codes: tuple[float, ...] = (0, 1, 2, 3, 4, 17, 18, 19, 20, 21, 40, 49, 54, 61, 90, 91, 90.1,
                                  91.1, 94)
    coolant_codes: tuple[int, ...] = (7, 8, 9)
    record_m_codes: tuple[int, ...] = ()
    home_is_origin: bool = False
    max_tool: int = 2**31 - 1
    line_buffer_chars: int = 0
    grbl_verdicts: bool = False
    description: str = field(default="", compare=False)

    def feed_to_mm_min(self, f: float) -> float:
        """Value of an F word → mm/min."""
        return f * 60.0 if self.feed_per_second else f

    def feed_from_mm_min(self, feed_mm_min: float) -> float:
        """mm/min → value to write after F."""
        return feed_mm_min / 60.0 if self.feed_per_second else feed_mm_min

    def dwell_to_s(self, p: float) -> float:
        """Value of a G4 P word → seconds."""
        return p / 1000.0 if self.dwell_in_ms else p

    def dwell_from_s(self, seconds: float) -> float:
        """Seconds → value to write after G4 P."""
        return seconds * 1000.0 if self.dwell_in_ms else seconds


#: What GRBL 1.1's gcode.c runs (its own list: doc/markdown/commands.md): G90.1 is not among
#: them (error 20), G91.1 is accepted as a no-op.
GRBL_G_CODES = (0, 1, 2, 3, 4, 10, 17, 18, 19, 20, 21, 28, 28.1, 30, 30.1, 38.2, 38.3, 38.4,
                38.5, 40, 43.1, 49, 53, 54, 55, 56, 57, 58, 59, 61, 80, 90, 91, 91.1, 92, 92.1,
                93, 94)

DIALECTS: dict[str, Dialect] = {
    "grbl": Dialect(
        name="grbl",
        full_circle_without_axes=False,
        extra_letters="LT",
        g_codes=GRBL_G_CODES,
        coolant_codes=(8, 9),
        max_tool=255,
        line_buffer_chars=80,
        grbl_verdicts=True,
        description="GRBL 1.1 laser mode: F mm/min, G4 P s, S 0-1000, M3/M4/M5",
    ),
    "labkit-fw": Dialect(
        name="labkit-fw",
        feed_per_second=True,
        dwell_in_ms=True,
        s_max=255.0,
        lookahead_g5=True,
        g_codes=Dialect.g_codes + (5,),
        arc_r_tol_mm=0.0005,
        require_axis_words=True,
        description="labkit firmware ([LaserApp]/[CBR40]): F mm/s, G4 P ms, S 0-255, G5 P look-ahead",
    ),
    "marlin": Dialect(
        name="marlin",
        dwell_in_ms=True,
        s_max=255.0,
        laser_on_codes=(3, 4, 106),
        laser_off_codes=(5, 107),
        line_numbers=True,
        checksums=True,
        extra_letters="ET",
        g_codes=Dialect.g_codes + (28, 92),
        record_m_codes=(82, 83, 84, 104, 109, 140, 190),
        home_is_origin=True,
        inline_power=False,
        rapids_beam_off=False,
        modal_motion=False,
        description="Marlin 2 laser: F mm/min, G4 P ms, S 0-255, M3/M4/M5 and M106/M107, N + checksum",
    ),
}


def get_dialect(dialect: str | Dialect) -> Dialect:
    """Return a :class:`Dialect` by name (or pass one through).

    >>> get_dialect("marlin").s_max
    255.0
    >>> get_dialect("fanuc")
    Traceback (most recent call last):
    ...
    ValueError: unknown G-code dialect 'fanuc'; choose one of grbl, labkit-fw, marlin
    """
    if isinstance(dialect, Dialect):
        return dialect
    try:
        return DIALECTS[dialect]
    except KeyError:
        raise ValueError(f"unknown G-code dialect {dialect!r}; choose one of "
                         f"{', '.join(DIALECTS)}") from None
