"""The material library: per machine, what power, speed and passes each operation on a material needs.

A library is one TOML file a person can read and edit. Its format (version 1)::

    format = "labkit-materials"          # required, exactly this
    version = 1                          # required; a later version is refused, not guessed at
    machine = "cbr40-laser"              # the machine the settings belong to

    [material."poplar-3mm"]
    thickness_mm = 3.0                   # optional, mm
    note = "free text"                   # optional

    [material."poplar-3mm".cut]          # one table per operation: cut, score, fill, image
    origin = "fit"                       # "typed" (by hand), "fit" (from a cutwidth fit),
                                         # or "starting-point" (shipped, not measured on your machine)
    power_mw = 2250.0                    # optical power, mW (the S word follows from the machine)
    speed_mm_min = 310.0                 # feed, mm/min
    passes = 1                           # optional, whole number >= 1 (default 1)
    line_interval_mm = 0.1               # optional: fill hatch spacing / image line pitch, mm
    kerf_mm = 0.182                      # optional: burned width, mm (a cut's closed shapes are
                                         # offset by half of it)
    kerf_ci_mm = [0.171, 0.193]          # optional: its interval from the fit
    air = true                           # optional: air assist on (recorded; labkit sends no M8)
    dynamic = true                       # optional: M4, power following speed
    note = "…"                           # optional

    [material."poplar-3mm".cut.fit]      # only with origin = "fit": where the numbers came from
    file = "fits/poplar.json"            # the fit file, as given
    sha256 = "…"                         # its hash when the entry was made
    date = "2026-11-25T12:00:00+00:00"   # when the entry was made (UTC)
    scan = "widths.csv"                  # the fit's source (its widths table)
    model = "dose"                       # the model used
    level = 0.95                         # the confidence level of kerf_ci_mm
    rule = "…"                           # how power and speed were chosen, in words

Power is stored in mW, not as an S word, so an entry means the same on a
controller with another ``$30``; a command converts it with the machine's
``laser_max_power_mw`` and its ``--s-max``. ``labkit materials add``,
``from-fit`` and ``remove`` rewrite the file whole (through
:func:`labkit._files.atomic_output`): comments are not kept, the ``note`` fields are.

A value typed on the command line always beats the library; the program's
header says which values came from where (:func:`apply_material`).
"""

from __future__ import annotations

import dataclasses
import datetime
import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path

from labkit._files import toml_number
from labkit.errors import InputError

__all__ = ["FORMAT", "VERSION", "OPERATIONS", "ORIGINS", "Setting", "Material", "Library",
           "default_library_path", "read_library", "write_library", "library_text", "setting_from_fit",
           "parse_material_spec", "add_material_options", "apply_material"]

FORMAT = "labkit-materials"
VERSION = 1
#: The operations a material may hold settings for.
OPERATIONS = ("cut", "score", "fill", "image")
#: How an entry's numbers were obtained.
ORIGINS = ("typed", "fit", "starting-point")

_SETTING_KEYS = {"origin", "power_mw", "speed_mm_min", "passes", "line_interval_mm", "kerf_mm", "kerf_ci_mm",
                 "air", "dynamic", "note", "fit"}
_FIT_KEYS = {"file", "sha256", "date", "scan", "model", "level", "rule"}
_MATERIAL_KEYS = {"thickness_mm", "note"} | set(OPERATIONS)


@dataclass
class Setting:
    """One operation's settings on one material.

    Attributes
    ----------
    origin : {"typed", "fit", "starting-point"}
    power_mw : float
        Optical power, mW.
    speed_mm_min : float
        Feed, mm/min.
    passes : int
    line_interval_mm, kerf_mm : float or None
        Hatch spacing / image line pitch and burned width, mm.
    kerf_ci_mm : tuple of 2 floats or None
        The kerf's interval (from a fit), mm.
    air, dynamic : bool or None
        Air assist; M4 (power following speed).
    note : str
    fit : dict or None
        Provenance of a fitted entry (keys ``file``, ``sha256``, ``date``, ``scan``, ``model``,
        ``level``, ``rule``).
    """

    origin: str
    power_mw: float
    speed_mm_min: float
    passes: int = 1
    line_interval_mm: float | None = None
    kerf_mm: float | None = None
    kerf_ci_mm: tuple | None = None
    air: bool | None = None
    dynamic: bool | None = None
    note: str = ""
    fit: dict | None = None

    def describe(self) -> str:
        """One line: power, speed, passes, kerf, origin."""
        parts = [f"{self.power_mw:g} mW", f"{self.speed_mm_min:g} mm/min"]
        if self.passes != 1:
            parts.append(f"{self.passes} passes")
        if self.line_interval_mm is not None:
            parts.append(f"interval {self.line_interval_mm:g} mm")
        if self.kerf_mm is not None:
            ci = self.kerf_ci_mm
            parts.append(f"kerf {self.kerf_mm:.3f} mm" + (f" ({ci[0]:.3f}…{ci[1]:.3f})" if ci else ""))
        if self.dynamic:
            parts.append("M4")
        if self.air:
            parts.append("air")
        return ", ".join(parts) + f" [{self.origin}]"


