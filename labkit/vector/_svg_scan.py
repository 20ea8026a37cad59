"""A streaming pass over an SVG document before svgelements sees it.

svgelements builds its tree recursively and expands ``<use>`` eagerly: a ``<use>``
that references its own ancestor recurses until Python gives up, ten thousand nested
groups take minutes (its cost grows with the square of the depth), and a fan-out of
``<use>`` copies (4 uses of 4 uses of … 11 levels: 4^11 shapes) takes all the memory
there is. Renderers refuse or cap these. This pass reads the document once with expat
(iterative, C speed, line and column of every element) and refuses, with the place:

* XML that does not parse, or a root element that is not ``<svg>``;
* nesting deeper than :data:`MAX_DEPTH` levels;
* ``<use>`` cycles (a reference to itself, to an ancestor, or a ring of references);
* more elements after expanding every ``<use>`` than the ``elements`` budget;
* a ``viewBox`` whose width or height is not positive (SVG: rendering is disabled —
  a renderer draws nothing, so labkit cuts nothing rather than a mirrored page);
* a geometry attribute holding a number that is not finite (``nan``, ``inf``, ``1e400``).
"""

from __future__ import annotations

import math
import re
import xml.parsers.expat
from collections import Counter
from dataclasses import dataclass

from labkit.budget import check_budget
from labkit.errors import GeometryError

__all__ = ["MAX_DEPTH", "scan_svg", "SvgScan"]

#: Deepest element nesting accepted. Drawing programs write under 30 levels;
#: svgelements' time grows with the square of the depth (1,000 levels: 7 s).
MAX_DEPTH = 256

_XLINK = "http://www.w3.org/1999/xlink"
_GEOMETRY_ATTRS = frozenset(("d", "points", "x", "y", "width", "height", "cx", "cy", "r", "rx",
                             "ry", "x1", "y1", "x2", "y2", "transform", "viewBox"))
_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
_NON_FINITE_WORD = re.compile(r"(?i)(?<![a-z])(nan|inf(inity)?)(?![a-z])")
# a number that can overflow has an exponent or more than 15 characters: text without
# either skips the per-number loop (path data is most of a drawing). The two searches
# run only where a cheap test of the text allows a match (``in`` on a letter), and the
# run of 16 number characters with ASCII digits where the text is ASCII: on path data
# the two patterns of one search cost 60 µs a path, half the scan of a drawing
_EXPONENT = re.compile(r"[\d.][eE]")
_LONG_NUMBER = re.compile(r"[-+.\d]{16}")
_LONG_ASCII_NUMBER = re.compile(r"[-+.0-9]{16}")


@dataclass
class SvgScan:
    """What the scan found: element counts before and after expanding ``<use>``."""

    elements: int
    expanded_elements: int
    max_depth: int
    uses: int
    unrendered: int = 0        # elements render_only rewrites (containers never drawn directly,
                               # switch, text, transform-origin, a rect's percentage radius)
    clip_transforms: dict = None   # clipPath id → its own transform attribute ("" when none):
                                   # svgelements folds the context where it is defined in too


def _local(tag: str) -> str:
    return tag.rsplit(" ", 1)[-1].rsplit("}", 1)[-1]


def _non_finite(value: str) -> str | None:
    """The first token of ``value`` that is not a finite number, or None."""
    if "n" in value or "N" in value:                 # both words hold an n
        m = _NON_FINITE_WORD.search(value)
        if m:
            return m.group(0)
    long_number = _LONG_ASCII_NUMBER if value.isascii() else _LONG_NUMBER
    if not (("e" in value or "E" in value) and _EXPONENT.search(value)) \
            and not (len(value) > 15 and long_number.search(value)):
        return None
    for tok in _NUMBER.findall(value):
        if len(tok) > 15 or "e" in tok or "E" in tok:      # only these can overflow a double
            if not math.isfinite(float(tok)):
                return tok
    return None


