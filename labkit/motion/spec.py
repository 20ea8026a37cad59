"""Machine description: what the motion reference needs to know about a machine.

A :class:`MachineSpec` holds the mechanics (steps per mm, maximum rates,
accelerations, travel), the controller settings the planners use ([CBR40]'s
ramp slopes in Hz per step, GRBL's junction deviation, the look-ahead depth),
the laser (maximum optical power, the S value of full power) and the step
timer (clock, prescaler, width). It is frozen; :meth:`MachineSpec.replace` makes a
changed copy. Descriptions live as small TOML files in ``labkit/motion/machines/`` and
load with :func:`load_machine`.

The default, :data:`CBR40`, is [CBR40]'s machine: a Colinbus CBR-40 frame
whose lead screws advance 3 mm per turn, driven at 1/32 microstep (6400 steps
per turn: 0.46875 µm per step), 300 × 400 × 100 mm of travel, at most
1546.0875 mm/min (54 972 steps/s), a 2500 mW diode laser and a 48 MHz step
timer. [CBR40] gives neither ramp slopes nor accelerations nor a prescaler;
the values here are chosen (and said so in ``labkit/motion/machines/README.md``).
"""

from __future__ import annotations

import dataclasses
import math
import os
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from labkit.errors import MotionError

__all__ = ["MachineSpec", "CBR40", "AXES", "load_machine", "machine_files", "MACHINES_DIR", "check_job_fits"]

#: Axis names in column order.
AXES = ("x", "y", "z")

#: Folder of the machine description files shipped with the repository.
# Shipped inside the package (package data), so a wheel install finds them too.
MACHINES_DIR = Path(__file__).resolve().parent / "machines"


def _triple(name: str, value) -> tuple[float, float, float]:
    arr = np.broadcast_to(np.asarray(value, dtype=float), (3,))
    return tuple(float(v) for v in arr)


#: GRBL settings a machine description gives through its own fields ($11, $12, $100-$132).
_GRBL_FROM_FIELDS = {11: "junction_deviation_mm", 12: "arc_tolerance_mm",
                     **{100 + a: "steps_per_mm" for a in range(3)},
                     **{110 + a: "max_rate_mm_min" for a in range(3)},
                     **{120 + a: "accel_mm_s2" for a in range(3)},
                     **{130 + a: "travel_mm" for a in range(3)}}


def _grbl_settings(machine: str, value) -> tuple:
    """``grbl_settings`` as sorted ``(N, number)`` pairs; a dict (from TOML) or pairs."""
    items = value.items() if isinstance(value, dict) else value
    out = {}
    try:
        pairs = [(k, v) for k, v in items]
    except (TypeError, ValueError):
        raise MotionError(f"machine {machine!r}: grbl_settings must map setting numbers to "
                          f"values, e.g. {{32 = 1}}; got {value!r}") from None
    for key, v in pairs:
        text = str(key).lstrip("$")
        if not text.isdigit():
            raise MotionError(f"machine {machine!r}: grbl_settings key {key!r} is not a GRBL "
                              f"setting number (expected e.g. 32 for $32)")
        number = int(text)
        if number in _GRBL_FROM_FIELDS:
            raise MotionError(f"machine {machine!r}: grbl_settings gives ${number}, which the "
                              f"description's {_GRBL_FROM_FIELDS[number]} already says")
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise MotionError(f"machine {machine!r}: grbl_settings ${number} must be a finite "
                              f"number, got {v!r}")
        out[number] = v
    return tuple(sorted(out.items()))


#: Whether the labkit firmware waits for its planner to empty at a change of M3/M4/M5 (GRBL
#: does, :attr:`MachineSpec.laser_change_syncs`): in its grbl dialect, yes (``firmware/src/gcode.c``
#: waits before it commits the line, as for a new S alone, M8/M9 and the offsets; the motion stops
#: there); its labkit-fw dialect keeps power in the step stream. The one place that says it: the
#: firmware's machine descriptions take it as their default, and the paced simulator's tests
#: (grbl dialect) read it.
FIRMWARE_LASER_CHANGE_SYNCS = True