@dataclass
class Material:
    """A material: its thickness and the settings of each operation on it."""

    name: str
    thickness_mm: float | None = None
    note: str = ""
    operations: dict = field(default_factory=dict)


@dataclass
class Library:
    """A machine's material library (see the module docstring for the file format)."""

    machine: str
    materials: dict = field(default_factory=dict)
    path: Path | None = None

    def get(self, name: str, operation: str | None = None) -> tuple[Material, str, Setting]:
        """The material ``name`` and one operation's settings.

        Without ``operation`` the material must hold exactly one, or a ``cut``.

        Raises
        ------
        InputError
            Unknown material or operation; the message lists what the library holds.
        """
        where = self.path or "the library"
        if name not in self.materials:
            have = ", ".join(self.materials) or "no materials"
            raise InputError(f"{where}: no material {name!r}; expected one of: {have}")
        m = self.materials[name]
        if operation is None:
            if len(m.operations) == 1:
                operation = next(iter(m.operations))
            elif "cut" in m.operations:
                operation = "cut"
            else:
                raise InputError(f"{where}: material {name!r} holds {', '.join(m.operations)}; "
                                 f"expected NAME:OPERATION, e.g. {name}:{next(iter(m.operations))}")
        if operation not in m.operations:
            raise InputError(f"{where}: material {name!r} has no {operation!r} settings; it has "
                             f"{', '.join(m.operations) or 'none'}")
        return m, operation, m.operations[operation]


def default_library_path(machine: str) -> Path:
    """The machine's library in the user's labkit configuration folder.

    ``<config>/materials/<machine>.toml``, beside the remembered machine settings
    (:func:`labkit.machine.link.config_path`: ``$LABKIT_CONFIG_DIR``, else
    ``~/.config/labkit`` and its Windows and macOS equivalents).
    """
    from labkit.machine.link import config_path

    return config_path().parent / "materials" / f"{machine}.toml"


# --- reading -----------------------------------------------------------------------------------

def _text(where, key, value):
    if not isinstance(value, str):
        raise InputError(f"{where}: {key} = {value!r}; expected a quoted string")
    return value


def _flag(where, key, value):
    if not isinstance(value, bool):
        raise InputError(f"{where}: {key} = {value!r}; expected true or false")
    return value


def _unknown(where, table: dict, known: set):
    extra = sorted(set(table) - known)
    if extra:
        raise InputError(f"{where}: unknown key(s) {', '.join(extra)}; expected some of {', '.join(sorted(known))}")


