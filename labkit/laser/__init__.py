"""Laser characterisation: test patterns for cut width against power and speed ([CBR40] §F, figure 10)."""

from labkit.laser.patterns import GridPattern, grid_pattern, steps, stroke_digits, write_pattern

__all__ = ["GridPattern", "grid_pattern", "steps", "stroke_digits", "write_pattern"]
