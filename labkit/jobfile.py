"""A job file: several sources, each a layer with an operation, composed into one program.

``svg2gcode``, ``dxf2gcode`` and ``img2gcode`` each turn one file into one program; a job file
composes them. Its format (version 1, TOML)::

    format = "labkit-job"          # required, exactly this
    version = 1                    # required; a later version is refused
    machine = "cbr40-laser"        # required: a machine name or a machine TOML
    material = "paperboard-0.2mm"  # optional: the library entry every layer uses unless it names its own
    library = "materials.toml"     # optional: the library file (default: the machine's)
    dialect = "grbl"               # optional (grbl, labkit-fw, marlin)
    s_max = 1000.0                 # optional: S of full power (GRBL $30)
    tol_mm = 0.01                  # optional: largest deviation of the cut from the drawing, mm

    [placement]                    # optional
    start_from = "absolute"        # "absolute": as drawn, in the work coordinates in effect;
                                   # "origin": the job's lower-left corner at the work origin;
                                   # "current": the job's lower-left corner where the head stands
    offset_mm = [0.0, 0.0]         # added after start_from, mm

    [[layer]]
    source = "card.svg"            # relative to the job file: .svg, .dxf, or an image; an SVG's
                                   # <text> is drawn in its font (labkit.vector.text), its colour its layer;
                                   # operation "image" on an SVG engraves the bitmaps it embeds where
                                   # it places them (svg_images; select by id)
    operation = "cut"              # cut, score, fill (vector: the hatch, then the outline, as
                                   # svg2gcode --fill), image (an image file)
    select = ["#000000"]           # optional (vector): only these SVG colours / DXF layers / element ids
    material = "card:cut"          # optional: NAME[:OPERATION], else the job's material with this operation
    power_mw = 1200.0              # optional overrides, each beating the library:
    speed_mm_min = 600.0           #   mW, mm/min, whole passes, kerf (cut) and line interval
    passes = 2                     #   (fill spacing, image pitch), mm; dynamic = M4
    kerf_mm = 0.2
    line_interval_mm = 0.1
    dynamic = true
    at_mm = [10.0, 10.0]           # image: where its lower-left corner goes, mm (default 0, 0)
    width_mm = 40.0                # image: engraved width, mm (else the file's dpi)
    mode = "gray"                  # image: zigzag, spiral, edges, gray or dither (default gray)
    tabs = 4                       # cut/score: uncut bridges per closed shape, spread evenly and
    tab_mm = 1.0                   #   slid clear of corners (tab_gaps), each this long, mm (default 1)
    perforate = [2.0, 1.0]         # cut/score: cut 2 mm, skip 1 mm, along every path (not with tabs)

A layer's settings come from its own keys first, then its material entry; one with neither power
nor speed is refused. The program is written in the order a laser user expects: images, then
fills, then scores, then cuts (engraving before cutting, so a part does not drop or shift before it
is engraved), layers of one operation in file order; a layer's passes run one after the other, each
pass the whole layer, and within each pass every shape inside another is cut before its container
(:mod:`labkit.geometry.order`'s inner-first rule), so a hole is cut while its part still holds.
Inner-first holds within a layer: two cut layers run in file order whatever their nesting.

**At the current position** (LightBurn's "Current Position" start-from) the program is written as for
"origin" and begins with ``G92 X0 Y0``: the head's position when the program starts becomes the
work origin (XY; Z is left alone), as a sender's "set zero here" does (LaserGRBL's is a G92). It
ends with ``G92.1``, which clears that offset again, so the next job runs in the coordinates it
expects. G92 rather than ``G10 L20`` (which rewrites the stored G54 origin in GRBL's EEPROM) and
rather than relative moves (G91: one lost line displaces all that follow, and the planner's arcs
and a resume want absolute positions). GRBL 1.1 clears a G92 offset on every reset, and a resume
restates the program's own state, which cannot know where the head stood, so a job placed here
and stopped by a reset (labkit's safe stop sends one) cannot be resumed: ``labkit stream
--resume-from`` refuses it with that reason (:func:`labkit.machine.resume.resume_text`) instead of
burning in the plain work coordinates. Burn it again from its start, or, for a job that must be resumable, set a work origin there (``G10 L20 P1 X0 Y0``, stored
in EEPROM) and place the job at the origin. The program's header and the record (``placement``)
say how the job was placed.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path

from labkit._files import toml_number
from labkit.errors import InputError
from labkit.vector.images import PlacedImage, svg_images      # re-exported: the job's bitmaps and text
from labkit.vector.text import svg_text_paths                 # are read where SVG is read

__all__ = ["FORMAT", "VERSION", "ORDER", "PLACEMENTS", "JobLayer", "JobFile", "read_job", "compose_job", "ComposedJob",
           "tab_gaps", "perforation_gaps", "split_at_gaps", "svg_text_paths", "svg_images", "PlacedImage",
           "engrave_images"]

FORMAT = "labkit-job"
VERSION = 1
#: Operations in the order they are burned.
ORDER = ("image", "fill", "score", "cut")
#: Where a job is placed (``[placement] start_from``), and how the program does it.
PLACEMENTS = {"absolute": "as drawn, in the work coordinates in effect",
              "origin": "the job's lower-left corner at the work origin",
              "current": "the job's lower-left corner where the head stands: G92 X0 Y0 before the first "
                         "move, G92.1 after the last"}
_TOP_KEYS = {"format", "version", "machine", "material", "library", "dialect", "s_max", "tol_mm", "placement",
             "layer"}
_LAYER_KEYS = {"source", "operation", "select", "material", "power_mw", "speed_mm_min", "passes", "kerf_mm",
               "line_interval_mm", "dynamic", "at_mm", "width_mm", "mode", "tabs", "tab_mm", "perforate"}
_IMAGE_SUFFIXES = {".png", ".bmp", ".jpg", ".jpeg", ".gif", ".tif", ".tiff", ".webp"}


@dataclass
class JobLayer:
    """One ``[[layer]]`` table, checked; ``index`` counts from 1 in file order."""

    index: int
    source: Path
    operation: str
    select: list = field(default_factory=list)
    material: str | None = None
    overrides: dict = field(default_factory=dict)
    at_mm: tuple = (0.0, 0.0)
    width_mm: float | None = None
    mode: str = "gray"
    tabs: int = 0
    tab_mm: float = 1.0
    perforate: tuple | None = None


@dataclass
class JobFile:
    """A job file read and checked (see the module docstring for the format)."""

    path: Path
    machine: str
    layers: list
    material: str | None = None
    library: Path | None = None
    dialect: str = "grbl"
    s_max: float = 1000.0
    tol_mm: float = 0.01
    start_from: str = "absolute"
    offset_mm: tuple = (0.0, 0.0)


_num = toml_number        # one checker for TOML numbers (labkit._files)


def _pair(where, key, v):
    if not (isinstance(v, list) and len(v) == 2):
        raise InputError(f"{where}: {key} = {v!r}; expected [x, y] in mm")
    return tuple(_num(where, key, c) for c in v)


def read_job(path) -> JobFile:
    """Read and check a job file; sources are resolved against its folder and must exist.

    Raises
    ------
    InputError
        Not TOML (line and column), another format or version, unknown keys, a bad value or a
        missing source — naming the file, the layer's number and the key.
    """
    from labkit._files import read_toml

    p, data = read_toml(path, what="labkit job file", format=FORMAT, version=VERSION)
    extra = sorted(set(data) - _TOP_KEYS)
    if extra:
        raise InputError(f"{p}: unknown key(s) {', '.join(extra)}; expected some of {', '.join(sorted(_TOP_KEYS))}")
    if not isinstance(data.get("machine"), str):
        raise InputError(f"{p}: machine is missing; expected machine = \"NAME\" (e.g. \"cbr40-laser\") or a TOML file")
    here = p.parent
    job = JobFile(path=p, machine=data["machine"], layers=[], material=data.get("material"),
                  dialect=data.get("dialect", "grbl"))
    if "library" in data:
        job.library = here / data["library"]
    if "s_max" in data:
        job.s_max = _num(str(p), "s_max", data["s_max"], lo=0, lo_open=True)
    if "tol_mm" in data:
        job.tol_mm = _num(str(p), "tol_mm", data["tol_mm"], lo=1e-4)
    place = data.get("placement", {})
    if not isinstance(place, dict) or set(place) - {"start_from", "offset_mm"}:
        raise InputError(f"{p}: [placement] takes start_from and offset_mm; got {place!r}")
    job.start_from = place.get("start_from", "absolute")
    if job.start_from not in PLACEMENTS:
        raise InputError(f"{p}: placement start_from = {job.start_from!r}; expected one of "
                         + ", ".join(f'"{k}"' for k in PLACEMENTS))
    if "offset_mm" in place:
        job.offset_mm = _pair(f"{p}: [placement]", "offset_mm", place["offset_mm"])
    layers = data.get("layer")
    if not isinstance(layers, list) or not layers:
        raise InputError(f"{p}: no [[layer]] tables; expected at least one layer with source and operation")
    for i, t in enumerate(layers, 1):
        job.layers.append(_layer(p, i, t))
    return job


def _layer(p: Path, i: int, t: dict) -> JobLayer:
    where = f"{p}: layer {i}"
    extra = sorted(set(t) - _LAYER_KEYS)
    if extra:
        raise InputError(f"{where}: unknown key(s) {', '.join(extra)}; "
                         f"expected some of {', '.join(sorted(_LAYER_KEYS))}")
    for key in ("source", "operation"):
        if not isinstance(t.get(key), str):
            raise InputError(f"{where}: {key} is missing; expected {key} = \"…\"")
    op = t["operation"]
    if op not in ORDER:
        raise InputError(f"{where}: operation = {op!r}; expected one of {', '.join(ORDER)}")
    src = p.parent / t["source"]
    if not src.is_file():
        raise InputError(f"{where}: source {t['source']!r} is not a file ({src}); expected a path relative to "
                         "the job file")
    is_image = src.suffix.lower() in _IMAGE_SUFFIXES
    if is_image != (op == "image") and not (op == "image" and src.suffix.lower() == ".svg"):
        raise InputError(f"{where}: operation {op!r} on {src.name}: images (and the bitmaps an SVG embeds) take "
                         "operation \"image\", SVG and DXF drawings cut, score or fill")
    if not is_image and src.suffix.lower() not in (".svg", ".dxf"):
        raise InputError(f"{where}: source {src.name}: expected an .svg, .dxf or image file")
    layer = JobLayer(index=i, source=src, operation=op, material=t.get("material"))
    sel = t.get("select", [])
    if isinstance(sel, str):
        sel = [sel]
    if not (isinstance(sel, list) and all(isinstance(s, str) for s in sel)):
        raise InputError(f"{where}: select = {sel!r}; expected a list of colours, layer names or ids")
    layer.select = sel
    for key in ("power_mw", "kerf_mm", "line_interval_mm", "speed_mm_min", "passes", "width_mm"):
        if key in t:
            lo, open_ = {"power_mw": (0, False), "kerf_mm": (0, False), "passes": (1, False)}.get(key, (0, True))
            v = _num(where, key, t[key], lo=lo, lo_open=open_, whole=key == "passes")
            if key == "width_mm":
                layer.width_mm = v
            else:
                layer.overrides[key] = v
    if "dynamic" in t:
        if not isinstance(t["dynamic"], bool):
            raise InputError(f"{where}: dynamic = {t['dynamic']!r}; expected true or false")
        layer.overrides["dynamic"] = t["dynamic"]
    if "at_mm" in t:
        layer.at_mm = _pair(where, "at_mm", t["at_mm"])
    if "tabs" in t or "tab_mm" in t or "perforate" in t:
        if op not in ("cut", "score"):
            raise InputError(f"{where}: tabs and perforate are for cut and score layers, not {op}")
        if "tabs" in t and "perforate" in t:
            raise InputError(f"{where}: tabs and perforate together; expected one of them")
        layer.tabs = _num(where, "tabs", t.get("tabs", 0), lo=1, whole=True) if "tabs" in t else 0
        layer.tab_mm = _num(where, "tab_mm", t.get("tab_mm", 1.0), lo=0, lo_open=True)
        if "perforate" in t:
            layer.perforate = tuple(_num(where, "perforate", v, lo=0, lo_open=True)
                                    for v in _pair(where, "perforate", t["perforate"]))
    if "mode" in t:
        from labkit.raster.engrave import MODES

        if t["mode"] not in MODES:
            raise InputError(f"{where}: mode = {t['mode']!r}; expected one of {', '.join(MODES)}")
        layer.mode = t["mode"]
    return layer


@dataclass
class ComposedJob:
    """The composed program and what each layer used.

    Attributes
    ----------
    moves : Moves
        Every layer, in burning order, placed.
    layers : list of dict
        Per layer in burning order: ``index``, ``source``, ``operation``, ``power_mw``, ``s_word``,
        ``speed_mm_min``, ``passes``, ``kerf_mm``, ``line_interval_mm``, ``dynamic``, ``material``
        (spec or None), ``from_library`` (keys taken from it), ``moves`` (rows), ``bounds_mm``.
    tol_mm : float
    warnings : list of str
        What a layer's reader could not cut or draw as a renderer does (each names its file and
        is said once however many layers read that file), as ``svg2gcode`` and ``dxf2gcode`` say it.
    """

    moves: object
    layers: list
    tol_mm: float
    warnings: list = field(default_factory=list)


def _settings(job: JobFile, layer: JobLayer, machine) -> dict:
    """The layer's settings: its own keys, then its material entry."""
    from labkit.materials import default_library_path, parse_material_spec, read_library

    spec = layer.material or job.material
    values, from_library = dict(layer.overrides), []
    if spec:
        name, op = parse_material_spec(spec)
        path = job.library or default_library_path(machine.name)
        if not Path(path).exists():
            raise InputError(f"{job.path}: layer {layer.index}: material {spec!r} but the library {path} does not "
                             "exist; expected library = \"FILE\" in the job or a machine library")
        _, op, s = read_library(path).get(name, op or layer.operation)
        entry = dict(power_mw=s.power_mw, speed_mm_min=s.speed_mm_min, passes=s.passes, dynamic=s.dynamic)
        if s.kerf_mm is not None and layer.operation == "cut":
            entry["kerf_mm"] = s.kerf_mm
        if s.line_interval_mm is not None:
            entry["line_interval_mm"] = s.line_interval_mm
        for k, v in entry.items():
            if k not in values and v is not None:
                values[k] = v
                from_library.append(k)
        spec = f"{name}:{op}"
    for key in ("power_mw", "speed_mm_min"):
        if key not in values:
            raise InputError(f"{job.path}: layer {layer.index}: no {key} (give {key} in the layer, or a material "
                             "whose entry has it)")
    values.setdefault("passes", 1)
    values.setdefault("dynamic", False)
    values.setdefault("kerf_mm", 0.0)
    values.setdefault("line_interval_mm", 0.1)
    values["material"] = spec
    values["from_library"] = from_library
    return values