def _setting(where: str, d) -> Setting:
    if not isinstance(d, dict):
        raise InputError(f"{where}: expected a table of settings, got {d!r}")
    _unknown(where, d, _SETTING_KEYS)
    for key in ("origin", "power_mw", "speed_mm_min"):
        if key not in d:
            raise InputError(f"{where}: {key} is missing")
    origin = _text(where, "origin", d["origin"])
    if origin not in ORIGINS:
        raise InputError(f"{where}: origin = {origin!r}; expected one of {', '.join(ORIGINS)}")
    s = Setting(origin=origin, power_mw=toml_number(where, "power_mw", d["power_mw"], lo=0),
                speed_mm_min=toml_number(where, "speed_mm_min", d["speed_mm_min"], lo=0, lo_open=True),
                passes=toml_number(where, "passes", d.get("passes", 1), lo=1, whole=True),
                note=_text(where, "note", d.get("note", "")))
    for key in ("line_interval_mm", "kerf_mm"):
        if key in d:
            setattr(s, key, toml_number(where, key, d[key], lo=0, lo_open=True))
    if "kerf_ci_mm" in d:
        ci = d["kerf_ci_mm"]
        if not (isinstance(ci, list) and len(ci) == 2):
            raise InputError(f"{where}: kerf_ci_mm = {ci!r}; expected [low, high] in mm")
        s.kerf_ci_mm = tuple(toml_number(where, "kerf_ci_mm", c, lo=0) for c in ci)
    for key in ("air", "dynamic"):
        if key in d:
            setattr(s, key, _flag(where, key, d[key]))
    if origin == "fit":
        fit = d.get("fit")
        if not isinstance(fit, dict):
            raise InputError(f"{where}: origin = \"fit\" needs a [.fit] table naming the fit file")
        _unknown(f"{where}.fit", fit, _FIT_KEYS)
        if "file" not in fit:
            raise InputError(f"{where}.fit: file is missing")
        s.fit = dict(fit)
    elif "fit" in d:
        raise InputError(f"{where}: a fit table with origin = {origin!r}; expected origin = \"fit\"")
    return s


def read_library(path) -> Library:
    """Read and check a library file.

    Parameters
    ----------
    path : str or os.PathLike

    Returns
    -------
    Library

    Raises
    ------
    InputError
        Not a file, not TOML (with its line and column), not this format, a later version, or a
        bad entry (the message names the material, the operation and the key).
    """
    from labkit._files import read_toml

    p, data = read_toml(path, what="labkit material library", format=FORMAT, version=VERSION)
    _unknown(str(p), data, {"format", "version", "machine", "material"})
    lib = Library(machine=_text(str(p), "machine", data.get("machine", "")), path=p)
    materials = data.get("material", {})
    if not isinstance(materials, dict):
        raise InputError(f"{p}: material = {materials!r}; expected [material.NAME] tables")
    for name, table in materials.items():
        where = f"{p}: material {name!r}"
        if not isinstance(table, dict):
            raise InputError(f"{where}: expected a table, got {table!r}")
        _unknown(where, table, _MATERIAL_KEYS)
        m = Material(name=name, note=_text(where, "note", table.get("note", "")))
        if "thickness_mm" in table:
            m.thickness_mm = toml_number(where, "thickness_mm", table["thickness_mm"], lo=0, lo_open=True)
        for op in OPERATIONS:
            if op in table:
                m.operations[op] = _setting(f"{where}, {op}", table[op])
        lib.materials[name] = m
    return lib


# --- writing -----------------------------------------------------------------------------------

def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(float(v))          # numpy floats print as np.float64(…)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)     # JSON's escapes are TOML basic-string escapes
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise TypeError(f"no TOML form for {v!r}")


def _key(name: str) -> str:
    return json.dumps(name, ensure_ascii=False)


def library_text(lib: Library) -> str:
    """The library as TOML text (what :func:`write_library` writes; :func:`read_library` reads it back)."""
    out = [f"# labkit material library for {lib.machine or 'a machine'}: see labkit.materials for the format",
           f"format = {_toml_value(FORMAT)}", f"version = {VERSION}", f"machine = {_toml_value(lib.machine)}"]
    for name, m in lib.materials.items():
        out += ["", f"[material.{_key(name)}]"]
        if m.thickness_mm is not None:
            out.append(f"thickness_mm = {_toml_value(m.thickness_mm)}")
        if m.note:
            out.append(f"note = {_toml_value(m.note)}")
        for op, s in m.operations.items():
            out += ["", f"[material.{_key(name)}.{op}]"]
            for f in dataclasses.fields(Setting):
                v = getattr(s, f.name)
                if f.name == "fit" or v is None or (f.name == "note" and not v):
                    continue
                out.append(f"{f.name} = {_toml_value(v)}")
            if s.fit:
                out += [f"[material.{_key(name)}.{op}.fit]"]
                out += [f"{k} = {_toml_value(v)}" for k, v in s.fit.items() if v is not None]
    return "\n".join(out) + "\n"


