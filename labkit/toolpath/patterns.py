"""Parametric CAM toolpaths ([MicroCAM] §6.1.3): helix, spirals, zig-zag, cone.

Every generator returns :class:`~labkit.toolpath.Moves` (positions in mm, feeds in
mm/min), so preview, planning, emitting and streaming work on them unchanged.
Curves are built from exact circular arcs where the geometry is made of them
(helix, closing circles) and fitted with arcs within a tolerance elsewhere
(Archimedean spiral, through :func:`labkit.geometry.arcfit.fit_arcs`); the square
spiral's sharp corners get the constant-velocity loops of
:func:`labkit.toolpath.corners.add_corner_loops`.
"""

from __future__ import annotations

import math

import numpy as np

from labkit.errors import GeometryError
from labkit.geometry.arcfit import fit_arcs
from labkit.geometry.path import Path
from labkit.toolpath.build import LayerSettings, build_moves
from labkit.toolpath.corners import add_corner_loops
from labkit.toolpath.moves import LaserMode, Moves, MovesBuilder

__all__ = ["helix", "archimedean_spiral", "square_spiral", "zigzag", "cone", "cone_sections"]


def _positive(name, value, unit):
    if not (isinstance(value, (int, float, np.floating, np.integer)) and math.isfinite(value) and value > 0):
        raise GeometryError(f"{name} must be a finite number > 0 {unit}, got {value!r}")
    return float(value)


def helix(centre=(0.0, 0.0), radius_mm=1.0, pitch_mm=0.5, turns=2.0, *, z_start_mm=0.0,
          feed_mm_min=600.0, s_word=1000.0, laser=LaserMode.CONSTANT, ccw=True) -> Moves:
    """A helix for holes, (x, y, z) = (a·cos t, a·sin t, b·t), descending, then a full circle.

    Parameters
    ----------
    centre : (x, y)
        Hole centre, mm.
    radius_mm : float
        Helix radius a (beam centre), mm, > 0.
    pitch_mm : float
        Z lost per turn, 2π·b, mm, > 0.
    turns : float
        Number of turns (> 0; fractional allowed).
    z_start_mm : float
        Z at the start point (x + a, y), mm; the helix ends ``turns·pitch`` lower.
    feed_mm_min, s_word, laser
        Cutting feed (mm/min), power word S and laser mode.
    ccw : bool
        Counter-clockwise (G3, t increasing) or clockwise (G2).

    Returns
    -------
    Moves
        A rapid to the start point, helical arcs of at most half a turn each
        (G2/G3 with Z), and a finishing full circle at the bottom Z (two half arcs).
        The arcs are the helix itself, so there is no fitting error.

    Examples
    --------
    >>> m = helix((0, 0), 2.0, 0.5, 3)
    >>> float(m.end[-1, 2]), len(m)           # 3 turns of 0.5 mm; 1 rapid, 6 + 2 arcs
    (-1.5, 9)
    >>> L = 3 * math.hypot(2 * math.pi * 2.0, 0.5) + 2 * math.pi * 2.0
    >>> bool(abs(m.lengths_mm()[1:].sum() - L) < 1e-9)
    True
    """
    a = _positive("radius_mm", radius_mm, "mm")
    p = _positive("pitch_mm", pitch_mm, "mm")
    n_turns = _positive("turns", turns, "turns")
    cx, cy = (float(v) for v in centre)
    z0 = float(z_start_mm)
    sign = 1.0 if ccw else -1.0
    n_arcs = max(1, math.ceil(2 * n_turns - 1e-9))
    t = sign * 2 * math.pi * n_turns * np.linspace(0, 1, n_arcs + 1)
    z = z0 - p * np.abs(t) / (2 * math.pi)
    b = MovesBuilder(feed_mm_min=feed_mm_min, s_word=s_word, laser=laser)
    b.rapid(x=cx + a, y=cy, z=z0)
    arc = b.arc_ccw if ccw else b.arc_cw
    for k in range(1, n_arcs + 1):
        x0, y0 = b.position[:2]
        arc(x=cx + a * math.cos(t[k]), y=cy + a * math.sin(t[k]), z=z[k], i=cx - x0, j=cy - y0)
    for k in (1, 2):        # finishing circle at the bottom, two half turns
        x0, y0 = b.position[:2]
        ang = t[-1] + sign * math.pi * k
        arc(x=cx + a * math.cos(ang), y=cy + a * math.sin(ang), z=z[-1], i=cx - x0, j=cy - y0)
    return b.build()