@dataclass(frozen=True)
class MachineSpec:
    """A laser CNC machine as the motion planner sees it.

    Parameters
    ----------
    name : str
        Short name (the file stem of its description).
    steps_per_mm : float or sequence of 3 floats
        Steps per mm of X, Y, Z (microsteps per turn / lead in mm).
    max_rate_mm_min : float or sequence of 3 floats
        Highest speed of each axis, mm/min (GRBL ``$110…$112``).
    accel_mm_s2 : float or sequence of 3 floats
        Acceleration of each axis, mm/s² (GRBL ``$120…$122``); used by the
        constant-acceleration ramp law and by junction speeds.
    travel_mm : float or sequence of 3 floats
        Length of each axis, mm.
    accel_hz_per_step, decel_hz_per_step : int
        [CBR40]'s ramp slopes: the driver axis' step rate rises (falls) by
        this many Hz per step, ≥ 1.
    start_rate_hz : int
        Slowest step rate of the driver axis, Hz: the step timer never times a
        tick slower (the floor of every step rate). It is also the rate the
        planner starts and stops the motors at without a ramp (the rest speed),
        unless ``rest_at_zero`` says otherwise.
    rest_at_zero : bool
        True when the controller's planner starts and stops its constant-acceleration
        ramps at speed 0 (GRBL: its minimum junction speed is 0), the step timer still
        ticking no slower than ``start_rate_hz``; False (default) when it plans from and
        to the start rate (the labkit firmware, [CBR40]). [CBR40]'s linear ramps (Hz
        per step) always rest at the start rate: they cannot start from 0.
    junction_deviation_mm : float
        GRBL ``$11``: how far the path may deviate at a corner, mm (> 0).
    arc_tolerance_mm : float
        GRBL ``$12``: chord tolerance when arcs are cut into lines, mm (> 0).
    buffer_blocks : int
        Look-ahead depth: planner buffer (GRBL: 16) or super block size
        ([LaserApp]'s ``G5 P``), ≥ 1.
    laser_max_power_mw : float
        Optical power at full duty, mW ([CBR40]: 2500 mW). The S word of
        full power belongs to the program (``Moves.s_max``, set by the dialect).
    timer_clock_hz : int
        Step timer input clock, Hz ([CBR40]: 48 MHz).
    prescaler : int
        Timer prescaler register: the timer counts at clock / (prescaler + 1).
    timer_bits : int
        Width of the period register (16 or 32).
    step_pulse_us : float
        Width of each step pulse, µs ([CBR40]: 5 µs); the fastest tick must
        hold the pulse high and as long low.
    grbl_settings : mapping of int to number
        The GRBL settings (``$N``) the machine's controller holds where they
        differ from GRBL 1.1's defaults, other than those the fields above give
        (``$11``, ``$12``, ``$100``–``$132``): e.g. ``{32: 1}``, laser mode. The
        virtual machine starts with them. Kept as sorted ``(N, value)`` pairs.
    link_baud : int
        Serial link speed, bits per second (115200 for GRBL and the labkit
        firmware).
    link_bits_per_byte : int
        Bits on the wire per byte: 10 for 8N1 (a start bit, 8 data bits, a stop
        bit), so 115200 baud carries 11,520 bytes/s.
    rx_buffer_bytes : int
        The controller's serial receive buffer, bytes: the window a
        character-counting sender fills (GRBL 1.1: 128, ``$I``'s
        ``[OPT:V,15,128]``; the labkit firmware: ``SERIAL_RX_SIZE``, 128).
    planner_blocks : int
        Blocks the controller's planner holds, the running one included (GRBL 1.1
        on a 328P: 15 usable, ``$I``'s ``[OPT:V,15,128]``; the labkit firmware:
        ``PLAN_BUFFER_SIZE`` in ``firmware/src/config.h``, 36).
    block_parse_s : float
        Time the controller takes to parse and plan one line, s (≥ 0). The
        labkit firmware's default is the host simulator's, measured
        (``labkit/motion/machines/README.md``); GRBL's is a 328P estimate whose
        source that README gives.
    waits_for_lookahead : bool
        True when the controller starts a block only once its whole look-ahead
        window (``buffer_blocks`` more blocks) has arrived or the stream has
        gone quiet (the labkit firmware); False when it runs whatever its
        planner holds (GRBL). Decides where a slow link makes it stop.
    laser_change_syncs : bool
        True when a line that changes the laser state (M3, M4, M5) waits for the planner
        to empty and the motion to end before it runs and is answered (GRBL 1.1's
        ``spindle_sync``, laser mode included): the motion stops there and the planner
        starts again from one block. Default :data:`FIRMWARE_LASER_CHANGE_SYNCS`, the
        labkit firmware's.
    description : str
        One line for people.

    Examples
    --------
    >>> CBR40.steps_per_mm[0], round(CBR40.resolution_um[0], 5)
    (2133.3333333333335, 0.46875)
    >>> CBR40.max_step_rate_hz
    (54972, 54972, 54972)
    >>> CBR40.replace(prescaler=3).tick_hz
    12000000.0
    >>> CBR40.link_bytes_per_s          # 115200 baud, 8N1
    11520.0
    """

    name: str = "cbr40-laser"
    steps_per_mm: tuple[float, float, float] = (6400 / 3,) * 3
    max_rate_mm_min: tuple[float, float, float] = (1546.0875,) * 3
    accel_mm_s2: tuple[float, float, float] = (500.0,) * 3
    travel_mm: tuple[float, float, float] = (300.0, 400.0, 100.0)
    accel_hz_per_step: int = 40
    decel_hz_per_step: int = 40
    start_rate_hz: int = 1000
    junction_deviation_mm: float = 0.01
    arc_tolerance_mm: float = 0.002
    buffer_blocks: int = 16
    laser_max_power_mw: float = 2500.0
    timer_clock_hz: int = 48_000_000
    prescaler: int = 0
    timer_bits: int = 16
    step_pulse_us: float = 5.0
    grbl_settings: tuple = ()
    link_baud: int = 115_200
    link_bits_per_byte: int = 10
    rx_buffer_bytes: int = 128
    planner_blocks: int = 36
    block_parse_s: float = 20e-6
    waits_for_lookahead: bool = True
    laser_change_syncs: bool = FIRMWARE_LASER_CHANGE_SYNCS
    rest_at_zero: bool = False
    description: str = dataclasses.field(default="", compare=False)

    def __post_init__(self):
        set_ = object.__setattr__
        for name in ("steps_per_mm", "max_rate_mm_min", "accel_mm_s2", "travel_mm"):
            vals = _triple(name, getattr(self, name))
            if not all(v > 0 and math.isfinite(v) for v in vals):
                raise MotionError(f"machine {self.name!r}: {name} must be > 0 and finite "
                                  f"for every axis, got {vals}")
            set_(self, name, vals)
        for name in ("accel_hz_per_step", "decel_hz_per_step", "start_rate_hz",
                     "buffer_blocks", "timer_clock_hz", "prescaler", "timer_bits",
                     "link_baud", "link_bits_per_byte", "rx_buffer_bytes", "planner_blocks"):
            v = getattr(self, name)
            if isinstance(v, float) and v.is_integer():
                v = int(v)
            if not isinstance(v, (int, np.integer)) or isinstance(v, bool):
                raise MotionError(f"machine {self.name!r}: {name} must be an integer, got {v!r}")
            set_(self, name, int(v))
        checks = [
            ("accel_hz_per_step", self.accel_hz_per_step >= 1, ">= 1 Hz per step"),
            ("decel_hz_per_step", self.decel_hz_per_step >= 1, ">= 1 Hz per step"),
            ("start_rate_hz", self.start_rate_hz >= 1, ">= 1 Hz"),
            ("buffer_blocks", self.buffer_blocks >= 1, ">= 1 block"),
            ("junction_deviation_mm", self.junction_deviation_mm > 0, "> 0 mm"),
            ("arc_tolerance_mm", self.arc_tolerance_mm > 0, "> 0 mm"),
            ("laser_max_power_mw", self.laser_max_power_mw > 0, "> 0 mW"),
            ("timer_clock_hz", self.timer_clock_hz >= 1, ">= 1 Hz"),
            ("prescaler", 0 <= self.prescaler < 2 ** 16, "in 0…65535"),
            ("timer_bits", self.timer_bits in (16, 32), "16 or 32"),
            ("step_pulse_us", self.step_pulse_us > 0, "> 0 µs"),
            ("link_baud", self.link_baud >= 1, ">= 1 baud"),
            ("link_bits_per_byte", 7 <= self.link_bits_per_byte <= 12, "7…12 bits (8N1: 10)"),
            ("rx_buffer_bytes", self.rx_buffer_bytes >= 82,
             ">= 82 bytes (an 80-character line, its newline and one free slot)"),
            ("planner_blocks", self.planner_blocks >= 1, ">= 1 block"),
            ("block_parse_s", isinstance(self.block_parse_s, (int, float))
             and not isinstance(self.block_parse_s, bool)
             and math.isfinite(self.block_parse_s) and self.block_parse_s >= 0, ">= 0 s and finite"),
        ]
        for name in ("rest_at_zero", "waits_for_lookahead", "laser_change_syncs"):
            if not isinstance(getattr(self, name), (bool, np.bool_)):
                raise MotionError(f"machine {self.name!r}: {name} must be true or false, "
                                  f"got {getattr(self, name)!r}")
            set_(self, name, bool(getattr(self, name)))
        set_(self, "grbl_settings", _grbl_settings(self.name, self.grbl_settings))
        for name, ok, allowed in checks:
            if not ok:
                raise MotionError(f"machine {self.name!r}: {name} must be {allowed}, "
                                  f"got {getattr(self, name)!r}")
        top = max(self.max_step_rate_hz)
        if self.start_rate_hz > top:
            raise MotionError(f"machine {self.name!r}: start_rate_hz ({self.start_rate_hz} Hz) "
                              f"exceeds the fastest axis step rate ({top} Hz)")
        # The slowest step rate must fit the period register (see labkit.motion.timer).
        longest = -(-self.timer_clock_hz // (self.start_rate_hz * (self.prescaler + 1))) - 1
        if longest > 2 ** self.timer_bits - 1:
            raise MotionError(
                f"machine {self.name!r}: start_rate_hz {self.start_rate_hz} Hz needs a timer "
                f"period of {longest} ticks, more than a {self.timer_bits}-bit register holds; "
                f"raise the prescaler or start_rate_hz")
        if 2e-6 * self.step_pulse_us * top > 1.0:
            raise MotionError(f"machine {self.name!r}: {self.step_pulse_us:g} µs step pulses do not fit "
                              f"twice in a tick at {top} Hz; shorten the pulse or lower max_rate_mm_min")
        if top * (self.prescaler + 1) > self.timer_clock_hz:
            raise MotionError(f"machine {self.name!r}: the timer ({self.tick_hz:g} Hz) is slower "
                              f"than the fastest step rate ({top} Hz); lower the prescaler")

    # -- derived values ------------------------------------------------------------------

    @property
    def resolution_um(self) -> tuple[float, float, float]:
        """Distance of one step per axis, µm ([CBR40] eq. 1: lead / steps per turn)."""
        return tuple(1000.0 / s for s in self.steps_per_mm)

    @property
    def max_rate_mm_s(self) -> np.ndarray:
        """Maximum axis speeds, mm/s (array of 3)."""
        return np.asarray(self.max_rate_mm_min) / 60.0

    @property
    def max_step_rate_hz(self) -> tuple[int, int, int]:
        """Fastest step rate of each axis, Hz (floor of max rate × steps per mm)."""
        return tuple(int(math.floor(r / 60.0 * s + 1e-9))
                     for r, s in zip(self.max_rate_mm_min, self.steps_per_mm))

    @property
    def tick_hz(self) -> float:
        """Counting rate of the step timer, Hz: clock / (prescaler + 1)."""
        return self.timer_clock_hz / (self.prescaler + 1)

    def rest_rate_hz(self, law: str) -> int:
        """Driver step rate the planner starts and stops the motors at under a ramp law, Hz:
        0 for constant acceleration (``"accel"``) on a machine whose planner rests at zero
        (:attr:`rest_at_zero`), else :attr:`start_rate_hz`.

        >>> CBR40.rest_rate_hz("accel"), CBR40.replace(rest_at_zero=True).rest_rate_hz("accel")
        (1000, 0)
        >>> CBR40.replace(rest_at_zero=True).rest_rate_hz("linear")     # a Hz-per-step ramp needs a start
        1000
        """
        return 0 if self.rest_at_zero and law == "accel" else self.start_rate_hz

    @property
    def link_bytes_per_s(self) -> float:
        """Bytes the serial link carries per second: baud / bits per byte (115200 8N1: 11,520)."""
        return self.link_baud / self.link_bits_per_byte

    def replace(self, **changes) -> "MachineSpec":
        """A copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict:
        """Every field as plain Python values (the TOML keys)."""
        return dataclasses.asdict(self)


#: [CBR40]'s machine (Colinbus CBR-40 frame, 6400 steps per 3 mm lead, 2500 mW laser).
CBR40 = MachineSpec(description="Colinbus CBR-40 frame with a 2500 mW diode laser ([CBR40])")

_FIELDS = {f.name for f in dataclasses.fields(MachineSpec)}


def machine_files() -> list[Path]:
    """The machine descriptions in ``labkit/motion/machines/`` (sorted)."""
    return sorted(MACHINES_DIR.glob("*.toml")) if MACHINES_DIR.is_dir() else []


def load_machine(source: str | Path | MachineSpec | None = None) -> MachineSpec:
    """Read a machine description.

    Parameters
    ----------
    source : str, Path, Machine or None
        A TOML file, or the stem of a file in ``labkit/motion/machines/``
        (``"cbr40-laser"``), or a :class:`MachineSpec` (returned as is).
        ``None`` gives :data:`CBR40`.

    Returns
    -------
    MachineSpec

    Raises
    ------
    MotionError
        Unknown name, unreadable TOML, unknown keys or bad values — the
        message names the file and the key.

    Notes
    -----
    The file is flat or grouped in tables; table names are ignored, keys are
    the :class:`MachineSpec` field names. ``steps_per_mm`` may be given instead as
    ``steps_per_rev`` and ``lead_mm`` ([CBR40] eq. 1: steps per mm = steps
    per turn / lead). A scalar applies to all three axes.

    Examples
    --------
    >>> load_machine("cbr40-laser") == CBR40
    True
    """
    if source is None:
        return CBR40
    if isinstance(source, MachineSpec):
        return source
    if not isinstance(source, (str, os.PathLike)):
        raise MotionError(f"machine must be a MachineSpec, a machine's name or a TOML file, "
                          f"got {type(source).__name__}")
    path = Path(source)
    if not path.suffix and not path.exists():
        candidate = MACHINES_DIR / f"{source}.toml"
        if not candidate.exists():
            names = ", ".join(p.stem for p in machine_files()) or "none"
            raise MotionError(f"unknown machine {str(source)!r}: give a TOML file or one of: {names}")
        path = candidate
    try:
        data = tomllib.loads(path.read_text("utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise MotionError(f"{path}: not valid TOML ({exc})") from None
    flat: dict = {}
    for key, value in data.items():
        if isinstance(value, dict) and key != "grbl_settings":     # a table only groups keys
            for k, v in value.items():
                if k in flat:
                    raise MotionError(f"{path}: key {k!r} given twice")
                flat[k] = v
        else:
            flat[key] = value
    if "steps_per_rev" in flat or "lead_mm" in flat:
        if "steps_per_mm" in flat:
            raise MotionError(f"{path}: give steps_per_mm or steps_per_rev with lead_mm, not both")
        try:
            rev = np.broadcast_to(np.asarray(flat.pop("steps_per_rev"), float), (3,))
            lead = np.broadcast_to(np.asarray(flat.pop("lead_mm"), float), (3,))
        except KeyError as exc:
            raise MotionError(f"{path}: steps_per_rev and lead_mm go together; {exc} is missing") from None
        if not (lead > 0).all():
            raise MotionError(f"{path}: lead_mm must be > 0 mm, got {lead.tolist()}")
        flat["steps_per_mm"] = tuple(float(r / ld) for r, ld in zip(rev, lead))
    unknown = set(flat) - _FIELDS
    if unknown:
        raise MotionError(f"{path}: unknown key(s) {sorted(unknown)}; known keys: {sorted(_FIELDS)}")
    flat.setdefault("name", path.stem)
    try:
        return MachineSpec(**flat)
    except MotionError as exc:
        raise MotionError(f"{path}: {exc}") from None
    except (TypeError, ValueError) as exc:
        raise MotionError(f"{path}: bad value ({exc})") from None


def check_job_fits(size_mm, machine: "MachineSpec | str | None" = None, *, force: bool = False,
                   what: str = "the job") -> str | None:
    """Refuse a job larger than the machine's travel.

    A drawing at the wrong scale (a 72 dpi photo read as a 1.4 m job, a DXF in inches
    read as mm) is the usual cause; the job cannot fit wherever its origin is set.

    Parameters
    ----------
    size_mm : sequence of 2 or 3 floats
        The job's extent along X, Y (and Z), mm.
    machine : MachineSpec, str or None
        As :func:`load_machine` takes it (None: [CBR40]'s machine).
    force : bool
        Return the message instead of raising (the job is written anyway).
    what : str
        How to call the job in the message.

    Returns
    -------
    str or None
        None when the job fits; the message when it does not and ``force`` is set.

    Raises
    ------
    MotionError
        The job is larger than the travel along some axis and ``force`` is not set.

    Examples
    --------
    >>> check_job_fits((250, 380), "cbr40-laser") is None
    True
    >>> check_job_fits((1400, 900), "cbr40-laser")
    Traceback (most recent call last):
    ...
    labkit.errors.MotionError: the job is 1400.0 × 900.0 mm, larger than the travel of cbr40-laser (300 × 400 mm) along X, Y; scale it down, or force it (--force)
    """
    m = load_machine(machine)
    size = np.asarray(size_mm, dtype=float).ravel()
    travel = np.asarray(m.travel_mm, dtype=float)[: len(size)]
    over = ~(size <= travel * (1 + 1e-9))          # NaN counts as over
    if not over.any():
        return None
    msg = (f"{what} is {' × '.join(f'{v:.1f}' for v in size)} mm, larger than the travel of "
           f"{m.name} ({' × '.join(f'{t:g}' for t in travel)} mm) along "
           f"{', '.join(a for a, o in zip('XYZ', over) if o)}")
    if force:
        return msg
    raise MotionError(msg + "; scale it down, or force it (--force)")
