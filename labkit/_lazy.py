"""A package's names loaded on first use (PEP 562), the one home of that pattern."""

from __future__ import annotations

import importlib


def lazy_names(package: str, where: dict, names_all) -> tuple:
    """``__getattr__`` and ``__dir__`` for a package whose names load on first use.

    Parameters
    ----------
    package : str
        The package's dotted name (``"labkit.gcode"``).
    where : dict
        Name → the submodule that defines it (``"reader"``), or ``None`` for a submodule
        that is itself the name.
    names_all : sequence of str
        The package's ``__all__``.

    Returns
    -------
    tuple
        ``(__getattr__, __dir__)`` to assign at the package's module level; a name, once
        looked up, is stored in the package so later look-ups skip ``__getattr__``.
    """
    import sys

    def __getattr__(name):
        try:
            module = where[name]
        except KeyError:
            raise AttributeError(f"module {package!r} has no attribute {name!r}") from None
        value = importlib.import_module(f"{package}.{module or name}")
        if module is not None:
            value = getattr(value, name)
        vars(sys.modules[package])[name] = value
        return value

    def __dir__():
        return sorted(set(vars(sys.modules[package])) | set(names_all))

    return __getattr__, __dir__
