"""SVG ``<text>`` as the glyph outlines a renderer draws.

A ``<text>`` element is a tree of runs: its own characters, its ``<tspan>`` children (Inkscape
writes one per line, with a nested one for a word in another weight) and the text after each
child (a *tail*). svgelements keeps each ``text``/``tspan`` as a flat element in the order its
tag closes and drops the tails, so before it parses the document :func:`mark_runs` (called by
``_svg_scan.render_only``) wraps every tail in a ``<tspan>`` of its own and numbers the runs
in document order. :func:`glyph_outlines` then lays the runs out as SVG 1.1 §10 does:

* white space: newlines and tabs become spaces; runs of spaces collapse to one and the
  text's leading and trailing spaces go, unless ``xml:space="preserve"``;
* the pen starts at the text's ``x``, ``y``; a run's own ``x``/``y`` moves it there (a list
  places characters one by one), ``dx``/``dy`` shift it; each run advances it by the
  glyphs' advances with the font's kerning;
* ``text-anchor`` (start, middle, end) shifts each chunk (from one absolute ``x`` to the
  next) by none, half or all of its advance;
* each run's glyphs come from its own font (``font-family`` list, ``font-weight``,
  ``font-style``, ``font-size``) through matplotlib's font manager and ``TextPath`` —
  a family list with nothing installed is an :class:`~labkit.errors.InputError` naming it.

* ``letter-spacing`` is added after every character and ``word-spacing`` after every space.

Not drawn (named by the reader): text on a path (``textPath``). ``rotate`` on characters is
not applied (named in a warning).
"""

from __future__ import annotations

import functools
import re
import warnings

import numpy as np

from labkit.budget import check_budget
from labkit.errors import InputError

__all__ = ["RUN_ATTR", "mark_runs", "run_key", "glyph_outlines", "svg_text_paths"]

#: The attribute :func:`mark_runs` numbers runs with: ``"<text index>.<run index>"``.
RUN_ATTR = "data-labkit-run"
_XML_SPACE = "{http://www.w3.org/XML/1998/namespace}space"
_NUMBERS = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?[a-z%]*")


def mark_runs(text, index: int) -> bool:
    """Number the runs of one ``<text>`` (an ElementTree element) in document order, in place.

    Every tail becomes a ``<tspan>`` of its own right after the element it follows, so it keeps
    its parent's style and its place. Returns True when the text holds a ``textPath`` (not
    drawn).

    Examples
    --------
    >>> import xml.etree.ElementTree as ET
    >>> t = ET.fromstring('<text>a<tspan>b</tspan>c</text>')
    >>> mark_runs(t, 0)
    False
    >>> [(el.tag, el.text, el.get(RUN_ATTR)) for el in t.iter()]
    [('text', 'a', '0.0'), ('tspan', 'b', '0.1'), ('tspan', 'c', '0.2')]
    """
    import xml.etree.ElementTree as ET

    tspan = text.tag[: -len("text")] + "tspan"          # the same namespace as the text
    count, on_path = 0, False
    todo = [text]
    while todo:                                         # pre-order, iterative
        el = todo.pop()
        if not isinstance(el.tag, str):
            continue
        if el.tag.rsplit("}", 1)[-1] == "textPath":
            on_path = True
        el.set(RUN_ATTR, f"{index}.{count}")
        count += 1
        children = [c for c in el if isinstance(c.tag, str)]
        for child in children:
            if child.tail:
                tail = ET.Element(tspan)
                tail.text, child.tail = child.tail, None
                el.insert(list(el).index(child) + 1, tail)
        todo.extend(reversed([c for c in el if isinstance(c.tag, str)]))
    return on_path


def run_key(el) -> tuple[str, int, bool]:
    """(text index, run index, is the ``<text>`` itself) of a run svgelements made."""
    attrs = el.values.get("attributes") or {}
    mark = str(attrs.get(RUN_ATTR, "-1.0"))
    text, _, run = mark.partition(".")
    return text, int(run or 0), attrs.get("tag") == "text"


def _own(el, key):
    """The run's own attribute (never its parent's), or None."""
    return (el.values.get("attributes") or {}).get(key)


def _lengths(value) -> list[float]:
    """An SVG length list (``"10 12.5mm"``) in user units."""
    import svgelements as se

    if value is None:
        return []
    out = []
    for token in _NUMBERS.findall(str(value)):
        try:
            out.append(float(se.Length(token).value(ppi=96.0)))
        except (ValueError, TypeError):
            raise InputError(f"text position {value!r}: {token!r} is not a length in user units") from None
    return out


