"""Point-to-path distance against a brute-force polyline reference; Hausdorff on closed forms."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from labkit.geometry import Path, hausdorff, path_distance


def _brute(paths, q):
    out = np.full(len(q), np.inf)
    for p in paths:
        s = p.sample(1e-6)
        a, b = s[:-1], s[1:]
        d = b - a
        L2 = np.maximum((d * d).sum(1), 1e-300)
        t = np.clip(((q[:, None] - a[None]) * d[None]).sum(-1) / L2, 0, 1)
        dist = np.hypot(*(q[:, None] - a[None] - t[..., None] * d[None]).transpose(2, 0, 1))
        out = np.minimum(out, dist.min(1))
    return out


@given(st.integers(0, 10_000))
@settings(max_examples=8, deadline=None)
def test_distance_matches_brute_force(seed):
    rng = np.random.default_rng(seed)
    paths = [Path.arc(rng.uniform(-50, 50, 2), rng.uniform(0.5, 20), rng.uniform(-3, 3),
                      rng.uniform(-6, 6)) for _ in range(6)]
    paths.append(Path.polyline(rng.uniform(-60, 60, (4, 2))))
    q = rng.uniform(-120, 120, (300, 2))
    np.testing.assert_allclose(path_distance(paths, q), _brute(paths, q), atol=2e-6)


def test_hausdorff_closed_forms():
    assert hausdorff(Path.rectangle(0, 0, 10, 10), Path.rectangle(1, 0, 10, 10)) == pytest.approx(1.0)
    # a half circle against its diameter: the top of the arc is r away
    arc = Path.arc((0, 0), 5, 0, np.pi)
    assert hausdorff(arc, Path([(5, 0), (-5, 0)])) == pytest.approx(5.0)
