"""A set of raw SVG drawings with transforms, written by this script (not by a drawing tool).

Each file is what an editor saves before any flattening: ``<path>`` elements with cubic and
quadratic Béziers, elliptical arcs and lines (absolute and relative commands), placed by
nested ``<g transform>`` groups and per-element transforms (translate, rotate about a point,
scale, skewX, matrix). Only ``<path>`` is used, so svg-to-gcode (which skips rect, circle,
ellipse and line elements) reads every element. The drawings are seeded, so every run of a
benchmark converts the same files.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

# rotate about a point is spelled out (svg-to-gcode reads only rotate(angle))
_TRANSFORMS = ("translate({a:.2f} {b:.2f})",
               "translate({a:.2f} {b:.2f}) rotate({r:.1f}) translate({na:.2f} {nb:.2f})",
               "scale({s:.3f})", "skewX({k:.1f})",
               "matrix({c:.4f} {d:.4f} {e:.4f} {c:.4f} {a:.2f} {b:.2f})")


def _transform(rng) -> str:
    r = rng.uniform(-180, 180)
    c, d = np.cos(np.radians(r)), np.sin(np.radians(r))
    form = _TRANSFORMS[rng.integers(len(_TRANSFORMS))]
    a, b = rng.uniform(-20, 20, 2)
    return form.format(a=a, b=b, na=-a, nb=-b, r=r,
                       s=rng.uniform(0.6, 1.5), k=rng.uniform(-25, 25), c=c, d=d, e=-d)


def _shape(rng, size: float) -> str:
    """Path data: a closed outline of 4–9 mixed curve segments about the origin."""
    n = int(rng.integers(4, 10))
    ang = np.sort(rng.uniform(0, 2 * np.pi, n))
    rad = size * rng.uniform(0.5, 1.0, n)
    pts = np.c_[rad * np.cos(ang), rad * np.sin(ang)]
    parts = [f"M{pts[0, 0]:.3f},{pts[0, 1]:.3f}"]
    for k in range(1, n + 1):
        a, b = pts[k - 1], pts[k % n]
        kind = rng.integers(4)
        if kind == 0:                                   # cubic, absolute
            c1 = a + rng.normal(0, size / 3, 2)
            c2 = b + rng.normal(0, size / 3, 2)
            parts.append(f"C{c1[0]:.3f},{c1[1]:.3f} {c2[0]:.3f},{c2[1]:.3f} {b[0]:.3f},{b[1]:.3f}")
        elif kind == 1:                                 # quadratic, relative
            c = a + rng.normal(0, size / 3, 2) - a
            d = b - a
            parts.append(f"q{c[0]:.3f},{c[1]:.3f} {d[0]:.3f},{d[1]:.3f}")
        elif kind == 2:                                 # elliptical arc
            rx = max(np.hypot(*(b - a)) * rng.uniform(0.6, 1.5), 0.5)
            ry = rx * rng.uniform(0.4, 1.0)
            parts.append(f"A{rx:.3f},{ry:.3f} {rng.uniform(0, 90):.1f} 0,{int(rng.integers(2))} "
                         f"{b[0]:.3f},{b[1]:.3f}")
        else:                                           # line, relative
            d = b - a
            parts.append(f"l{d[0]:.3f},{d[1]:.3f}")
    return " ".join(parts) + " Z"


def drawing(seed: int, elements: int) -> str:
    """One SVG document of ``elements`` paths, 200 × 200 mm, in groups of 2–6 with transforms."""
    rng = np.random.default_rng(seed)
    out = ['<?xml version="1.0" encoding="UTF-8"?>',
           '<svg xmlns="http://www.w3.org/2000/svg" width="200mm" height="200mm" viewBox="0 0 200 200">']
    left = elements
    while left:
        group = min(left, int(rng.integers(2, 7)))
        out.append(f'  <g transform="translate({rng.uniform(30, 170):.2f} {rng.uniform(30, 170):.2f}) '
                   f'{_transform(rng)}" fill="none" stroke="black" stroke-width="0.2">')
        for _ in range(group):
            size = rng.uniform(3, 25)
            extra = f' transform="{_transform(rng)}"' if rng.random() < 0.5 else ""
            out.append(f'    <path d="{_shape(rng, size)}"{extra}/>')
        out.append("  </g>")
        left -= group
    out.append("</svg>")
    return "\n".join(out) + "\n"


def write_set(folder, files: int = 10, elements: int = 45) -> list[Path]:
    """Write ``files`` drawings of ``elements`` paths each into ``folder``; returns their paths."""
    folder = Path(folder)
    paths = []
    for k in range(files):
        p = folder / f"drawing_{elements}_{k:02d}.svg"
        p.write_text(drawing(1000 + 17 * elements + k, elements))
        paths.append(p)
    return paths