def _spiral_path(centre, a, b, r_end, tol_mm, ccw):
    """The Archimedean spiral r = a + b·θ from r = a to r_end, fitted with arcs."""
    theta_end = (r_end - a) / b
    # samples dense enough that the chords stay within tol/4 of the curve:
    # sagitta = r·(1 − cos(Δθ/2)) ≤ tol/4 with r ≤ r_end
    dtheta = 2 * math.acos(max(-1.0, 1 - tol_mm / (4 * r_end)))
    n = max(8, math.ceil(theta_end / dtheta) + 1)
    th = np.linspace(0.0, theta_end, n)
    r = a + b * th
    sgn = 1.0 if ccw else -1.0
    pts = np.c_[centre[0] + r * np.cos(sgn * th), centre[1] + r * np.sin(sgn * th)]
    return fit_arcs(pts, 0.75 * tol_mm, base_deviation_mm=0.25 * tol_mm), sgn * theta_end


def archimedean_spiral(centre=(0.0, 0.0), outer_radius_mm=5.0, step_mm=0.2, *, inner_radius_mm=0.0,
                       tol_mm=0.005, z_mm=0.0, feed_mm_min=600.0, s_word=1000.0,
                       laser=LaserMode.CONSTANT, ccw=True, head=(0.0, 0.0, 0.0)) -> Moves:
    """The Archimedean spiral r = a + b·θ closed by a full circle ([MicroCAM] eq. 6.3).

    Parameters
    ----------
    centre : (x, y)
        Spiral centre, mm.
    outer_radius_mm : float
        Radius R of the closing circle (beam centre), mm, > ``inner_radius_mm``.
    step_mm : float
        Radial step per turn, 2π·b, mm (for filling: about the beam diameter), > 0.
    inner_radius_mm : float
        a, the radius at θ = 0, mm, ≥ 0.
    tol_mm : float
        Largest distance between the arcs and the spiral, mm, > 0.
    z_mm : float
        Z of the whole spiral, mm.
    feed_mm_min, s_word, laser
        Cutting feed (mm/min), power word S and laser mode.
    ccw : bool
        Turning direction.
    head : (x, y, z)
        Head position before the spiral, mm (default machine zero, where a
        program starts); a rapid joins it to the start (x + a, y, z).

    Returns
    -------
    Moves
        The spiral as arcs (and lines where they fit
        better) until r = R, then a full circle of radius R.

    Examples
    --------
    Ten turns of 0.5 mm, within 5 µm, take a few dozen arcs rather than thousands of chords:

    >>> m = archimedean_spiral((0, 0), 5.0, 0.5, tol_mm=0.005)
    >>> bool(len(m) < 100), round(float(np.hypot(*m.end[-1, :2])), 9)
    (True, 5.0)
    """
    R = _positive("outer_radius_mm", outer_radius_mm, "mm")
    step = _positive("step_mm", step_mm, "mm")
    tol = _positive("tol_mm", tol_mm, "mm")
    a = float(inner_radius_mm)
    if not (math.isfinite(a) and 0 <= a < R):
        raise GeometryError(f"inner_radius_mm must be in [0, outer_radius_mm = {R}) mm, got {inner_radius_mm!r}")
    c = np.array([float(v) for v in centre])
    spiral, theta_end = _spiral_path(c, a, step / (2 * math.pi), R, tol, ccw)
    circle = Path.arc(c, R, theta_end, 2 * math.pi if ccw else -2 * math.pi)
    settings = LayerSettings(feed_mm_min=feed_mm_min, s_word=s_word, laser=laser)
    start = (c[0] + a, c[1], float(z_mm))
    moves = build_moves([spiral, circle], settings, origin=start)   # build_moves cuts at origin's Z
    if np.allclose(head, start, rtol=0, atol=1e-9):
        return moves
    travel = MovesBuilder(origin=head, feed_mm_min=feed_mm_min, s_word=s_word, laser=laser)
    travel.rapid(*start)
    return Moves.concat([travel.build(), moves])


