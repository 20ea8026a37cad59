"""A simulated GRBL 1.1 laser machine: the default when no port is given.

:class:`VirtualMachine` behaves like a pyserial port (``write``, ``read``,
``in_waiting``, ``timeout``, ``close``) with GRBL behind it: a 128-byte RX
buffer (bytes that do not fit are lost, as on the real controller), a
planner of the machine's depth (a line is read from the RX buffer only when the
planner has room, so ``ok`` comes late when it is full), ``ok`` /
``error:N`` for every line, real-time bytes, status reports with ``MPos``,
``FS``, ``Bf`` and ``WCO``, work offsets (G10 L2/L20 origins of G54–G59 kept
through a reset as in GRBL's EEPROM, G92 and G43.1 cleared by it; ``WCO`` is their
sum), soft limits in GRBL's machine space (−$13x…0: ALARM:2, then nothing answered until
a reset), ``$`` commands (``$$ $I $I= $G $# $X $H $J= $C $N $Nx= $RST= $SLP $x=V``, in the
order and with the errors of GRBL 1.1h),
G4 answered when its dwell ends, M0 held until cycle start, ``[MSG:Pgm End]`` at M2/M30,
feed hold, resume and soft reset (a reset while moving raises ALARM:3, as GRBL does), simulated
limit switches (``switches``: ``Pn:`` in status reports, ALARM:1 with hard limits ``$21=1``) and
GRBL's homing cycle (``$H`` with ``$22=1``, ``$23``-``$27``, ALARM:6/7/8/9, the power-up lock). Its
replies are checked against conversations recorded from GRBL 1.1h itself
(``tests/firmware/test_grbl_transcripts.py``).

The serial link can be modelled (``baud``: bytes arrive at baud/10 per second of simulated
time, 8N1) and so can the controller's time to parse a line (``parse_s``); every time the
planner stands empty while a line is on its way it is recorded in :attr:`starvations`
(:class:`labkit.motion.stall.Starvation`).

Lines are interpreted one at a time by :class:`labkit.gcode.Interpreter`, which
keeps the modal state (:class:`labkit.gcode.ModalState`, its one home) between them;
arcs are cut into GRBL's ``$12`` chord segments and every move becomes a block as
:func:`labkit.motion.build_blocks` makes it (a move of no step makes none, as in GRBL). The
blocks are planned by :mod:`labkit.motion`'s junction-deviation planner
(:func:`labkit.motion.lookahead`), the one ``labkit plan --planner junction`` uses: when a block
starts, its exit speed is planned over the blocks queued behind it (the queue must be able to
stop at its end) and then fixed while it runs. A stream that keeps the planner full therefore
takes the time :func:`labkit.motion.plan` gives the whole job, and a starved planner (send-response
over a slow link) slows the machine down as it does a real GRBL.

Time is simulated: ``time_scale`` simulated seconds pass per wall-clock
second (1 = real time, 10 = ten times faster), or with ``time_scale=0`` each
poll of the port advances ``tick_s`` of machine time (deterministic, as fast
as the host polls: for tests).

What the machine did is recorded for tests and notebooks: :attr:`executed`
(every piece of motion, with its line, laser power and whether it burned), :attr:`starvations`,
:attr:`unsafe_stops` (times the machine stood still with the beam on),
:attr:`overflows` (bytes lost to a full RX buffer) and :attr:`rx_fill`
(RX-buffer use over time).
"""

from __future__ import annotations

import math
import threading
import time
from collections import deque
from dataclasses import dataclass

import numpy as np

from dataclasses import replace

from labkit.errors import AlarmCode, ErrorCode, Feedback, MotionError
from labkit.gcode.reader import Interpreter, grbl_system_verdict, strip_comments
from labkit.gcode.state import ModalState, grbl_sync_reasons, grbl_words, is_motion_line
from labkit.machine.grbl import grbl_reply
# The one place labkit.machine imports the motion machine description (a rename is a one-line fix);
# the virtual machine plans with labkit.motion's junction-deviation planner, never its own.
from labkit.motion import (Blocks, block_profiles, build_blocks, expand_arcs, load_machine,
                           lookahead, reach_speed)
from labkit.motion.stall import Starvation

__all__ = ["VirtualMachine", "Piece", "burn_coverage"]

#: Bytes that act the moment they arrive instead of waiting in the RX buffer for a line end.
_ACTS_ON_ARRIVAL = frozenset(b"\n?!~\x18\x84\x85") | frozenset(range(0x90, 0x9E))

_ALARMED = -1      # _gcode's answer when the line raised an alarm instead of ok/error
_DEFERRED = -2     # _gcode's answer when the line's reply waits for its last block to end

_REALTIME = {0x3F: "status", 0x21: "hold", 0x7E: "start", 0x18: "reset", 0x84: "door",
             0x85: "jog_cancel"}

#: GRBL 1.1's default settings (its DEFAULTS_GENERIC, as ``$$`` prints them): soft limits, hard
#: limits, homing and laser mode off, status reports with MPos and without the buffer state.
#: The machine description replaces $11, $12 and $100-$132, and its ``grbl_settings`` any other.
_DEFAULT_SETTINGS = {
    0: "10", 1: "25", 2: "0", 3: "0", 4: "0", 5: "0", 6: "0", 10: "1", 11: "0.010", 12: "0.002",
    13: "0", 20: "0", 21: "0", 22: "0", 23: "0", 24: "25.000", 25: "500.000", 26: "250",
    27: "1.000", 30: "1000", 31: "0", 32: "0",
    100: "250.000", 101: "250.000", 102: "250.000", 110: "500.000", 111: "500.000",
    112: "500.000", 120: "10.000", 121: "10.000", 122: "10.000", 130: "200.000", 131: "200.000",
    132: "200.000",
}

#: How GRBL prints each setting: on/off flags as 0/1, bytes as integers, $30/$31 (rpm) without
#: decimals, every other number with three.
_FLAG_SETTINGS = {4, 5, 6, 13, 20, 21, 22, 32}
_BYTE_SETTINGS = {0, 1, 2, 3, 10, 23, 26}
_RPM_SETTINGS = {30, 31}


#: GRBL 1.1h's line buffer holds 79 characters (LINE_BUFFER_SIZE 80 with its terminator).
GRBL_LINE_MAX = 79

#: How long GRBL's axes keep their speed after a probe switches before they brake, s: the step
#: segments already prepared (up to 5 of 10 ms) run out first. Measured on GRBL 1.1h in grbl-sim
#: (record.py's probe topic: 0.077 mm at 100 mm/min beyond the 0.139 mm of braking); the replay
#: of tests/vectors/grbl/probe.json checks it (GRBL stopped at Z-2.200 after touching at -2.000).
_SEGMENT_LEAD_S = 0.046

#: GRBL's factor for reports in inches (``$13=1``), nuts_bolts.h's INCH_PER_MM.
_INCH_PER_MM = 0.0393701


#: What streaming one line to the virtual machine costs its kernels as Python more than
#: compiled (its reading of the line, the planner's passes), in the parse's units of work
#: (bytes; :func:`labkit.gcode._kernel.interpret`). Measured with ``labkit stream`` on the
#: first N lines of cncjs's tball job (22 bytes a line; CPU s, Python only / compiled only):
#: 1.73 / 1.73 at 1,000 lines, 8.21 / 6.23 at 5,000. With the file's own traced reading
#: (6 × 22 units a line) this puts the rule's switch at those 1,000 lines.
STREAM_LINE_WORK = 620


def stream_work(lines: int) -> dict:
    """The kernels' work of streaming ``lines`` lines to the virtual machine, for
    :func:`labkit._jit.expecting` (``later=True``) while the job's file is read.

    Parameters
    ----------
    lines : int
        Lines of the program.

    Returns
    -------
    dict
        ``{kernel: units of work}``.
    """
    from labkit.gcode import _kernel as K

    return {K.interpret: int(lines) * STREAM_LINE_WORK}


def _grbl_number(value: float, decimals: int) -> str:
    """A number as GRBL's printFloat writes it: a minus sign for any negative value, then
    rounded half up at ``decimals`` places.

    >>> _grbl_number(2.5, 0), _grbl_number(100.45, 1), _grbl_number(-0.0001, 3), _grbl_number(-0.0, 3)
    ('3', '100.5', '-0.000', '0.000')
    """
    n = int(abs(value) * 10 ** decimals + 0.5)
    sign = "-" if value < 0 else ""
    if not decimals:
        return f"{sign}{n}"
    whole, frac = divmod(n, 10 ** decimals)
    return f"{sign}{whole}.{frac:0{decimals}d}"


def _startup_jog(line: str) -> str:
    """A start-up line that begins with ``$`` as GRBL runs it: a jog, read from its fourth
    character on (``$XYG91X1F100`` is ``$J=G91X1F100``)."""
    return "$J=" + line[3:]


def _grbl_line(text: str) -> tuple[str, bool]:
    """A line as GRBL's serial reader keeps it, and whether it overflowed the line buffer:
    comments, spaces, control characters and the block-delete ``/`` dropped, letters upper case.

    >>> _grbl_line("g1 x10 (cut) /y5 ; to the corner")
    ('G1X10Y5', False)
    >>> _grbl_line("G0X" + "0" * 80)[1]
    True
    """
    kept = "".join(c for c in strip_comments(text) if c > " " and c != "/").upper()
    return kept[:GRBL_LINE_MAX], len(kept) > GRBL_LINE_MAX


def _setting_text(number: int, value: float) -> str:
    """A setting's value as GRBL 1.1 stores and prints it (``$$``)."""
    if number in _FLAG_SETTINGS:
        return "1" if int(value) else "0"
    if number in _BYTE_SETTINGS:
        return str(int(value) & 0xFF)
    return f"{value:.0f}" if number in _RPM_SETTINGS else f"{value:.3f}"


def _parser_field(name: str, doc: str) -> property:
    """A read-only view of one field of the virtual machine's parser state."""
    return property(lambda self: getattr(self._parser.state, name), doc=doc)


@dataclass(frozen=True)
class Piece:
    """A stretch of motion the virtual machine executed."""

    line: int              #: 1-based count of G-code lines the machine accepted since power-up
    n_word: int            #: the line's N number (-1 when none)
    text: str              #: the line as received
    start: tuple
    end: tuple
    power: float           #: beam power as a fraction of full (0 when off)
    rapid: bool
    t_end: float           #: simulated time it finished (s)


@dataclass
class _Block:
    line: int
    n_word: int
    text: str
    start: np.ndarray
    end: np.ndarray
    speed_mm_s: float
    duration_s: float
    power: float           # beam fraction while moving
    rapid: bool
    accel_mm_s2: float = math.inf
    is_dwell: bool = False
    constant: bool = False # M3 in laser mode: GRBL leaves the PWM on when motion stops
    started: bool = False
    exit_mm_s: float = 0.0
    done_s: float = 0.0    # time already spent on it
    row: Blocks | None = None   # the block as labkit.motion plans it (one row; None for a dwell)
    length_mm: float = 0.0      # what is left of it to run (all of it until a hold re-arms it)
    #: the line's replies, sent when this block ends (GRBL answers G4, M0, M2 and M30 only
    #: once the moves before them have run); the next line waits until then
    replies: tuple = ()
    pause: bool = False         # M0: a feed hold once the moves before it have run
    probe: int = 0              # G38.2-G38.5 as 382-385: the move stops when the probe switches
    probe_point: np.ndarray | None = None   # where it switched (the block now brakes past it)


#: GRBL 1.1h's homing (config.h as released): Z first, then X and Y together; the search covers
#: 1.5 x the longest travel of the group, the slow locate 10 x the pull-off.
_HOMING_GROUPS = ((2,), (0, 1))
_HOMING_SEARCH_SCALE = 1.5
_HOMING_LOCATE_SCALE = 10.0