def write_library(lib: Library, path=None) -> Path:
    """Write the library whole (to ``path`` or ``lib.path``), creating its folder if needed."""
    from labkit._files import atomic_output

    p = Path(path or lib.path)
    p.parent.mkdir(parents=True, exist_ok=True)
    with atomic_output(p, encoding="utf-8") as fh:
        fh.write(library_text(lib))
    lib.path = p
    return p


# --- entries from a cut-width fit -------------------------------------------------------------------

def _width_band(fit, power_mw: float, speed_mm_min: float) -> tuple[float, float, float]:
    """Width (mm) at a setting and its delta-method interval from the fit's covariance."""
    import numpy as np
    from scipy import stats

    w = float(fit.width(power_mw, speed_mm_min))
    if fit.cov is None:
        return w, float("nan"), float("nan")
    x = fit.vector()
    grad = np.empty(len(x))
    for k in range(len(x)):
        h = 1e-6 * max(abs(x[k]), 1e-3)
        up, dn = x.copy(), x.copy()
        up[k] += h
        dn[k] -= h
        grad[k] = (float(fit.with_vector(up).width(power_mw, speed_mm_min))
                   - float(fit.with_vector(dn).width(power_mw, speed_mm_min))) / (2 * h)
    sd = float(np.sqrt(grad @ np.asarray(fit.cov, float) @ grad))
    t = stats.t.ppf(0.5 + fit.level / 2.0, max(fit.n - len(x), 1))
    return w, float(w - t * sd), float(w + t * sd)


def setting_from_fit(fit_path, operation: str = "cut", *, power_mw: float, width_mm: float | None = None,
                     cut_probability: float = 0.95, model: str | None = None, passes: int = 1,
                     dynamic: bool | None = None, air: bool | None = None, max_speed_mm_min: float | None = None,
                     now=None) -> Setting:
    """Derive one operation's settings from a saved ``labkit cutwidth fit -o FIT.json``.

    Parameters
    ----------
    fit_path : str or os.PathLike
        The fit file (format ``labkit-cutwidth-fit``).
    operation : {"cut", "score", "fill", "image"}
        ``cut``: the fastest speed at ``power_mw`` whose predicted probability of cutting through
        (the fit's logistic cut-through model) is ``cut_probability``; the kerf is the width
        model's prediction there. ``score``, ``fill``, ``image``: the speed at which the width model
        burns ``width_mm`` at ``power_mw``; fill and image lines are ``width_mm`` apart.
    power_mw : float
        Optical power, mW.
    width_mm : float, optional
        Wanted line width (required except for ``cut``).
    cut_probability : float
        For ``cut``, 0 < p < 1.
    model : str, optional
        The fit's model to use (default: the one the fit chose).
    passes : int
    dynamic, air : bool, optional
        Recorded as given.
    max_speed_mm_min : float, optional
        The machine's fastest feed: a cut whose fastest cutting speed lies above it is entered at
        this speed (slower still cuts through; the rule says so).
    now : datetime, optional
        The entry's date (default: now, UTC).

    Returns
    -------
    Setting
        ``origin = "fit"``, with the fit's file, hash, date, scan, model and level attached.

    Raises
    ------
    InputError
        The fit has no cut-through model (for a cut), a cut's power lies outside the measured
        powers, or the width model gives the wanted width only outside the measured speeds widened
        by half their span (:func:`labkit.laser.models.check_width_reach`).
    """
    import numpy as np

    from labkit.laser.models import check_width_reach, load_fit, speed_for_width
    from labkit.record import file_entry

    if operation not in OPERATIONS:
        raise InputError(f"operation {operation!r}; expected one of {', '.join(OPERATIONS)}")
    if not (math.isfinite(power_mw) and power_mw > 0):
        raise InputError(f"power {power_mw!r} mW; expected a finite number > 0")
    res, fit = load_fit(fit_path, model)
    if operation == "cut":
        ct = res.get("cut_through")
        if not ct or not (ct.get("b1", 0) > 0):
            raise InputError(f"{fit_path}: the fit has no usable cut-through model (its widths table needs a "
                             "cut_through column with some lines cut and some not); a cut cannot be derived — "
                             "type the cut's settings with 'labkit materials add', or derive a score with --width")
        if not 0 < cut_probability < 1:
            raise InputError(f"cut probability {cut_probability!r}; expected 0 < p < 1")
        # logistic: logit(p) = b0 + b1 ln(P/v) → the smallest P/v that cuts with probability p
        ratio = math.exp((math.log(cut_probability / (1 - cut_probability)) - ct["b0"]) / ct["b1"])
        speed = power_mw / ratio
        rule = (f"fastest speed at {power_mw:g} mW with a {100 * cut_probability:g} % predicted chance of "
                f"cutting through (logistic on ln P/v, {ct['n_cut']} of {ct['n']} lines cut)")
        if max_speed_mm_min is not None and speed > max_speed_mm_min:
            rule += f", {speed:.0f} mm/min, held to the machine's {max_speed_mm_min:g} mm/min"
            speed = float(max_speed_mm_min)
    else:
        if width_mm is None:
            raise InputError(f"a {operation} from a fit needs the wanted line width (--width MM)")
        with np.errstate(all="ignore"):
            speed = float(speed_for_width(fit, width_mm, power_mw))
        check_width_reach(fit, res, width_mm, power_mw, speed if math.isfinite(speed) else None, solve_for="speed")
        rule = f"speed at which the {fit.model} model burns {width_mm:g} mm at {power_mw:g} mW"
    if operation == "cut":
        # the cut-through model knows P/v alone; at a power far from the measured ones heat flow differs
        lo, hi = res["data"]["power_mw"]
        if not lo <= power_mw <= hi:
            raise InputError(f"{fit_path}: a cut at {power_mw:g} mW lies outside the measured powers "
                             f"{lo:g}…{hi:g} mW; expected a power in that range (--power-mw)")
    kerf, k_lo, k_hi = _width_band(fit, power_mw, speed)
    when = (now or datetime.datetime.now(datetime.timezone.utc)).isoformat(timespec="seconds")
    s = Setting(origin="fit", power_mw=float(power_mw), speed_mm_min=round(float(speed), 3), passes=passes,
                kerf_mm=round(kerf, 5), air=air, dynamic=dynamic,
                fit=dict(file=os.fspath(fit_path), sha256=file_entry(fit_path, "fit")["sha256"], date=when,
                         scan=str(res.get("source", "")), model=fit.model, level=float(fit.level), rule=rule))
    if math.isfinite(k_lo) and math.isfinite(k_hi):
        s.kerf_ci_mm = (round(max(k_lo, 0.0), 5), round(k_hi, 5))
    if operation in ("fill", "image"):
        s.line_interval_mm = float(width_mm)
    return s