def square_spiral(centre=(0.0, 0.0), size_mm=10.0, step_mm=0.5, *, z_mm=0.0, feed_mm_min=600.0,
                  s_word=1000.0, laser=LaserMode.CONSTANT, accel_mm_s2=500.0, loops=True):
    """A square spiral at a constant step, outward from the centre, with corner loops.

    Legs of length s, s, 2s, 2s, 3s, 3s, … (s = ``step_mm``) turning left, until the
    square of side ``size_mm`` is covered; with ``loops`` every sharp corner gets a
    laser-off constant-velocity loop and each end a lead
    (:func:`labkit.toolpath.corners.add_corner_loops`, [MicroCAM] §6.1.2).

    Parameters
    ----------
    centre : (x, y)
        Centre of the square, mm.
    size_mm : float
        Side of the covered square (beam centres), mm, ≥ ``step_mm``.
    step_mm : float
        Distance between neighbouring passes, mm, > 0.
    z_mm : float
        Z of the spiral, mm.
    feed_mm_min, s_word, laser
        Cutting feed (mm/min), power word S and laser mode.
    accel_mm_s2 : float
        Machine acceleration for the loops' size (r = v²/a), mm/s².
    loops : bool
        Add the corner loops and leads.

    Returns
    -------
    moves : Moves
        The cuts (and the loops between them).
    report : dict
        What :func:`add_corner_loops` added (empty counts without ``loops``).

    Examples
    --------
    >>> m, rep = square_spiral((0, 0), 2.0, 0.5)
    >>> int(m.laser_on.sum()), rep["triangle_loops"] + rep["arc_loops"]
    (9, 8)
    >>> m.bounds(m.laser_on)[:, :2].tolist()
    [[-1.0, -1.0], [1.0, 1.0]]
    """
    s = _positive("step_mm", step_mm, "mm")
    size = _positive("size_mm", size_mm, "mm")
    n = int(math.floor(size / s + 1e-9))
    if n < 1:
        raise GeometryError(f"size_mm must be >= step_mm = {s} mm, got {size_mm!r}")
    # legs 1, 1, 2, 2, …, n, n, n (the last closes the square), directions E N W S …
    lengths = np.repeat(np.arange(1, n + 1), 2)
    lengths = np.append(lengths, n) * s
    dirs = np.array([[1, 0], [0, 1], [-1, 0], [0, -1]], float)[np.arange(len(lengths)) % 4]
    steps = dirs * lengths[:, None]
    pts = np.vstack([[0.0, 0.0], np.cumsum(steps, axis=0)])
    # centre the square: the covered points span [min, max] in each axis
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    pts += np.asarray(centre, float) - (lo + hi) / 2
    pts3 = np.c_[pts, np.full(len(pts), float(z_mm))]
    moves = Moves.from_cuts(pts3[:-1], pts3[1:], feed_mm_min=feed_mm_min, s_word=s_word,
                            laser=laser)
    if not loops:
        return moves, {"arc_loops": 0, "triangle_loops": 0, "leads": 0, "added_length_mm": 0.0}
    return add_corner_loops(moves, accel_mm_s2=_positive("accel_mm_s2", accel_mm_s2, "mm/s²"))


_AXIS = {"x": 0, "y": 1, "z": 2}
_PLANE_AXES = {"xy": (0, 1), "xz": (0, 2)}