def _vector_moves(job: JobFile, layer: JobLayer, s: dict, s_word: float):
    import warnings

    from labkit.toolpath.build import LayerSettings
    from labkit.toolpath.job import vector_job
    from labkit.toolpath.moves import LaserMode

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        if layer.source.suffix.lower() == ".svg":
            from labkit.vector.svg import read_svg

            drawing = read_svg(layer.source, tol_mm=job.tol_mm)
        else:
            from labkit.vector.dxf import read_dxf

            drawing = read_dxf(layer.source, tol_mm=job.tol_mm)
    # what the reader could not cut is said, as svg2gcode and dxf2gcode say it; bitmaps an image
    # layer of this job engraves from the same file are not "lost"
    engraved_here = any(L.operation == "image" and L.source == layer.source for L in job.layers)
    only_bitmaps = all(k.split("#")[0].split("[")[0] == "image" for k in drawing.skipped)
    said = [str(w.message) for w in caught          # each names its file; said once per job
            if not (engraved_here and only_bitmaps and " not cut: " in str(w.message))]
    paths = list(drawing.paths)             # an SVG's text among them, drawn by the reader
    if layer.select:
        paths = [q for q in paths if q.layer in layer.select or q.source in layer.select
                 or q.source.lstrip("#") in layer.select]
    if not paths:
        have = ", ".join(drawing.layers) or "none"
        raise InputError(f"{job.path}: layer {layer.index}: nothing to {layer.operation} in {layer.source.name}"
                         + (f" with select {layer.select} (its layers: {have})" if layer.select else ""))
    laser = LaserMode.DYNAMIC if s["dynamic"] else LaserMode.CONSTANT
    settings = LayerSettings(feed_mm_min=s["speed_mm_min"], s_word=s_word, passes=int(s["passes"]), laser=laser)
    fill = layer.operation == "fill"
    if layer.tabs or layer.perforate:
        return _gapped_moves(job, layer, paths, s, settings), said
    vj = vector_job(paths, default=settings, tol_mm=job.tol_mm, kerf_mm=s["kerf_mm"], fill=fill,
                    fill_spacing_mm=s["line_interval_mm"], s_max=job.s_max)
    return vj.moves, said


