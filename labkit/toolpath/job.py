"""A vector job: drawing paths → ordered toolpath → Moves → G-code, decided in one place.

``labkit svg2gcode`` and ``dxf2gcode`` parse their options and print; everything between
the imported paths and the written program happens here: the checks that keep a job
within what the machine and memory can take, the geometry pipeline
(:func:`labkit.toolpath.build.prepare_paths`), the Moves (:func:`build_moves`) and the
written resolution (:func:`labkit.geometry.arcfit.tolerance_budget`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np

from labkit.budget import check_budget
from labkit.errors import GeometryError
from labkit.geometry.arcfit import tolerance_budget
from labkit.geometry.path import Path, bounds_each
from labkit.toolpath.build import LayerSettings, build_moves, prepare_paths
from labkit.toolpath.moves import Moves
from labkit.units import s_within

__all__ = ["VectorJob", "vector_job"]


@dataclass
class VectorJob:
    """The toolpath of a vector drawing and its Moves.

    Attributes
    ----------
    paths : list of Path
        What is cut, in cutting order (after chaining, kerf, fill and ordering), mm.
    moves : Moves
        The program, every pass of every layer.
    tol_mm : float
        The job's tolerance (deviation of the cut from the drawing), mm.
    """

    paths: list[Path]
    moves: Moves
    tol_mm: float

    def gcode(self, dialect="grbl", *, travel_beam_off=None, comment=None) -> str:
        """The program as G-code text, written at the resolution the tolerance allows.

        Parameters
        ----------
        dialect : str or Dialect
            ``"grbl"``, ``"labkit-fw"``, ``"marlin"`` …
        travel_beam_off : bool, optional
            M5 before every rapid (controllers that burn on G0); default: the dialect's.
        comment : str, optional
            A comment line in the header.
        """
        from labkit.gcode import emit

        return emit(self.moves, dialect=dialect, tol_mm=tolerance_budget(self.tol_mm).emit_mm,
                    travel_beam_off=travel_beam_off, comment=comment)


def vector_job(paths: Sequence[Path], *, default: LayerSettings = LayerSettings(),
               layers: Mapping[str, LayerSettings] | None = None, tol_mm=0.01, arcs=True, kerf_mm=0.0,
               fill=False, fill_spacing_mm=0.1, fill_angle_rad=0.0, order=True, improve=True,
               s_max=1000.0) -> VectorJob:
    """Turn imported paths into a laser job.

    Parameters
    ----------
    paths : sequence of Path
        The drawing (from :func:`labkit.vector.read_svg` or :func:`~labkit.vector.read_dxf`,
        read with the same ``tol_mm`` and ``arcs``), mm.
    default : LayerSettings
        Feed, power, passes, Z step and laser mode of layers not in ``layers``.
    layers : mapping of str to LayerSettings, optional
        Settings per layer (SVG colour such as ``"#ff0000"``, DXF layer name).
    tol_mm : float
        Largest deviation of the cut from the drawing, mm.
    arcs : bool
        Keep arcs (G2/G3); False gives straight segments only.
    kerf_mm : float
        Beam kerf; closed shapes are offset by half of it so parts come out to size, mm.
    fill, fill_spacing_mm, fill_angle_rad
        Hatch closed shapes before their contours, lines this far apart (the beam width,
        mm) at this angle (rad).
    order, improve : bool
        Order paths to shorten travel (greedy), then improve the order (2-opt).
    s_max : float
        S of full power (GRBL ``$30``); every power must lie within 0…``s_max``.

    Returns
    -------
    VectorJob

    Examples
    --------
    >>> job = vector_job([Path.rectangle(0, 0, 10, 5)], default=LayerSettings(600, 800))
    >>> job.moves.motion_lines, round(float(job.moves.lengths_mm()[job.moves.kind == 1].sum()), 6)
    (4, 30.0)
    """
    tolerance_budget(tol_mm, arcs=arcs)          # refuses a tolerance that is not a length
    layers = dict(layers or {})
    for name, layer in [("default", default)] + list(layers.items()):
        if not s_within(layer.s_word, s_max):      # LayerSettings refused S < 0
            raise GeometryError(f"layer {name}: power S{layer.s_word:g} is above s_max {s_max:g}; "
                                f"expected a power within 0…{s_max:g}")
    paths = list(paths)
    if not arcs and any(p.is_arc.any() for p in paths):
        raise GeometryError("arcs=False but the paths hold arcs: read the drawing with arcs=False "
                            "too (the reader shares the tolerance with the chords)")
    if fill and paths:
        # Hatch lines across each closed shape: its extent over the spacing, estimated
        # before hatching so that a spacing of 1e-5 mm is refused, not computed.
        extents = np.ptp(bounds_each([p for p in paths if p.closed]), axis=1).max(axis=1, initial=0.0).tolist()
        check_budget("hatch_lines", sum(extents) / fill_spacing_mm,
                     cause=f"hatching {len(extents)} closed shape(s) at {fill_spacing_mm:g} mm",
                     option="the drawing, or raise --fill-spacing")
    cut = prepare_paths(paths, kerf_mm=kerf_mm, tol_mm=tol_mm, arcs=arcs, fill=fill,
                        fill_spacing_mm=fill_spacing_mm, fill_angle_rad=fill_angle_rad, order=order,
                        improve=improve)
    most_passes = max([default.passes] + [v.passes for v in layers.values()])
    segments = sum(len(p.vertices) for p in cut)
    check_budget("moves", float(segments) * most_passes,
                 cause=f"{segments:,} segments × {most_passes:,} passes", option="--passes")
    moves = build_moves(cut, layers, default=default, s_max=s_max)
    return VectorJob(cut, moves, float(tol_mm))