def _parse_switches(spec: str, option: str = "switches"):
    """The ``switches`` option (or ``probe``, the same form): switch positions (mm from
    power-up), sides (+1/-1, 0 = none) and which are stuck pressed.

    >>> mm, side, stuck = _parse_switches("X:+5,Z:stuck")
    >>> mm.tolist(), side.tolist(), stuck.tolist()
    ([5.0, 0.0, 0.0], [1.0, 0.0, 0.0], [False, False, True])
    """
    from labkit.errors import MachineError

    mm, side, stuck = np.zeros(3), np.zeros(3), np.zeros(3, bool)
    for item in filter(None, spec.replace(" ", "").split(",")):
        axis, _, where = item.upper().partition(":")
        if axis not in ("X", "Y", "Z") or not where:
            raise MachineError(f"{option} {spec!r}: {item!r} is not AXIS:MM or AXIS:stuck "
                               f"(expected e.g. 'X:+5,Y:+5,Z:stuck')")
        a = "XYZ".index(axis)
        if where == "STUCK":
            stuck[a] = True
            continue
        try:
            mm[a] = float(where)
        except ValueError:
            raise MachineError(f"{option} {spec!r}: {where!r} after {axis}: is not a distance "
                               f"in mm nor 'stuck'") from None
        if mm[a] == 0 or not math.isfinite(mm[a]):
            raise MachineError(f"{option} {spec!r}: the {axis} input needs a side, a nonzero "
                               f"distance from power-up such as +5 or -5 (got {where!r})")
        side[a] = math.copysign(1.0, mm[a])
    return mm, side, stuck


def _time_at(profile, distance_mm: float) -> float:
    """When a move profiled from rest (:func:`labkit.motion.profile.block_profiles`, one block,
    constant acceleration) has covered ``distance_mm``, s."""
    acc, cru, peak = float(profile.accel_mm[0]), float(profile.cruise_mm[0]), float(profile.peak_mm_s[0])
    up, down = float(profile.up[0]), float(profile.down[0])
    if distance_mm <= acc:
        return math.sqrt(2.0 * distance_mm / up)
    if distance_mm <= acc + cru:
        return float(profile.accel_s[0]) + (distance_mm - acc) / peak
    s = min(distance_mm - acc - cru, float(profile.decel_mm[0]))
    return (float(profile.accel_s[0]) + float(profile.cruise_s[0])
            + (peak - math.sqrt(max(0.0, peak * peak - 2.0 * down * s))) / down)


@dataclass
class _Homing:
    """The homing cycle under way: the steps still to do and the one running.

    A step is ``("move", axes, distance_mm, rate_mm_min, seek)`` (each axis of ``axes`` starts
    again at 0 and moves ``distance_mm`` towards its switch when ``seek``, stopping there, or
    away from it), ``("wait", s)`` (the debounce, ``$26``) or ``("home", axes)`` (the position
    GRBL sets once the group is homed)."""

    todo: deque
    step: tuple | None = None
    t: float = 0.0                       # time into the running step, s
    duration_s: float = 0.0
    sign: np.ndarray | None = None       # direction of each moving axis (+1/-1, 0: still)
    stop_mm: np.ndarray | None = None    # distance at which each axis meets its switch (inf: never)
    profile: object = None
    status_asked: bool = False           # a '?' came during the cycle (answered at its end)


