"""[MicroCAM]'s micro-machining studies (ch. 3–5).

- :mod:`~labkit.micromachining.chipvolume`: chip volume along a toolpath on a z-map
  workpiece (ch. 3.1);
- :mod:`~labkit.micromachining.feedschedule`: feed per position from the chip volume
  (eq. 3.2), smoothed, one feed per position or one per original block (ch. 3.2, 3.4);
- :mod:`~labkit.micromachining.dexel`: the dual-dexel workpiece and ploughing (ch. 5);
- :mod:`~labkit.micromachining.probe`: the rotating-wire probe and automated scanning (ch. 4).

Modules load on first use (``import labkit.micromachining`` is light).
"""

import importlib

__all__ = ["chipvolume", "feedschedule", "dexel", "probe"]


def __getattr__(name):
    if name in __all__:
        return importlib.import_module(f"labkit.micromachining.{name}")
    raise AttributeError(f"module 'labkit.micromachining' has no attribute {name!r}")
