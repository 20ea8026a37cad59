"""A name means one thing (issue 11): no package attribute is a function or class that
shares its name with a submodule — importing the submodule would silently replace it."""

from __future__ import annotations

import importlib
import inspect
import pkgutil

import labkit


def test_no_function_shadows_a_module_of_the_same_name():
    clashes = []
    for info in pkgutil.walk_packages(labkit.__path__, "labkit."):
        if not info.ispkg:
            continue
        package = importlib.import_module(info.name)
        for sub in pkgutil.iter_modules(package.__path__):
            value = getattr(package, sub.name, None)         # lazy attributes load here
            if value is not None and not inspect.ismodule(value):
                clashes.append(f"{info.name}.{sub.name}")
    assert not clashes, f"functions named like their modules: {clashes}"


def test_the_motion_description_and_the_hardware_links_have_different_names():
    import labkit.machine
    import labkit.motion

    assert hasattr(labkit.motion, "MachineSpec") and not hasattr(labkit.motion, "Machine")
    assert not set(labkit.motion.__all__) & set(labkit.machine.__all__)