class VirtualMachine:
    """A simulated GRBL laser machine that looks like a pyserial port.

    Parameters
    ----------
    machine : str, Machine or None
        Machine description (:func:`labkit.motion.load_machine`; default
        ``grbl-diode``): travel, maximum rates, acceleration, planner depth.
    time_scale : float
        Simulated seconds per wall-clock second; 0 = advance ``tick_s`` per poll.
    tick_s : float
        Machine time per poll when ``time_scale`` is 0.
    rx_bytes : int, optional
        Serial RX buffer size (default the machine's: GRBL 128; grblHAL 1024).
    planner_blocks : int, optional
        Planner depth, the running block included (default the machine description's
        ``planner_blocks``: 15 for grbl-diode, GRBL 1.1 on a 328P, ``[OPT:V,15,128]``).
    baud : int, optional
        Model the serial link at this speed (e.g. the machine description's ``link_baud``,
        115200): bytes take ``bits per byte / baud`` seconds of simulated time each (8N1: 10
        bits), real-time bytes included, in the order written. None or 0 (the default): every
        byte arrives the moment it is written.
    parse_s : float, optional
        Model the time GRBL takes to parse and plan one line, s (e.g. the machine description's
        ``block_parse_s``, grbl-diode 3.7 ms): a line leaves the RX buffer, is parsed for this
        long, then waits for planner room. None or 0 (the default): at once.
    banner : bool
        Print the start-up banner when opened, as a board does after its USB reset.
    switches : str, optional
        Limit switches, as the firmware simulator's ``--switches`` and grbl-sim took them for the
        recorded homing transcripts: ``"X:+5,Y:+5,Z:stuck"`` puts the switch of each named axis
        that many mm from the power-up position on the side its sign names (it reads pressed at
        or beyond that point, wherever homing later sets the machine's zero); ``stuck`` is a
        switch always pressed; an axis not named has none. None (the default): no switch wired,
        so ``$H`` with homing on ends in ALARM:9 as on a GRBL without switches.
    probe : str, optional
        The probe input for G38.2-G38.5, in the same form: ``"Z:-2"`` touches at 2 mm below the
        power-up position and beyond, ``"Z:stuck"`` always touches (``$6`` inverts it). None
        (the default): it never touches, so G38.2 ends in ALARM:5 as on a GRBL with no probe.

    Examples
    --------
    >>> vm = VirtualMachine(time_scale=0)
    >>> _ = vm.write(b"G1 X10 F600\\n")
    >>> _ = vm.write(b"?")
    >>> reply = b""
    >>> for _ in range(5):
    ...     reply += vm.read(vm.in_waiting)
    >>> b"ok" in reply, b"<Run|MPos:" in reply
    (True, True)
    """

    def __init__(self, machine=None, *, time_scale: float = 1.0, tick_s: float = 0.02,
                 rx_bytes: int | None = None, planner_blocks: int | None = None,
                 baud: int | None = None, parse_s: float | None = None, banner: bool = True,
                 switches: str | None = None, probe: str | None = None):
        self.machine = load_machine(machine or "grbl-diode")
        # limit switches in machine coordinates (shifted when homing sets the position), the side
        # each one is on (+1/-1; 0: none wired) and whether it is stuck pressed
        self._switch_mm, self._switch_side, self._switch_stuck = _parse_switches(switches or "")
        self._homing: _Homing | None = None     # the homing cycle under way
        # the probe input: where it touches (the same form as a switch) and GRBL's last result
        self._probe_mm, self._probe_side, self._probe_stuck = _parse_switches(probe or "", "probe")
        self._probe_at = np.zeros(3)            # GRBL's sys_probe_position, machine mm
        self._probe_touched = False             # GRBL's sys.probe_succeeded
        #: after ALARM:1/2, the replies the reset owes (None: no critical alarm waits for one)
        self._critical_owed: tuple | None = None
        self.time_scale = float(time_scale)
        self.tick_s = float(tick_s)
        self.rx_bytes = int(rx_bytes or self.machine.rx_buffer_bytes)
        #: bytes per second of simulated time the link carries (baud / 10 for 8N1; inf: no link)
        self.link_bytes_per_s = baud / self.machine.link_bits_per_byte if baud else math.inf
        #: time the controller takes to parse and plan one line, s
        self.parse_s = float(parse_s or 0.0)
        self._wire: deque = deque()          # [first byte's start s, bytes, bytes already arrived]
        self._wire_free_s = 0.0              # when the link has sent all that was written
        self._parsed: tuple | None = None    # (line, time its parse ends) read from RX, not yet run
        # the blocks of the line GRBL is in that wait for planner room (an arc's chords enter one
        # at a time as blocks end), and that line's replies, sent once the last has entered
        self._admitting: deque = deque()
        self._admit_replies: tuple = ()
        self._sync_verdict: tuple = ("", False)   # (line, whether it waits for an empty planner)
        self._wco_preview = None            # the WCO a waiting line has set already (reports)
        self._soft_limit_braking = False    # a soft limit hit while moving: braking, then ALARM:2
        self._dry_since: float | None = None
        #: every time the planner ran dry and a line's blocks arrived later (simulated s since
        #: power-up, the line's count since power-up as :attr:`lines_run`, the wait)
        self.starvations: list[Starvation] = []
        #: every time a block started with no block queued behind it and a line's blocks came
        #: later (GRBL then plans it to stop at its end: :func:`labkit.motion.stall.short_queues`,
        #: the predictor's figure for it); recorded as :attr:`starvations` are
        self.short_queues: list[Starvation] = []
        self._short_since: float | None = None
        self._into_empty = None              # the block that last entered an empty planner
        self._synced = False                 # a line that waited for an empty planner ran last
        #: G-code lines run since power-up (answered ok or error; not ``$`` lines, not in check mode)
        self.lines_run = 0
        self.planner_blocks = int(planner_blocks or self.machine.planner_blocks)
        self.timeout = 0.05
        self.is_open = True
        self.settings = self._initial_settings(self.machine)
        self.build_info = ""                 #: ``$I=`` text (GRBL keeps it in EEPROM)
        self.startup_lines = ["", ""]        #: ``$N0=`` and ``$N1=``, run after every reset
        self._partial = bytearray()          # the start of a line read out of the RX buffer
        self.overrides = (100, 100, 100)     # feed, rapid, laser power (%), GRBL's Ov: field
        self._lock = threading.RLock()
        self._out = bytearray()
        self._rx = bytearray()
        self._blocks: deque[_Block] = deque()
        self._sim_t = 0.0
        self._wall = time.monotonic()
        self.pos = np.zeros(3)
        self.state = "Idle"
        self.substate = 0
        self.alarm_code = 0
        self.check_mode = False
        self.lines_accepted = 0
        self.executed: list[Piece] = []
        self.unsafe_stops: list[tuple[float, str, float]] = []
        self.overflows = 0
        self.rx_fill: list[tuple[float, int]] = []
        #: every change of the beam: (simulated s, power as a fraction of full, state, line),
        #: the rows of the firmware simulator's --beam-log
        self.beam_log: list[tuple[float, float, str, int]] = []
        self._beam_level = 0.0
        # GRBL's report refresh counters: a report shows WCO: (Ov:) when its counter is 0, and
        # what changes the offsets (the spindle, coolant or an override) sets it to 0
        self._wco_counter = self._ovr_counter = 0
        self._flood = False                 # the coolant output (M8), as GRBL's A:F reads it
        self._hold_stopped_laser = False    # a hold in laser mode switched the beam off
        self._speed = 0.0           # mm/s at the end of the last block executed
        self._hold_v = 0.0          # mm/s while braking for a feed hold
        self._parser = Interpreter("grbl", streaming=True)   # GRBL reads a stream: % is error:1
        self._reset_parser()
        if self._flag(22):                  # GRBL's HOMING_INIT_LOCK: homing first, or $X
            self.state, self.alarm_code = "Alarm", 0
        if banner:
            self._greet()

    def _greet(self) -> bool:
        """GRBL's start after power-on or a reset: the banner; with hard limits on, a pressed
        limit input locks it in Alarm; a locked GRBL says how to unlock. True: unlocked."""
        self._emit("\r\nGrbl 1.1h ['$' for help]")
        if self._flag(21) and self._pressed().any():
            if self.state != "Alarm":
                self.state, self.alarm_code = "Alarm", 0
            self._emit(grbl_reply(Feedback.CHECK_LIMITS))
        if self.state == "Alarm":
            self._emit(grbl_reply(Feedback.ALARM_LOCK))
            return False
        return True

    @staticmethod
    def _initial_settings(machine) -> dict:
        """GRBL 1.1's defaults, then what the machine description says."""
        from labkit.errors import MachineError

        settings = dict(_DEFAULT_SETTINGS)
        settings[11] = _setting_text(11, machine.junction_deviation_mm)
        settings[12] = _setting_text(12, machine.arc_tolerance_mm)
        for axis in range(3):
            settings[100 + axis] = _setting_text(100, machine.steps_per_mm[axis])
            settings[110 + axis] = _setting_text(110, machine.max_rate_mm_min[axis])
            settings[120 + axis] = _setting_text(120, machine.accel_mm_s2[axis])
            settings[130 + axis] = _setting_text(130, machine.travel_mm[axis])
        for number, value in machine.grbl_settings:
            if number not in settings:
                raise MachineError(f"machine {machine.name!r}: grbl_settings ${number} is not a "
                                   f"GRBL 1.1 setting (known: {', '.join(f'${k}' for k in sorted(settings))})")
            settings[number] = _setting_text(number, value)
        if settings[20] == "1" and settings[22] != "1":
            raise MachineError(f"machine {machine.name!r}: grbl_settings $20=1 (soft limits) needs "
                               f"$22=1 (homing), as GRBL refuses it otherwise (error:10)")
        return settings

    def _flag(self, number: int) -> bool:
        """An on/off setting ($20 soft limits, $22 homing, $32 laser mode …)."""
        return self.settings.get(number, "0") not in ("0", "")

    # -- limit switches and homing ------------------------------------------------------------

    def _pressed(self, pos=None) -> np.ndarray:
        """The limit inputs as GRBL reads them (``$5`` inverts them) with the head at ``pos``
        (machine mm; default where it is): one bool per axis."""
        pos = self.pos if pos is None else np.asarray(pos, float)
        wired = self._switch_side != 0
        reached = (pos - self._switch_mm) * self._switch_side >= -1e-9
        raw = self._switch_stuck | (wired & reached)
        return raw ^ self._flag(5)

    @property
    def limit_pins(self) -> str:
        """The limit inputs that read pressed now, as the status report's ``Pn:`` names them
        (``"X"``, ``"XZ"``; ``""`` when none)."""
        with self._lock:
            return "".join(a for a, on in zip("XYZ", self._pressed()) if on)

    def _set_axis(self, axis: int, value_mm: float) -> None:
        """Give ``axis`` a new machine position without moving it (homing): its switch stays
        where it physically is."""
        self._switch_mm[axis] += value_mm - self.pos[axis]
        self._probe_mm[axis] += value_mm - self.pos[axis]
        self.pos[axis] = value_mm

    def _stop_at_switch(self, start: np.ndarray) -> bool:
        """Whether the motion from ``start`` to here tripped GRBL's hard limit: an input changed,
        pressed or released (its pin-change interrupt; GRBL 1.1h as built does not check which,
        HARD_LIMIT_FORCE_STATE_CHECK is off). If so the head is put back at the first whole step
        (``$100``-``$102``) where an input changed (the step is a straight line): a switch is
        pressed at its position, released one step off it."""
        before = self._pressed(start)
        hit = self._pressed() != before
        if not hit.any():
            return False
        travel = self.pos - start
        with np.errstate(divide="ignore", invalid="ignore"):
            where = np.where(travel != 0, (self._switch_mm - start) / travel, 0.0)
        spm = np.array([float(self.settings[100 + a]) for a in range(3)])
        first = math.inf
        for a in np.flatnonzero(hit):
            f = float(np.clip(where[a], 0.0, 1.0))
            if self._pressed(start + travel * f)[a] == before[a]:   # still as before: a release
                f += 1.0 / (spm[a] * abs(travel[a]))   # (may end a step past this tick's end)
            first = min(first, f)
        self.pos = start + travel * first
        return True

    def _probe_touching(self, pos=None) -> bool:
        """The probe input as GRBL reads it (``$6`` inverts it) with the head at ``pos``."""
        pos = self.pos if pos is None else np.asarray(pos, float)
        wired = self._probe_side != 0
        reached = (pos - self._probe_mm) * self._probe_side >= -1e-9
        return bool(self._probe_stuck.any() or (wired & reached).any()) ^ self._flag(6)

    def _probe_reached(self, kind: int, pos=None) -> bool:
        """Whether the probe input is where a G38 move of ``kind`` (382-385) stops: touching
        for G38.2/G38.3, no longer touching for G38.4/G38.5 (``$6`` inverts the input)."""
        return self._probe_touching(pos) != (kind >= 384)

    def _probe_result(self, b: "_Block", touched: bool) -> None:
        """GRBL's end of a probe cycle (mc_probe_cycle): the touch position kept, or for G38.3 and
        G38.5 where it stopped, or for G38.2 and G38.4 ALARM:5 (the last position kept); then
        ``[PRB:x,y,z:0|1]`` (machine mm) and the line's ok."""
        self._probe_touched = touched
        if touched:
            self._probe_at = b.probe_point.copy()
        elif b.probe in (383, 385):
            self._probe_at = self.pos.copy()
        else:
            self.state, self.alarm_code = "Alarm", AlarmCode.PROBE_FAIL_CONTACT
            self._emit(grbl_reply(AlarmCode.PROBE_FAIL_CONTACT))
        self._emit(self._prb_line())

    def _probe_crossing(self, kind: int, start: np.ndarray) -> np.ndarray:
        """Where between ``start`` and here the probe input switched (a straight step): the
        first point found reached, by bisection to well under a step."""
        lo, hi = 0.0, 1.0
        for _ in range(40):
            mid = 0.5 * (lo + hi)
            if self._probe_reached(kind, start + (self.pos - start) * mid):
                hi = mid
            else:
                lo = mid
        return start + (self.pos - start) * hi

    def _probe_step(self, kind: int, start: np.ndarray, b: "_Block") -> np.ndarray:
        """The step at which GRBL sees the probe switch between ``start`` and here: the first
        whole step (``$100``-``$102``) along the move where the input reads switched."""
        spm = np.array([float(self.settings[100 + a]) for a in range(3)])
        way = np.sign(b.end - b.start)
        p = self._probe_crossing(kind, start) * spm
        steps = np.where(way > 0, np.ceil(p - 1e-6), np.where(way < 0, np.floor(p + 1e-6), np.round(p)))
        for _ in range(4):                   # at the switch point itself it may not read switched
            if self._probe_reached(kind, steps / spm):
                break
            steps = steps + way
        return steps / spm

    def _probe_stop(self, b: "_Block", start: np.ndarray) -> None:
        """The probe switched during ``b``: GRBL records the step (``[PRB:]``), cancels the motion
        and brakes along the move: the prepared segments first (:data:`_SEGMENT_LEAD_S`), then
        at the block's acceleration, never past the probe's target. The block becomes that
        braking; its end finishes the probe cycle."""
        touch = self._probe_step(b.probe, start, b)
        v = self._current_speed()
        acc = b.accel_mm_s2 if math.isfinite(b.accel_mm_s2) else 1e9
        length = float(np.linalg.norm(b.end - b.start))
        u = (b.end - b.start) / length if length > 0 else np.zeros(3)
        left = max(0.0, float(np.dot(b.end - touch, u)))
        lead = v * _SEGMENT_LEAD_S
        d = min(left, lead + v * v / (2.0 * acc))
        if d <= lead:
            t = d / v if v > 0 else 0.0
        else:
            t = _SEGMENT_LEAD_S + (v - math.sqrt(max(0.0, v * v - 2.0 * acc * (d - lead)))) / acc
        b.probe_point = touch
        b.start, b.end = touch.copy(), touch + u * d
        b.done_s, b.duration_s = 0.0, t
        self.pos = touch.copy()

    def _prb_line(self) -> str:
        return f"[PRB:{self._coords(self._probe_at)}:{self._probe_touched:d}]"

    def _outside_travel(self, points) -> bool:
        """GRBL 1.1h's soft-limit test (system_check_travel_limits, built without
        HOMING_FORCE_SET_ORIGIN): a machine position (mm) outside −$13x…0 on any axis."""
        travel = np.array([float(self.settings[130 + a]) for a in range(3)])
        p = np.asarray(points, float).reshape(-1, 3)
        return bool(np.any(p > 1e-6) or np.any(p < -travel - 1e-6))

    def _critical_alarm(self, alarm: int) -> None:
        """A soft or hard limit: GRBL stops at once (the queue, the RX buffer and the beam cleared),
        says the alarm and that a reset is needed, and is locked in Alarm. Until that reset it
        reads no line and answers no real-time byte ('?' included); the reset then answers the
        line GRBL was in (the one that hit the soft limit, or a line waiting for the planner or
        for a G4 when a switch was hit) before its banner."""
        if alarm == AlarmCode.SOFT_LIMIT or self._parsed is not None:
            owed = (grbl_reply(ErrorCode.OK),)
        else:
            owed = self._waiting_replies()
        self._critical_owed = owed
        self._blocks.clear()
        self._admitting.clear()
        self._admit_replies = ()
        self._rest_level = 0.0
        self._rx.clear()
        self._speed = 0.0
        self.state, self.alarm_code = "Alarm", alarm
        self._emit(grbl_reply(AlarmCode(alarm)))
        self._emit(grbl_reply(Feedback.RESET_TO_CONTINUE))

    def _start_homing(self) -> None:
        """``$H``: GRBL 1.1h's homing cycle, group by group (Z, then X and Y): a search at
        ``$25`` over 1.5 x the group's longest travel (``$13x``), a pull-off of ``$27`` at
        ``$25``, a slow locate at ``$24`` over 10 x the pull-off, the pull-off again, ``$26`` ms
        of debounce after each; ``$23`` names the axes that home towards -. The beam is off."""
        pulloff = float(self.settings[27])
        seek, feed = float(self.settings[25]), float(self.settings[24])
        debounce = int(self.settings[26]) / 1000.0
        todo: deque = deque()
        for axes in _HOMING_GROUPS:
            search = _HOMING_SEARCH_SCALE * max(float(self.settings[130 + a]) for a in axes)
            for distance, rate, towards in ((search, seek, True), (pulloff, seek, False),
                                            (_HOMING_LOCATE_SCALE * pulloff, feed, True),
                                            (pulloff, seek, False)):
                todo.append(("move", axes, distance, rate, towards))
                todo.append(("wait", debounce))
            todo.append(("home", axes))
        self._homing = _Homing(todo)
        self.state = "Home"
        self._speed = 0.0
        self._rest_level = 0.0          # the beam stays off after the cycle until a line lights it

    def _begin_homing_step(self, h: _Homing) -> None:
        """Start the next step of the cycle: zero the moving axes and time their move."""
        h.step, h.t = h.todo.popleft(), 0.0
        if h.step[0] == "wait":
            h.duration_s = h.step[1]
            return
        if h.step[0] == "home":
            h.duration_s = 0.0
            return
        _, axes, distance, rate, seek = h.step
        towards_minus = int(self.settings[23])
        h.sign = np.zeros(3)
        h.stop_mm = np.full(3, math.inf)
        for a in axes:
            self._set_axis(a, 0.0)      # GRBL counts each phase from 0
            side = -1.0 if towards_minus & (1 << a) else 1.0
            h.sign[a] = side if seek else -side
        if seek:
            pressed_now = self._pressed()
            for a in axes:
                # the switch point along the way, if the input reads pressed just beyond it
                to_switch = float(self._switch_mm[a] * h.sign[a])
                if pressed_now[a]:
                    h.stop_mm[a] = 0.0
                elif 0.0 < to_switch <= distance and self._pressed(
                        np.where(np.arange(3) == a, h.sign * (to_switch + 1e-6), self.pos))[a]:
                    h.stop_mm[a] = to_switch
        # every axis of the group at the homing rate (GRBL's rate x sqrt(n) along the path),
        # within the slowest axis' maximum rate and acceleration
        top = min([rate] + [self.machine.max_rate_mm_min[a] for a in axes]) / 60.0
        accel = min(self.machine.accel_mm_s2[a] for a in axes)
        h.profile = block_profiles(distance, 0.0, top, 0.0, accel, accel, "accel")
        if seek and all(math.isfinite(h.stop_mm[a]) for a in axes):
            h.duration_s = _time_at(h.profile, max(float(h.stop_mm[a]) for a in axes))
        else:
            h.duration_s = float(h.profile.time_s[0])

    def _run_homing(self, dt: float) -> float:
        """Run the homing cycle for ``dt`` s; the time left when it ended."""
        h = self._homing
        while dt > 0 and self.state == "Home":
            if h.step is None:
                if not h.todo:
                    self._homing_done()
                    return dt
                self._begin_homing_step(h)
            step = min(dt, h.duration_s - h.t)
            h.t += step
            self._sim_t += step
            dt -= step
            if h.step[0] == "move":
                start = self.pos.copy()
                s = float(h.profile.sample(0, h.t)[0])
                moving = h.sign != 0
                self.pos[moving] = (h.sign * np.minimum(s, h.stop_mm))[moving]
                self.executed.append(Piece(self.lines_accepted, -1, "$H", tuple(start),
                                           tuple(self.pos), 0.0, True, self._sim_t))
            if h.t < h.duration_s - 1e-12:
                continue
            step_done, h.step = h.step, None
            if step_done[0] == "move":
                _, axes, _, _, seek = step_done
                if seek and not all(math.isfinite(h.stop_mm[a]) for a in axes):
                    self._homing_failed(AlarmCode.HOMING_FAIL_APPROACH)     # no switch found
                elif not seek and self._pressed()[list(axes)].any():
                    self._homing_failed(AlarmCode.HOMING_FAIL_PULLOFF)      # still pressed
            elif step_done[0] == "home":
                # homed: the switch end of the travel is 0 (GRBL's machine space is -$13x..0),
                # the axis one pull-off inside it
                pulloff = float(self.settings[27])
                for a in step_done[1]:
                    travel = float(self.settings[130 + a])
                    towards_minus = int(self.settings[23]) & (1 << a)
                    self._set_axis(a, -travel + pulloff if towards_minus else -pulloff)
        return dt

    def _homing_done(self) -> None:
        """The cycle ended well: a '?' that came meanwhile is answered (still in Home, as GRBL's
        homing loop serves no real-time request), the start-up lines run, then $H's ok."""
        h, self._homing = self._homing, None
        if h.status_asked:
            self._emit(self._status_report())
        self.state, self.alarm_code = "Idle", 0
        self._run_startup_lines()
        self._emit(grbl_reply(ErrorCode.OK))

    def _homing_failed(self, alarm: int) -> None:
        """The cycle failed (no switch, still pressed, a reset or the door): the alarm, $H's ok,
        and the soft reset GRBL then makes (its banner, locked until $H or $X). A '?' sent
        during the cycle is lost with the reset, as in GRBL."""
        self._homing = None
        self.state, self.alarm_code = "Alarm", alarm
        self._emit(grbl_reply(AlarmCode(alarm)))
        self._emit(grbl_reply(ErrorCode.OK))
        self._realtime("reset")


    # -- pyserial-like surface ----------------------------------------------------------------

    @property
    def in_waiting(self) -> int:
        with self._lock:
            self._advance()
            return len(self._out)

    def write(self, data: bytes) -> int:
        if not self.is_open:
            raise OSError("virtual machine is closed")
        with self._lock:
            self._advance()
            data = bytes(data)
            if math.isinf(self.link_bytes_per_s):
                self._arrive(data)
                self._take_lines()
            elif data:
                start = max(self._wire_free_s, self._sim_t)
                self._wire.append([start, data, 0])
                self._wire_free_s = start + len(data) / self.link_bytes_per_s
            self._log_beam()
        return len(data)

    def _arrive(self, data: bytes) -> None:
        """Bytes off the link: real-time ones act at once, the rest wait in the RX buffer."""
        for byte in data:
            kind = _REALTIME.get(byte)
            if kind:
                self._realtime(kind)
            elif 0x90 <= byte <= 0x9D:
                self._override(byte)
            else:
                if len(self._rx) >= self.rx_bytes:
                    self._take_lines()          # GRBL's main loop reads on while bytes arrive
                if len(self._rx) < self.rx_bytes:   # GRBL 1.1's ring holds all 128 bytes
                    self._rx.append(byte)
                else:
                    self.overflows += 1

    def _next_arrival_s(self) -> float:
        """When the next byte that changes anything (a line end, a real-time byte, or the end
        of what was written) has arrived; inf when the link is idle."""
        if not self._wire:
            return math.inf
        start, data, done = self._wire[0]
        k = next((i for i in range(done, len(data)) if data[i] in _ACTS_ON_ARRIVAL), len(data) - 1)
        return start + (k + 1) / self.link_bytes_per_s

    def _receive(self) -> None:
        """Hand over every byte the link has carried by now."""
        while self._wire:
            start, data, done = chunk = self._wire[0]
            arrived = min(len(data), int((self._sim_t - start) * self.link_bytes_per_s + 1e-6))
            if arrived > done:
                chunk[2] = arrived
                self._arrive(data[done:arrived])
            if arrived < len(data):
                return
            self._wire.popleft()

    def read(self, size: int = 1) -> bytes:
        if not self.is_open:
            raise OSError("virtual machine is closed")
        deadline = time.monotonic() + (self.timeout or 0.0)
        while True:
            with self._lock:
                self._advance()
                if self._out:
                    data = bytes(self._out[:size])
                    del self._out[:size]
                    return data
            if time.monotonic() >= deadline:
                return b""
            time.sleep(min(0.002, max(0.0, deadline - time.monotonic())))

    def flush(self) -> None:
        pass

    def advance(self, seconds: float) -> None:
        """Let ``seconds`` of simulated time pass now, on top of what ``time_scale`` or
        ``tick_s`` give: motion runs, bytes arrive, replies are written. With ``time_scale=0``
        and ``tick_s=0`` the machine's clock moves only here, so a test can replay a
        conversation with the waits it was recorded with.

        Examples
        --------
        >>> vm = VirtualMachine(time_scale=0, tick_s=0.0, banner=False)
        >>> _ = vm.write(b"G1 X1 F600\\nG4 P0\\n")      # 1 mm at 10 mm/s, then a dwell
        >>> vm.read(64)
        b'ok\\r\\n'
        >>> vm.advance(1.0)
        >>> vm.read(64), vm.sim_time_s
        (b'ok\\r\\n', 1.0)
        """
        if seconds < 0:
            raise ValueError(f"advance: seconds must be >= 0, got {seconds}")
        with self._lock:
            self._advance(float(seconds))

    def close(self) -> None:
        self.is_open = False

    def reset_input_buffer(self) -> None:
        with self._lock:
            self._out.clear()

    # -- inspection ---------------------------------------------------------------------------

    @property
    def sim_time_s(self) -> float:
        return self._sim_t

    @property
    def rx_used(self) -> int:
        return len(self._rx)

    def starvations_since(self, start_s: float, first_run: int, sent_lines, events=None) -> list[Starvation]:
        """The starvations of a job: those after ``start_s`` (simulated s), timed from it, each
        naming the source line it waited for.

        Parameters
        ----------
        start_s : float
            :attr:`sim_time_s` when the job's first byte was written.
        first_run : int
            :attr:`lines_run` then.
        sent_lines : sequence of int
            The source line of every G-code line the job sent (not its ``$`` lines), in order.
        events : list of Starvation, optional
            Other records numbered as :attr:`starvations` (:attr:`short_queues`).

        Examples
        --------
        >>> vm = VirtualMachine(time_scale=0, tick_s=0.0, parse_s=0.0, banner=False)
        >>> _ = vm.write(b"G1 X1 F600\\n")        # 1 mm at 10 mm/s: about 0.1 s
        >>> vm.tick_s = 0.5
        >>> _ = vm.read(64)                        # half a second later: done, dry since ~0.1 s
        >>> vm.tick_s = 0.0
        >>> _ = vm.write(b"G1 X2\\n")
        >>> [(s.line, round(s.time_s, 1), round(s.duration_s, 1)) for s in vm.starvations_since(0.0, 0, [7, 8])]
        [(8, 0.1, 0.4)]
        """
        out = []
        for s in self.starvations if events is None else events:
            k = s.line - first_run - 1
            if s.time_s >= start_s and 0 <= k < len(sent_lines):
                out.append(Starvation(s.time_s - start_s, int(sent_lines[k]), s.duration_s))
        return out

    def laser_output(self) -> float:
        """Beam power now, as a fraction of full.

        In laser mode (``$32=1``), as GRBL 1.1 does: a burning block lights it while it moves
        (braking in a hold included) and goes off once a feed hold has stopped the head, M3 and M4
        alike (GRBL's DISABLE_LASER_DURING_HOLD, on by default; cycle start restores it); when the
        queue runs out, M4 (dynamic power) switches it off, while M3 (constant power) leaves it at
        the last block's power in G1-G3 mode until M5, S0, G0, M2/M30, a reset or an alarm (a line
        of M3 S without motion in G1-G3 mode switches it on at rest: focusing). A dwell keeps the level
        it starts with. A door and an alarm switch it off. With ``$32=0`` the beam follows M3/M4
        S whatever the motion (GRBL's spindle).
        """
        with self._lock:
            return self._laser_output()

    def _laser_output(self) -> float:
        if self.state == "Home":
            return 0.0                                  # GRBL homes with the beam off
        moving = (self.state in ("Run", "Jog") or self._braking) and self._blocks
        if self.state == "Door" and self.substate != 2:
            return 0.0                                  # GRBL de-energizes once the door hold stops
        if self._flag(32):                              # laser mode
            if moving:
                return self._blocks[0].power
            if self.state == "Hold":
                # stopped in a hold: GRBL 1.1 (DISABLE_LASER_DURING_HOLD, on in its default
                # config.h) de-energizes the laser in laser mode, M3 and M4 alike, until cycle start
                return 0.0
            return self._rest_level if self.state == "Idle" and not self._blocks else 0.0
        # spindle mode ($32=0): the beam follows M3/M4 S whatever the motion
        return self._beam_fraction(self.laser_mode_word, self.s_word) if self.laser_mode_word else 0.0

    @property
    def _braking(self) -> bool:
        """Decelerating along the path after a feed hold (Hold:1) or a door (Door:2)."""
        return (self.state, self.substate) in (("Hold", 1), ("Door", 2))

    # -- internals --------------------------------------------------------------------------------

    def _emit(self, text: str) -> None:
        self._out += text.encode("ascii") + b"\r\n"

    def _reset_parser(self) -> None:
        """GRBL's reset: the power-on modal state (G54, no G92, no tool offset) where the head
        is; the G54…G59 origins and the G28.1/G30.1 positions stay (GRBL keeps them in EEPROM)."""
        kept = self._parser.state
        self._parser.state = ModalState(position=tuple(float(v) for v in self.pos),
                                        coord_origins=kept.coord_origins, home28=kept.home28,
                                        home30=kept.home30)
        self._rest_level = 0.0      # the beam once the queue is empty (GRBL's M3 leaves it on)

    # the parser's state, as GRBL's $G and $# and the status report show it
    motion = _parser_field("motion", "Motion mode: 0-3, 80 or 382-385 (G38.2-G38.5).")
    plane = _parser_field("plane", "17, 18 or 19.")
    units = _parser_field("units", "20 (inch) or 21 (mm).")
    distance = _parser_field("distance", "90 or 91.")
    feed_mm_min = _parser_field("feed_mm_min", "F, mm/min (NaN while undefined).")
    s_word = _parser_field("s_word", "S as written.")
    coord_system = _parser_field("coord_system", "54-59.")
    tool_offset = _parser_field("tool_offset", "G43.1 tool length offset, mm.")

    @property
    def laser_mode_word(self) -> int:
        """3 (M3), 4 (M4) or 0 (M5)."""
        return self._parser.state.laser % 5

    @property
    def coord_origins(self) -> np.ndarray:
        """G54…G59 origins, machine mm."""
        return np.array(self._parser.state.coord_origins, float)

    @property
    def g92(self) -> np.ndarray:
        """G92 offset, mm."""
        return np.array(self._parser.state.g92, float)

    @property
    def work_offset(self) -> np.ndarray:
        """WCO: machine position minus work position, mm (G54…G59 origin + G92 + TLO on Z)."""
        return self._parser.state.work_offset

    def _beam_fraction(self, laser: int, s: float) -> float:
        s_max = float(self.settings[30]) or 1000.0
        return max(0.0, min(1.0, s / s_max)) if laser in (3, 4) else 0.0

    def _log_beam(self) -> None:
        """Append a :attr:`beam_log` row when the beam changed."""
        level = self.laser_output()
        if level != self._beam_level:
            self._beam_level = level
            line = self._blocks[0].line if self._blocks else 0
            self.beam_log.append((self._sim_t, level, self.state, line))
            if len(self.beam_log) > 1_000_000:
                del self.beam_log[:500_000]

    def _note_stop(self, why: str) -> None:
        power = self.laser_output()
        if power > 0:
            self.unsafe_stops.append((self._sim_t, why, power))

    def _realtime(self, kind: str) -> None:
        if self._critical_owed is not None and kind != "reset":
            return                              # GRBL's critical-event loop waits for a reset
        if self.state == "Home":
            # GRBL's homing loop serves no real-time request: a '?' is answered once the cycle
            # has ended; a reset or the door ends it in an alarm; hold and cycle start wait
            if kind == "status":
                self._homing.status_asked = True
            elif kind in ("reset", "door"):
                self._homing_failed(AlarmCode.HOMING_FAIL_RESET if kind == "reset"
                                    else AlarmCode.HOMING_FAIL_DOOR)
            return
        if kind == "status":
            self._emit(self._status_report())
        elif kind == "hold":
            if self.state in ("Run",):
                # GRBL decelerates along the path (Hold:1) and reports Hold:0 once stopped
                self.state, self.substate = "Hold", 1
                self._hold_v = self._current_speed()
            elif self.state == "Jog":
                self._blocks.clear()
                self.state = "Idle"
            elif self.state == "Idle":          # GRBL holds at rest too, until cycle start
                self.state, self.substate = "Hold", 0
                self._hold_complete()
        elif kind == "door":
            # GRBL 1.1 without a door switch: a feed hold that de-energizes the spindle/laser once
            # stopped (Door:2 while it does, Door:0 after: closed, ready to resume with '~')
            if self.state in ("Run", "Hold"):
                braking = self.state == "Run" or self.substate == 1
                if self.state == "Run":
                    self._hold_v = self._current_speed()
                self.state, self.substate = "Door", 2 if braking else 0
            elif self.state in ("Idle", "Jog"):
                if self.state == "Jog":
                    self._blocks.clear()
                self.state, self.substate = "Door", 0
                self._hold_complete()
        elif kind == "start":
            # GRBL resumes only a completed hold (Hold:0, Door:0): a '~' while it still brakes
            # is dropped (protocol.c: cycle start needs SUSPEND_HOLD_COMPLETE)
            if self.state in ("Hold", "Door") and self.substate == 0:
                if self.state == "Hold" and self._hold_stopped_laser:
                    # laser mode: the hold switched the beam off (DISABLE_LASER_DURING_HOLD); GRBL
                    # says so and lights it again with the next segment (no Ov: refresh)
                    self._hold_stopped_laser = False
                    if self.laser_mode_word:
                        self._emit(grbl_reply(Feedback.RESTORING_SPINDLE))
                elif self.state == "Door":
                    # the door restores what it switched off: the spindle outside laser mode and
                    # the coolant, each setting the Ov: counter
                    if self.laser_mode_word and not self._flag(32):
                        self._ovr_counter = 0
                    if 8 in self._parser.state.coolant:
                        self._flood, self._ovr_counter = True, 0
                self.state = "Run" if self._blocks else "Idle"
                self.substate = 0
        elif kind == "jog_cancel":
            if self.state == "Jog":
                self._blocks.clear()
                self.state = "Idle"
        elif kind == "reset":
            for reply in self._critical_owed or ():
                self._emit(reply)
            self._critical_owed = None
            moving = self._moving()
            waiting = self._waiting_replies()
            if moving:
                self._emit(grbl_reply(AlarmCode.ABORT_CYCLE))
            for reply in waiting:           # GRBL leaves its wait and answers the line it was in
                self._emit(reply)
            self._rx.clear()
            self._partial.clear()
            self._parsed = None
            self._sync_verdict, self._wco_preview = ("", False), None
            self._dry_since = None
            self._blocks.clear()
            self._admitting.clear()
            self._admit_replies = ()
            self._soft_limit_braking = False
            self._speed = 0.0
            self._reset_parser()
            self.check_mode = False
            self._wco_counter = self._ovr_counter = 0   # GRBL clears its system state
            self._flood = self._hold_stopped_laser = False
            self._probe_at, self._probe_touched = np.zeros(3), False   # GRBL clears them
            if moving:
                self.state, self.alarm_code = "Alarm", AlarmCode.ABORT_CYCLE
            elif self.state == "Sleep":                 # GRBL wakes from sleep locked
                self.state, self.alarm_code = "Alarm", 0
            elif self.state != "Alarm":
                self.state = "Idle"
            if self._greet():
                self._run_startup_lines()

    def _moving(self) -> bool:
        """Whether the axes are moving (or braking): a running block that is no dwell."""
        return ((self.state in ("Run", "Jog") or self._braking) and bool(self._blocks)
                and not self._blocks[0].is_dwell)

    def _waiting_replies(self) -> tuple:
        """The replies of the line GRBL is in, still unanswered: its blocks wait for planner
        room, or it waits for the planner to empty (G4, M0, M2, M30, G38)."""
        if self._soft_limit_braking:
            return (grbl_reply(ErrorCode.OK),)
        if self._parsed is not None and not self._parsed[0].startswith("$"):
            # read and waiting (parsed, the planner full or a sync): GRBL ends the line at the
            # reset and answers it as its parser judged it
            line, overflow = _grbl_line(self._parsed[0])
            if overflow:
                return (grbl_reply(ErrorCode.LINE_OVERFLOW),)
            saved = self._parser.state
            _, error = self._parser.feed(line) if line else (None, None)
            after, self._parser.state = self._parser.state, saved
            if error is None:
                # GRBL leaves its wait and finishes the line: what it writes to EEPROM (G10
                # L2/L20, G28.1, G30.1) is written, from the parser's position (the end of the
                # move the reset cut short); the rest goes with the reset
                self._parser.state = replace(saved, coord_origins=after.coord_origins,
                                             home28=after.home28, home30=after.home30)
                if "end" in self._sync_reasons(line):   # GRBL still ends the program
                    return grbl_reply(Feedback.PROGRAM_END), grbl_reply(ErrorCode.OK)
            return (grbl_reply(ErrorCode.OK if error is None else ErrorCode(error.code)),)
        if self._admitting:
            return self._admit_replies + self._admitting[-1].replies
        return self._blocks[-1].replies if self._blocks else ()

    def _run_startup_lines(self) -> None:
        """GRBL's start-up lines (``$N0=``, ``$N1=``), each answered ``>line:ok`` (or its error)."""
        for startup in self.startup_lines:
            if startup:
                jog = startup.startswith("$")
                err = self._gcode(_startup_jog(startup) if jog else startup, jog=jog)
                if err == _DEFERRED:            # answered here, not when it has run
                    (self._admitting or self._blocks)[-1].replies = ()
                code = ErrorCode.OK if err in (None, _DEFERRED) else ErrorCode(err)
                self._answer(f">{startup}:{grbl_reply(code)}")

    def _override(self, byte: int) -> None:
        """GRBL 1.1's override bytes: feed 10–200 %, rapid 25/50/100 %, laser power 10–200 %.
        They apply to blocks that start from now on (GRBL re-plans the queue; close enough for
        a simulation), and the status report's Ov: field shows them."""
        feed, rapid, power = self.overrides
        if byte == 0x90:
            feed = 100
        elif byte in (0x91, 0x92, 0x93, 0x94):
            feed += {0x91: 10, 0x92: -10, 0x93: 1, 0x94: -1}[byte]
        elif byte in (0x95, 0x96, 0x97):
            rapid = {0x95: 100, 0x96: 50, 0x97: 25}[byte]
        elif byte == 0x99:
            power = 100
        elif byte in (0x9A, 0x9B, 0x9C, 0x9D):
            power += {0x9A: 10, 0x9B: -10, 0x9C: 1, 0x9D: -1}[byte]
        new = (min(200, max(10, feed)), rapid, min(200, max(10, power)))
        if new != self.overrides:
            self._ovr_counter = 0               # GRBL: "report change immediately"
        self.overrides = new

    def _coords(self, values) -> str:
        """Positions as GRBL prints them: mm with 3 decimals, or with ``$13=1`` inches with 4."""
        if self._flag(13):
            return ",".join(_grbl_number(float(v) * _INCH_PER_MM, 4) for v in values)
        return ",".join(_grbl_number(float(v), 3) for v in values)

    def _rate(self, mm_min: float) -> str:
        """A feed rate as GRBL prints it: mm/min without decimals, or in/min with one ($13=1)."""
        if self._flag(13):
            return _grbl_number(mm_min * _INCH_PER_MM, 1)
        return _grbl_number(mm_min, 0)

    def _status_report(self) -> str:
        state = self.state
        if state == "Run" and self._blocks and self._blocks[0].is_dwell:
            state = "Idle"              # GRBL dwells (G4) with its planner empty: Idle
        st = state + (f":{self.substate}" if state in ("Hold", "Door") else "")
        if self.check_mode and state == "Idle":
            st = "Check"
        feed = self._blocks[0].speed_mm_s * 60 if self._blocks and state == "Run" else 0.0
        lit = self.laser_output() > 0
        s = self.s_word if lit else 0.0
        # GRBL's planner holds motion only: its G4, M0 and M2 wait outside it
        free_blocks = self.planner_blocks - sum(not b.is_dwell for b in self._blocks)
        free_rx = self.rx_bytes - len(self._rx)
        wco = self.work_offset if self._wco_preview is None else self._wco_preview
        mask = int(self.settings[10])
        # $10 bit 0: MPos (1) or WPos (0); bit 1: the buffer state Bf
        if mask & 1:
            text = f"<{st}|MPos:{self._coords(self.pos)}"
        else:
            text = f"<{st}|WPos:{self._coords(self.pos - wco)}"
        if mask & 2:
            text += f"|Bf:{free_blocks},{free_rx}"
        text += f"|FS:{self._rate(feed)},{_grbl_number(s, 0)}"
        pins = ("P" if self._probe_touching() else "") + self.limit_pins
        if pins:                                        # GRBL: the inputs that read pressed
            text += f"|Pn:{pins}"
        # GRBL's refresh counters (report.c): WCO when its counter is 0, then again after 10
        # reports idle (30 busy: the state of this report); Ov on the report after a WCO, then
        # after 10 idle (20 busy). What changes the offsets, the spindle/laser or coolant output
        # or an override sets the counter to 0 (see _report_events). No Ln: (not in GRBL's build).
        busy = state in ("Run", "Hold", "Jog", "Door", "Home")
        if self._wco_counter > 0:
            self._wco_counter -= 1
        else:
            self._wco_counter = (30 if busy else 10) - 1
            self._ovr_counter = self._ovr_counter or 1
            text += f"|WCO:{self._coords(wco)}"
        if self._ovr_counter > 0:
            self._ovr_counter -= 1
        else:
            self._ovr_counter = (20 if busy else 10) - 1
            text += "|Ov:{},{},{}".format(*self.overrides)
            # GRBL: the outputs that are on, A:S (M3) or A:C (M4) while the PWM runs, F the coolant
            accessories = ("S" if self.laser_mode_word == 3 else "C") if lit else ""
            accessories += "F" if self._flood else ""
            if accessories:
                text += "|A:" + accessories
        return text + ">"

    def _advance(self, extra_s: float = 0.0) -> None:
        now = time.monotonic()
        if self.time_scale > 0:
            dt = (now - self._wall) * self.time_scale
        else:
            dt = self.tick_s
        self._wall = now
        target = self._sim_t + dt + extra_s
        while True:
            # run to the next event: a byte that acts arrives, a parse ends, or a block ends
            t_next = min(target, self._next_arrival_s())
            if self._parsed is not None and self._parsed[1] > self._sim_t:
                t_next = min(t_next, self._parsed[1])
            self._run_for(t_next - self._sim_t)
            if self._sim_t >= t_next - 1e-12:
                self._sim_t = max(self._sim_t, t_next)
            self._receive()
            self._take_lines()
            if self._sim_t >= target:
                break
        self._log_beam()
        self.rx_fill.append((self._sim_t, len(self._rx)))
        if len(self.rx_fill) > 200_000:
            del self.rx_fill[:100_000]

    def _current_speed(self) -> float:
        """Speed of the head now, mm/s (the block's mean speed: blocks move at a steady
        rate between their timed ends)."""
        if self._blocks and self._blocks[0].started and not self._blocks[0].is_dwell:
            b = self._blocks[0]
            length = float(np.linalg.norm(b.end - b.start))
            return length / b.duration_s if b.duration_s > 0 else 0.0
        return self._speed

    def _rearm(self, speed: float) -> None:
        """The head block continues from where the head is, timed afresh from ``speed``."""
        b = self._blocks[0]
        b.start = self.pos.copy()
        b.length_mm = float(np.linalg.norm(b.end - b.start))
        b.done_s, b.started = 0.0, False
        self._speed = speed

    def _brake(self, dt: float) -> float:
        """Feed hold: decelerate along the queued path at the block's acceleration until the
        head stops (then Hold:0); returns the time left of ``dt``."""
        while dt > 0 and self._hold_v > 1e-9 and self._blocks:
            b = self._blocks[0]
            if b.is_dwell:
                break
            acc = b.accel_mm_s2 if math.isfinite(b.accel_mm_s2) else 1e9
            length = float(np.linalg.norm(b.end - b.start))
            if not b.started:                       # entering a queued block while braking
                b.started, b.done_s = True, 0.0
                b.duration_s = length / self._hold_v if self._hold_v > 0 else math.inf
            done = length * (b.done_s / b.duration_s if b.duration_s > 0 else 1.0)
            left = max(0.0, length - done)
            v = self._hold_v
            step = min(dt, v / acc)
            dist = v * step - 0.5 * acc * step * step
            start = self.pos.copy()
            if dist >= left:                         # this block ends before the head stops
                step = (v - math.sqrt(max(0.0, v * v - 2.0 * acc * left))) / acc
                self.pos = b.end.copy()
                self._blocks.popleft()
            else:
                u = (b.end - b.start) / length if length > 0 else np.zeros(3)
                self.pos = self.pos + u * dist
                b.done_s = (done + dist) / length * b.duration_s
            self._hold_v = max(0.0, v - acc * step)
            self._sim_t += step
            dt -= step
            hit = self._flag(21) and self._stop_at_switch(start)
            self.executed.append(Piece(b.line, b.n_word, b.text, tuple(start), tuple(self.pos),
                                       b.power, b.rapid, self._sim_t))
            if hit:                                  # $21: braking onto a switch
                self._hold_v = 0.0
                self._critical_alarm(AlarmCode.HARD_LIMIT)
                return dt
        if self._hold_v <= 1e-9 or not self._blocks or self._blocks[0].is_dwell:
            self.substate, self._hold_v = 0, 0.0
            if self._blocks and not self._blocks[0].is_dwell:
                self._rearm(0.0)
            self._speed = 0.0
            if self._soft_limit_braking:         # stopped: now GRBL's soft-limit alarm
                self._soft_limit_braking = False
                self.state, self.substate = "Idle", 0
                self._critical_alarm(AlarmCode.SOFT_LIMIT)
                return dt
            self._hold_complete()
            self._note_stop("safety door" if self.state == "Door" else "feed hold")
        return dt

    def _hold_complete(self) -> None:
        """A feed hold (Hold:0), a program pause or a door (Door:0) has stopped the machine:
        GRBL's suspend de-energizes. The door switches the spindle/laser and the coolant off;
        a hold in laser mode switches an enabled laser off (DISABLE_LASER_DURING_HOLD). Either
        sets the Ov: counter (the next report shows Ov: and A:)."""
        if self.state == "Door":
            self._ovr_counter = 0
            self._flood = False
        elif self._flag(32) and self.laser_mode_word:
            self._ovr_counter = 0
            self._hold_stopped_laser = True

    def _run_for(self, dt: float) -> None:
        while dt > 0:
            if self.state == "Home":
                dt = self._run_homing(dt)
                continue
            if self._braking:
                dt = self._brake(dt)
                continue
            if self.state not in ("Run", "Jog") or not self._blocks:
                self._sim_t += dt
                if self.state in ("Run", "Jog") and not self._blocks:
                    self.state = "Idle"
                return
            b = self._blocks[0]
            if not b.started and b.probe and self._probe_reached(b.probe):
                # GRBL's probe cycle: the input already where the move should take it
                self._blocks.clear()
                self.state, self.alarm_code = "Alarm", AlarmCode.PROBE_FAIL_INITIAL
                self._emit(grbl_reply(AlarmCode.PROBE_FAIL_INITIAL))
                self._emit(grbl_reply(ErrorCode.OK))
                continue
            if not b.started:
                self._start_block(b)
                if b.pause:                     # M0: the moves before it have run; hold here
                    b.pause = False
                    self.state, self.substate = "Hold", 0
                    self._hold_complete()
                    continue
            left = b.duration_s - b.done_s
            step = min(dt, left)
            start = self.pos.copy()
            b.done_s += step
            frac = 1.0 if b.duration_s <= 0 else min(1.0, b.done_s / b.duration_s)
            self.pos = b.start + (b.end - b.start) * frac
            probed = bool(b.probe) and b.probe_point is None and self._probe_reached(b.probe)
            if probed:                          # switched: brake past it, then the cycle ends
                moved = float(np.linalg.norm(self.pos - start))
                self._probe_stop(b, start)
                if moved > 0:                   # blocks run at a steady rate: the rest of this
                    step *= min(1.0, float(np.linalg.norm(self.pos - start)) / moved)   # step brakes
            self._sim_t += step
            dt -= step
            hit = self._flag(21) and self._stop_at_switch(start)
            self.executed.append(Piece(b.line, b.n_word, b.text, tuple(start), tuple(self.pos),
                                       b.power, b.rapid, self._sim_t))
            if hit:                             # $21: GRBL's hard limit
                self._critical_alarm(AlarmCode.HARD_LIMIT)
                self._log_beam()
                return
            self._log_beam()
            if probed:
                continue
            touched = b.probe_point is not None
            if b.done_s >= b.duration_s - 1e-12:
                self.pos = b.end.copy()
                self._speed = 0.0 if touched else b.exit_mm_s
                self._blocks.popleft()
                if not self._blocks:
                    self._speed = 0.0           # the planner ran empty: the axes have stopped
                if b.probe:
                    self.state = "Idle"
                    self._probe_result(b, bool(touched))
                for reply in b.replies:         # G4, M0, M2, M30: answered now
                    self._emit(reply)
                self._take_lines()              # a line waiting in RX refills the planner now
                if not self._blocks:
                    if self.state != "Alarm":       # ALARM:5 stays
                        self.state = "Idle"
                    self._speed = 0.0
                    self._dry_since = self._sim_t
                    self._note_stop("buffer empty")
                self._log_beam()
                return                          # the caller looks at the link and the parser

    def _take_lines(self) -> None:
        """GRBL's main loop: read a line from the RX buffer, parse it (``parse_s``), run it
        once the planner has room; not while a G4, M0, M2 or M30 waits to be answered."""
        while True:
            if self._critical_owed is not None:
                return                                  # after ALARM:1/2 nothing is read
            if not self._admit():
                return                                  # GRBL is still in a line (mc_line)
            if self._parsed is None:
                if self._blocks and self._blocks[-1].replies:
                    return
                if self.state in ("Hold", "Door", "Home"):   # GRBL's main loop waits (a suspend,
                    return                                   # the homing cycle)
                cut = self._rx.find(b"\n")
                if cut < 0:             # GRBL reads on into its line buffer: the RX empties
                    if len(self._partial) < 4096:
                        self._partial += self._rx
                    self._rx.clear()
                    return
                raw = bytes(self._partial + self._rx[:cut])
                del self._rx[:cut + 1]
                self._partial.clear()
                text = raw.decode("ascii", "replace").strip()
                self._parsed = (text, self._sim_t + self.parse_s)
            text, ready_s = self._parsed
            if ready_s > self._sim_t + 1e-12:
                return
            if not text.startswith("$") and len(self._blocks) >= self.planner_blocks:
                return                                  # planner full: the line waits
            if self._blocks and self._waits_for_sync(text):
                return                                  # GRBL empties the planner first
            if self._short_since is not None and self._waits_for_sync(text):
                self._short_since = None                # a stop the program asks for
            if self._waits_for_sync(text):
                self._synced = True                     # the next block enters a planner it emptied
            self._parsed = None
            self._sync_verdict, self._wco_preview = ("", False), None
            self._line(text)

    def _line(self, text: str) -> None:
        """One line as GRBL's serial reader hands it over: spaces, control characters, ``/``
        and comments dropped, letters upper case, at most 79 characters (else error:11)."""
        line, overflow = _grbl_line(text)
        if self.state == "Sleep":
            return                                  # asleep: GRBL reads nothing until a reset
        if overflow:
            self._emit(grbl_reply(ErrorCode.LINE_OVERFLOW))
            return
        if not line:
            self._emit(grbl_reply(ErrorCode.OK))    # GRBL answers an empty or comment line
            return
        if line.startswith("$"):
            self._system(line)
            return
        self.lines_run += 0 if self.check_mode else 1
        if self.state in ("Alarm", "Jog"):           # GRBL takes no G-code while it jogs either
            self._emit(grbl_reply(ErrorCode.GCODE_LOCKED))
            return
        err = self._gcode(line, jog=False, text=text)
        if err not in (_ALARMED, _DEFERRED):      # an alarm replaces the line's answer
            self._answer(grbl_reply(ErrorCode.OK if err is None else ErrorCode(err)))

    def _system(self, line: str) -> None:
        """A ``$`` line, in the order GRBL 1.1h's system_execute_line checks it; the grammar of
        settings and start-up lines is :func:`labkit.gcode.reader.grbl_system_verdict`'s."""
        reply = self._system_reply(line)
        if reply is not None:
            self._answer(grbl_reply(reply))

    def _system_reply(self, line: str):
        """Do a ``$`` line; the status to answer (None: answered already)."""
        cmd, rest = line[1:2], line[2:]
        if cmd == "":
            self._emit("[HLP:$$ $# $G $I $N $x=val $Nx=line $J=line $SLP $C $X $H ~ ! ? ctrl-x]")
            return ErrorCode.OK
        if cmd == "J":
            if self.state not in ("Idle", "Jog"):
                return ErrorCode.NOT_IDLE if self.state != "Alarm" else ErrorCode.GCODE_LOCKED
            if not rest.startswith("="):
                return ErrorCode.INVALID_STATEMENT
            err = self._gcode(line, jog=True)          # the parser runs $J= as GRBL's jog
            return ErrorCode.OK if err is None else ErrorCode(err)
        if cmd in "$GCX":
            if rest:
                return ErrorCode.INVALID_STATEMENT
            if cmd == "$":
                if self.state in ("Run", "Hold", "Jog") or self._blocks:
                    return ErrorCode.NOT_IDLE
                for k in sorted(self.settings):
                    self._emit(f"${k}={self.settings[k]}")
            elif cmd == "G":
                laser = {0: "M5", 3: "M3", 4: "M4"}[self.laser_mode_word]
                feed = 0 if math.isnan(self.feed_mm_min) else self.feed_mm_min
                st = self._parser.state
                coolant = " ".join(f"M{m}" for m in st.coolant) or "M9"
                self._emit(f"[GC:G{self.motion} G{self.coord_system} G{self.plane} G{self.units} "
                           f"G{self.distance} G{st.feed_mode} {laser} {coolant} T0 F{self._rate(feed)} "
                           f"S{_grbl_number(self.s_word, 0)}]")
            elif cmd == "X":
                if self.state == "Alarm":
                    self.state, self.alarm_code = "Idle", 0
                    self._emit(grbl_reply(Feedback.ALARM_UNLOCK))
            else:                                       # $C
                if not self.check_mode and (self._blocks or self.state != "Idle"):
                    return ErrorCode.NOT_IDLE
                self.check_mode = not self.check_mode
                self._check_pos = self.pos.copy()
                self._emit(grbl_reply(Feedback.ENABLED if self.check_mode else Feedback.DISABLED))
                if not self.check_mode:
                    # GRBL ends check mode with a soft reset: the line's ok, then the banner
                    # and the start-up lines; what waited in the RX buffer is dropped
                    self._emit(grbl_reply(ErrorCode.OK))
                    self._realtime("reset")
                    return None
            return ErrorCode.OK
        # the rest needs an idle (or alarmed) machine, not in check mode
        if self.check_mode or self.state not in ("Idle", "Alarm") or self._blocks:
            return ErrorCode.NOT_IDLE
        if cmd == "#":
            if rest:
                return ErrorCode.INVALID_STATEMENT
            for k in range(6):
                self._emit(f"[G{54 + k}:{self._coords(self.coord_origins[k])}]")
            st = self._parser.state
            for name, p in (("G28", st.home28), ("G30", st.home30)):
                self._emit(f"[{name}:{self._coords(p)}]")
            self._emit(f"[G92:{self._coords(self.g92)}]")
            self._emit(f"[TLO:{self._coords([self.tool_offset])}]")
            self._emit(self._prb_line())
            return ErrorCode.OK
        if cmd == "H":
            if not self._flag(22):
                return ErrorCode.SETTING_DISABLED       # homing is off ($22=0)
            if rest:                                    # GRBL's default build: no $HX, $HY …
                return ErrorCode.INVALID_STATEMENT
            self._start_homing()
            return None                                 # answered when the cycle ends
        if cmd == "S":
            if rest != "LP":
                return ErrorCode.INVALID_STATEMENT
            self._emit(grbl_reply(ErrorCode.OK))
            self._emit(grbl_reply(Feedback.SLEEPING))
            self.state = "Sleep"
            return None
        if cmd == "I":
            if rest and not rest.startswith("="):
                return ErrorCode.INVALID_STATEMENT
            if rest:
                self.build_info = rest[1:]
                return ErrorCode.OK
            self._emit(f"[VER:1.1h.20190830:{self.build_info}]")
            self._emit(f"[OPT:V,{self.planner_blocks},{self.rx_bytes}]")
            return ErrorCode.OK
        if cmd == "R":
            if rest not in ("ST=$", "ST=#", "ST=*"):
                return ErrorCode.INVALID_STATEMENT
            what = rest[-1]
            if what in "$*":
                self.settings = self._initial_settings(self.machine)
            if what in "#*":
                zero = ((0.0, 0.0, 0.0),) * 3
                self._parser.state = replace(self._parser.state, coord_origins=zero * 2,
                                             home28=zero[0], home30=zero[0])
            if what == "*":
                self.startup_lines = ["", ""]
                self.build_info = ""
            self._emit(grbl_reply(Feedback.RESTORING_DEFAULTS))
            self._emit(grbl_reply(ErrorCode.OK))
            self._realtime("reset")                     # GRBL resets after restoring
            return None
        if cmd == "N" and not rest:
            for k, startup in enumerate(self.startup_lines):
                self._emit(f"$N{k}={startup}")
            return ErrorCode.OK
        verdict = grbl_system_verdict(line)
        if verdict is not None and not (verdict[0] == "soft_limit_error" and self._flag(22)):
            return ErrorCode[verdict[0].upper()]
        number, _, value = line[2 if cmd == "N" else 1:].partition("=")
        key = int(float(number))
        if cmd == "N":
            if self.state != "Idle":
                return ErrorCode.NOT_IDLE
            if value.startswith("$") and key < len(self.startup_lines):
                # GRBL checks a start-up line by running it: one that begins with '$' is a
                # jog from its fourth character on, and its ok waits for the jog's end (GRBL
                # writes the line to EEPROM with its planner empty)
                err = self._gcode(_startup_jog(value), jog=True, text=line)
                if err is not None:
                    return ErrorCode(err)
                self.startup_lines[key] = value
                queue = self._admitting or self._blocks
                if queue:
                    queue[-1].replies = (grbl_reply(ErrorCode.OK),)
                    return None
                return ErrorCode.OK
            if key < len(self.startup_lines) and value:
                # GRBL checks a G-code start-up line by running it: its modes and moves take
                # effect now (the startup_store transcript); it writes the line with its
                # planner empty, so the ok follows the line's moves
                queued = len(self._admitting or self._blocks)
                err = self._gcode(value, jog=False, text=line)
                if err not in (None, _DEFERRED):
                    return None if err == _ALARMED else ErrorCode(err)
                self.startup_lines[key] = value
                queue = self._admitting or self._blocks
                if err == _DEFERRED:                # answered when the line has run
                    return None
                if len(queue) > queued:
                    queue[-1].replies = (grbl_reply(ErrorCode.OK),)
                    return None
                return ErrorCode.OK
            if key < len(self.startup_lines):
                self.startup_lines[key] = value
            elif key == len(self.startup_lines):    # GRBL's EEPROM: the build info's place
                self.build_info = ""
            return ErrorCode.OK
        self.settings[key] = _setting_text(key, float(value))
        if key == 13:
            self._wco_counter = 0                       # GRBL: WCO at once, in the new unit
        if key == 22 and not float(value):
            self.settings[20] = "0"                     # GRBL: homing off forces soft limits off
        return ErrorCode.OK

    def _gcode(self, line: str, *, jog: bool, text: str | None = None) -> int | None:
        """Interpret one line (as GRBL's reader keeps it) after the modal state and queue its
        blocks; ``text`` is the line as received, for :attr:`executed`.

        Returns None (accepted), an error code, or ``_ALARMED``.
        """
        text = line if text is None else text
        # the parser works at the end of what is queued, not where the machine is now
        base = self._blocks[-1].end if self._blocks else self.pos
        if self.check_mode:
            base = self._check_pos
        before = self._parser.state
        if not np.array_equal(before.position, base):   # moved under the parser: a stop, $H
            before = replace(before, position=tuple(float(v) for v in base))
            self._parser.state = before
        moves, error = self._parser.feed(line)
        if error is not None:
            return error.code
        after = self._parser.state
        new_pos = np.array(after.position, float)
        # soft limits ($20, GRBL: off by default) in GRBL's machine space, −$13x…0: a jog's
        # target (error:15), or each straight piece a line's motion is cut into as GRBL plans
        # it (G28's via point, arc chords): the pieces before the first outside are planned
        outside_at = None
        if self._flag(20):
            if jog:
                if self._outside_travel(new_pos):
                    self._parser.state = before
                    return ErrorCode.TRAVEL_EXCEEDED
            elif len(moves):
                chords = expand_arcs(moves, float(self.settings[12]))
                ends = np.asarray(chords.end, float)[:, :3]
                travel = np.array([float(self.settings[130 + a]) for a in range(3)])
                out = chords.is_motion & ((ends > 1e-6) | (ends < -travel - 1e-6)).any(axis=1)
                if out.any():
                    outside_at = int(np.argmax(out))
        if outside_at is not None:
            return self._soft_limit(moves, outside_at, base, text, before)
        self.lines_accepted += 1
        if not jog:
            self._report_events(line, before, after)
        if self.check_mode:
            # GRBL's check mode moves nothing but keeps the parser's state: G10 L2/L20, G28.1
            # and G30.1 are written to EEPROM (they outlast the reset that ends check mode)
            self._check_pos = new_pos
            if any(r.kind == "end" for r in moves.records):
                self._emit(grbl_reply(Feedback.PROGRAM_END))
            return None
        n_word = -1
        head = line
        if head.startswith("N"):
            digits = "".join(c for c in head[1:].split(" ")[0] if c.isdigit())
            n_word = int(digits) if digits else -1
        new = self._blocks_of(moves, base, text, n_word, jog)
        kinds = {r.kind for r in moves.records}
        if "probe" in kinds:                 # G38.x: its ok waits for the probe cycle's end
            for b in new:
                b.probe = int(after.motion)
        deferred = not jog and (bool(kinds & {"pause", "end"})
                                or any(b.is_dwell or b.probe for b in new))
        if deferred:
            if "pause" in kinds or "end" in kinds or not new:
                # a stop of no time at the end of the queue: it holds (M0) or answers (M2, M30)
                # once the moves before it have run
                new.append(_Block(self.lines_accepted, n_word, text, np.array(base, float),
                                  np.array(base, float), 0.0, 0.0, 0.0, False,
                                  is_dwell=True, pause="pause" in kinds))
            new[-1].replies = ((grbl_reply(Feedback.PROGRAM_END),) if "end" in kinds else ()) + (
                grbl_reply(ErrorCode.OK),)
        self._admitting.extend(new)
        self._admit()
        if not jog:
            if new:                                      # the level the last block leaves
                last = new[-1]
                self._rest_level = last.power if last.constant else 0.0
            else:                                        # GRBL syncs the spindle/laser state
                lit = self.laser_mode_word == 3 and self.motion in (1, 2, 3)
                self._rest_level = self._beam_fraction(3, self.s_word) if lit else 0.0
        if not jog and "end" in kinds:
            self.overrides = (100, 100, 100)         # GRBL's RESTORE_OVERRIDES_AFTER_PROGRAM_END
        return _DEFERRED if deferred else None

    def _report_events(self, line: str, before: ModalState, after: ModalState) -> None:
        """What a line GRBL accepted does to the status report's refresh counters (gcode.c):
        the WCO: counter is set to 0 by a change of coordinate system, a G10 L2/L20 of the
        active one, G92 and G92.1, a new tool length offset and M2/M30; the Ov: counter by
        what switches the spindle/laser or the coolant output (not in check mode, where
        GRBL drives no output): a new M3/M4/M5 or M8/M9, a new S while the spindle is on
        (in laser mode not on a motion line, which carries its power with it), M3's
        laser switching between a G1-G3 mode and another at rest, and M2/M30."""
        values = {k: set(v) for k, v in (grbl_words(line) or {}).items()}   # an accepted line reads
        g, m = values.get("G", set()), values.get("M", set())
        end = bool(m & {2.0, 30.0})
        systems = {w for w in g if 54.0 <= w <= 59.0 and w == int(w)}
        wco = bool(systems and int(systems.pop()) != before.coord_system)
        if 10.0 in g and values.get("L", set()) & {2.0, 20.0}:
            p = int(min(values.get("P", {0.0})))
            wco |= (p == 0 or 53 + p == after.coord_system)
        wco |= bool(g & {92.0, 92.1}) or after.tool_offset != before.tool_offset
        if end and not self.check_mode:
            wco = True
        if wco:
            self._wco_counter = 0
        if self.check_mode:
            return
        self._flood = 8 in after.coolant
        laser_mode = self._flag(32)
        motion_line = is_motion_line(values)
        cutting = (1, 2, 3)
        force = (laser_mode and not motion_line and before.laser == 3
                 and (before.motion in cutting) != (after.motion in cutting))
        s_sync = ((after.s_word != before.s_word or force) and before.laser != 5
                  and not (laser_mode and motion_line))
        if (end or s_sync or after.laser != before.laser or after.coolant != before.coolant):
            self._ovr_counter = 0

    def _waits_for_sync(self, text: str) -> bool:
        """Whether GRBL runs this line only once its planner is empty (its
        protocol_buffer_synchronize): a new M3/M4/M5 (or a new S while the spindle is on, but
        for a laser-mode motion line, whose power rides with its moves), a new M8/M9, a G10
        L2/L20, G28.1 or G30.1 (EEPROM writes), a new coordinate system, G92 or G92.1, a new
        tool length offset, and a probe move (G38.2-G38.5). G4, M0, M2 and M30 wait too, as
        blocks of their own. A line GRBL refuses waits for nothing: its error comes at once."""
        if self._sync_verdict[0] == text:
            return self._sync_verdict[1]
        line, overflow = _grbl_line(text)
        verdict, self._wco_preview = False, None
        reasons = set()
        if not (overflow or not line or line.startswith("$") or self.check_mode
                or self.state in ("Alarm", "Jog")):
            reasons = self._sync_reasons(line)
        if reasons:
            saved = self._parser.state           # a trial parse: does GRBL accept it?
            _, error = self._parser.feed(line)
            after, self._parser.state = self._parser.state, saved
            verdict = error is None
            # GRBL sets a new tool offset, coordinate system or G92 first and then waits: a
            # report meanwhile shows the new WCO (unless an earlier wait in the line comes first)
            if verdict and reasons == {"wco"}:
                self._wco_preview = after.work_offset
        self._sync_verdict = (text, verdict)
        return verdict

    def _sync_reasons(self, line: str) -> set:
        """GRBL's planner-sync rules for ``line`` from the parser's state
        (:func:`labkit.gcode.state.grbl_sync_reasons`, with this machine's ``$32``), and a
        program end (M2, M30), whose reset of the modal state GRBL makes only once the moves
        before it have ended (the program_end_moving transcript)."""
        reasons = grbl_sync_reasons(line, self._parser.state, laser_mode=self._flag(32))
        words = grbl_words(line) or {}
        if {2.0, 30.0} & set(words.get("M", ())):
            reasons.add("end")
        return reasons

    def _soft_limit(self, moves, outside_at: int, base, text: str, before) -> int:
        """GRBL's soft limit (limits_soft_check) at the line's piece ``outside_at``: the pieces
        before it are planned; a running cycle brakes to a stop along the queued path (a feed
        hold: Hold:1) and only then comes ALARM:2, the reset message and the critical-event
        lock; from rest the alarm comes at once. The line's ok waits for the reset."""
        self._parser.state = before                   # GRBL resets: the parser starts afresh
        pieces = self._blocks_of(moves, base, text, -1, False, limit=outside_at)
        if self.state == "Run" and (self._blocks or pieces):
            self._blocks.extend(pieces[:max(0, self.planner_blocks - len(self._blocks))])
            self._soft_limit_braking = True
            self.state, self.substate = "Hold", 1
            self._hold_v = self._current_speed()
            return _ALARMED
        self._critical_alarm(AlarmCode.SOFT_LIMIT)
        return _ALARMED

    def _admit(self) -> bool:
        """Move the blocks of the line GRBL is in into the planner while it has room (GRBL's
        mc_line waits for a free block, chord by chord for an arc); once the last is in, the
        line's replies go out. False while some still wait."""
        if not self._admitting:
            return True
        jog = self._admitting[0].text.startswith("$J=")
        before = len(self._blocks)
        while self._admitting and len(self._blocks) < self.planner_blocks:
            self._blocks.append(self._admitting.popleft())
        if self._admitting and not self._blocks:
            self._blocks.append(self._admitting.popleft())   # a planner of no depth still moves
        starved = False
        if len(self._blocks) > before:
            if self._dry_since is not None:
                if self._sim_t > self._dry_since:          # the planner stood empty for this line
                    self.starvations.append(Starvation(self._dry_since, self.lines_run,
                                                       self._sim_t - self._dry_since))
                    starved = True
                self._dry_since = None
            if self.state == "Idle":
                self.state = "Jog" if jog else "Run"
        self._note_short_queue(before, starved)
        if self._admitting:
            return False
        replies, self._admit_replies = self._admit_replies, ()
        for reply in replies:
            self._emit(reply)
        return True

    def _answer(self, reply: str) -> None:
        """A line's answer: now, or once its last block has entered the planner."""
        if self._admitting:
            self._admit_replies += (reply,)
        else:
            self._emit(reply)

    def _blocks_of(self, moves, base, text: str, n_word: int, jog: bool,
                   limit: int | None = None) -> list:
        """A line's moves as the blocks GRBL plans: arcs cut into ``$12`` chords, a move of no
        step dropped (GRBL plans no block for it), a dwell as a block of its own; with
        ``limit``, only the pieces before that one (a soft limit stops the line there)."""
        chords = expand_arcs(moves, float(self.settings[12]))
        rows = build_blocks(chords, self.machine).with_rest(self.machine, "accel")
        out = []
        for r in range(len(rows)):
            i = int(rows.move[r])
            if limit is not None and i >= limit:
                break
            a, b = chords.start[i].astype(float), chords.end[i].astype(float)
            if int(rows.kind[r]) == 4:                 # dwell: standing still at the beam's level
                out.append(_Block(self.lines_accepted, n_word, text, a, a, 0.0,
                                  float(rows.dwell_s[r]), self._rest_level, False, is_dwell=True,
                                  constant=True))
                continue
            rapid = bool(rows.rapid[r])
            beam = 0.0 if rapid else self._beam_fraction(int(chords.laser[i]), float(chords.s_word[i]))
            out.append(_Block(self.lines_accepted, n_word, text, a, b, float(rows.cap_mm_s[r]), 0.0,
                              beam, rapid, accel_mm_s2=float(rows.accel_mm_s2[r]),
                              constant=int(chords.laser[i]) == 3 and not rapid, row=rows[r],
                              length_mm=float(rows.length_mm[r])))
        if limit is not None:
            return out
        # the parser's end: a last move too short for a step still moves the position GRBL's
        # parser holds (the next block's steps are counted from it)
        end = np.array(moves.end[-1], float) if len(moves) else np.asarray(base, float)
        if out and not out[-1].is_dwell:
            out[-1].end = end
        elif not out and len(moves) and not np.array_equal(end, base):
            if self._blocks:
                self._blocks[-1].end = end
            else:
                self.pos = end.copy()
        return out

    def _start_block(self, b: "_Block") -> None:
        """Time the head block as it starts, with labkit.motion's junction-deviation planner
        (:func:`labkit.motion.lookahead`, as ``labkit plan --planner junction``) over the
        blocks queued now: its exit is the highest speed from which the queue behind it can
        still stop at its end and its entry (the current speed) can reach, then fixed while it
        runs. Planning the head again at every push would give the same head: only the
        running block's exit is ever executed from a plan, so a streamed job that keeps the
        planner full runs in the time :func:`labkit.motion.plan` gives the whole job."""
        b.started = True
        if b.is_dwell:
            self._speed = 0.0
            return
        feed_ov, rapid_ov, power_ov = self.overrides
        if not b.rapid:
            b.power = min(1.0, b.power * power_ov / 100.0)
        run = []
        for q in self._blocks:                      # the motion up to a dwell (a full stop)
            if q.is_dwell:
                break
            run.append(q)
        rows = Blocks.concat([q.row for q in run])
        # overrides scale the programmed rates (GRBL re-plans its queue with them)
        cap = np.where(rows.rapid, rows.limit_mm_s * rapid_ov / 100.0,
                       np.minimum(rows.feed_mm_s * feed_ov / 100.0, rows.limit_mm_s))
        # the step timer's slowest speed, which a dip must go below to show (GRBL plans from 0)
        timer_floor = np.minimum(rows.speed_at_rate(self.machine.start_rate_hz), cap)
        rows = replace(rows, cap_mm_s=cap, rest_mm_s=np.minimum(rows.rest_mm_s, cap))
        up = rows.accel_mm_s2.copy()
        up[0] = 1e30        # the head ramps from its real entry below; the plan gives the limit behind
        la = lookahead(rows, planner="junction", law="accel", buffer_blocks=self.planner_blocks,
                       junction_deviation_mm=float(self.settings[11]),
                       axis_accel_mm_s2=self.machine.accel_mm_s2, up=up, down=rows.accel_mm_s2)
        acc, top, length = float(rows.accel_mm_s2[0]), float(cap[0]), b.length_mm
        floor = min(float(rows.rest_mm_s[0]), top)
        entry = min(max(self._speed, floor), top)
        v_out = min(float(la.speed_mm_s[1]), float(reach_speed(entry, length, acc, "accel")))
        # an override lowered since the entry was planned: brake as hard as the block allows
        v_out = max(v_out, math.sqrt(max(0.0, entry * entry - 2.0 * acc * length)))
        self._short_since = self._sim_t if self._queue_short(b, run, rows, float(timer_floor[-1]),
                                                             float(la.speed_mm_s[1]),
                                                             min(top, reach_speed(entry, length, acc, "accel"))) else None
        b.speed_mm_s = top
        b.exit_mm_s = v_out
        b.duration_s = float(block_profiles(length, entry, top, max(v_out, floor), acc, acc,
                                            "accel").time_s[0]) if length > 0 else 0.0


    # ---- short queues (issue 30 §2): kept apart from the rest, one call in, one out
    def _queue_short(self, b, run, rows, floor: float, v_exit: float, v_own: float) -> bool:
        """Whether the head ``b`` leaves slower than it would with more queued: its exit
        ``v_exit`` (planned over ``run``, the queue up to a dwell) is what the blocks behind
        it let it shed by the queue's end, from rest, and ``v_own``, what its own cap and
        length allow, is above what they let it shed from ``floor``, the last block's speed
        at the step timer's slowest rate (a dip below it cannot show: the steps run at it)
        (:func:`labkit.motion.stall.short_queues`).
        Not when the planner is full, the queue ends at a dwell, or ``b`` is a job's first."""
        if b is self._into_empty or len(run) != len(self._blocks) or len(run) >= self.planner_blocks:
            return False
        shed = float(np.sum(2.0 * rows.accel_mm_s2[1:] * rows.length_mm[1:]))
        binds = v_exit >= math.sqrt(float(rows.rest_mm_s[-1]) ** 2 + shed) * (1 - 1e-9)
        return binds and v_own * (1 - 1e-9) > max(v_exit, math.sqrt(floor ** 2 + shed))

    def _note_short_queue(self, queued: int, starved: bool) -> None:
        """A line's blocks were queued behind ``queued`` others (``starved``: after a
        starvation): if the running block started short (:meth:`_queue_short`), the line came
        that long after its start. The first block into an empty planner that did not starve
        (a job's first, on a fresh machine) or that a line waiting for an empty planner (an
        M3/M4/M5 change, G92, ...) emptied is not counted: nothing could be behind it, at any
        feed."""
        added = len(self._blocks) > queued
        if added and self._blocks[queued].is_dwell:
            self._short_since = None    # G4, M0, M2, M30: GRBL syncs, the head stops there anyway
        if added and queued == 0 and (not starved or self._synced):
            self._into_empty = self._blocks[0]
        if added:
            self._synced = False
        if added and self._short_since is not None:
            if self._sim_t > self._short_since:
                self.short_queues.append(Starvation(self._short_since, self.lines_run,
                                                    self._sim_t - self._short_since))
            self._short_since = None