def _spacing(el, key: str) -> float:
    """``letter-spacing`` or ``word-spacing`` (inherited) in user units; ``normal`` is 0."""
    value = str(el.values.get(key) or "normal").strip()
    if value == "normal":
        return 0.0
    found = _lengths(value)
    return found[0] if found else 0.0


def _collapse(texts: list[str], preserve: bool) -> list[str]:
    """SVG white space over a text's runs (collapsing runs across run boundaries)."""
    texts = [re.sub(r"[\n\r\t]", " ", t or "") for t in texts]
    if preserve:
        return texts
    out, space = [], True                    # True: a space here would be leading or doubled
    for t in texts:
        kept = []
        for ch in t:
            if ch == " ":
                if space:
                    continue
                space = True
            else:
                space = False
            kept.append(ch)
        out.append("".join(kept))
    for i in range(len(out) - 1, -1, -1):    # the text's trailing space
        if out[i]:
            out[i] = out[i].rstrip(" ")
            if out[i]:
                break
    return out


def _font(el, source: str, label: str, sample: str):
    """The run's font: (FontProperties, size in user units, font file)."""
    from matplotlib.font_manager import FontProperties, findfont

    families = [f.strip().strip("'\"") for f in str(el.font_family or "sans-serif").split(",") if f.strip()]
    weight = str(el.font_weight or "normal").strip().lower()
    weight = {"bolder": "bold", "lighter": "light"}.get(weight, weight)
    style = str(el.font_style or "normal").strip().lower()
    try:
        size = float(el.font_size)
    except (TypeError, ValueError):
        raise InputError(f"{source}: {label} ({sample!r}): font-size {el.font_size!r} is not a length; "
                         "expected a size such as 12px or 4mm") from None
    prop = FontProperties(family=families, weight=int(weight) if weight.isdigit() else weight,
                          style=style if style in ("normal", "italic", "oblique") else "normal")
    try:
        path = findfont(prop, fallback_to_default=False)
    except ValueError:
        raise InputError(f"{source}: {label} ({sample!r}): font {', '.join(families)!r} is not installed; "
                         "expected an installed family (matplotlib.font_manager.get_font_names() lists them)"
                         ", or the text converted to paths in the drawing program") from None
    return prop, size, path


@functools.lru_cache(maxsize=4096)
def _advance(text: str, path: str, size: float) -> float:
    """The pen's advance over ``text`` (kerning and ligatures included), in user units.

    Read from the layout ``TextPath`` itself places glyphs by (matplotlib's ``_text_helpers``:
    no public call gives the pen's advance): the last glyph's position plus its advance.
    """
    from matplotlib import _text_helpers, ft2font
    from matplotlib.font_manager import get_font
    from matplotlib.textpath import text_to_path

    no_hinting = ft2font.LoadFlags.NO_HINTING if hasattr(ft2font, "LoadFlags") else ft2font.LOAD_NO_HINTING
    font = get_font(path)
    font.set_size(text_to_path.FONT_SCALE, text_to_path.DPI)
    items = list(_text_helpers.layout(text, font))
    if not items:
        return 0.0
    last = items[-1]
    index = getattr(last, "glyph_index", getattr(last, "glyph_idx", None))     # 3.11 / 3.8 name
    width = last.ft_object.load_glyph(index, flags=no_hinting).linearHoriAdvance / 65536
    return (last.x + width) * size / text_to_path.FONT_SCALE


