"""Seeded jobs shared by the motion tests (built with MovesBuilder)."""

import numpy as np

from labkit.toolpath import LaserMode, MovesBuilder


def zigzag_moves(rows=12, width_mm=20.0, pitch_mm=0.5, feed_mm_min=1200.0, s_word=500.0,
                 segments_per_row=1, laser=LaserMode.DYNAMIC):
    """A bidirectional raster like [CBR40]'s fig. 17 job: rows burned, step-overs dark."""
    b = MovesBuilder(feed_mm_min=feed_mm_min, s_word=s_word, laser=laser)
    b.rapid(x=0, y=0)
    x = 0.0
    for r in range(rows):
        target = width_mm if x == 0.0 else 0.0
        for s in range(1, segments_per_row + 1):
            b.line(x=x + (target - x) * s / segments_per_row, y=r * pitch_mm, line=2 * r + 1,
                   s_word=s_word * (0.5 + 0.5 * (s % 2)))
        x = target
        if r + 1 < rows:
            b.line(y=(r + 1) * pitch_mm, s_word=0, line=2 * r + 2)
    return b.build()


def random_polyline_moves(seed, n=40, feed_range=(300, 3000), spread=30.0):
    rng = np.random.default_rng(seed)
    b = MovesBuilder(feed_mm_min=1000, s_word=400, laser=LaserMode.DYNAMIC)
    b.rapid(x=rng.uniform(0, spread), y=rng.uniform(0, spread))
    for i in range(n):
        kind = rng.random()
        if kind < 0.1:
            b.rapid(x=rng.uniform(0, spread), y=rng.uniform(0, spread), line=i + 1)
        elif kind < 0.15:
            b.dwell(0.05, line=i + 1)
        else:
            step = rng.normal(0, 1, 2) * rng.choice([0.05, 0.5, 5.0])
            p = b.position[:2] + step
            b.line(x=p[0], y=p[1], line=i + 1, feed_mm_min=rng.uniform(*feed_range),
                   s_word=rng.uniform(0, 1000), laser=rng.choice([LaserMode.CONSTANT, LaserMode.DYNAMIC]))
    return b.build()
