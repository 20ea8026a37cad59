"""Predict a program's burn, then check a scan of the real burn against it (issue 31 §4, a first part).

The prediction is :func:`labkit.laser.simulate.simulate_burn`'s: the planned motion's dose through
the material's fitted dose model (``w0_mm``, ``fth_mj_mm2``), M3 or M4 as the program says. A scan is
compared as a burned/not-burned mask on the prediction's pixel grid (threshold a grey scan first, and
resample it to that grid: :mod:`labkit.laser.measure` registers and scales real scans):

1. **registration** — the scan's shift against the prediction by phase correlation (scikit-image's
   ``phase_cross_correlation``, to a tenth of a pixel), reported in mm and undone;
2. **differences** — *missing* burn (predicted, not in the scan) and *extra* burn (in the scan, not
   predicted), each as connected regions larger than one beam spot, with their area and bounding box;
3. **per layer** — the program's layers are told apart by the S of their moves: each region is
   credited to the layer whose predicted burn lies nearest.

What it does not do yet: darkness (a grey scan's level against the dose), a width per line, a
picture written by a command, and real scans (they go through ``labkit.laser.measure`` first).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from labkit.errors import InputError

__all__ = ["BurnDefect", "BurnCheck", "predict_burn", "check_burn", "overlay"]


@dataclass
class BurnDefect:
    """One region where the scan differs from the prediction."""

    kind: str                      #: "missing" or "extra"
    area_mm2: float
    bbox_mm: tuple                 #: (x0, y0, x1, y1)
    layer_s: float | None = None   #: S of the nearest predicted layer


@dataclass
class BurnCheck:
    """The comparison: the registration shift and the defects, largest first."""

    shift_mm: tuple                #: (dx, dy) of the scan against the prediction, mm
    predicted_mm2: float
    scanned_mm2: float
    defects: list = field(default_factory=list)

    def summary(self) -> str:
        """The comparison in words."""
        lines = [f"scan shifted by ({self.shift_mm[0]:+.3f}, {self.shift_mm[1]:+.3f}) mm; burned "
                 f"{self.scanned_mm2:.2f} mm² against {self.predicted_mm2:.2f} mm² predicted"]
        for d in self.defects:
            x0, y0, x1, y1 = d.bbox_mm
            lines.append(f"  {d.kind:<7} {d.area_mm2:7.3f} mm² at x {x0:.2f}…{x1:.2f}, y {y0:.2f}…{y1:.2f} mm"
                         + (f" (layer S{d.layer_s:g})" if d.layer_s is not None else ""))
        if not self.defects:
            lines.append("  no region differs by more than one beam spot")
        return "\n".join(lines)


def predict_burn(moves, *, w0_mm: float, fth_mj_mm2: float, pixel_mm: float | None = None, machine=None):
    """The burned mask a program leaves in a material of the given dose model.

    Returns
    -------
    burn : labkit.laser.simulate.Burn
        ``burn.burned`` is the mask (row 0 at ``burn.y_mm[0]``), ``burn.x_mm``/``y_mm`` its pixel centres.
    """
    from labkit.laser.simulate import simulate_burn

    return simulate_burn(moves, w0_mm=w0_mm, fth_mj_mm2=fth_mj_mm2, pixel_mm=pixel_mm, machine=machine)


def _layer_map(burn, moves):
    """For each pixel, the S of the nearest predicted burned pixel's layer (NaN far from any)."""
    from scipy import ndimage

    s_grid = np.full(burn.burned.shape, np.nan)
    on = moves.laser_on
    for s in np.unique(moves.power_s[on]):
        sub = moves[on & (moves.power_s == s)]
        for a, b in zip(sub.start[:, :2], sub.end[:, :2]):
            n = int(np.ceil(np.hypot(*(b - a)) / burn.pixel_mm)) + 1
            pts = a + (b - a) * np.linspace(0, 1, n)[:, None]
            c = np.clip(np.round((pts[:, 0] - burn.x_mm[0]) / burn.pixel_mm).astype(int), 0, len(burn.x_mm) - 1)
            r = np.clip(np.round((pts[:, 1] - burn.y_mm[0]) / burn.pixel_mm).astype(int), 0, len(burn.y_mm) - 1)
            s_grid[r, c] = s
    known = ~np.isnan(s_grid)
    if not known.any():
        return s_grid
    _, (ri, ci) = ndimage.distance_transform_edt(~known, return_indices=True)
    return s_grid[ri, ci]


