"""Plots (matplotlib) and widgets (ipywidgets) for every area, imported lazily.

Nothing outside this package imports matplotlib or ipywidgets, so the core
stays headless. One module per area: :mod:`labkit.viz.gcode` (program
previews), and the modules of the geometry, raster and motion chapters.
"""