def scan_svg(data: bytes, name: str) -> SvgScan:
    """Check an SVG document's structure before it is parsed into shapes.

    Parameters
    ----------
    data : bytes
        The whole document.
    name : str
        The file name used in messages.

    Returns
    -------
    SvgScan
        Element counts; raises :class:`~labkit.errors.GeometryError` (or
        :class:`~labkit.errors.BudgetError`) for the cases in the module docstring.

    Examples
    --------
    >>> s = scan_svg(b'<svg xmlns="http://www.w3.org/2000/svg"><rect id="a" width="1" height="1"/>'
    ...              b'<use href="#a"/><use href="#a"/></svg>', "x.svg")
    >>> (s.elements, s.expanded_elements, s.uses)
    (4, 6, 2)
    >>> scan_svg(b'<svg xmlns="http://www.w3.org/2000/svg"><g id="g"><use href="#g"/></g></svg>',
    ...          "loop.svg")
    Traceback (most recent call last):
    ...
    labkit.errors.GeometryError: loop.svg:1:51: <use> cycle: #g → #g (a renderer refuses to draw it)
    """
    parser = xml.parsers.expat.ParserCreate(namespace_separator=" ")
    stack: list[list] = []            # per open element: [id or None, Counter of use targets below]
    ids: dict[str, tuple[int, int]] = {}
    subtree: dict[str, tuple[int, Counter]] = {}   # id → (elements in its subtree, use targets)
    use_at: dict[str, tuple[int, int]] = {}        # a use target → place of its first use
    root_targets: Counter = Counter()
    state = {"n": 0, "depth": 0, "uses": 0, "root": None, "unrendered": 0}
    counts: list[int] = []            # running element count per open element (to size subtrees)
    clips: dict[str, str] = {}

    def where() -> str:
        return f"{name}:{parser.CurrentLineNumber}:{parser.CurrentColumnNumber + 1}"

    def start(tag, attrs):
        local = _local(tag)
        if state["root"] is None:
            state["root"] = local
            if local != "svg":
                raise GeometryError(f"{where()}: not an SVG document (the root element is "
                                    f"<{local}>, expected <svg>)")
        state["n"] += 1
        depth = len(stack) + 1
        if depth > MAX_DEPTH:
            raise GeometryError(f"{where()}: elements nested {depth} deep; labkit reads at most "
                                f"{MAX_DEPTH} levels (drawing programs write under 30) — "
                                f"flatten the groups in the drawing program")
        state["depth"] = max(state["depth"], depth)
        ident = None
        for key, value in attrs.items():
            k = _local(key)
            if k == "id":
                ident = value
                ids.setdefault(value, (parser.CurrentLineNumber, parser.CurrentColumnNumber + 1))
            elif k in _GEOMETRY_ATTRS:
                bad = _non_finite(value)
                if bad is not None:
                    raise GeometryError(f"{where()}: <{local}> attribute {k}={value[:40]!r} holds "
                                        f"{bad!r}, not a finite number")
                if k == "viewBox":
                    nums = [float(t) for t in _NUMBER.findall(value)]
                    if len(nums) == 4 and not (nums[2] > 0 and nums[3] > 0):
                        raise GeometryError(
                            f"{where()}: <{local}> viewBox={value!r} has a width or height that is "
                            f"not positive; SVG disables rendering of such an element (a renderer "
                            f"draws nothing), so labkit will not cut it")
        if local == "clipPath" and ident is not None:
            clips[ident] = attrs.get("transform", "")
        if (local in _UNRENDERED or local in ("switch", "text") or "transform-origin" in attrs
                or (local == "rect" and "%" in attrs.get("rx", "") + attrs.get("ry", ""))):
            state["unrendered"] += 1
        stack.append([ident, Counter()])
        counts.append(state["n"])
        if local == "use":
            href = attrs.get(f"{_XLINK} href") or attrs.get("href") or ""
            if href.startswith("#"):
                target = href[1:]
                state["uses"] += 1
                use_at.setdefault(target, (parser.CurrentLineNumber, parser.CurrentColumnNumber + 1))
                stack[-1][1][target] += 1
                # a use inside the element it references (or inside a use pointing here): a cycle
                if any(frame[0] == target for frame in stack):
                    raise GeometryError(f"{where()}: <use> cycle: #{target} → #{target} "
                                        f"(a renderer refuses to draw it)")

    def end(tag):
        ident, targets = stack.pop()
        first = counts.pop()
        if ident is not None:
            subtree[ident] = (state["n"] - first + 1, targets.copy() if stack else targets)
        if not targets:                  # most elements use nothing: skip Counter.update
            return
        if stack:
            stack[-1][1].update(targets)
        else:
            root_targets.update(targets)

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    try:
        parser.Parse(data, True)
    except xml.parsers.expat.ExpatError as exc:
        raise GeometryError(f"{name}:{exc.lineno}:{exc.offset + 1}: not well-formed XML "
                            f"({xml.parsers.expat.ErrorString(exc.code)}); expected an SVG "
                            f"document") from None
    if state["root"] is None:
        raise GeometryError(f"{name}: empty document; expected an SVG document")

    # Expanded size of each referenced element, by an iterative depth-first walk over
    # the reference graph (id → ids its subtree uses); a grey node met again is a cycle.
    size: dict[str, int] = {}
    for target in use_at:
        if target in size or target not in subtree:
            continue
        path, todo = [target], [(target, iter(subtree[target][1]))]
        grey = {target}
        while todo:
            node, children = todo[-1]
            for child in children:
                if child not in subtree or child in size:
                    continue
                if child in grey:
                    ring = path[path.index(child):] + [child]
                    line, col = use_at[child]
                    raise GeometryError(f"{name}:{line}:{col}: <use> cycle: "
                                        f"{' → '.join('#' + r for r in ring)} "
                                        f"(a renderer refuses to draw it)")
                grey.add(child)
                path.append(child)
                todo.append((child, iter(subtree[child][1])))
                break
            else:
                todo.pop()
                path.pop()
                grey.discard(node)
                own, uses = subtree[node]
                size[node] = own + sum(k * size.get(t, 0) for t, k in uses.items())
                check_budget("elements", size[node],
                             cause=f"<use> copies of #{node} in {name}")
    expanded = state["n"] + sum(k * size.get(t, 0) for t, k in root_targets.items())
    check_budget("elements", expanded, cause=f"<use> copies in {name}")
    return SvgScan(state["n"], expanded, state["depth"], state["uses"], state["unrendered"], clips)