# --- the command line: --material NAME[:OPERATION] on the converters ---------------------------------

def parse_material_spec(text: str) -> tuple[str, str | None]:
    """``NAME[:OPERATION]`` → (name, operation or None).

    >>> parse_material_spec("poplar-3mm:score")
    ('poplar-3mm', 'score')
    >>> parse_material_spec("poplar-3mm")
    ('poplar-3mm', None)
    """
    name, sep, op = text.rpartition(":")
    if sep and op in OPERATIONS:
        return name, op
    if sep and op and name:
        raise InputError(f"--material {text!r}: operation {op!r}; expected one of {', '.join(OPERATIONS)}")
    return text, None


class _UntypedFloat(float):
    """A default the user did not type (so a library value may replace it)."""


class _UntypedInt(int):
    """A default the user did not type (so a library value may replace it)."""


#: What a library setting fills in on each kind of command: option dest → how to read it from a setting.
_VECTOR_FIELDS = ("feed", "power", "passes", "kerf", "dynamic", "fill", "fill_spacing")
_RASTER_FIELDS = ("feed", "power", "max_power", "beam")


def add_material_options(parser, kind: str) -> None:
    """Add ``--material`` and ``--library`` and mark the defaults a library may replace.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        A converter's parser, after its own options.
    kind : {"vector", "raster"}
    """
    parser.add_argument("--material", default=None, metavar="NAME[:OPERATION]",
                        help="take power, speed, passes and kerf from the material library (operation "
                             "cut, score, fill or image); an option typed here beats the library")
    parser.add_argument("--library", default=None, metavar="FILE",
                        help="material library (default: the machine's, in labkit's configuration folder)")
    fields = _VECTOR_FIELDS if kind == "vector" else _RASTER_FIELDS
    marked = {}
    for action in parser._actions:
        if action.dest in fields:
            d = action.default
            if isinstance(d, bool) or d is False:
                marked[action.dest] = None          # store_true: None = not typed, reads as false
            elif isinstance(d, int):
                marked[action.dest] = _UntypedInt(d)
            elif isinstance(d, float):
                marked[action.dest] = _UntypedFloat(d)
    parser.set_defaults(**marked)


