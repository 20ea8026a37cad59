"""The rotating-wire probe: contact sensing by acoustic emission and automated XY scanning
([MicroCAM] ch. 4).

**Geometry (fig. 4-1).** A wire leaves the end of a spinning stylus at a distance R_s from
the spin axis and is bent outwards by β from the axis; a length L lies beyond the bend.
Its tip is then at R_s + L·sin β from the axis (and L·cos β below the bend), so as the
stylus spins the tip sweeps a circle of diameter

    D_e = 2·R_s + 2·L·sin β                                        (eq. 4.1, re-derived)

— the printed equation is garbled (``2 2 sine eD R L``); this is the reading that
matches the figure and the text ("the effective diameter depends on the length of the
wire"). With a wire of diameter d_w the outermost point of its cut end adds
(d_w / 2)·cos β. The wire must reach beyond the stylus' own radius, or the stylus
touches first.

**Contact (fig. 4-3).** The probe approaches the part at a feed f_p while spinning at
RPM; the tip touches the part once per revolution, at the moment it faces it, as soon as
the part is within R_e = D_e / 2 of the axis. Each touch makes an acoustic-emission
burst; the signal (sampled at 20 kHz) is noise plus decaying bursts. The seed's rules:
the first sample above the threshold stops the probe, later pulses are ignored, the
probe position is recorded and the probe returns to its start. The probe can overshoot
the geometric contact by up to one feed per revolution f_p / RPM (the tip may have just
passed the contact direction) plus the travel of one sample period: the resolution is
the feed per revolution.

**Scan (fig. 4-4, eqs. 4.2–4.7).** Two contacts P0, P1 along the initial direction; then
the next start point is found by going a step-over R_s beyond P1 along P0→P1 (P2) and an
offset R_o out along the normal (P3); the probe approaches from P3 back towards P2. The
last two contacts define the next line. Eqs. 4.2–4.7 intersect circles with lines
written by their slope S, which fails for a vertical line (S infinite); the same points
are computed here with unit vectors. The scan stops when it comes back to P0.
The part's profile is the contact centres offset by R_e towards the part, along the
normal estimated from the neighbouring contacts.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from labkit.errors import GeometryError

__all__ = ["effective_diameter_mm", "calibrate_effective_diameter_mm", "ProbeSettings", "ae_signal",
           "detect_contact", "probe_contact", "scan_xy", "ScanResult", "circle_part", "rounded_square_part",
           "profile_error_mm", "scan_errors", "fit_circle"]

#: The seed's DAQ rate for the AE signal, Hz.
SAMPLE_RATE_HZ = 20_000.0


def effective_diameter_mm(wire_length_mm: float, bend_deg: float = 45.0, stylus_radius_mm: float = 0.0,
                          wire_diameter_mm: float = 0.0, stylus_outer_radius_mm: float | None = None) -> float:
    """D_e = 2·R_s + 2·L·sin β (+ d_w·cos β for the wire's own thickness), mm (see the module notes).

    Parameters
    ----------
    wire_length_mm : float
        L, the wire beyond the bend, mm.
    bend_deg : float
        β, the bend from the spin axis, degrees (0 < β ≤ 90).
    stylus_radius_mm : float
        R_s, the distance from the spin axis where the wire leaves the stylus, mm.
    wire_diameter_mm : float
        d_w, mm (0: the wire's centre line).
    stylus_outer_radius_mm : float, optional
        If given, the tip must sweep outside it (else the stylus touches first).

    Examples
    --------
    >>> round(effective_diameter_mm(1.0, 45.0), 6)                  # a wire on the axis
    1.414214
    >>> round(effective_diameter_mm(0.5, 30.0, stylus_radius_mm=0.1), 6)
    0.7
    """
    if not (wire_length_mm > 0 and 0 < bend_deg <= 90 and stylus_radius_mm >= 0 and wire_diameter_mm >= 0):
        raise GeometryError(f"need L > 0, 0 < β <= 90°, R_s >= 0, d_w >= 0; got {wire_length_mm!r}, "
                            f"{bend_deg!r}, {stylus_radius_mm!r}, {wire_diameter_mm!r}")
    b = math.radians(bend_deg)
    de = 2 * stylus_radius_mm + 2 * wire_length_mm * math.sin(b) + wire_diameter_mm * math.cos(b)
    if stylus_outer_radius_mm is not None and de / 2 <= stylus_outer_radius_mm:
        raise GeometryError(f"the tip sweeps a radius of {de / 2:g} mm, inside the stylus' {stylus_outer_radius_mm:g} "
                            "mm: the stylus would touch first; expected a longer wire or a larger bend")
    return de


@dataclass(frozen=True)
class ProbeSettings:
    """Probe and signal parameters.

    Attributes
    ----------
    effective_diameter_mm : float
        D_e, mm.
    rpm : float
        Spindle speed, rev/min.
    feed_mm_min : float
        Approach feed f_p, mm/min (resolution = f_p / RPM per revolution).
    noise_rms : float
        AE noise, volts RMS.
    burst_amplitude : float
        Peak of one touch's burst, volts.
    burst_decay_s : float
        Decay time of a burst, s.
    burst_freq_hz : float
        Ringing frequency of a burst as sampled, Hz (below the Nyquist 10 kHz).
    threshold : float
        Detection threshold on |signal|, volts.
    sample_rate_hz : float
        DAQ rate, Hz.
    """

    effective_diameter_mm: float = 1.629
    rpm: float = 10_000.0
    feed_mm_min: float = 1.0
    noise_rms: float = 0.01
    burst_amplitude: float = 1.0
    burst_decay_s: float = 0.002
    burst_freq_hz: float = 3_000.0
    threshold: float = 0.1
    sample_rate_hz: float = SAMPLE_RATE_HZ

    @property
    def radius_mm(self) -> float:
        return self.effective_diameter_mm / 2

    @property
    def feed_per_rev_mm(self) -> float:
        """The resolution: approach per revolution, mm."""
        return self.feed_mm_min / self.rpm


def ae_signal(t_s: np.ndarray, impacts_s: np.ndarray, settings: ProbeSettings, rng) -> np.ndarray:
    """Noise plus a decaying burst after every touch, volts.

    >>> s = ProbeSettings(noise_rms=0.0)
    >>> t = np.arange(5) / 20_000
    >>> ae_signal(t, np.array([1e-4]), s, np.random.default_rng(0)).round(3).tolist()
    [0.0, 0.0, 1.0, 0.573, -0.294]
    """
    out = rng.normal(0.0, settings.noise_rms, len(t_s))
    for ti in impacts_s:
        dt = t_s - ti
        on = dt >= 0
        out[on] += (settings.burst_amplitude * np.exp(-dt[on] / settings.burst_decay_s)
                    * np.cos(2 * math.pi * settings.burst_freq_hz * dt[on]))
    return out


def detect_contact(signal: np.ndarray, threshold: float) -> int:
    """Index of the first sample whose magnitude exceeds the threshold (later pulses are
    ignored: the probe stops there), or -1.

    >>> detect_contact(np.array([0.01, -0.02, 0.5, 0.9, 0.1]), 0.3)
    2
    """
    above = np.flatnonzero(np.abs(signal) > threshold)
    return int(above[0]) if len(above) else -1


def probe_contact(start, direction, distance_fn, settings: ProbeSettings, rng, *, max_travel_mm: float = 1.0):
    """One approach: the recorded probe-centre position at detection, and the true geometric one.

    Parameters
    ----------
    start : (x, y)
        Start of the approach, mm (outside the part by more than R_e).
    direction : (dx, dy)
        Approach direction (normalised here).
    distance_fn : callable
        Signed distance from a point (x, y) to the part, mm (negative inside).
    settings : ProbeSettings
    rng : numpy Generator
        For the noise, the tip's phase and the DAQ clock's phase.
    max_travel_mm : float
        Give up after this travel (no contact: an error).

    Returns
    -------
    recorded, geometric : ndarray (2,)
        The position recorded at detection, and where the centre first came within R_e.
    """
    p0 = np.asarray(start, float)
    d = np.asarray(direction, float)
    d = d / np.hypot(*d)
    r = settings.radius_mm
    v = settings.feed_mm_min / 60.0                           # mm/s
    if distance_fn(p0) <= r:
        raise GeometryError(f"the approach starts within the probe's reach of the part at {p0.tolist()}")
    # the travel s* where the part first comes within R_e: march by the distance left (it
    # cannot overshoot the first contact), then bisect the last step
    s_star, gap = 0.0, distance_fn(p0) - r
    while gap > 1e-12:
        s_star += gap
        if s_star > max_travel_mm:
            raise GeometryError(f"no contact within {max_travel_mm:g} mm from {p0.tolist()} along {d.tolist()}")
        gap = distance_fn(p0 + s_star * d) - r
    lo, hi = max(0.0, s_star - 1e-9), s_star + 1e-9
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if distance_fn(p0 + mid * d) > r else (lo, mid)
    s_star = hi
    t_star = s_star / v
    # the tip faces the part once per revolution; its phase at t* is uniform
    rev_s = 60.0 / settings.rpm
    first = t_star + rng.uniform(0.0, rev_s)
    n_imp = 8
    impacts = first + rev_s * np.arange(n_imp)
    # the DAQ samples from the start of the approach, with a random clock phase; only the
    # samples around the touches need making: before them the signal is noise alone
    dt = 1.0 / settings.sample_rate_hz
    phase = rng.uniform(0.0, dt)
    k0 = max(0, int((t_star - 4 * rev_s - phase) / dt))
    k1 = int((impacts[-1] + 10 * dt - phase) / dt) + 1
    t = phase + dt * np.arange(k0, k1)
    sig = ae_signal(t, impacts, settings, rng)
    k = detect_contact(sig, settings.threshold)
    if k < 0:
        raise GeometryError("the AE signal never crossed the threshold: raise the burst or lower the threshold")
    recorded = p0 + min(v * t[k], max_travel_mm) * d
    return recorded, p0 + s_star * d


def circle_part(centre=(0.0, 0.0), radius_mm: float = 6.35):
    """Signed distance function of a cylinder (a disc in XY): mm, negative inside.

    >>> part = circle_part((1.0, 0.0), 2.0)
    >>> part((4.0, 0.0)), part((1.0, 0.5))
    (1.0, -1.5)
    """
    c = np.asarray(centre, float)
    return lambda p: float(np.hypot(*(np.asarray(p, float) - c))) - radius_mm


def rounded_square_part(centre=(0.0, 0.0), side_mm: float = 10.0, corner_mm: float = 2.0):
    """Signed distance function of a square of side ``side_mm`` with corners rounded at
    ``corner_mm``: mm, negative inside.

    >>> part = rounded_square_part((0, 0), 10.0, 2.0)
    >>> part((6.0, 0.0)), part((0.0, 0.0)), round(part((5.0, 5.0)), 6)
    (1.0, -5.0, 0.828427)
    """
    c = np.asarray(centre, float)
    h = side_mm / 2 - corner_mm
    if not (corner_mm >= 0 and h >= 0):
        raise GeometryError(f"need 0 <= corner_mm <= side_mm / 2, got side {side_mm!r}, corner {corner_mm!r}")

    def dist(p):
        q = np.abs(np.asarray(p, float) - c) - h
        outside = float(np.hypot(*np.maximum(q, 0.0)))
        return outside + min(float(q.max()), 0.0) - corner_mm
    return dist


def profile_error_mm(profile, distance_fn) -> np.ndarray:
    """Signed distance (mm) of each reconstructed profile point from the true surface:
    positive outside the part, negative inside."""
    return np.array([distance_fn(q) for q in np.asarray(profile, float)])


def calibrate_effective_diameter_mm(centre_distance_mm: float, block_mm: float) -> float:
    """D_e from a gauge block ([MicroCAM] §4.4): the probe centres touching its two faces
    lie a block width plus one effective diameter apart.

    >>> round(calibrate_effective_diameter_mm(21.629, 20.0), 6)
    1.629
    """
    de = float(centre_distance_mm) - float(block_mm)
    if not de > 0:
        raise GeometryError(f"the contact centres ({centre_distance_mm!r} mm apart) must lie farther apart than the "
                            f"block is wide ({block_mm!r} mm)")
    return de


@dataclass
class ScanResult:
    """An automated scan: contact centres (recorded and geometric), approach starts, and the
    profile compensated by R_e, all (n, 2) in mm."""

    contacts: np.ndarray
    geometric: np.ndarray
    starts: np.ndarray
    profile: np.ndarray


def _next_start(p_prev, p_last, step_mm, offset_mm, side):
    """Eqs. 4.2–4.7 in vector form: P2 = P1 + R_s·u, P3 = P2 + R_o·n (n the outward normal)."""
    u = p_last - p_prev
    u = u / np.hypot(*u)
    n = side * np.array([-u[1], u[0]])
    p2 = p_last + step_mm * u
    return p2 + offset_mm * n, -n


def scan_xy(distance_fn, p_start, initial_direction, settings: ProbeSettings, *, step_mm: float = 0.5,
            offset_mm: float = 0.2, second_start_shift_mm: float | None = None, max_points: int = 2000,
            seed: int = 0) -> ScanResult:
    """The automated XY scan of [MicroCAM] fig. 4-5 around a part.

    Parameters
    ----------
    distance_fn : callable
        Distance from (x, y) to the part, mm.
    p_start : (x, y)
        Start of the first approach, outside the part, mm.
    initial_direction : (dx, dy)
        I_dir: the first two approaches go this way (towards the part).
    settings : ProbeSettings
    step_mm : float
        Step-over R_s between contacts, mm.
    offset_mm : float
        R_o: each approach starts this far out from the predicted surface, mm.
    second_start_shift_mm : float, optional
        The second start is the first shifted sideways by this (default ``step_mm``),
        counter-clockwise around the part.
    max_points : int
        Give up after this many contacts.
    seed : int
        Seeds the noise and phases.

    Returns
    -------
    ScanResult

    Examples
    --------
    A 12.7 mm plug gauge scanned every 0.5 mm at 0.1 µm per revolution:

    >>> part = circle_part((0, 0), 6.35)
    >>> res = scan_xy(part, (-8.0, 0.0), (1.0, 0.0), ProbeSettings(), step_mm=0.5)
    >>> len(res.contacts) > 70, bool(np.abs(np.hypot(*res.profile.T) - 6.35).max() < 0.001)
    (True, True)
    """
    rng = np.random.default_rng(seed)
    d0 = np.asarray(initial_direction, float)
    d0 = d0 / np.hypot(*d0)
    shift = step_mm if second_start_shift_mm is None else second_start_shift_mm
    side_vec = np.array([d0[1], -d0[0]])          # to the right of the approach: CCW around the part
    starts = [np.asarray(p_start, float), np.asarray(p_start, float) + shift * side_vec]
    contacts, geometric = [], []
    for s in starts:
        rec, geo = probe_contact(s, d0, distance_fn, settings, rng, max_travel_mm=50.0)
        contacts.append(rec)
        geometric.append(geo)
    # the outward side: the normal pointing back against the approach
    u = contacts[1] - contacts[0]
    side = 1.0 if np.dot([-u[1], u[0]], -d0) > 0 else -1.0
    travelled = 0.0
    while len(contacts) < max_points:
        start, direction = _next_start(contacts[-2], contacts[-1], step_mm, offset_mm, side)
        rec, geo = probe_contact(start, direction, distance_fn, settings, rng,
                                 max_travel_mm=offset_mm + 4 * step_mm + 1.0)
        travelled += float(np.hypot(*(rec - contacts[-1])))
        contacts.append(rec)
        geometric.append(geo)
        starts.append(start)
        if travelled > 3 * step_mm and np.hypot(*(rec - contacts[0])) < 0.75 * step_mm:
            break
    else:
        raise GeometryError(f"the scan did not close after {max_points} contacts")
    c = np.array(contacts)
    # profile: centres offset by R_e towards the part along the normal of the centre polyline
    tangent = np.roll(c, -1, axis=0) - np.roll(c, 1, axis=0)
    tangent /= np.hypot(*tangent.T)[:, None]
    inward = -side * np.c_[-tangent[:, 1], tangent[:, 0]]
    profile = c + settings.radius_mm * inward
    return ScanResult(c, np.array(geometric), np.array(starts), profile)


def fit_circle(points) -> tuple[np.ndarray, float]:
    """Least-squares circle through points (Kåsa): centre (2,), radius, mm.

    >>> t = np.linspace(0, 2 * np.pi, 20, endpoint=False)
    >>> c, r = fit_circle(np.c_[1 + 3 * np.cos(t), -2 + 3 * np.sin(t)])
    >>> c.round(9).tolist(), round(r, 9)
    ([1.0, -2.0], 3.0)
    """
    p = np.asarray(points, float)
    a = np.c_[2 * p, np.ones(len(p))]
    b = (p ** 2).sum(axis=1)
    sol = np.linalg.lstsq(a, b, rcond=None)[0]
    centre = sol[:2]
    return centre, float(math.sqrt(sol[2] + centre @ centre))


def scan_errors(distance_fn, p_start, initial_direction, *, step_overs_mm, feeds_per_rev_mm,
                settings: ProbeSettings = ProbeSettings(), offset_mm: float = 0.2, seed: int = 0):
    """Reconstruction error of the automated scan against the true profile, for every pair of
    step-over and feed per revolution.

    Parameters
    ----------
    distance_fn : callable
        Signed distance to the part, mm.
    p_start, initial_direction : (x, y)
        As for :func:`scan_xy`.
    step_overs_mm : sequence of float
        Step-overs R_s to try, mm.
    feeds_per_rev_mm : sequence of float
        Approach per spindle revolution to try, mm (the feed is set from ``settings.rpm``).
    settings : ProbeSettings
    offset_mm : float
        R_o, mm.
    seed : int

    Returns
    -------
    DataFrame
        ``step_mm``, ``feed_per_rev_mm``, ``feed_mm_min``, ``contacts``, ``max_error_mm``
        (largest |signed distance| of the compensated profile from the surface),
        ``mean_error_mm`` (signed: the probe stops late, so the profile lies inside) and
        ``rms_error_mm``.
    """
    import dataclasses

    import pandas as pd

    rows = []
    for step in step_overs_mm:
        for fpr in feeds_per_rev_mm:
            s = dataclasses.replace(settings, feed_mm_min=float(fpr) * settings.rpm)
            res = scan_xy(distance_fn, p_start, initial_direction, s, step_mm=float(step), offset_mm=offset_mm,
                          seed=seed)
            e = profile_error_mm(res.profile, distance_fn)
            rows.append(dict(step_mm=float(step), feed_per_rev_mm=float(fpr), feed_mm_min=s.feed_mm_min,
                             contacts=len(e), max_error_mm=float(np.abs(e).max()),
                             mean_error_mm=float(e.mean()), rms_error_mm=float(np.sqrt((e ** 2).mean()))))
    return pd.DataFrame(rows)