def _gapped_moves(job: JobFile, layer: JobLayer, paths, s: dict, settings):
    """A cut or score with tabs or perforation: the kerf and the order as vector_job gives them, then
    each path (as a polyline within tol_mm) cut in pieces with the gaps left uncut."""
    import numpy as np

    from labkit.geometry.path import Path as GeoPath
    from labkit.toolpath.build import build_moves, prepare_paths

    ordered = prepare_paths(paths, kerf_mm=s["kerf_mm"], tol_mm=job.tol_mm)
    pieces = []
    for p in ordered:
        pts = p.sample(job.tol_mm)
        if layer.tabs:
            gaps = tab_gaps(pts, layer.tabs, layer.tab_mm) if p.closed else []
        else:
            gaps = perforation_gaps(pts, *layer.perforate)
        # a dash shorter than the tolerance is the drawing's rounding, not a cut
        pieces += [GeoPath.polyline(q, layer=p.layer) for q in split_at_gaps(pts, gaps, closed=p.closed)
                   if len(q) >= 2 and float(np.hypot(*np.diff(q, axis=0).T).sum()) >= job.tol_mm]
    return build_moves(pieces, settings, default=settings, s_max=job.s_max)


def _image_moves(job: JobFile, layer: JobLayer, s: dict, s_word: float):
    from labkit.raster.io import read_image

    if layer.source.suffix.lower() == ".svg":          # the bitmaps it embeds, where it places them
        placed = [p for p in svg_images(layer.source)
                  if not layer.select or p.name in layer.select or p.name.split("#")[-1] in layer.select]
        if not placed:
            raise InputError(f"{job.path}: layer {layer.index}: {layer.source.name} embeds no bitmap"
                             + (f" named {layer.select}" if layer.select else ""))
        items = [p.engraving_item for p in placed]
    else:
        items = [(read_image(layer.source), layer.width_mm, None, layer.at_mm)]
    moves = engrave_images(items, mode=layer.mode, line_interval_mm=s["line_interval_mm"],
                           feed_mm_min=s["speed_mm_min"], s_word=s_word, s_max=job.s_max, dynamic=s["dynamic"],
                           where=f"{job.path}: layer {layer.index}: {layer.source.name}")
    passes = int(s["passes"])
    return moves if passes == 1 else _chain([moves] * passes)