def glyph_outlines(runs, matrix_of, *, source: str, label: str):
    """The glyph outlines of one ``<text>``'s runs, placed.

    Parameters
    ----------
    runs : list of svgelements.Text
        Every run of one text element (any order; :func:`run_key` orders them).
    matrix_of : callable
        Run → 3 × 3 matrix from the run's user space to the output frame (mm).
    source, label : str
        The file and the text element's name, for messages.

    Returns
    -------
    list of (run, vertices, codes)
        Per non-empty piece of a run: matplotlib path vertices (k, 2) in the output frame and
        their codes (MOVETO, LINETO, CURVE3, CURVE4, CLOSEPOLY).
    """
    from labkit.geometry import transform as tf

    runs = sorted(runs, key=lambda r: run_key(r)[1])
    if not runs:
        return []
    root = runs[0]
    preserve = str(_own(root, _XML_SPACE) or "") == "preserve"
    texts = _collapse([r.text for r in runs], preserve)
    characters = sum(len(t) for t in texts)
    check_budget("segments", 64 * characters, cause=f"{characters} characters of text in {label} ({source}), "
                 "up to 64 outline segments each")
    pen = [float(root.x or 0.0), float(root.y or 0.0)]
    chunk = [pen[0], getattr(root, "anchor", "start"), []]     # start x, anchor, pieces
    pieces: list = []

    trail = [0.0]                              # letter spacing after the last character so far

    def close(chunk):                          # text-anchor: by the pen's advance, not the ink,
        share = {"middle": 0.5, "end": 1.0}.get(chunk[1], 0.0)      # less the spacing after its
        for p in chunk[2]:                                           # last character (as resvg)
            p[4] -= share * (pen[0] - trail[0] - chunk[0])
        pieces.extend(chunk[2])

    for run, text in zip(runs, texts):
        xs, ys = _lengths(_own(run, "x")), _lengths(_own(run, "y"))
        dxs, dys = _lengths(_own(run, "dx")), _lengths(_own(run, "dy"))
        letter, word = _spacing(run, "letter-spacing"), _spacing(run, "word-spacing")
        if _own(run, "rotate") not in (None, "", "0") and text.strip():
            warnings.warn(f"{source}: {label}: rotate={_own(run, 'rotate')!r} on characters is not applied; "
                          "they are cut upright (rotate them in the drawing program)", stacklevel=2)
        spaced = letter != 0.0 or (word != 0.0 and " " in text)
        each = len(text) if spaced else max(len(xs), len(ys), len(dxs), len(dys), 1)   # one by one
        cuts = list(range(min(each, max(len(text), 1))))
        for a, b in zip(cuts, cuts[1:] + [max(len(text), 1)]):
            if a < len(xs):                    # an absolute x starts a new chunk
                close(chunk)
                pen[0] = xs[a]
                chunk = [pen[0], getattr(run, "anchor", "start"), []]
            if a < len(ys):
                pen[1] = ys[a]
            pen[0] += dxs[a] if a < len(dxs) else 0.0
            pen[1] += dys[a] if a < len(dys) else 0.0
            piece = text[a:b]
            if not piece:
                continue
            prop, size, font_path = _font(run, source, label, text)
            if not size > 0:                   # renderers draw nothing (a negative size is invalid)
                continue
            chunk[2].append([run, piece, prop, size, pen[0], pen[1]])
            if spaced and b < len(text):       # one character: its advance with the kerning
                pen[0] += _advance(text[a:b + 1], font_path, size) - _advance(text[b], font_path, size)
            else:                              # to the next one kept
                pen[0] += _advance(piece, font_path, size)
            trail[0] = 0.0
            if spaced:                          # CSS: after every character; a space gets word too
                pen[0] += letter + (word if piece == " " else 0.0)
                trail[0] = letter
    close(chunk)
    out = []
    for run, piece, prop, size, x, y in pieces:
        if not piece.strip():
            continue
        vertices, codes = _glyphs(piece, prop, size)
        if not len(vertices):
            continue
        place = matrix_of(run) @ tf.matrix(1, 0, 0, -1, x, y)       # glyphs y up, SVG y down
        out.append((run, tf.apply(place, vertices), codes))
    return out


@functools.lru_cache(maxsize=4096)          # text placed character by character repeats them
def _glyphs(piece: str, prop, size: float):
    """The outlines of ``piece`` set from its pen at (0, 0): (vertices, codes), y up."""
    from matplotlib.textpath import TextPath

    glyphs = TextPath((0, 0), piece.replace("$", r"\$"), size=size, prop=prop)   # never mathtext
    return np.asarray(glyphs.vertices, float), np.asarray(glyphs.codes)


def svg_text_paths(source, *, tol_mm: float = 0.01, flip_y: bool = True) -> list:
    """The outlines of an SVG's ``<text>`` elements, in mm, as closed Paths.

    The text :func:`labkit.vector.read_svg` draws, alone (straight segments within ``tol_mm``):
    each glyph from its font, placed by the text's position, ``text-anchor`` and transform.

    Parameters
    ----------
    source : str, path or bytes
        The SVG file (or document), as ``read_svg`` takes it.
    tol_mm : float
        Largest distance of a flattened curve from the glyph's, mm.
    flip_y : bool
        As ``read_svg``'s.

    Returns
    -------
    list of Path
        Closed; layer the stroke colour, else the fill colour; source ``text#ID``.

    Raises
    ------
    InputError
        A font family that is not installed (the message names it and the text).
    """
    from labkit.vector.svg import read_svg

    drawing = read_svg(source, tol_mm=tol_mm, arcs=False, flip_y=flip_y, warn=False)
    return [p for p in drawing.paths if p.source.startswith("text")]
