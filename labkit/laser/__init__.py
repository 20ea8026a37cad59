"""Laser characterisation ([CBR40] §F, figure 10): cut width against power and speed, and the source.

Test grids (:mod:`~labkit.laser.patterns`), widths from a scan (:mod:`~labkit.laser.measure`), the dose
and empirical models with cross-validation, cut-through and inverse design (:mod:`~labkit.laser.models`),
the virtual material (:mod:`~labkit.laser.simulate`) and the laser source's curves
(:mod:`~labkit.laser.source`). Command: ``labkit cutwidth``; chapter 16.
"""

from labkit.laser.measure import measure_lines, register, render_scan, scale_from_reference
from labkit.laser.models import (Fit, cross_validate, cut_probability, dose_width, fit_cut_through, fit_dose,
                                 fit_empirical, fit_power_law, power_band, power_for_width, speed_for_width)
from labkit.laser.source import SourceFit, fit_source, label_ratio, read_source_csv
from labkit.laser.simulate import Burn, beam_positions, simulate_burn
from labkit.laser.patterns import GridPattern, grid_pattern, steps, stroke_digits, write_pattern

__all__ = ["measure_lines", "register", "render_scan", "scale_from_reference", "Fit", "cross_validate",
           "cut_probability", "dose_width", "fit_cut_through", "fit_dose", "fit_empirical", "fit_power_law",
           "power_band", "power_for_width", "speed_for_width", "Burn", "beam_positions", "simulate_burn",
           "SourceFit", "fit_source", "label_ratio", "read_source_csv", "GridPattern", "grid_pattern", "steps", "stroke_digits", "write_pattern"]