def engrave_images(items, *, mode: str, line_interval_mm: float, feed_mm_min: float, s_word: float,
                   s_max: float, dynamic: bool = False, where: str = "image"):
    """Bitmaps engraved through :mod:`labkit.raster`, each at its size and place, one after another.

    The one way a job's image layer and ``svg2gcode --images`` engrave.

    Parameters
    ----------
    items : list of (image, width_mm, pixel_aspect, (x_mm, y_mm))
        A :class:`~labkit.raster.io.RasterImage`, its engraved width (mm, or None for its dpi),
        its pixels' height over width (None: the image's own) and where its lower-left corner
        goes, mm (:attr:`labkit.vector.images.PlacedImage.engraving_item` for an SVG's bitmaps).
    mode : str
        :data:`labkit.raster.engrave.MODES`.
    line_interval_mm, feed_mm_min, s_word, s_max : float
        Line interval (mm), speed (mm/min), power S of full black and S of full power.
    dynamic : bool
        M4 (power follows speed).
    where : str
        Names the source in the error.

    Returns
    -------
    Moves
        Every bitmap in order; the first move leaves from where the first bitmap's own program
        starts, before it is placed.

    Raises
    ------
    InputError
        A bitmap with nothing to burn in this mode.
    """
    import numpy as np

    from labkit.raster.engrave import RasterSettings, image_to_job
    from labkit.toolpath.moves import LaserMode

    parts = []
    for img, width_mm, pixel_aspect, at in items:
        settings = RasterSettings(mode=mode, beam_mm=line_interval_mm, width_mm=width_mm,
                                  pixel_aspect=pixel_aspect, feed_mm_min=feed_mm_min, s_max=s_max,
                                  s_word=s_word, max_power=min(s_word / s_max, 1.0),
                                  laser=LaserMode.DYNAMIC if dynamic else None)
        moves = image_to_job(img, settings).moves
        if not len(moves):
            raise InputError(f"{where}: nothing to burn (mode {mode})")
        parts.append(_shift(moves, np.array([at[0], at[1], 0.0])))
    home = parts[0].start[0] - np.array([*items[0][3], 0.0])
    moves = _chain(parts)
    moves.start[0] = home
    return moves


