"""labkit.toolpath.patterns against closed forms and through emit → parse."""

import math

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.spatial import cKDTree

from labkit.errors import GeometryError
from labkit.gcode import emit, parse
from labkit.toolpath import MoveKind
from labkit.toolpath.patterns import archimedean_spiral, cone, cone_sections, helix, square_spiral, zigzag


def roundtrip(m):
    return parse(emit(m, tol_mm=1e-4))


def dense(m, step=0.002):
    """Points along every burning move (lines and arcs, with helical Z), mm."""
    out = []
    for k in np.flatnonzero(m.laser_on):
        s, e, c = m.start[k], m.end[k], m.centre[k]
        n = max(2, int(math.ceil(m.lengths_mm()[k] / step)) + 1)
        u = np.linspace(0, 1, n)
        if m.kind[k] in (MoveKind.ARC_CW, MoveKind.ARC_CCW):
            a0 = math.atan2(s[1] - c[1], s[0] - c[0])
            sweep = m.sweep_rad()[k]
            r = math.hypot(s[0] - c[0], s[1] - c[1])
            ang = a0 + sweep * u
            out.append(np.c_[c[0] + r * np.cos(ang), c[1] + r * np.sin(ang), s[2] + (e[2] - s[2]) * u])
        else:
            out.append(s + (e - s) * u[:, None])
    return np.vstack(out)


@pytest.mark.parametrize("ccw", [True, False])
@pytest.mark.parametrize("turns", [1.0, 2.5, 4.0])
def test_helix_closed_form(turns, ccw):
    a, p, z0, c = 1.7, 0.3, 2.0, (4.0, -1.0)
    m = helix(c, a, p, turns, z_start_mm=z0, ccw=ccw)
    cut = m.laser_on
    assert m.kind[0] == MoveKind.RAPID and np.allclose(m.end[0], [c[0] + a, c[1], z0])
    # length: turns × one turn's length by the integral of |r'(t)|, plus the bottom circle
    b = p / (2 * math.pi)
    turn_len = quad(lambda t: math.sqrt(a * a + b * b), 0, 2 * math.pi)[0]
    assert m.lengths_mm()[cut].sum() == pytest.approx(turns * turn_len + 2 * math.pi * a, rel=1e-12)
    assert m.end[-1, 2] == pytest.approx(z0 - turns * p)
    pts = dense(m)
    assert np.allclose(np.hypot(pts[:, 0] - c[0], pts[:, 1] - c[1]), a, atol=1e-9)
    # z per turn: z drops by p for every 2π of angle on the helical part
    helical = pts[pts[:, 2] > z0 - turns * p + 1e-9]
    ang = np.unwrap(np.arctan2(helical[:, 1] - c[1], helical[:, 0] - c[0]))
    assert np.allclose(z0 - np.abs(ang - ang[0]) * p / (2 * math.pi), helical[:, 2], atol=1e-9)
    assert set(m.kind[cut].tolist()) == {MoveKind.ARC_CCW if ccw else MoveKind.ARC_CW}
    back = roundtrip(m)
    assert np.allclose(back.end, m.end, atol=1e-4)
    assert np.allclose(back.lengths_mm()[back.laser_on].sum(), m.lengths_mm()[cut].sum(), rtol=1e-5)


@pytest.mark.parametrize("a,step,R,tol", [(0.0, 0.5, 5.0, 0.005), (1.0, 0.2, 4.0, 0.001), (0.3, 1.0, 6.0, 0.02)])
def test_archimedean_spiral_within_tolerance(a, step, R, tol):
    c = np.array([2.0, 3.0])
    m = archimedean_spiral(c, R, step, inner_radius_mm=a, tol_mm=tol)
    b = step / (2 * math.pi)
    th_end = (R - a) / b
    # the closed form, densely sampled, and the closing circle
    th = np.linspace(0, th_end, 400_000)
    ref = np.c_[c + (a + b * th)[:, None] * np.c_[np.cos(th), np.sin(th)]]
    phi = np.linspace(0, 2 * math.pi, 20_000)
    ref = np.vstack([ref, c + R * np.c_[np.cos(phi), np.sin(phi)]])
    sample_gap = max(np.hypot(*np.diff(ref[:400_000], axis=0).T).max(), 2 * math.pi * R / 20_000)
    pts = dense(m)[:, :2]
    d_out, _ = cKDTree(ref).query(pts)
    d_in, _ = cKDTree(pts).query(ref)
    assert d_out.max() <= tol + sample_gap
    assert d_in.max() <= tol + 0.002
    # arcs, not chords: far fewer moves than a chord approximation would need
    chords = th_end * R / (2 * math.sqrt(2 * R * tol))
    assert len(m) < chords / 3
    assert m.is_arc[m.laser_on].mean() > 0.5
    # path length against the integral of sqrt(r² + r'²)
    L = quad(lambda t: math.hypot(a + b * t, b), 0, th_end, limit=500)[0] + 2 * math.pi * R
    assert m.lengths_mm()[m.laser_on].sum() == pytest.approx(L, abs=tol * len(m))
    back = roundtrip(m)
    assert np.allclose(back.end, m.end, atol=1e-4)
    arcs = back.is_arc & back.laser_on
    assert np.allclose(back.radius_mm()[arcs], m.radius_mm()[arcs], atol=2e-4)
    lo, hi = back.bounds(back.laser_on)[:, :2]
    assert np.allclose(lo, c - R, atol=1e-3) and np.allclose(hi, c + R, atol=1e-3)