def zigzag(origin=(0.0, 0.0, 0.0), width_mm=10.0, height_mm=5.0, step_mm=0.5, *, along="x", plane="xy",
           lead_mm=0.0, reverse=False, feed_mm_min=600.0, s_word=1000.0,
           laser=LaserMode.CONSTANT) -> Moves:
    """Zig-zag face machining of a rectangle ([MicroCAM] §6.1.3.4).

    Parameters
    ----------
    origin : (x, y, z)
        The rectangle's lower corner, mm.
    width_mm, height_mm : float
        Extent along the plane's first and second axis (X then Y for ``"xy"``,
        X then Z for ``"xz"``), mm, > 0.
    step_mm : float
        Step-over between passes, mm, > 0.
    along : {"x", "y", "z"}
        Axis the passes run along; it must lie in ``plane``.
    plane : {"xy", "xz"}
        Plane of the face.
    lead_mm : float
        Laser-off lead-in before and lead-out after every pass, mm, ≥ 0.
    reverse : bool
        Step from the far side of the rectangle back to the origin side
        (direction of the step-over) instead of away from it.
    feed_mm_min, s_word, laser
        Cutting feed (mm/min), power word S and laser mode.

    Returns
    -------
    Moves
        A rapid to the first lead-in, then per pass: lead-in (laser off), the
        cut, lead-out (laser off), the step-over (laser off); passes alternate
        direction. ``floor(extent / step) + 1`` passes cover the extent (the last
        one on the far edge when the step divides it).

    Examples
    --------
    >>> m = zigzag((0, 0, 0), 10, 2, 0.5, lead_mm=1)
    >>> int(m.laser_on.sum()), float(m.lengths_mm()[m.laser_on].sum())
    (5, 50.0)
    >>> m.bounds(m.laser_on).tolist()
    [[0.0, 0.0, 0.0], [10.0, 2.0, 0.0]]
    """
    if plane not in _PLANE_AXES:
        raise GeometryError(f"plane must be 'xy' or 'xz', got {plane!r}")
    if along not in _AXIS or _AXIS[along] not in _PLANE_AXES[plane]:
        raise GeometryError(f"along must be an axis of plane {plane!r} ({', '.join(plane)}), got {along!r}")
    w = _positive("width_mm", width_mm, "mm")
    h = _positive("height_mm", height_mm, "mm")
    s = _positive("step_mm", step_mm, "mm")
    lead = float(lead_mm)
    if not (math.isfinite(lead) and lead >= 0):
        raise GeometryError(f"lead_mm must be a finite number >= 0 mm, got {lead_mm!r}")
    ax1, ax2 = _PLANE_AXES[plane]
    extent = {ax1: w, ax2: h}
    run = _AXIS[along]
    cross = ax2 if run == ax1 else ax1
    n_pass = int(math.floor(extent[cross] / s + 1e-9)) + 1
    offsets = np.arange(n_pass) * s
    if reverse:
        offsets = extent[cross] - offsets
    o = np.asarray(origin, float)
    b = MovesBuilder(feed_mm_min=feed_mm_min, s_word=s_word, laser=LaserMode.OFF)

    def point(u, v):
        p = o.copy()
        p[run] += u
        p[cross] += v
        return p

    L = extent[run]
    for k, v in enumerate(offsets):
        u0, u1, d = (0.0, L, 1.0) if k % 2 == 0 else (L, 0.0, -1.0)
        if k == 0:
            b.rapid(*point(u0 - d * lead, v))
        else:
            b.line(*point(u0 - d * lead, v), laser=LaserMode.OFF)       # step-over
        if lead > 0:
            b.line(*point(u0, v), laser=LaserMode.OFF)
        b.line(*point(u1, v), laser=laser)
        if lead > 0:
            b.line(*point(u1 + d * lead, v), laser=LaserMode.OFF)
    return b.build()