def _shift(moves, d):
    out = moves.copy()
    out.start[:] += d
    out.end[:] += d
    out.centre[:] += d
    return out


def _chain(parts):
    """Concatenate programs so each part's first move starts where the one before ended."""
    from labkit.toolpath.moves import Moves

    parts = [p.copy() for p in parts if len(p)]
    for before, after in zip(parts, parts[1:]):
        after.start[0] = before.end[-1]
    return Moves.concat(parts)


def compose_job(job: JobFile) -> ComposedJob:
    """Build every layer and join them in burning order, placed.

    Parameters
    ----------
    job : JobFile
        From :func:`read_job`.

    Returns
    -------
    ComposedJob
    """
    import numpy as np

    from labkit.motion.spec import load_machine
    from labkit.units import mw_to_s

    machine = load_machine(job.machine)
    order = sorted(job.layers, key=lambda L: (ORDER.index(L.operation), L.index))
    parts, info, warned = [], [], []
    for layer in order:
        s = _settings(job, layer, machine)
        s_word = float(mw_to_s(s["power_mw"], s_max=job.s_max, max_power_mw=machine.laser_max_power_mw))
        if s["power_mw"] > machine.laser_max_power_mw:
            raise InputError(f"{job.path}: layer {layer.index}: power {s['power_mw']:g} mW is above the machine's "
                             f"{machine.laser_max_power_mw:g} mW")
        if layer.operation == "image":
            moves = _image_moves(job, layer, s, s_word)
        else:
            moves, said = _vector_moves(job, layer, s, s_word)
            warned += [w for w in said if w not in warned]
        parts.append(moves)
        info.append(dict(index=layer.index, source=os.fspath(layer.source), operation=layer.operation,
                         power_mw=s["power_mw"], s_word=round(s_word, 3), speed_mm_min=s["speed_mm_min"],
                         passes=int(s["passes"]), kerf_mm=s["kerf_mm"], line_interval_mm=s["line_interval_mm"],
                         dynamic=bool(s["dynamic"]), material=s["material"], from_library=s["from_library"],
                         moves=len(moves)))
    home = parts[0].start[0].copy()          # where the head is before the program (the origin)
    if job.start_from == "current":
        home[:2] = 0.0                       # the head stands at the origin G92 X0 Y0 makes
    if job.start_from != "absolute" or any(job.offset_mm):
        shift = np.array([*job.offset_mm, 0.0])
        if job.start_from != "absolute":
            lows = np.min([p.bounds(p.laser_on)[0] for p in parts], axis=0)
            shift[:2] -= lows[:2]
        parts = [_shift(p, shift) for p in parts]
    moves = _chain(parts)
    moves.start[0] = home                    # the first move leaves from there, not from a placed copy
    if job.start_from == "current":
        from labkit.toolpath.moves import Record

        # written as they stand, before the first move and after the last (as a $ line is)
        moves.records = ((Record(0, 0, "system", "G92 X0 Y0"),) + tuple(moves.records)
                         + (Record(0, len(moves), "system", "G92.1"),))
    for d, p in zip(info, parts):
        b = p.bounds(p.laser_on)
        d["bounds_mm"] = [[round(float(v), 4) for v in b[0][:2]], [round(float(v), 4) for v in b[1][:2]]]
    if not all(math.isfinite(v) for d in info for row in d["bounds_mm"] for v in row):
        raise InputError(f"{job.path}: a layer burns nothing")
    return ComposedJob(moves=moves, layers=info, tol_mm=job.tol_mm, warnings=warned)


