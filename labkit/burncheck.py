"""Predict a program's burn, then check a scan of the real burn against it (issue 31 §4).

The prediction is :func:`labkit.laser.simulate.simulate_burn`'s: the planned motion's dose through
the material's fitted dose model (``w0_mm``, ``fth_mj_mm2``), M3 or M4 as the program says. Its
*predicted darkness* is the burned share of each pixel (:attr:`~labkit.laser.simulate.Burn.coverage`),
averaged over the scan's pixel when a scan is compared: 0 is paper, 1 a solid burn.

A scan's darkness is ``1 − grey / paper`` (as :mod:`labkit.laser.tone` measures a wedge), divided by
the darkness of a solid burn — the material's, given, or the scan's own median where the prediction
says solid (so a uniformly pale burn is found only when the solid darkness is given). Then:

1. **registration** — the scan's shift against the prediction by phase correlation (scikit-image's
   ``phase_cross_correlation``, to a tenth of a pixel), undone; for a scan file the prediction is
   found in the scan first (zero-padded correlation, so the piece may lie anywhere on it);
2. **each layer's own shift** — the program's layers are told apart by their power (S); each
   layer's zone (the pixels nearer its burn than any other's, within ``2·w0`` of it) is registered
   again — darkness through a saturating ramp, so a paler half does not pull it, and searched within
   ``2·w0`` only, so a line is not matched to its neighbour — and a layer that landed 0.1 mm off the
   rest (lost steps, a re-homed head) is measured against the layers holding most of the burn,
   reported and undone before the areas are compared. A hatch's position along its lines rests on
   its line ends alone, which a weaker beam moves (a paler hatch read 0.026 mm off along x);
3. **differences** — *missing* burn (predicted, not in the scan) and *extra* burn (in the scan, not
   predicted), a pixel counting as burned at half the solid darkness; and, where both burned,
   regions *lighter* or *darker* than predicted by more than ``tolerance`` (a share of the solid
   darkness) — each as connected regions of at least one beam spot (π·w0²) with area, bounding box,
   layer and mean darkness difference;
4. **numbers per layer and over the part** — burned areas predicted and scanned, missing and extra
   area, the area difference per millimetre of burning path (a line's width change), and the mean
   darkness over the predicted burn, predicted and scanned.

``labkit burncheck compare -o REPORT.json`` writes the numbers in this format (version 2)::

    {
      "format": "labkit-burncheck",       # exactly this
      "version": 2,                       # a later version changes these keys (1 named s_word power_s)
      "program": "label.gcode", "scan": "scan.png", "dpi": 600.0,
      "model": "dose model w0 … mm, F_th … mJ/mm² (fit fit.json)", "tolerance": 0.15,
      "shift_mm": [x, y], "turn_deg": 0.5,   # where the prediction lies in the scan, its turn (CCW)
      "in_scan": true, "pixel_mm": 0.0423,
      "predicted_mm2": …, "scanned_mm2": …, "solid_darkness": 0.63, "solid_darkness_given": false,
      "layers": [{"s_word": 300.0, "length_mm": …, "predicted_mm2": …, "scanned_mm2": …,
                  "missing_mm2": …, "extra_mm2": …, "width_change_mm": …, "predicted_darkness": …,
                  "scanned_darkness": …, "shift_mm": [x, y]}, …],
      "part": {… the same keys, s_word null, shift_mm [0, 0] …},
      "defects": [{"kind": "missing" | "extra" | "light" | "dark", "area_mm2": …,
                   "bbox_mm": [x0, y0, x1, y1], "layer_s": 300.0 | null, "darkness": …}, …]
    }

A piece squared by eye lies turned on the scanner (0.1° moves the far end of a 50 mm part by
0.09 mm): after the first registration each half of each layer (left, right, bottom, top) is
registered on its own (a layer is rigid, so one burned off the rest is not read as a turn), the
turn read from how the halves moved, and the scan resampled turned back, five rounds at most (the
test label at 600 dpi turned 0.5° reads +0.500°, turned −1° −1.001°). Not handled: turns of more
than a few degrees (the halves are searched within 1 mm), a scan whose scale is not its stated
dpi, and materials whose darkness is not proportional to the burned share
(a grey engraving's tone curve, :mod:`labkit.laser.tone`).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from labkit.errors import InputError

__all__ = ["FORMAT", "VERSION", "BurnDefect", "LayerCheck", "BurnCheck", "predict_burn", "predicted_scan",
           "scan_darkness", "check_burn", "check_scan", "overlay"]

#: The report's format and version (``labkit burncheck compare -o``).
FORMAT = "labkit-burncheck"
VERSION = 2

_MM_PER_INCH = 25.4
# Burn.scan draws paper at 0.9 and a solid burn at 0.1: the predicted scan's darkness is read back
# through these two levels (tests/job/test_burncheck.py checks them against Burn.scan)
_PAPER, _SOLID = 0.9, 0.1
# the colours of the overlay picture
_COLOURS = {"missing": (220, 30, 30), "extra": (30, 60, 220), "light": (240, 150, 0), "dark": (150, 0, 170)}


@dataclass
class BurnDefect:
    """One region where the scan differs from the prediction.

    Attributes
    ----------
    kind : str
        "missing", "extra", "light" or "dark".
    area_mm2 : float
        The region's area, mm².
    bbox_mm : tuple
        (x0, y0, x1, y1) of its pixel centres, mm.
    layer_s : float or None
        S of the layer whose predicted burn lies nearest (None: no layer near, or layers unknown).
    darkness : float or None
        Mean darkness difference over the region, scan − prediction (1 = a solid burn).
    """

    kind: str
    area_mm2: float
    bbox_mm: tuple
    layer_s: float | None = None
    darkness: float | None = None


@dataclass
class LayerCheck:
    """Numbers for one layer (``s_word`` its S) or, with ``s_word`` None, for the whole part.

    Areas in mm², ``length_mm`` the burning path's length, ``width_change_mm`` the burned-area
    difference (scanned − predicted) per mm of that path, darkness means over the predicted
    burn (1 = a solid burn) and ``shift_mm`` the layer's shift against the rest of the part.
    """

    s_word: float | None
    length_mm: float
    predicted_mm2: float
    scanned_mm2: float
    missing_mm2: float
    extra_mm2: float
    width_change_mm: float
    predicted_darkness: float
    scanned_darkness: float
    shift_mm: tuple = (0.0, 0.0)

    @property
    def darkness_change(self) -> float:
        """Scanned − predicted mean darkness over the predicted burn."""
        return self.scanned_darkness - self.predicted_darkness


@dataclass
class BurnCheck:
    """The comparison: where the scan lay, the defects (largest first), per-layer and part numbers.

    ``shift_mm`` is the scan's shift against the prediction: on the prediction's own grid
    (:func:`check_burn`) a shift of the whole burn; in a scan file (:func:`check_scan`) where the
    piece lies on the scanner, which says nothing about the burn.
    """

    shift_mm: tuple
    predicted_mm2: float
    scanned_mm2: float
    defects: list = field(default_factory=list)
    layers: list = field(default_factory=list)
    part: LayerCheck | None = None
    solid_darkness: float = 1.0
    solid_darkness_given: bool = False
    pixel_mm: float = 0.0
    in_scan: bool = False
    turn_deg: float = 0.0          #: the piece's turn on the scanner, counter-clockwise (scan files)
    predicted: np.ndarray | None = field(default=None, repr=False)    #: predicted darkness, row 0 = low y
    scanned: np.ndarray | None = field(default=None, repr=False)      #: registered scan darkness, same grid
    extent_mm: tuple = field(default=(0.0, 0.0, 0.0, 0.0), repr=False)  #: (left, right, bottom, top)
    _regions: dict = field(default_factory=dict, repr=False)

    def summary(self) -> str:
        """The comparison in words."""
        where = "scan found at" if self.in_scan else "scan shifted by"
        solid = "given" if self.solid_darkness_given else "the scan's, where the prediction is solid"
        turned = f", turned {self.turn_deg:+.2f}°" if abs(self.turn_deg) >= 0.01 else ""
        lines = [f"{where} ({self.shift_mm[0]:+.3f}, {self.shift_mm[1]:+.3f}) mm{turned}; burned "
                 f"{self.scanned_mm2:.2f} mm² against {self.predicted_mm2:.2f} mm² predicted; "
                 f"solid darkness {self.solid_darkness:.3f} ({solid})"]
        if self.layers:
            lines.append("  layer    path mm  pred mm²  scan mm²  missing  extra  width Δ mm  dark pred  scan"
                         "     shift mm")
            for L in self.layers + [self.part]:
                name = "part" if L.s_word is None else f"S{L.s_word:g}"
                lines.append(f"  {name:<7}{L.length_mm:9.1f}{L.predicted_mm2:10.2f}{L.scanned_mm2:10.2f}"
                             f"{L.missing_mm2:9.2f}{L.extra_mm2:7.2f}{L.width_change_mm:+11.3f}"
                             f"{L.predicted_darkness:11.2f}{L.scanned_darkness:6.2f}"
                             + ("" if L.s_word is None else f"  ({L.shift_mm[0]:+.3f}, {L.shift_mm[1]:+.3f})"))
        for d in self.defects:
            x0, y0, x1, y1 = d.bbox_mm
            lines.append(f"  {d.kind:<7} {d.area_mm2:7.3f} mm² at x {x0:.2f}…{x1:.2f}, y {y0:.2f}…{y1:.2f} mm"
                         + (f", darkness {d.darkness:+.2f}" if d.darkness is not None else "")
                         + (f" (layer S{d.layer_s:g})" if d.layer_s is not None else ""))
        if not self.defects:
            lines.append("  no region differs by more than one beam spot")
        return "\n".join(lines)

    def to_dict(self) -> dict:
        """The numbers as plain JSON-ready values (no pictures)."""
        return {"shift_mm": list(self.shift_mm), "turn_deg": self.turn_deg, "in_scan": self.in_scan,
                "pixel_mm": self.pixel_mm,
                "predicted_mm2": self.predicted_mm2, "scanned_mm2": self.scanned_mm2,
                "solid_darkness": self.solid_darkness, "solid_darkness_given": self.solid_darkness_given,
                "layers": [asdict(L) | {"shift_mm": list(L.shift_mm)} for L in self.layers],
                "part": asdict(self.part) if self.part is not None else None,
                "defects": [asdict(d) | {"bbox_mm": list(d.bbox_mm)} for d in self.defects]}

    def overlay(self) -> np.ndarray:
        """An RGB picture (uint8, rows top = high y): the registered scan in grey, missing burn red,
        extra blue, regions lighter than predicted tinted orange, darker tinted purple."""
        if self.scanned is None:
            raise InputError("this comparison kept no pictures")
        grey = np.clip(255 * (1 - 0.85 * np.clip(self.scanned, 0, 1)), 0, 255).astype(np.uint8)
        img = np.repeat(grey[..., None], 3, axis=2)
        for kind, mask in self._regions.items():
            if kind in ("light", "dark"):      # tinted: the burn under a darkness region stays visible
                img[mask] = (0.45 * img[mask] + 0.55 * np.array(_COLOURS[kind])).astype(np.uint8)
            else:
                img[mask] = _COLOURS[kind]
        return img[::-1]


def predict_burn(moves, *, w0_mm: float, fth_mj_mm2: float, pixel_mm: float | None = None, machine=None):
    """The burn a program leaves in a material of the given dose model.

    Parameters
    ----------
    moves : Moves
        The program.
    w0_mm, fth_mj_mm2 : float
        The dose model: 1/e² beam radius (mm) and threshold fluence (mJ/mm²).
    pixel_mm : float, optional
        Grid spacing, mm (default w0 / 8).
    machine : str or MachineSpec, optional
        The machine whose planner moves the head (default: labkit's default machine).

    Returns
    -------
    burn : labkit.laser.simulate.Burn
        ``burn.burned`` is the mask (row 0 at ``burn.y_mm[0]``), ``burn.coverage`` the burned share.
    """
    from labkit.laser.simulate import simulate_burn

    return simulate_burn(moves, w0_mm=w0_mm, fth_mj_mm2=fth_mj_mm2, pixel_mm=pixel_mm, machine=machine)


def predicted_scan(burn, *, dpi: float = 600.0, margin_mm: float = 0.0) -> np.ndarray:
    """The scan a burn should give: grey 0…1 (paper 0.9, solid burn 0.1), rows down, y up, at ``dpi``.

    It is the prediction a scan is compared with, and written as a PNG by ``labkit burncheck
    predict``; ``margin_mm`` of paper surrounds it.
    """
    return burn.scan(dpi=dpi, margin_mm=margin_mm)


def scan_darkness(image, *, paper: float | None = None) -> np.ndarray:
    """A grey scan's darkness, ``1 − grey / paper`` (0 paper, about 0.9 a charred burn).

    Parameters
    ----------
    image : ndarray, 2-D
        Grey 0…1, paper light and burn dark.
    paper : float, optional
        The paper's grey level (default: the median of the light pixels, Otsu's threshold between
        light and dark).

    Examples
    --------
    >>> img = np.full((4, 4), 0.8); img[1:3, 1:3] = 0.2
    >>> scan_darkness(img)[1, :2].round(3).tolist()      # paper, then the burn
    [0.0, 0.75]
    """
    img = np.asarray(image, float)
    if img.ndim != 2 or img.size < 4 or not np.isfinite(img).all():
        raise InputError(f"the scan must be a 2-D grey image of finite values; got shape {img.shape}")
    if paper is None:
        from skimage.filters import threshold_otsu

        light = img > threshold_otsu(img) if np.ptp(img) > 0 else np.ones(img.shape, bool)
        paper = float(np.median(img[light]))
    if not paper > 0:
        raise InputError(f"the scan's paper level must be > 0, got {paper!r} (is the scan black?)")
    return 1.0 - img / paper


def _register(reference, moving, *, pad: bool = False):
    """(row, col) shift that lands ``moving`` on ``reference``, to a tenth of a pixel."""
    from skimage.registration import phase_cross_correlation

    if not (np.ptp(reference) > 0 and np.ptp(moving) > 0):
        return np.zeros(2)
    if pad:       # linear, not circular, correlation: the piece may lie anywhere on a larger scan
        shape = tuple(a + b for a, b in zip(reference.shape, moving.shape))
        ref = np.zeros(shape)
        ref[:reference.shape[0], :reference.shape[1]] = reference
        mov = np.zeros(shape)
        mov[:moving.shape[0], :moving.shape[1]] = moving
        reference, moving = ref, mov
    shift, _, _ = phase_cross_correlation(reference, moving, upsample_factor=10, normalization=None)
    return np.asarray(shift, float)


def _ramp(darkness):
    """Darkness mapped 0 below 0.2 of a solid burn, 1 above 0.8, linearly between."""
    return np.clip((darkness - 0.2) / 0.6, 0.0, 1.0)


def _placed(image, shape, rc, turn_rad: float):
    """``image`` sampled on a grid of ``shape`` whose pixel p lies at ``centre + R(turn)(p − centre) − rc``
    (rows and columns; the turn counter-clockwise with columns as x and rows as y, both upwards)."""
    from scipy import ndimage

    rr, cc = np.mgrid[0:shape[0], 0:shape[1]].astype(float)
    r0, c0 = (shape[0] - 1) / 2, (shape[1] - 1) / 2
    cos, sin = np.cos(turn_rad), np.sin(turn_rad)
    r = r0 + sin * (cc - c0) + cos * (rr - r0) - rc[0]
    c = c0 + cos * (cc - c0) - sin * (rr - r0) - rc[1]
    return ndimage.map_coordinates(image, [r, c], order=1, mode="constant", cval=0.0)


def _turned(predicted, dark, rc, labels, *, max_px: float, rounds: int = 5):
    """The shift refined and the turn of a piece squared by eye on the scanner (radians).

    Within each layer (``labels``: its index per pixel, −1 none) each half of its burn — left and
    right, bottom and top — is registered on its own: a turn moves the right half up against the
    left by the turn times their distance, and the top half left against the bottom. Layers are
    rigid, so one layer burned off the others reads as a shift here, not a turn; the layers'
    readings are joined by their weighted median (weights: the burn times the halves' distance
    squared, as a reading's precision grows). Halves with too little burn are left out.
    """
    from scipy import ndimage

    ref_all = _ramp(predicted)
    h, w = predicted.shape
    rr, cc = np.mgrid[0:h, 0:w].astype(float)
    layers = []
    for k in range(int(labels.max()) + 1):
        mask = (labels == k) & (ref_all > 0)
        if mask.sum() < 100:
            continue
        sl = ndimage.find_objects((labels == k).astype(int))[0]
        m = (labels == k)[sl]
        wgt = ref_all[sl] * m
        cy, cx = (rr[sl] * wgt).sum() / wgt.sum(), (cc[sl] * wgt).sum() / wgt.sum()
        layers.append((sl, m, wgt, cy, cx))
    turn, rc = 0.0, np.asarray(rc, float)
    for _ in range(rounds):
        moved_all = _ramp(_placed(dark, predicted.shape, rc, turn))
        turns, shifts = [], []
        for sl, m, wgt, cy, cx in layers:
            moved = moved_all[sl] * m
            found = {}
            for name, half in (("L", cc[sl] < cx), ("R", cc[sl] >= cx), ("B", rr[sl] < cy), ("T", rr[sl] >= cy)):
                weight = (wgt * half).sum()
                if weight < 50:                 # too little burn in this half to find its place
                    continue
                centre = ((rr[sl] * wgt * half).sum() / weight, (cc[sl] * wgt * half).sum() / weight)
                found[name] = (_local_shift(wgt * half, moved * half, max_px), centre, weight)
            if "L" in found and "R" in found and found["R"][1][1] - found["L"][1][1] > 10:
                arm = found["R"][1][1] - found["L"][1][1]
                turns.append(((found["R"][0][0] - found["L"][0][0]) / arm, (found["L"][2] + found["R"][2]) * arm ** 2))
            if "B" in found and "T" in found and found["T"][1][0] - found["B"][1][0] > 10:
                arm = found["T"][1][0] - found["B"][1][0]
                turns.append((-(found["T"][0][1] - found["B"][0][1]) / arm, (found["B"][2] + found["T"][2]) * arm ** 2))
            if found:
                shifts.append((np.mean([f[0] for f in found.values()], axis=0), float(wgt.sum())))
        if not shifts:
            break
        step = _weighted_median([t for t, _ in turns], [q for _, q in turns]) if turns else 0.0
        move = np.array([_weighted_median([s[k] for s, _ in shifts], [q for _, q in shifts]) for k in (0, 1)])
        turn -= step
        rc = rc + move
        if abs(step) < 1e-5 and np.hypot(*move) < 0.02:
            break
    return rc, turn


def _weighted_median(values, weights) -> float:
    """The value below and above which lie at most half the weight."""
    order = np.argsort(values)
    cum = np.cumsum(np.asarray(weights, float)[order])
    return float(np.asarray(values, float)[order][np.searchsorted(cum, cum[-1] / 2)])


def _local_shift(reference, moving, max_px: float):
    """(row, col) shift that lands ``moving`` on ``reference``, searched within ``max_px`` of none.

    The cross-correlation's highest value within the window, refined by a parabola through it and its
    two neighbours on each axis. Looking near zero only keeps a layer's lines from being matched to
    their neighbours (a score line missing, a hatch's next line one interval away).
    """
    m = int(np.ceil(max_px)) + 1
    shape = tuple(n + 2 * m for n in reference.shape)
    f = np.fft.rfft2(reference, shape) * np.conj(np.fft.rfft2(moving, shape))
    cc = np.fft.irfft2(f, shape)
    offsets = np.arange(-m, m + 1)
    window = cc[np.ix_(offsets % shape[0], offsets % shape[1])]
    if not window.max() > 0:
        return np.zeros(2)
    r, c = np.unravel_index(int(np.argmax(window)), window.shape)
    shift = np.array([offsets[r], offsets[c]], float)
    for axis, k in ((0, r), (1, c)):
        if 0 < k < len(offsets) - 1:
            a, b, d = (window[k - 1, c], window[k, c], window[k + 1, c]) if axis == 0 else \
                      (window[r, k - 1], window[r, k], window[r, k + 1])
            den = a - 2 * b + d
            if den < 0:
                shift[axis] += 0.5 * (a - d) / den
    return shift


class _Grid:
    """Pixel centres of a comparison grid (row 0 at low y) and the program's layers on it."""

    def __init__(self, x_mm, y_mm, burn, moves):
        from scipy import ndimage

        self.x_mm, self.y_mm = np.asarray(x_mm, float), np.asarray(y_mm, float)
        self.px = float(self.x_mm[1] - self.x_mm[0])
        shape = (len(self.y_mm), len(self.x_mm))
        b = burn.plan.blocks
        s = burn.samples
        on = s["power_mw"] > 0
        blk = s["block"][on]
        # a layer is a programmed power; it is named by its S when the program is known
        key = np.round(b.power_mw[blk], 6)
        self.keys = np.unique(key)
        if moves is not None and len(moves) and b.move.max() < len(moves):
            s_of = {float(k): float(moves.s_word[b.move[blk][key == k][0]]) for k in self.keys}
        else:
            s_of = {float(k): None for k in self.keys}
        self.label = [s_of[float(k)] for k in self.keys]
        motion_on = b.laser_on & ~b.rapid
        self.length_mm = [float(b.length_mm[motion_on & (np.round(b.power_mw, 6) == k)].sum()) for k in self.keys]
        seeds = np.full(shape, -1, np.int64)
        c = np.clip(np.rint((s["x_mm"][on] - self.x_mm[0]) / self.px).astype(np.int64), 0, shape[1] - 1)
        r = np.clip(np.rint((s["y_mm"][on] - self.y_mm[0]) / self.px).astype(np.int64), 0, shape[0] - 1)
        seeds[r, c] = np.searchsorted(self.keys, key)
        if (seeds >= 0).any():
            dist, (ri, ci) = ndimage.distance_transform_edt(seeds < 0, return_indices=True)
            self.nearest = seeds[ri, ci]
            self.seed_dist_mm = dist * self.px
        else:
            self.nearest = np.full(shape, -1)
            self.seed_dist_mm = np.full(shape, np.inf)

    def bbox(self, sl):
        r0, r1, c0, c1 = sl[0].start, sl[0].stop - 1, sl[1].start, sl[1].stop - 1
        return (float(self.x_mm[c0]), float(self.y_mm[r0]), float(self.x_mm[c1]), float(self.y_mm[r1]))


def _solid(scan_dark, predicted, given):
    """The scan's darkness of a solid burn: given, or the median where the prediction is solid."""
    if given is not None:
        if not (np.isfinite(given) and given > 0):
            raise InputError(f"solid_darkness must be > 0, got {given!r}")
        return float(given)
    solid = predicted >= 0.9
    if solid.sum() >= 20:
        value = float(np.median(scan_dark[solid]))
    else:                            # hairlines only: the burned share scales the darkness
        part = predicted >= 0.5
        value = float(np.median(scan_dark[part] / predicted[part])) if part.any() else 0.0
    if not value > 0.05:
        raise InputError(f"the scan is not darker where the prediction burns (solid darkness {value:.3f}); "
                         "expected a scan of this program's burn (paper light, burn dark), or give the "
                         "solid darkness")
    return value


def _compare(grid: _Grid, predicted, scan_raw, *, w0_mm, solid_darkness, tolerance, min_area_mm2,
             shift_tol_mm) -> tuple:
    """Per-layer shifts undone, then defects, layers and part numbers on one grid."""
    from scipy import ndimage

    px = grid.px
    solid = _solid(scan_raw, predicted, solid_darkness)
    scan = scan_raw / solid
    pred_on = predicted >= 0.5
    reach = 2.0 * w0_mm
    near = ndimage.distance_transform_edt(~pred_on) * px <= reach if pred_on.any() else np.zeros_like(pred_on)
    zone_all = near | (grid.seed_dist_mm <= reach)
    zones = [zone_all & (grid.nearest == i) for i in range(len(grid.keys))]
    shifts = [np.zeros(2)] * len(zones)
    if len(zones) > 1:
        # each layer against the prediction again: one that landed off the rest is measured and undone
        for i, zone in enumerate(zones):
            if zone.any():
                sl = ndimage.find_objects(zone.astype(int))[0]
                # darkness through a ramp that saturates: a layer burned paler on one side would pull a
                # plain grey correlation towards its darker side while its lines stay where they were;
                # a hard threshold would lose the edges' place within a pixel
                ref = np.where(zone[sl], _ramp(predicted[sl]), 0.0)
                rc = _local_shift(ref, np.where(zone[sl], _ramp(scan[sl]), 0.0), reach / px)
                shifts[i] = rc
        # the shifts are against the layers holding most of the burn (the area-weighted median)
        area = np.array([float((pred_on & z).sum()) for z in zones])
        order = [np.argsort(np.array([s[k] for s in shifts])) for k in (0, 1)]
        ref_rc = np.array([shifts[o[np.searchsorted(np.cumsum(area[o]), area.sum() / 2)]][k]
                           for k, o in enumerate(order)])
        aligned = ndimage.shift(scan, ref_rc, order=1, mode="constant")
        for i, zone in enumerate(zones):
            if np.hypot(*(shifts[i] - ref_rc)) * px >= shift_tol_mm:
                aligned[zone] = ndimage.shift(scan, shifts[i], order=1, mode="constant")[zone]
        scan = aligned
        shifts = [(float(-(s[1] - ref_rc[1]) * px) + 0.0, float(-(s[0] - ref_rc[0]) * px) + 0.0) for s in shifts]
    else:
        shifts = [(0.0, 0.0)] * len(zones)
    scan_on = scan >= 0.5
    min_area = np.pi * w0_mm ** 2 if min_area_mm2 is None else float(min_area_mm2)
    layer_of = np.where(zone_all, grid.nearest, -1)
    # darkness is compared over a patch, not a pixel: a hatch's lines narrowed by a weak beam leave
    # each line's centre as dark as before, and only the patch's mean lighter
    sigma = max(2.0 * w0_mm / px, 2.0)
    pred_mean = ndimage.gaussian_filter(predicted, sigma)
    diff = ndimage.gaussian_filter(scan, sigma) - pred_mean
    envelope = pred_mean >= 0.2
    masks = {"missing": pred_on & ~scan_on, "extra": scan_on & ~pred_on,
             "light": envelope & (diff < -tolerance), "dark": envelope & (diff > tolerance)}
    defects, regions = [], {}
    for kind, mask in masks.items():
        # one pixel of disagreement along an edge is the registration's rounding, not a defect
        mask = ndimage.binary_opening(mask)
        if kind in ("light", "dark"):
            # a missing or extra stroke shifts the patch's mean too: it is reported once, as itself
            stroke = ndimage.binary_dilation(regions["missing"] | regions["extra"], iterations=int(3 * sigma))
            labels, _ = ndimage.label(mask)
            touched = np.unique(labels[stroke & mask])
            mask &= ~np.isin(labels, touched[touched > 0])
        labels, _ = ndimage.label(mask)
        kept = np.zeros_like(mask)
        for k, sl in enumerate(ndimage.find_objects(labels), 1):
            region = labels[sl] == k
            area = float(region.sum()) * px * px
            if area < min_area:
                continue
            kept[sl] |= region
            idx = layer_of[sl][region]
            idx = idx[idx >= 0]
            layer = grid.label[int(np.bincount(idx).argmax())] if len(idx) else None
            local = diff if kind in ("light", "dark") else scan - predicted
            defects.append(BurnDefect(kind, area, grid.bbox(sl), layer, float(np.mean(local[sl][region]))))
        regions[kind] = kept
    defects.sort(key=lambda d: -d.area_mm2)

    def numbers(sel, label, length, shift):
        pa, sa = float((pred_on & sel).sum()) * px * px, float((scan_on & sel).sum()) * px * px
        where = pred_on & sel
        return LayerCheck(label, length, pa, sa, float((masks["missing"] & sel).sum()) * px * px,
                          float((masks["extra"] & sel).sum()) * px * px,
                          (sa - pa) / length if length > 0 else 0.0,
                          float(predicted[where].mean()) if where.any() else 0.0,
                          float(scan[where].mean()) if where.any() else 0.0, shift)

    layers = [numbers(z, grid.label[i], grid.length_mm[i], shifts[i]) for i, z in enumerate(zones)]
    part = numbers(np.ones_like(pred_on), None, float(sum(grid.length_mm)), (0.0, 0.0))
    return defects, layers, part, scan, regions, solid, pred_on, scan_on


def _check_args(tolerance, min_area_mm2, shift_tol_mm):
    if not (np.isfinite(tolerance) and 0 < tolerance < 1):
        raise InputError(f"tolerance must be > 0 and < 1 (a share of the solid darkness), got {tolerance!r}")
    if min_area_mm2 is not None and not (np.isfinite(min_area_mm2) and min_area_mm2 >= 0):
        raise InputError(f"min_area_mm2 must be >= 0, got {min_area_mm2!r}")
    if not (np.isfinite(shift_tol_mm) and shift_tol_mm > 0):
        raise InputError(f"shift_tol_mm must be > 0, got {shift_tol_mm!r}")


def check_burn(burn, scan, *, moves=None, min_area_mm2: float | None = None, solid_darkness: float | None = None,
               tolerance: float = 0.15, shift_tol_mm: float = 0.025) -> BurnCheck:
    """Register a scanned burn, already on the prediction's grid, to the prediction and list where they differ.

    Parameters
    ----------
    burn : Burn
        From :func:`predict_burn`.
    scan : ndarray, same shape as ``burn.burned``
        The real burn on the prediction's grid (row 0 at ``burn.y_mm[0]``): a burned mask (bool),
        or grey darkness (float, ``1 − grey / paper``: :func:`scan_darkness`).
    moves : Moves, optional
        The program, to name each layer by its S (otherwise layers are told apart by power, unnamed).
    min_area_mm2 : float, optional
        Smallest region reported, mm² (default: one beam spot, π·w0²).
    solid_darkness : float, optional
        The scan's darkness of a solid burn (default: the scan's median where the prediction is solid;
        1 for a mask).
    tolerance : float
        A darkness difference, as a share of the solid darkness, that makes a region lighter or
        darker than predicted.
    shift_tol_mm : float
        A layer's shift against the rest at least this large is reported and undone, mm.

    Returns
    -------
    BurnCheck
    """
    from scipy import ndimage

    _check_args(tolerance, min_area_mm2, shift_tol_mm)
    predicted = np.clip(burn.coverage, 0.0, 1.0)
    raw = np.asarray(scan)
    if raw.shape != predicted.shape:
        raise InputError(f"scan {raw.shape} and prediction {predicted.shape} differ; expected the scan "
                         "resampled to the prediction's grid (or a scan file: check_scan)")
    mask_given = raw.dtype == bool
    raw = raw.astype(float)
    if not np.isfinite(raw).all():
        raise InputError("the scan holds values that are not finite numbers")
    rc = _register(predicted, raw)
    aligned = ndimage.shift(raw, rc, order=1, mode="constant")
    grid = _Grid(burn.x_mm, burn.y_mm, burn, moves)
    solid = 1.0 if mask_given and solid_darkness is None else solid_darkness
    defects, layers, part, scan_n, regions, solid, pred_on, scan_on = _compare(
        grid, predicted, aligned, w0_mm=burn.w0_mm, solid_darkness=solid, tolerance=tolerance,
        min_area_mm2=min_area_mm2, shift_tol_mm=shift_tol_mm)
    px = grid.px
    # the scan moved by −shift to land on the prediction: its own shift is the opposite, (x, y) = (col, row)
    return BurnCheck(shift_mm=(float(-rc[1] * px) + 0.0, float(-rc[0] * px) + 0.0),   # + 0.0: no −0
                     predicted_mm2=float(pred_on.sum()) * px * px, scanned_mm2=float(scan_on.sum()) * px * px,
                     defects=defects, layers=layers if moves is not None or len(layers) > 1 else [], part=part,
                     solid_darkness=solid, solid_darkness_given=solid_darkness is not None or mask_given,
                     pixel_mm=px, predicted=predicted, scanned=scan_n, extent_mm=tuple(burn.extent),
                     _regions=regions)


def check_scan(burn, image, *, dpi: float, moves=None, paper: float | None = None,
               solid_darkness: float | None = None, tolerance: float = 0.15, min_area_mm2: float | None = None,
               shift_tol_mm: float = 0.025) -> BurnCheck:
    """Find a program's predicted burn in a grey scan and list where the real burn differs.

    The prediction is drawn at the scan's pixel (:func:`predicted_scan`), found in the scan by
    zero-padded phase correlation (the piece may lie anywhere on it), its turn read from its halves
    (a piece squared by eye: a degree or two), and the scan is resampled onto it; then as
    :func:`check_burn`.

    Parameters
    ----------
    burn : Burn
        From :func:`predict_burn`, with a pixel no larger than the scan's.
    image : ndarray, 2-D
        The scan, grey 0…1 (paper light, burn dark), rows down, y up, as the scanner saw the piece.
    dpi : float
        The scan's resolution, dots per inch.
    moves, solid_darkness, tolerance, min_area_mm2, shift_tol_mm
        As :func:`check_burn`.
    paper : float, optional
        The paper's grey level (default: :func:`scan_darkness`'s estimate).

    Returns
    -------
    BurnCheck
        ``shift_mm`` is where the prediction's lower-left corner lies in the scan (mm from its lower
        left, before the turn about the prediction's centre), ``turn_deg`` the piece's turn.
    """
    from scipy import ndimage

    _check_args(tolerance, min_area_mm2, shift_tol_mm)
    if not (np.isfinite(dpi) and dpi > 0):
        raise InputError(f"dpi must be > 0, got {dpi!r}")
    px = _MM_PER_INCH / dpi
    dark = scan_darkness(image, paper=paper)[::-1]                        # row 0 at low y
    expect = predicted_scan(burn, dpi=dpi)[::-1]
    predicted = np.clip((_PAPER - expect) / (_PAPER - _SOLID), 0.0, 1.0)
    if dark.shape[0] < predicted.shape[0] or dark.shape[1] < predicted.shape[1]:
        raise InputError(f"the scan ({dark.shape[1]} × {dark.shape[0]} px at {dpi:g} dpi) is smaller than the "
                         f"predicted burn ({predicted.shape[1]} × {predicted.shape[0]} px); expected a scan of "
                         "the whole part, or the wrong dpi")
    from labkit.budget import check_budget

    check_budget("pixels", 2.0 * (dark.shape[0] + predicted.shape[0]) * (dark.shape[1] + predicted.shape[1]),
                 cause="registering the scan to the prediction", option="the scan (crop it to the part)")
    x_lo, x_hi, y_lo, y_hi = burn.extent
    # Burn.scan's pixel centres (margin 0): from the extent's left and top edges inwards
    x_mm = x_lo + px / 2 + px * np.arange(predicted.shape[1])
    y_mm = (y_hi - px / 2 - px * np.arange(predicted.shape[0]))[::-1]
    grid = _Grid(x_mm, y_mm, burn, moves)
    rc = _register(predicted, dark, pad=True)
    # each pixel near the burn labelled with its layer: the turn is read within layers
    labels = np.where((grid.seed_dist_mm <= 2.0 * burn.w0_mm) | (predicted > 0), grid.nearest, -1)
    rc, turn = _turned(predicted, dark, rc, labels, max_px=1.0 / px)   # 1 mm: a turn of a degree or two
    aligned = _placed(dark, predicted.shape, rc, turn)
    defects, layers, part, scan_n, regions, solid, pred_on, scan_on = _compare(
        grid, predicted, aligned, w0_mm=burn.w0_mm, solid_darkness=solid_darkness, tolerance=tolerance,
        min_area_mm2=min_area_mm2, shift_tol_mm=shift_tol_mm)
    return BurnCheck(shift_mm=(float(-rc[1] * px) + 0.0, float(-rc[0] * px) + 0.0),
                     predicted_mm2=float(pred_on.sum()) * px * px, scanned_mm2=float(scan_on.sum()) * px * px,
                     defects=defects, layers=layers, part=part, solid_darkness=solid,
                     solid_darkness_given=solid_darkness is not None, pixel_mm=px, in_scan=True,
                     turn_deg=float(np.degrees(turn)) + 0.0,
                     predicted=predicted, scanned=scan_n,
                     extent_mm=(x_mm[0] - px / 2, x_mm[-1] + px / 2, y_mm[0] - px / 2, y_mm[-1] + px / 2),
                     _regions=regions)


def overlay(burn, scan_mask) -> np.ndarray:
    """An RGB picture (uint8, rows top = high y) of a prediction and a scanned mask on its grid:
    both black, missing red, extra blue, neither white (:meth:`BurnCheck.overlay` draws a check's)."""
    p = np.asarray(burn.burned, bool)
    s = np.asarray(scan_mask, bool)
    img = np.full(p.shape + (3,), 255, np.uint8)
    img[p & s] = (0, 0, 0)
    img[p & ~s] = _COLOURS["missing"]
    img[~p & s] = _COLOURS["extra"]
    return img[::-1]