@pytest.mark.parametrize("size,step", [(2.0, 0.5), (5.0, 0.25), (3.0, 1.0)])
def test_square_spiral(size, step):
    m, rep = square_spiral((1.0, 1.0), size, step, feed_mm_min=1200, accel_mm_s2=500)
    n = int(round(size / step))
    cut = m.laser_on
    assert int(cut.sum()) == 2 * n + 1
    # cut length: 2·s·(1 + … + n) + n·s
    assert m.lengths_mm()[cut].sum() == pytest.approx(step * (n * (n + 1) + n))
    assert np.allclose(m.bounds(cut)[:, :2], [[1 - size / 2] * 2, [1 + size / 2] * 2])
    assert rep["triangle_loops"] + rep["arc_loops"] == 2 * n and rep["leads"] == 2
    # neighbouring parallel passes are one step apart
    ys = np.unique(np.round(m.start[cut & (np.abs(m.end[:, 1] - m.start[:, 1]) < 1e-12), 1], 9))
    assert np.allclose(np.diff(ys), step)
    plain, _ = square_spiral((1.0, 1.0), size, step, loops=False)
    assert int((plain.kind == MoveKind.LINE).sum()) == 2 * n + 1 and len(m) > len(plain)
    assert np.allclose(roundtrip(m).end, m.end, atol=1e-4)


@pytest.mark.parametrize("plane,along", [("xy", "x"), ("xy", "y"), ("xz", "x"), ("xz", "z")])
@pytest.mark.parametrize("reverse", [False, True])
def test_zigzag(plane, along, reverse):
    o = np.array([1.0, 2.0, 3.0])
    w, h, s, lead = 6.0, 2.0, 0.5, 0.7
    m = zigzag(o, w, h, s, along=along, plane=plane, lead_mm=lead, reverse=reverse)
    ax = {"xy": (0, 1), "xz": (0, 2)}[plane]
    run = "xyz".index(along)
    cross = ax[1] if run == ax[0] else ax[0]
    ext = {ax[0]: w, ax[1]: h}
    cut = m.laser_on
    n = int(ext[cross] / s) + 1
    assert int(cut.sum()) == n
    assert np.allclose(m.lengths_mm()[cut], ext[run])
    lo, hi = m.bounds(cut)
    assert np.allclose(lo[list(ax)], o[list(ax)]) and np.allclose(hi[list(ax)], o[list(ax)] + [w, h])
    other = 3 - sum(ax)
    assert m.kind[0] == MoveKind.RAPID and np.allclose(m.start[0], 0.0)
    assert np.allclose(m.start[1:, other], o[other]) and np.allclose(m.end[:, other], o[other])
    off = np.unique(np.round(m.start[cut, cross], 9))
    assert np.allclose(np.diff(off), s)
    first = m.start[np.flatnonzero(cut)[0], cross]
    assert first == pytest.approx(o[cross] + (ext[cross] if reverse else 0.0))
    # passes alternate direction, leads extend each pass by lead_mm with the beam off
    d = np.sign(m.end[cut, run] - m.start[cut, run])
    assert np.all(d[1:] == -d[:-1])
    span = m.bounds(np.arange(len(m)) > 0)[:, run]
    assert span[1] - span[0] == pytest.approx(ext[run] + 2 * lead)
    assert np.allclose(roundtrip(m).end, m.end, atol=1e-4)


def test_zigzag_rejects_axis_outside_plane():
    with pytest.raises(GeometryError, match="along"):
        zigzag(along="y", plane="xz")
    with pytest.raises(GeometryError, match="step_mm"):
        zigzag(step_mm=0)


def test_cone_sections_is_a_diameter():
    d1, d2, H, zl = 12.0, 5.0, 4.0, 8
    depth, dia = cone_sections(d1, d2, H, zl)
    # the cone's geometry: diameter varies linearly from d1 at depth 0 to d2 at depth H
    assert np.allclose(dia, d1 + (d2 - d1) * depth / H)
    assert dia[0] == pytest.approx(d1)
    assert np.allclose(np.diff(depth), H / zl)


def test_cone_levels():
    d1, d2, H, zl, beam = 10.0, 4.0, 3.0, 3, 0.4
    m = cone((1.0, 2.0), d1, d2, H, zl, beam, z_start_mm=5.0, tol_mm=0.002)
    cut = m.laser_on
    zs = np.round(m.end[cut, 2], 9)
    assert sorted(set(zs.tolist())) == pytest.approx([5.0 - H * k / zl for k in range(zl)][::-1])
    for k in range(zl):
        z = 5.0 - k * H / zl
        D = d1 + (d2 - d1) * k / zl
        on = cut & np.isclose(m.end[:, 2], z)
        lo, hi = m.bounds(on)[:, :2]
        assert np.allclose(hi - lo, D - beam, atol=1e-6)
        # the closing circle lies at the section radius less half the beam
        assert np.hypot(*(m.end[np.flatnonzero(on)[-1], :2] - [1, 2])) == pytest.approx(D / 2 - beam / 2)
    # levels joined with the beam off, no cut crosses levels
    assert np.all(np.isclose(m.start[cut, 2], m.end[cut, 2]))
    with pytest.raises(GeometryError, match="beam_mm"):
        cone((0, 0), 1.0, 0.5, 1.0, 2, 0.8)
    back = roundtrip(m)
    assert np.allclose(back.end, m.end, atol=1e-4)


def test_invalid_helix():
    with pytest.raises(GeometryError, match="pitch_mm"):
        helix((0, 0), 1.0, -1.0, 2)
    with pytest.raises(GeometryError, match="radius_mm"):
        helix((0, 0), float("nan"), 1.0, 2)