# --- tabs and perforation: uncut gaps along a cut -------------------------------------------------

def _arclength(points):
    import numpy as np

    return np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(points, axis=0).T))])


def tab_gaps(points, count: int, length_mm: float, *, corner_deg: float = 30.0):
    """Where ``count`` tabs of ``length_mm`` go on a closed polyline: (start, end) arc lengths, mm.

    The tabs are spread evenly along the perimeter; a tab whose span, widened by one tab length on
    each side, holds a corner (a turn sharper than ``corner_deg``) slides along the outline to the
    nearest position clear of corners (a tab on a corner breaks as the part is pushed out and leaves
    a nub where the part should be square). Where no clear position exists the even one is kept.

    Parameters
    ----------
    points : ndarray, shape (n, 2)
        The closed polyline, first point repeated at the end, mm.
    count : int
        Tabs on this shape (>= 1).
    length_mm : float
        Each tab's length along the path, mm.

    Returns
    -------
    list of (float, float)
        Sorted; arc lengths from the first point, each within 0…perimeter (a gap may wrap past the end).

    Examples
    --------
    >>> import numpy as np
    >>> square = np.array([[0, 0], [40, 0], [40, 40], [0, 40], [0, 0]], float)
    >>> tab_gaps(square, 4, 2.0)
    [(19.0, 21.0), (59.0, 61.0), (99.0, 101.0), (139.0, 141.0)]
    """
    import numpy as np

    pts = np.asarray(points, float)
    s = _arclength(pts)
    perimeter = float(s[-1])
    if count < 1 or not length_mm > 0:
        raise InputError(f"tabs: {count} of {length_mm!r} mm; expected a whole number >= 1 of a length > 0")
    if count * length_mm >= perimeter:
        raise InputError(f"tabs: {count} × {length_mm:g} mm do not fit on a shape {perimeter:.3g} mm round")
    d_in = pts[1:-1] - pts[:-2]
    d_out = pts[2:] - pts[1:-1]
    turn = np.degrees(np.abs(np.arctan2(d_in[:, 0] * d_out[:, 1] - d_in[:, 1] * d_out[:, 0],
                                        (d_in * d_out).sum(axis=1))))
    corners = list(s[1:-1][turn > corner_deg])
    d0, d1 = pts[1] - pts[0], pts[0] - pts[-2]          # the closing vertex
    if abs(np.degrees(np.arctan2(d1[0] * d0[1] - d1[1] * d0[0], (d1 * d0).sum()))) > corner_deg:
        corners.append(0.0)
    corners = np.array(corners)
    clear = 1.5 * length_mm                              # half the tab plus one tab length

    def blocked(c):
        if not len(corners):
            return False
        d = np.abs(((corners - c) + perimeter / 2) % perimeter - perimeter / 2)
        return bool((d < clear).any())

    step = perimeter / 400
    gaps = []
    for k in range(count):
        centre = (k + 0.5) * perimeter / count
        best = centre
        for j in range(200):                             # search both ways, nearest first
            found = [c for c in (centre + j * step, centre - j * step) if not blocked(c % perimeter)]
            if found:
                best = found[0] % perimeter
                break
        gaps.append((best - length_mm / 2, best + length_mm / 2))
    return sorted((a % perimeter, (a % perimeter) + length_mm) for a, _ in gaps)