def cone_sections(d1_mm, d2_mm, height_mm, levels):
    """Pass depths and section diameters of a cone ([MicroCAM] eqs. 6.4–6.6).

    α = atan(((d1 − d2)/2) / H) (6.4), H_Pn = H − Pn·H/Zlevel (6.5), and the
    section (6.6), printed as "r_C = d2 + 2·H_Pn·tan α": with tan α =
    (d1 − d2)/(2H) this gives d1 at Pn = 0 (H_Pn = H) and d2 at H_Pn = 0, so the
    quantity is a **diameter**, not a radius (a radius would be
    d2/2 + H_Pn·tan α). We use it as the diameter D_Pn = d2 + 2·H_Pn·tan α.
    H_Pn is the height of the section above the d2 end; pass Pn runs
    Pn·H/Zlevel below the start, so the d1 end is at the start Z.

    Parameters
    ----------
    d1_mm, d2_mm : float
        Diameters at the start Z and at depth H, mm (> 0).
    height_mm : float
        H, mm, > 0.
    levels : int
        Zlevel, number of passes, ≥ 1.

    Returns
    -------
    depth_mm, diameter_mm : ndarray
        Depth below the start, Pn·H/Zlevel, and section diameter, Pn = 0…Zlevel−1.

    Examples
    --------
    >>> depth, dia = cone_sections(10, 4, 3, 3)
    >>> depth.tolist(), dia.tolist()
    ([0.0, 1.0, 2.0], [10.0, 8.0, 6.0])
    """
    d1 = _positive("d1_mm", d1_mm, "mm")
    d2 = _positive("d2_mm", d2_mm, "mm")
    H = _positive("height_mm", height_mm, "mm")
    if int(levels) != levels or levels < 1:
        raise GeometryError(f"levels must be an integer >= 1, got {levels!r}")
    alpha = math.atan(((d1 - d2) / 2) / H)                     # (6.4)
    pn = np.arange(int(levels), dtype=float)
    h_pn = H - pn * H / levels                                  # (6.5)
    return pn * H / levels, d2 + 2 * h_pn * math.tan(alpha)     # (6.6), a diameter


def cone(centre=(0.0, 0.0), d1_mm=10.0, d2_mm=4.0, height_mm=2.0, levels=4, beam_mm=0.2, *,
         z_start_mm=0.0, tol_mm=0.005, feed_mm_min=600.0, s_word=1000.0,
         laser=LaserMode.CONSTANT) -> Moves:
    """A cone as stacked Archimedean spirals ([MicroCAM] §6.1.3.5).

    Pass Pn (0…``levels``−1) runs at Z = z_start − Pn·H/Zlevel and fills the
    section of diameter D_Pn (:func:`cone_sections`: eq. 6.6 read as a
    diameter) with a spiral stepping by the beam diameter, from the centre to a
    closing circle of radius D_Pn/2 − beam/2, so the cut edge lies on the section.

    Parameters
    ----------
    centre : (x, y)
        Cone axis, mm.
    d1_mm, d2_mm : float
        Diameters at the start Z and at depth H, mm.
    height_mm : float
        H, mm.
    levels : int
        Zlevel, number of passes.
    beam_mm : float
        Beam diameter: the spirals' step and the edge compensation, mm; smaller
        than every section diameter.
    z_start_mm, tol_mm, feed_mm_min, s_word, laser
        Start Z (mm), arc-fit tolerance (mm), feed (mm/min), power S, laser mode.

    Returns
    -------
    Moves
        The levels in order, joined by laser-off rapids.

    Examples
    --------
    >>> m = cone((0, 0), 10, 4, 3, 3, 0.5)
    >>> sorted(set(np.round(m.end[m.laser_on, 2], 9).tolist()))
    [-2.0, -1.0, 0.0]
    """
    beam = _positive("beam_mm", beam_mm, "mm")
    depth, dia = cone_sections(d1_mm, d2_mm, height_mm, levels)
    if not np.all(dia > beam):
        raise GeometryError(f"beam_mm = {beam} mm must be smaller than every section diameter "
                            f"(smallest {float(dia.min())} mm)")
    parts, head = [], (0.0, 0.0, 0.0)
    for dz, D in zip(depth, dia):
        part = archimedean_spiral(centre, D / 2 - beam / 2, beam, tol_mm=tol_mm, z_mm=z_start_mm - dz,
                                  feed_mm_min=feed_mm_min, s_word=s_word, laser=laser, head=head)
        parts.append(part)
        head = part.end[-1]
    return Moves.concat(parts)
