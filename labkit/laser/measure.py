"""Widths of burned test-grid lines from a scan: registration on the corner fiducials, then profiles.

The scan is a grey image (paper light, burn dark) at a known dpi. The four corner
crosses of :func:`labkit.laser.patterns.grid_pattern` are the dark blobs
furthest towards the image's corners; a similarity transform (rotation, scale,
shift — :class:`skimage.transform.SimilarityTransform`) from their layout
positions to their centroids places every line. The crosses alone are symmetric:
a piece turned 180° on the scanner fits them as well as an upright one. The
engraved row and column numbers are not (rows on the left, columns on top), so
the orientation is the one that finds them where the layout puts them.
Across each line, at many stations along it, the darkness (0 paper … 1 burn) is
integrated over the row pitch: the integral is the width, and it does not depend
on blur or anti-aliasing, which only move darkness sideways.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy import ndimage
from skimage import filters, measure, transform

from labkit.errors import InputError

__all__ = ["render_scan", "register", "measure_lines", "scale_from_reference", "read_widths", "read_table",
           "check_layout", "REQUIRED", "WIDTHS_FORMAT", "WIDTHS_VERSION", "WIDTHS_HEADER"]

#: Columns a widths table must have to be fitted (the tidy format of ``data/cutwidth/README.md``).
REQUIRED = ("power_mw", "speed_mm_min", "width_mm")
#: The widths table's format and version, stated on its first line as ``# labkit-cutwidth-table
#: version 2`` (:data:`WIDTHS_HEADER`). Version 2 names the S word column ``s_word``; version 1
#: (a table without that line, as the files of ``data/cutwidth/``) named it ``power_s``.
WIDTHS_FORMAT = "labkit-cutwidth-table"
WIDTHS_VERSION = 2
#: The first line of a widths table labkit writes.
WIDTHS_HEADER = f"# {WIDTHS_FORMAT} version {WIDTHS_VERSION}"

_MM_PER_INCH = 25.4


def _segments(layout, widths_mm, fiducial_width_mm):
    segs = [(d["x0_mm"], d["y_mm"], d["x1_mm"], d["y_mm"], w) for d, w in zip(layout["lines"], widths_mm)]
    h = layout["fiducial_mm"]
    for fx, fy in layout["fiducials_mm"]:
        segs += [(fx - h, fy, fx + h, fy, fiducial_width_mm), (fx, fy - h, fx, fy + h, fiducial_width_mm)]
    segs += [(*s, fiducial_width_mm) for s in _label_strokes(layout)]
    return np.asarray(segs, float)


def _label_strokes(layout, kind: str | None = None) -> np.ndarray:
    """The engraved numbers (of one ``kind``, "row" or "col", or all) as strokes (x0, y0, x1, y1), mm."""
    from labkit.laser.patterns import stroke_digits

    h = layout.get("label_mm", 0.0)
    strokes = []
    for lab in layout.get("labels", []) if h > 0 else []:
        if kind is not None and lab.get("kind") != kind:
            continue
        for poly in stroke_digits(lab["text"], x_mm=lab["x_mm"], y_mm=lab["y_mm"], height_mm=h):
            strokes += [(*a, *b) for a, b in zip(poly[:-1], poly[1:])]
    return np.asarray(strokes, float).reshape(-1, 4)


def _what(value) -> str:
    return f"{value!r} (text)" if isinstance(value, str) else repr(value)


def _field_number(obj, key, name, where, *, lo=None, lo_open=False, whole=False):
    """``obj[key]`` as a finite float (within the bound), or an InputError naming ``name``."""
    if key not in obj:
        raise InputError(f"{where}{name} is missing; expected a number")
    v = obj[key]
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v):
        raise InputError(f"{where}{name} is {_what(v)}; expected a finite number")
    if whole and v != int(v):
        raise InputError(f"{where}{name} is {v!r}; expected a whole number")
    if lo is not None and (v <= lo if lo_open else v < lo):
        raise InputError(f"{where}{name} is {v!r}; expected a number {'>' if lo_open else '>='} {lo:g}")
    return float(v)


def check_layout(layout, *, source=None) -> dict:
    """Return ``layout`` in the current version if it is a usable test-grid layout, else name
    the field that is not.

    A layout is written by :func:`labkit.laser.patterns.write_pattern`; a hand-edited
    one may miss fields, hold numbers as text, NaN or an empty line list: each is
    refused here, before any of it is used. Both versions are read: version 2 (what
    labkit writes, :data:`labkit.laser.patterns.LAYOUT_VERSION`) and version 1, whose lines
    name the S word ``power_s`` (a layout without a version is version 1); a version 1
    layout comes back as a version 2 copy, the file's dict untouched.

    Parameters
    ----------
    layout : dict
        The parsed layout JSON.
    source : str or os.PathLike, optional
        The file it came from, for the message.

    Returns
    -------
    dict
        ``layout`` itself (version 2), or its version 2 copy (version 1).

    Raises
    ------
    InputError
        Naming the field (``lines[3].x1_mm``, ``pitch_mm``, ``fiducials_mm[2]`` …),
        what it holds and what was expected.

    Examples
    --------
    >>> check_layout({"lines": []}, source="GRID.json")
    Traceback (most recent call last):
    ...
    labkit.errors.InputError: GRID.json: lines is empty; expected at least one burned line
    """
    where = f"{source}: " if source is not None else "layout: "
    if not isinstance(layout, dict):
        raise InputError(f"{where}not a cut-width layout (a JSON object with 'lines'); "
                         "write one with 'labkit cutwidth pattern'")
    if "lines" not in layout:
        raise InputError(f"{where}not a cut-width layout (no 'lines'); write one with 'labkit cutwidth pattern'")
    from labkit.laser.patterns import LAYOUT_VERSION

    version = layout.get("version", 1)
    if version not in (1, LAYOUT_VERSION):
        raise InputError(f"{where}layout version {_what(version)}; this labkit reads versions 1 and "
                         f"{LAYOUT_VERSION}")
    s_key = "s_word" if version == LAYOUT_VERSION else "power_s"      # version 1's name
    lines = layout["lines"]
    if not isinstance(lines, list):
        raise InputError(f"{where}lines is {_what(lines)}; expected a list of burned lines")
    if not lines:
        raise InputError(f"{where}lines is empty; expected at least one burned line")
    for i, d in enumerate(lines):
        name = f"lines[{i}]"
        if not isinstance(d, dict):
            raise InputError(f"{where}{name} is {_what(d)}; expected an object with x0_mm, x1_mm, y_mm, "
                             "power_mw, speed_mm_min, …")
        x0 = _field_number(d, "x0_mm", f"{name}.x0_mm", where)
        x1 = _field_number(d, "x1_mm", f"{name}.x1_mm", where)
        _field_number(d, "y_mm", f"{name}.y_mm", where)
        if not x1 > x0:
            raise InputError(f"{where}{name}: x1_mm ({x1:g}) is not beyond x0_mm ({x0:g}); "
                             "expected a line burned in +X")
        for key in ("power_mw", "speed_mm_min"):
            _field_number(d, key, f"{name}.{key}", where, lo=0, lo_open=True)
        _field_number(d, s_key, f"{name}.{s_key}", where, lo=0)
        for key in ("row", "col", "repeat"):
            _field_number(d, key, f"{name}.{key}", where, lo=0, whole=True)
    _field_number(layout, "pitch_mm", "pitch_mm", where, lo=0, lo_open=True)
    _field_number(layout, "fiducial_mm", "fiducial_mm", where, lo=0)
    fid = layout.get("fiducials_mm")
    if not isinstance(fid, list) or len(fid) != 4:
        raise InputError(f"{where}fiducials_mm is {'missing' if fid is None else _what(fid)}; "
                         "expected the four corner crosses as [[x, y], …] in mm")
    for k, f in enumerate(fid):
        if not isinstance(f, list) or len(f) != 2:
            raise InputError(f"{where}fiducials_mm[{k}] is {_what(f)}; expected [x, y] in mm")
        for j, axis in enumerate("xy"):
            _field_number(dict(enumerate(f)), j, f"fiducials_mm[{k}] {axis}", where)
    if "bounds_mm" in layout:
        b = layout["bounds_mm"]
        if not isinstance(b, list) or len(b) != 4:
            raise InputError(f"{where}bounds_mm is {_what(b)}; expected [x_min, y_min, x_max, y_max] in mm")
        for j in range(4):
            _field_number(dict(enumerate(b)), j, f"bounds_mm[{j}]", where)
    labels = layout.get("labels", [])
    if not isinstance(labels, list):
        raise InputError(f"{where}labels is {_what(labels)}; expected a list of engraved numbers")
    if labels:
        _field_number(layout, "label_mm", "label_mm", where, lo=0)
    for k, lab in enumerate(labels):
        if not isinstance(lab, dict):
            raise InputError(f"{where}labels[{k}] is {_what(lab)}; expected an object with text, x_mm, y_mm")
        text = lab.get("text")
        if not (isinstance(text, str) and text.isdigit() and text.isascii()):
            raise InputError(f"{where}labels[{k}].text is {'missing' if text is None else _what(text)}; "
                             "expected digits")
        for key in ("x_mm", "y_mm"):
            _field_number(lab, key, f"labels[{k}].{key}", where)
        if lab.get("kind") not in ("row", "col"):
            raise InputError(f"{where}labels[{k}].kind is {_what(lab.get('kind'))}; expected 'row' or 'col' "
                             "(the numbers left of the rows, above the columns)")
    if version != LAYOUT_VERSION:
        layout = dict(layout, version=LAYOUT_VERSION,
                      lines=[{("s_word" if k == "power_s" else k): v for k, v in d.items()} for d in lines])
    return layout


def render_scan(layout: dict, widths_mm, *, dpi: float = 600.0, rotation_deg: float = 0.0,
                margin_mm: float = 5.0, noise: float = 0.0, blur_px: float = 0.0,
                fiducial_width_mm: float = 0.3, seed: int = 0) -> np.ndarray:
    """A synthetic scan of a burned grid with known widths (paper 0.9, burn 0.1).

    Parameters
    ----------
    layout : dict
        From :func:`labkit.laser.patterns.grid_pattern`.
    widths_mm : array_like
        Burned width of each layout line, mm (0: did not burn).
    dpi : float
        Scan resolution, dots per inch.
    rotation_deg : float
        Rotation of the piece on the scanner, degrees counter-clockwise.
    margin_mm : float
        Paper around the pattern, mm.
    noise : float
        Standard deviation of additive Gaussian noise (grey levels 0…1).
    blur_px : float
        Gaussian blur sigma, pixels.
    fiducial_width_mm : float
        Line width of the corner crosses and the engraved numbers, mm.
    seed : int
        Noise generator seed.

    Returns
    -------
    ndarray, shape (rows, cols), float in [0, 1]
    """
    layout = check_layout(layout)
    px = _MM_PER_INCH / dpi
    segs = _segments(layout, np.asarray(widths_mm, float), fiducial_width_mm)
    x_lo, y_lo, x_hi, y_hi = layout["bounds_mm"]
    cx, cy = (x_lo + x_hi) / 2, (y_lo + y_hi) / 2
    half = np.hypot(x_hi - x_lo, y_hi - y_lo) / 2 + margin_mm
    n = int(np.ceil(2 * half / px))
    # pixel centres → mm in the layout frame (image rows go down, layout y goes up)
    u = (np.arange(n) + 0.5) * px - half
    uu, vv = np.meshgrid(u, -u)
    t = np.deg2rad(rotation_deg)
    x = cx + np.cos(t) * uu + np.sin(t) * vv
    y = cy - np.sin(t) * uu + np.cos(t) * vv
    dark = np.zeros((n, n))
    c, s = np.cos(t), np.sin(t)
    for x0, y0, x1, y1, w in segs:
        if w <= 0:
            continue
        # only the pixels near the stroke can be dark: its end points' pixels, widened by the
        # half width and two pixels (coverage is 0 from half a pixel beyond the edge on)
        ex, ey = np.array([x0, x1]) - cx, np.array([y0, y1]) - cy
        col = (c * ex - s * ey + half) / px - 0.5
        row = (-(s * ex + c * ey) + half) / px - 0.5
        reach = w / 2 / px + 2
        r0, r1 = max(int(row.min() - reach), 0), min(int(np.ceil(row.max() + reach)) + 1, n)
        c0, c1 = max(int(col.min() - reach), 0), min(int(np.ceil(col.max() + reach)) + 1, n)
        if r0 >= r1 or c0 >= c1:
            continue
        xs, ys = x[r0:r1, c0:c1], y[r0:r1, c0:c1]
        d = np.array([x1 - x0, y1 - y0]); L = np.hypot(*d); d /= L
        along = np.clip((xs - x0) * d[0] + (ys - y0) * d[1], 0, L)
        dist = np.hypot(xs - (x0 + along * d[0]), ys - (y0 + along * d[1]))
        # area coverage of a pixel by the stroke edge, linear over one pixel
        window = dark[r0:r1, c0:c1]
        np.maximum(window, np.clip(0.5 + (w / 2 - dist) / px, 0, 1), out=window)
    # paper 0.9 and burn 0.1 keep noise away from the 0/1 clip, which would bias it
    img = 0.9 - 0.8 * dark
    if blur_px > 0:
        img = ndimage.gaussian_filter(img, blur_px)
    if noise > 0:
        img = img + np.random.default_rng(seed).normal(0, noise, img.shape)
    return np.clip(img, 0, 1)


def register(image, layout: dict) -> transform.SimilarityTransform:
    """Layout mm (x, y up) → image pixels (column, row), from the four corner fiducials.

    The four crosses are the dark blobs furthest towards the image's corners. The
    piece may lie on the scanner turned by any multiple of 90° (plus a small skew):
    each turn that fits the crosses is a candidate, and the engraved row and column
    numbers decide — the right turn finds their strokes dark where the layout puts
    them. The transform's ``rotation`` then says how the scan was turned (about π
    for a piece upside down).

    Parameters
    ----------
    image : ndarray
        Grey scan (paper light, burn dark).
    layout : dict
        From :func:`labkit.laser.patterns.grid_pattern` (checked by :func:`check_layout`).

    Returns
    -------
    skimage.transform.SimilarityTransform

    Raises
    ------
    InputError
        When the image does not show four separate dark blobs at its corners, they
        do not form the layout's rectangle, or the engraved numbers are not found
        at any turn (a mirrored scan, or another grid's). A layout without
        numbers (``label_mm`` 0) cannot be checked: its scan is taken as upright.
    """
    layout = check_layout(layout)
    img = np.asarray(image, float)
    fid = np.asarray(layout["fiducials_mm"], float)
    dark = img < filters.threshold_otsu(img)
    props = measure.regionprops(measure.label(dark))
    if len(props) < 4:
        raise InputError(f"the scan shows {len(props)} dark blobs; the grid's four corner crosses were not found")
    cent = np.array([p.centroid[::-1] for p in props])          # (col, row)
    mm = fid * [1, -1]                                           # y up → rows down
    found = []
    for f in mm:
        # the fiducial towards this corner is the blob furthest along the corner's direction
        s = np.sign(f - mm.mean(axis=0))
        found.append(cent[np.argmax(cent @ s)])
    found = np.array(found)
    # the row numbers (left) and the column numbers (top) are checked apart: a mirrored scan
    # can put one set back in place, never both
    strokes = [s for s in (_label_strokes(layout, "row"), _label_strokes(layout, "col")) if len(s)]
    fits = []
    # the fiducials go round the grid (lower left, lower right, upper right, upper left):
    # a piece turned by k quarter turns puts layout corner i where blob i + k was found
    for turn in range(4) if len(strokes) else (0,):
        tf = transform.SimilarityTransform.from_estimate(mm, np.roll(found, -turn, axis=0))
        if tf and np.hypot(*(tf(mm) - np.roll(found, -turn, axis=0)).T).max() <= 0.02 * np.hypot(*img.shape):
            fits.append(tf)
    if not fits:
        raise InputError("the corner crosses do not form the layout's rectangle; the grid was not found")
    if not len(strokes):
        return fits[0]
    seen = [min(_share_dark(dark, tf, s) for s in strokes) for tf in fits]
    best = int(np.argmax(seen))
    others = max(seen[:best] + seen[best + 1:], default=0.0)
    if seen[best] < 0.6 or others > 0.5 * seen[best]:
        raise InputError(f"the engraved row and column numbers are not where the layout puts them, whichever "
                         f"way the scan is turned (at most {100 * seen[best]:.0f} % of either's strokes found); "
                         "expected a scan of this layout's grid, not mirrored (scanned through the back)")
    return fits[best]


def _share_dark(dark, tf, strokes) -> float:
    """Share of points along ``strokes`` (mm) that ``tf`` puts on dark pixels (or next to one)."""
    step = 0.5 / tf.scale                                        # half a pixel, mm
    pts = []
    for x0, y0, x1, y1 in strokes:
        n = max(2, int(np.hypot(x1 - x0, y1 - y0) / step))
        t = np.linspace(0.0, 1.0, n)[:, None]
        pts.append(np.column_stack([x0 + t[:, 0] * (x1 - x0), y0 + t[:, 0] * (y1 - y0)]))
    px = np.floor(tf(np.vstack(pts) * [1, -1])).astype(int)     # pixel (col, row) holding each point
    near = ndimage.binary_dilation(dark, np.ones((3, 3), bool))  # a pixel of registration error is allowed
    inside = (px[:, 0] >= 0) & (px[:, 0] < dark.shape[1]) & (px[:, 1] >= 0) & (px[:, 1] < dark.shape[0])
    hit = np.zeros(len(px), bool)
    hit[inside] = near[px[inside, 1], px[inside, 0]]
    return float(hit.mean())


def scale_from_reference(p0_px, p1_px, length_mm: float) -> float:
    """Scan resolution (dpi) from a length marked in the image.

    Parameters
    ----------
    p0_px, p1_px : (float, float)
        The ends of the marked length, pixels (column, row) — for example the
        ends of a ruler's 50 mm, clicked in an image viewer.
    length_mm : float
        Its true length, mm.

    Returns
    -------
    float
        Dots per inch.

    Examples
    --------
    600 px across a 25.4 mm inch is 600 dpi, whichever way the ruler lies.

    >>> round(scale_from_reference((10, 10), (10 + 360, 10 + 480), 25.4), 9)
    600.0
    """
    d = float(np.hypot(p1_px[0] - p0_px[0], p1_px[1] - p0_px[1]))
    if not (np.isfinite(length_mm) and length_mm > 0):
        raise InputError(f"the reference length must be > 0 mm, got {length_mm!r}")
    if not d > 0:
        raise InputError("the reference length's two ends are the same pixel")
    return d / length_mm * _MM_PER_INCH


def _median_level(values) -> float:
    """The median grey level, read between the grey steps of an 8-bit scan.

    An 8-bit scan's plain median is a whole step (1/255), up to half a step off
    the level it estimates; that offset moved paper or burn alike under every
    line, and every width with it (−3.5 µm at 600 dpi on a rotated, noisy
    round trip). Where the values sit on the 1/255 grid, the median is
    interpolated within its step as for grouped data (the step's lower edge
    plus the share of the step's count needed to reach half the pixels); other
    images take the plain median.

    >>> _median_level(np.array([0, 1, 1, 1, 2]) / 255) * 255
    1.0
    >>> round(_median_level(np.array([1, 1, 2, 2, 2, 2]) / 255) * 255, 6)
    1.75
    """
    v = np.asarray(values, float).ravel()
    steps = np.rint(v * 255.0)
    if not np.allclose(v * 255.0, steps, rtol=0, atol=1e-6):
        return float(np.median(v))
    levels, counts = np.unique(steps, return_counts=True)
    below = np.cumsum(counts) - counts                           # pixels under each step
    k = int(np.searchsorted(np.cumsum(counts), len(v) / 2.0))    # the step holding the middle pixel
    return float((levels[k] - 0.5 + (len(v) / 2.0 - below[k]) / counts[k]) / 255.0)


def _ink_level(img):
    """Grey level of a full burn: the darkest median over the dark pixels k pixels inside a burn.

    Edge pixels are partly paper, the more so the more the scan is blurred; a
    low percentile of all dark pixels is pulled darker by noise. The median
    of the pixels at least k pixels inside the burned areas is not moved by
    noise, and darkens as k grows until the blur no longer reaches in: the
    darkest of those medians (each over at least 200 pixels) is the burn's
    level. Falls back to the darkest tenth of the dark pixels when no burn is
    that wide (only hairlines).
    """
    dark = img < filters.threshold_otsu(img)
    region = ndimage.binary_closing(dark)
    medians = []
    for _ in range(12):
        region = ndimage.binary_erosion(region)
        if region.sum() < 200:
            break
        medians.append(_median_level(img[region]))
    return min(medians) if medians else float(np.percentile(img[dark], 10))


def measure_lines(image, layout: dict, *, dpi: float | None = None, stations: int = 40,
                  min_burned: float = 0.5, transform=None):
    """Width profile of every layout line in a scan.

    Parameters
    ----------
    image : ndarray
        Grey scan (paper light, burn dark; any scale).
    layout : dict
        From :func:`labkit.laser.patterns.grid_pattern`.
    dpi : float, optional
        Scan resolution (from the file, or :func:`scale_from_reference`), used to
        check the registered scale (±20 %). None: the scale is the one the
        corner crosses give — their distances in the layout are a reference
        length burned into the piece.
    stations : int
        Profiles taken along each line (its central 80 %).
    min_burned : float
        Fraction of stations that must show a burn for the line to count as burned.
    transform : skimage.transform.SimilarityTransform, optional
        Layout → pixels, from :func:`register` (default: registered here).

    Returns
    -------
    pandas.DataFrame
        One row per line: its layout fields, ``width_mm`` (mean, 0 when not
        burned), ``width_sd_mm``, ``burned_fraction``, ``burned``.
    """
    layout = check_layout(layout)
    img = np.asarray(image, float)
    if img.ndim == 3:
        img = img[..., :3].mean(axis=2)
    if not np.ptp(img) > 0:
        raise InputError("the scan is blank: the grid cannot be found")
    # paper is most of the image; the burn level is the darkest tenth of the dark class.
    # Darkness is not clipped: noise must average out across the profile, not add up.
    paper = _median_level(img)
    ink = _ink_level(img)
    darkness = (paper - img) / (paper - ink)
    tf = register(img, layout) if transform is None else transform
    px_per_mm = tf.scale
    if dpi is not None and abs(px_per_mm / (dpi / _MM_PER_INCH) - 1) > 0.2:
        raise InputError(f"the registered scale ({px_per_mm * _MM_PER_INCH:.0f} dpi) disagrees with dpi={dpi:g}")
    half = layout["pitch_mm"] / 2
    step = 0.25 / px_per_mm                    # quarter-pixel sampling across the line, mm
    across = np.arange(-half, half + step / 2, step)
    rows = []
    for d in layout["lines"]:
        L = d["x1_mm"] - d["x0_mm"]
        xs = d["x0_mm"] + L * np.linspace(0.1, 0.9, stations)
        X, Y = np.meshgrid(xs, d["y_mm"] + across, indexing="ij")
        pix = tf(np.column_stack([X.ravel(), -Y.ravel()]))
        vals = ndimage.map_coordinates(darkness, [pix[:, 1] - 0.5, pix[:, 0] - 0.5], order=1)
        # rows of the image are pixel centres at index + 0.5 in the transform's frame
        width = vals.reshape(X.shape).sum(axis=1) * step
        burnt = width > 0.5 / px_per_mm
        frac = float(burnt.mean())
        ok = frac >= min_burned
        rows.append(dict(d, width_mm=float(width[burnt].mean()) if ok else 0.0,
                         width_sd_mm=float(width[burnt].std()) if ok else 0.0,
                         burned_fraction=frac, burned=bool(ok)))
    return pd.DataFrame(rows)


def _leading_comments(path) -> list[str]:
    """The lines starting with ``#`` at the head of a text file."""
    comments = []
    with open(path, encoding="utf-8") as fh:
        for line in fh:
            if not line.startswith("#"):
                break
            comments.append(line.rstrip("\r\n"))
    return comments


def read_table(path, required, *, optional=(), what: str = "CSV"):
    """A CSV table whose ``required`` (and present ``optional``) columns must hold numbers.

    Leading lines starting with ``#`` are comments (the SYNTHETIC marks of
    ``data/cutwidth/``, a table's format and version); ``#`` elsewhere is data.

    Raises
    ------
    InputError
        Not a CSV; a required column missing (named, with those present); a
        cell that is not a number (file:line and column).
    """
    from labkit._files import check_input_file

    path = check_input_file(path, what=what)
    skip = len(_leading_comments(path))
    try:
        df = pd.read_csv(path, skiprows=skip)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: not a CSV table ({str(exc).splitlines()[0]})") from None
    for col in required:
        if col not in df.columns:
            raise InputError(f"{path}: column '{col}' is missing (have: {', '.join(map(str, df.columns))}); "
                             f"expected {', '.join(required)}")
    for col in [*required, *(c for c in optional if c in df.columns)]:
        values = pd.to_numeric(df[col], errors="coerce")
        bad = values.isna()
        if bad.any():
            k = int(bad.to_numpy().argmax())
            raise InputError(f"{path}:{skip + k + 2}: column '{col}' holds {df[col].iloc[k]!r}; expected a number")
        df[col] = values
    return df


def read_widths(path):
    """A tidy widths CSV (``data/cutwidth/README.md``) as a DataFrame, in the current version.

    Version 2 (:data:`WIDTHS_HEADER` on its first line, what ``labkit cutwidth measure`` writes)
    and version 1 (no such line; its S word column ``power_s`` comes back as ``s_word``) are read.

    Raises
    ------
    InputError
        A required column (``power_mw``, ``speed_mm_min``, ``width_mm``) is
        missing — named — or holds something other than numbers; a version this labkit
        does not read.

    Examples
    --------
    >>> from pathlib import Path
    >>> old = read_widths(Path(__file__).parents[2] / "data/cutwidth/synthetic_paperboard.csv")
    >>> "s_word" in old.columns, "power_s" in old.columns       # a version 1 file
    (True, False)
    """
    from labkit._files import check_input_file

    path = check_input_file(path, what="widths CSV")
    version = 1
    for line in _leading_comments(path):
        words = line.lstrip("#").split()
        if words[:2] == [WIDTHS_FORMAT, "version"]:
            version = int(words[2]) if len(words) > 2 and words[2].isdigit() else None
            if version not in (1, WIDTHS_VERSION):
                raise InputError(f"{path}: {line.lstrip('# ')}; this labkit reads versions 1 and {WIDTHS_VERSION}")
    df = read_table(path, REQUIRED, what="widths CSV")
    return df.rename(columns={"power_s": "s_word"}) if version == 1 else df