#: Elements whose content a renderer draws only through a reference (symbol, marker, mask,
#: pattern) or never (metadata, Inkscape 0.92's flowRoot text frames, whose flowRegion
#: rectangle is a text box, not a shape).
_UNRENDERED = frozenset(("symbol", "marker", "mask", "pattern", "metadata", "flowRoot", "title",
                         "desc"))
_REFERENCED_ONLY = frozenset(("symbol", "marker", "mask", "pattern"))


def render_only(data: bytes) -> tuple[bytes, list[str]]:
    """The document with only what a renderer draws directly: ``symbol``, ``marker``,
    ``mask`` and ``pattern`` moved into ``<defs>`` (still usable by ``<use>``, never drawn
    where they stand), ``metadata``/``title``/``desc`` and ``flowRoot`` text frames removed,
    each ``<switch>`` reduced to its first child (the one a renderer without optional
    features picks), ``transform-origin`` (SVG 2, which svgelements ignores) folded
    into the ``transform`` as translate(o) · T · translate(−o), and a rect's ``rx``/``ry``
    given in percent resolved against the nearest viewport (rx of its width, ry of its
    height, as renderers do; svgelements takes them of the rect's own size); a mask of
    opaque white shapes becomes the clip-path it is equivalent to (:func:`_masks_as_clips`);
    each ``<text>``'s runs are numbered and its tails wrapped (:func:`labkit.vector.text.mark_runs`).

    Returns
    -------
    (bytes, list of str)
        The rewritten document and the labels of what is not drawn: removed text frames
        (``flowRoot#id``) and text on a path (``text#id (on a path)``).

    Examples
    --------
    >>> doc, dropped = render_only(b'<svg xmlns="http://www.w3.org/2000/svg"><symbol id="s">'
    ...     b'<rect width="1" height="1"/></symbol><flowRoot id="f"><flowRegion><rect/>'
    ...     b'</flowRegion></flowRoot></svg>')
    >>> doc.decode(), dropped
    ('<svg xmlns="http://www.w3.org/2000/svg"><defs><symbol id="s"><rect width="1" height="1" /></symbol></defs></svg>', ['flowRoot#f'])
    """
    import xml.etree.ElementTree as ET

    svg_ns = "http://www.w3.org/2000/svg"
    ET.register_namespace("", svg_ns)
    ET.register_namespace("xlink", _XLINK)
    from labkit.vector.text import mark_runs

    root = ET.fromstring(data)
    dropped: list[str] = []
    todo = [(root, _viewport(root, None))]
    while todo:                               # iterative: depth is bounded, but recursion is not needed
        parent, viewport = todo.pop()
        in_defs = _local(parent.tag) == "defs"
        for i, child in enumerate(list(parent)):
            tag = _local(child.tag) if isinstance(child.tag, str) else ""
            if tag in ("metadata", "title", "desc"):
                parent.remove(child)
            elif tag == "flowRoot":
                dropped.append(f"flowRoot#{child.get('id')}" if child.get("id") else "flowRoot")
                parent.remove(child)
            elif tag in _REFERENCED_ONLY and not in_defs:
                defs = ET.Element(f"{{{svg_ns}}}defs")
                defs.append(child)
                parent.remove(child)
                parent.insert(i, defs)
            else:
                origin = child.get("transform-origin")
                if origin is not None:
                    child.set("transform", _with_origin(child.get("transform", ""), origin))
                    del child.attrib["transform-origin"]
                if tag == "switch":
                    kids = [k for k in child if isinstance(k.tag, str)]
                    for k in kids[1:]:
                        child.remove(k)
                if tag == "rect":
                    _resolve_radii(child, viewport)
                todo.append((child, _viewport(child, viewport) if tag == "svg" else viewport))
    _masks_as_clips(root)
    texts = [el for el in root.iter() if isinstance(el.tag, str) and _local(el.tag) == "text"]
    for k, text in enumerate(texts):                   # document order, symbols' and masks' too
        if mark_runs(text, k):
            dropped.append(f"text#{text.get('id')} (on a path)" if text.get("id") else "text (on a path)")
    return ET.tostring(root, encoding="unicode").encode("utf-8"), dropped