def perforation_gaps(points, cut_mm: float, skip_mm: float):
    """The skipped spans of a cut/skip dash pattern along a polyline: (start, end) arc lengths, mm.

    >>> import numpy as np
    >>> perforation_gaps(np.array([[0, 0], [10, 0]], float), 2.0, 1.0)
    [(2.0, 3.0), (5.0, 6.0), (8.0, 9.0)]
    """
    import numpy as np

    if not (cut_mm > 0 and skip_mm > 0):
        raise InputError(f"perforation: cut {cut_mm!r} mm, skip {skip_mm!r} mm; expected two lengths > 0")
    total = float(_arclength(np.asarray(points, float))[-1])
    starts = np.arange(cut_mm, total, cut_mm + skip_mm)
    return [(float(a), float(min(a + skip_mm, total))) for a in starts]


def split_at_gaps(points, gaps, *, closed: bool):
    """The pieces of a polyline left when the spans ``gaps`` (arc lengths, mm) are not cut.

    A closed polyline's piece that runs past the end continues from its start, so the cut keeps
    one direction. Returns a list of (k, 2) arrays in cutting order.
    """
    import numpy as np

    pts = np.asarray(points, float)
    s = _arclength(pts)
    total = float(s[-1])

    def at(t):
        return np.array([np.interp(t, s, pts[:, 0]), np.interp(t, s, pts[:, 1])])

    def piece(a, b):
        inner = (s > a) & (s < b)
        return np.vstack([at(a), pts[inner], at(b)])

    gaps = sorted(gaps)
    if not gaps:
        return [pts]
    spans = []
    if closed:
        wrap_end = gaps[0][0] + total                       # cut from the last gap round to the first
        for (_, b), (a2, _) in zip(gaps, gaps[1:] + [(wrap_end, None)]):
            spans.append((b, a2))
    else:
        edges = [0.0] + [v for g in gaps for v in g] + [total]
        spans = [(edges[i], edges[i + 1]) for i in range(0, len(edges), 2)]
    out = []
    for a, b in spans:
        if b - a <= 1e-9:
            continue
        if closed and b > total:
            first, second = piece(a, total) if a < total else None, piece(max(a - total, 0.0), b - total)
            parts = [q for q in (first, second) if q is not None]
            out.append(np.vstack([parts[0], parts[1][1:]]) if len(parts) == 2 else parts[0])
        elif closed and a >= total:
            out.append(piece(a - total, b - total))
        else:
            out.append(piece(a, b))
    return out
