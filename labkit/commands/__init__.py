"""Command-line commands, one module per area, loaded on demand by :mod:`labkit.cli`."""