_SHAPES = frozenset(("rect", "circle", "ellipse", "path", "polygon", "polyline", "line"))
_WHITE = frozenset(("#fff", "#ffffff", "white", "rgb(255,255,255)"))


def _style(el, key: str) -> str | None:
    """A presentation property of ``el`` from its style attribute or its own attribute."""
    for item in el.get("style", "").split(";"):
        name, _, value = item.partition(":")
        if name.strip() == key:
            return value.strip().lower().replace(" ", "")
    value = el.get(key)
    return None if value is None else value.strip().lower().replace(" ", "")


def _opaque_white(mask) -> bool:
    """Whether a mask shows exactly the union of its shapes: every shape (in plain groups)
    filled opaque white, with no stroke, no opacity and no transform on a group, and the
    mask's region left at its default (the masked element's box and a 10 % margin)."""
    if any(mask.get(k) is not None for k in ("x", "y", "width", "height", "maskUnits")):
        return False
    shapes = 0
    todo = list(mask)
    while todo:
        el = todo.pop()
        tag = _local(el.tag) if isinstance(el.tag, str) else ""
        if tag == "g" and not el.attrib:
            todo.extend(el)
            continue
        if tag not in _SHAPES or _style(el, "fill") not in _WHITE:
            return False
        if _style(el, "stroke") not in (None, "none"):
            return False
        if any(_style(el, k) not in (None, "1") for k in ("opacity", "fill-opacity")):
            return False
        shapes += 1
    return shapes > 0


