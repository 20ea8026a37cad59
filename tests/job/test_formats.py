"""Issue 31's files each have a documented format with a version field: the module that reads or
writes it shows the format's name and version in its docstring, the code overview names them, and
the name and version are the module's constants (so the documentation cannot drift from the code)."""

import importlib
import re
from pathlib import Path

import pytest

README = (Path(__file__).resolve().parents[2] / "labkit" / "README.md").read_text()


@pytest.mark.parametrize("module, example", [
    ("labkit.materials", 'format = "{f}"'),     # TOML: the library
    ("labkit.jobfile", 'format = "{f}"'),       # TOML: the job file
    ("labkit.record", '"format": "{f}"'),       # JSON: the record
    ("labkit.burncheck", '"format": "{f}"'),    # JSON: the burn check's report
])
def test_the_format_and_its_version_are_documented(module, example):
    m = importlib.import_module(module)
    doc = m.__doc__
    assert example.format(f=m.FORMAT) in doc
    assert re.search(rf"[\"']?version[\"']?\s*[=:]\s*{m.VERSION}\b", doc), f"{module}: no version {m.VERSION} example"
    assert re.search(rf"\(version {m.VERSION}\b", doc)          # the docstring says which version it shows
    assert f"`{m.FORMAT}` v{m.VERSION}" in README              # and the code overview names it