def burn_coverage(moves, vm: VirtualMachine, *, tol_mm: float = 1e-3, origin_mm=(0.0, 0.0)):
    """How often each burning move of a job was burned by the virtual machine.

    Every piece of motion the machine executed with the beam on is laid onto
    the job's burning straight moves (within ``tol_mm`` of the line).
    ``origin_mm`` is the work offset (XY, mm) the controller held when the job
    started — the job's own coordinates are relative to it.

    Returns
    -------
    covered : ndarray
        Burned length on each burning move, mm (equal to its length when burned fully).
    doubled : ndarray
        Length burned more than once on each burning move, mm.
    stray_mm : float
        Burned length on none of the job's moves.
    lengths : ndarray
        Length of each burning move, mm.
    """
    on = np.flatnonzero(moves.laser_on & ~moves.is_arc)
    shift = np.asarray(origin_mm, float)[:2]
    segments = [(moves.start[i, :2] + shift, moves.end[i, :2] + shift) for i in on]
    pieces = [(np.array(p.start[:2]), np.array(p.end[:2])) for p in vm.executed
              if p.power > 0 and not p.rapid and p.start != p.end]
    covered = np.zeros(len(segments))
    doubled = np.zeros(len(segments))
    lengths = np.array([float(np.linalg.norm(b - a)) for a, b in segments])
    used = np.zeros(len(pieces), bool)
    for k, (a, b) in enumerate(segments):
        if lengths[k] == 0:
            continue
        u = (b - a) / lengths[k]
        n = np.array([-u[1], u[0]])
        spans = []
        for j, (p, q) in enumerate(pieces):
            if abs(np.dot(p - a, n)) > tol_mm or abs(np.dot(q - a, n)) > tol_mm:
                continue
            s0, s1 = sorted((float(np.dot(p - a, u)), float(np.dot(q - a, u))))
            s0, s1 = max(s0, 0.0), min(s1, lengths[k])
            if s1 - s0 > 1e-12:
                spans.append((s0, s1))
                used[j] = True
        reach = 0.0
        for s0, s1 in sorted(spans):
            if s0 < reach - tol_mm:
                doubled[k] += min(reach, s1) - s0
            covered[k] += max(0.0, s1 - max(s0, reach))
            reach = max(reach, s1)
    stray = float(sum(np.linalg.norm(q - p) for (p, q), u_ in zip(pieces, used) if not u_))
    return covered, doubled, stray, lengths
