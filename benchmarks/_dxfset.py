"""DXF drawings of many parts, written by this script with ezdxf (not by a CAD program).

Each part is what a CAD drawing of plates holds: an outline of LINEs and ARCs (rounded
corners), a closed LWPOLYLINE with bulges, CIRCLE holes and a SPLINE, placed side by side on a
sheet in mm. Only entities both labkit and vpype-dxf read, so both convert every entity. The
drawings are seeded: every run of a benchmark converts the same files.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np


def _part(msp, rng, x0: float, y0: float, size: float) -> int:
    """One part at (x0, y0): returns the number of entities added."""
    w, h = size * rng.uniform(0.6, 1.0), size * rng.uniform(0.6, 1.0)
    r = 0.15 * min(w, h)
    corners = [((x0 + w - r, y0 + r), -90), ((x0 + w - r, y0 + h - r), 0), ((x0 + r, y0 + h - r), 90),
               ((x0 + r, y0 + r), 180)]
    ends = []
    for (cx, cy), a in corners:
        msp.add_arc((cx, cy), r, a, a + 90)
        ends.append(((cx + r * np.cos(np.radians(a)), cy + r * np.sin(np.radians(a))),
                     (cx + r * np.cos(np.radians(a + 90)), cy + r * np.sin(np.radians(a + 90)))))
    for k in range(4):                                     # the straight sides between the arcs
        msp.add_line(ends[k][1], ends[(k + 1) % 4][0])
    n = 0
    for _ in range(int(rng.integers(1, 4))):               # holes
        msp.add_circle((x0 + w * rng.uniform(0.3, 0.7), y0 + h * rng.uniform(0.3, 0.7)),
                       min(w, h) * rng.uniform(0.03, 0.08))
        n += 1
    px, py = x0 + 0.2 * w, y0 + 0.2 * h                    # a slot: a closed polyline with bulges
    msp.add_lwpolyline([(px, py, 0, 0, 0), (px + 0.3 * w, py, 0, 0, 1.0), (px + 0.3 * w, py + 0.1 * h, 0, 0, 0),
                        (px, py + 0.1 * h, 0, 0, 1.0)], format="xyseb", close=True)
    fit = [(x0 + w * t, y0 + h * (0.75 + 0.1 * np.sin(7 * t + rng.uniform(0, 6)))) for t in np.linspace(0.2, 0.8, 5)]
    msp.add_spline(fit_points=fit)
    return 8 + n + 2


def write_dxf(path, parts: int, seed: int = 0) -> Path:
    """Write a drawing of ``parts`` parts (about 12 entities each) to ``path``."""
    import ezdxf

    rng = np.random.default_rng(seed)
    doc = ezdxf.new("R2010")
    doc.header["$INSUNITS"] = 4                            # mm
    msp = doc.modelspace()
    side = int(np.ceil(np.sqrt(parts)))
    for k in range(parts):
        _part(msp, rng, 40.0 * (k % side), 40.0 * (k // side), 35.0)
    doc.saveas(path)
    return Path(path)