def check_burn(burn, scan_mask, *, moves=None, min_area_mm2: float | None = None) -> BurnCheck:
    """Register a scanned burn mask to the prediction and list where they differ.

    Parameters
    ----------
    burn : Burn
        From :func:`predict_burn`.
    scan_mask : ndarray of bool, same shape as ``burn.burned``
        The real burn on the prediction's grid (row 0 at ``burn.y_mm[0]``).
    moves : Moves, optional
        The program, to credit each defect to a layer (by S).
    min_area_mm2 : float, optional
        Smallest region reported (default: one beam spot, π·w0²).

    Returns
    -------
    BurnCheck
    """
    from scipy import ndimage
    from skimage.registration import phase_cross_correlation

    predicted = np.asarray(burn.burned, bool)
    scan = np.asarray(scan_mask, bool)
    if scan.shape != predicted.shape:
        raise InputError(f"scan mask {scan.shape} and prediction {predicted.shape} differ; expected the scan "
                         "resampled to the prediction's grid")
    px = burn.pixel_mm
    shift_rc, _, _ = phase_cross_correlation(predicted.astype(float), scan.astype(float), upsample_factor=10)
    aligned = ndimage.shift(scan.astype(float), shift_rc, order=1, mode="constant") >= 0.5
    min_area = np.pi * burn.w0_mm ** 2 if min_area_mm2 is None else float(min_area_mm2)
    layers = _layer_map(burn, moves) if moves is not None else None
    defects = []
    for kind, diff in (("missing", predicted & ~aligned), ("extra", aligned & ~predicted)):
        # one pixel of disagreement along every edge is the registration's rounding, not a defect
        diff = ndimage.binary_opening(diff)
        labels, n = ndimage.label(diff)
        for k, sl in enumerate(ndimage.find_objects(labels), 1):
            region = labels[sl] == k
            area = float(region.sum()) * px * px
            if area < min_area:
                continue
            r0, r1, c0, c1 = sl[0].start, sl[0].stop - 1, sl[1].start, sl[1].stop - 1
            layer = None
            if layers is not None:
                vals = layers[sl][region]
                vals = vals[~np.isnan(vals)]
                layer = float(np.median(vals)) if len(vals) else None
            defects.append(BurnDefect(kind, area, (float(burn.x_mm[c0]), float(burn.y_mm[r0]),
                                                   float(burn.x_mm[c1]), float(burn.y_mm[r1])), layer))
    defects.sort(key=lambda d: -d.area_mm2)
    # the scan moved by −shift to land on the prediction: its own shift is the opposite, (x, y) = (col, row)
    return BurnCheck(shift_mm=(float(-shift_rc[1] * px) + 0.0, float(-shift_rc[0] * px) + 0.0),   # no −0
                     predicted_mm2=float(predicted.sum()) * px * px, scanned_mm2=float(scan.sum()) * px * px,
                     defects=defects)


def overlay(burn, scan_mask) -> np.ndarray:
    """An RGB picture (uint8, rows top = high y) of prediction and scan: both black, missing red,
    extra blue, neither white."""
    p = np.asarray(burn.burned, bool)
    s = np.asarray(scan_mask, bool)
    img = np.full(p.shape + (3,), 255, np.uint8)
    img[p & s] = (0, 0, 0)
    img[p & ~s] = (220, 30, 30)
    img[~p & s] = (30, 60, 220)
    return img[::-1]