def _masks_as_clips(root) -> None:
    """Apply a mask that shows exactly the union of its white shapes (:func:`_opaque_white`)
    as the clip-path it is equivalent to: the mask becomes a clipPath (its content units
    become clipPathUnits) and each ``mask="url(#id)"`` on an element without a clip-path of
    its own a ``clip-path``. Any other mask is left for the reader, which names what it
    masks in a warning."""
    clips = {}
    for mask in root.iter():
        if isinstance(mask.tag, str) and _local(mask.tag) == "mask" and mask.get("id") \
                and _opaque_white(mask):
            clips[mask.get("id")] = mask
    if not clips:
        return
    used = set()
    for el in root.iter():
        ref = el.get("mask", "").strip()
        ident = ref[5:-1].strip().strip("'\"") if ref.startswith("url(#") and ref.endswith(")") else None
        if ident in clips and el.get("clip-path") is None:
            del el.attrib["mask"]
            el.set("clip-path", f"url(#{ident})")
            used.add(ident)
    for ident in used:
        mask = clips[ident]
        mask.tag = mask.tag[:-len("mask")] + "clipPath"
        units = mask.attrib.pop("maskContentUnits", None)
        if units is not None:
            mask.set("clipPathUnits", units)



#: CSS absolute units in px (96 per inch), for a viewport given by width and height alone.
_PX_PER_UNIT = {"": 1.0, "px": 1.0, "in": 96.0, "cm": 96.0 / 2.54, "mm": 96.0 / 25.4,
                "pt": 96.0 / 72.0, "pc": 16.0}


def _viewport(svg, outer) -> tuple[float, float] | None:
    """Width and height in user units of the viewport an ``<svg>`` element sets up: its
    viewBox, else its width and height (absolute units), else 100 % of ``outer``."""
    nums = [float(t) for t in _NUMBER.findall(svg.get("viewBox", ""))]
    if len(nums) == 4 and nums[2] > 0 and nums[3] > 0:
        return nums[2], nums[3]
    size = []
    for key, share in (("width", 0), ("height", 1)):
        m = re.fullmatch(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*([a-z%]*)\s*",
                         svg.get(key, "100%"))
        if m is None:
            return None
        value, unit = float(m.group(1)), m.group(2)
        if unit == "%":
            if outer is None:
                return None
            size.append(value / 100.0 * outer[share])
        elif unit in _PX_PER_UNIT:
            size.append(value * _PX_PER_UNIT[unit])
        else:
            return None
    return size[0], size[1]


def _resolve_radii(rect, viewport) -> None:
    """A rect's ``rx``/``ry`` in percent as user units: rx of the viewport's width, ry of its
    height (an ``ry`` left out or ``auto`` stays so: it takes rx's value, and the renderer
    clamps each to half the side)."""
    for key, share in (("rx", 0), ("ry", 1)):
        value = rect.get(key, "").strip()
        if value.endswith("%"):
            if viewport is None:
                raise GeometryError(f"<rect> {key}={value!r}: a percentage needs the viewport's "
                                    f"size, and the document gives none (no viewBox, width or "
                                    f"height); give {key} in user units")
            try:
                rect.set(key, repr(float(value[:-1]) / 100.0 * viewport[share]))
            except ValueError:
                raise GeometryError(f"<rect> {key}={value!r}: expected a number or a "
                                    f"percentage") from None


def _with_origin(transform: str, origin: str) -> str:
    """``transform`` about ``origin`` ("x y" in user units; keywords and percentages, which
    need the element's box, are refused)."""
    nums = _NUMBER.findall(origin)
    rest = _NUMBER.sub("", origin).replace(",", "").replace("px", "").strip()
    if rest or not 1 <= len(nums) <= 2:
        raise GeometryError(f"transform-origin={origin!r}: labkit reads it only as one or two "
                            f"numbers in user units; expected e.g. transform-origin=\"5 5\"")
    ox, oy = (float(nums[0]), float(nums[-1] if len(nums) == 2 else 0.0))
    return f"translate({ox!r} {oy!r}) {transform} translate({-ox!r} {-oy!r})"
