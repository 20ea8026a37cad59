"""Laser characterisation: test patterns for cut width against power and speed ([CBR40] §F, figure 10)."""

from labkit.laser.measure import measure_lines, register, render_scan
from labkit.laser.models import Fit, dose_width, fit_dose, fit_power_law, power_for_width, speed_for_width
from labkit.laser.patterns import GridPattern, grid_pattern, steps, stroke_digits, write_pattern

__all__ = ["measure_lines", "register", "render_scan", "Fit", "dose_width", "fit_dose", "fit_power_law", "power_for_width", "speed_for_width", "GridPattern", "grid_pattern", "steps", "stroke_digits", "write_pattern"]