def _typed(value) -> bool:
    return value is not None and not isinstance(value, (_UntypedFloat, _UntypedInt))


def _plain(value):
    if value is None:
        return False
    if isinstance(value, _UntypedInt):
        return int(value)
    if isinstance(value, _UntypedFloat):
        return float(value)
    return value


def apply_material(args, kind: str, *, raster_mode: str | None = None) -> str:
    """Fill a converter's untyped options from ``--material``; returns what was used, for the header.

    Every option marked by :func:`add_material_options` becomes a plain value again, whether or
    not a material was named. With ``--material``: feed ← ``speed_mm_min``; power (S) ←
    ``power_mw`` through the machine's ``laser_max_power_mw`` and ``--s-max``; vector: passes,
    kerf (a cut only), M4, and for a fill the hatch at ``line_interval_mm``; raster: the image's
    ``--max-power`` (gray/dither) and ``--beam`` ← ``line_interval_mm``.

    Returns
    -------
    str
        Empty without ``--material``; else one sentence naming the entry, its origin (and fit
        file) and which options came from the library and which were typed.
    """
    fields = _VECTOR_FIELDS if kind == "vector" else _RASTER_FIELDS
    spec = getattr(args, "material", None)
    if not spec:
        for f in fields:
            if hasattr(args, f):
                setattr(args, f, _plain(getattr(args, f)))
        return ""
    from labkit.motion.spec import load_machine
    from labkit.units import mw_to_s

    machine = load_machine(args.machine)
    path = args.library or default_library_path(machine.name)
    if not args.library and not Path(path).exists():
        raise InputError(f"--material {spec}: the machine {machine.name!r} has no material library yet "
                         f"({path}); expected one made with 'labkit materials add/from-fit', or name a file "
                         "with --library (examples: data/materials/)")
    lib = read_library(path)
    name, op = parse_material_spec(spec)
    if lib.machine and lib.machine != machine.name:
        raise InputError(f"--library {path}: its settings are for the machine {lib.machine!r}, the job is for "
                         f"{machine.name!r}; expected --machine {lib.machine} or that machine's library")
    m, op, s = lib.get(name, op)
    s_max = float(args.s_max)
    s_word = float(mw_to_s(s.power_mw, s_max=s_max, max_power_mw=machine.laser_max_power_mw))
    offered = {"feed": s.speed_mm_min, "power": round(s_word, 3)}
    if kind == "vector":
        offered["passes"] = s.passes
        if op == "cut" and s.kerf_mm is not None:
            offered["kerf"] = s.kerf_mm
        if s.dynamic is not None:
            offered["dynamic"] = s.dynamic
        if op == "fill":
            offered["fill"] = True
            if s.line_interval_mm is not None:
                offered["fill_spacing"] = s.line_interval_mm
    else:
        if raster_mode in ("gray", "dither"):
            offered["max_power"] = round(min(s_word / s_max, 1.0), 6)
        if s.line_interval_mm is not None:
            offered["beam"] = s.line_interval_mm
    used, typed = [], []
    for f in fields:
        if not hasattr(args, f):
            continue
        value = getattr(args, f)
        if f in offered and not _typed(value):
            setattr(args, f, offered[f])
            used.append(f"--{f.replace('_', '-')} {offered[f]:g}" if not isinstance(offered[f], bool)
                        else f"--{f}")
        else:
            if f in offered:
                typed.append(f"--{f.replace('_', '-')}")
            setattr(args, f, _plain(value))
    source = {"fit": f"fit {s.fit.get('file')}" if s.fit else "fit", "typed": "typed by hand",
              "starting-point": "a starting point, not measured on this machine"}[s.origin]
    text = (f"{m.name}:{op} from {Path(path).name} ({source}; {s.power_mw:g} mW = S{s_word:g})"
            f": library {' '.join(used) or 'nothing'}")
    if typed:
        text += f"; typed {' '.join(typed)}"
    return text
