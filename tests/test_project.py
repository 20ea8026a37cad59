"""The project's own promises: data provenance, notebook links, commands, CI entry."""

import importlib
import json
import re
from pathlib import Path

import pytest

from labkit.cli import COMMANDS

ROOT = Path(__file__).resolve().parents[1]


def test_every_data_folder_records_source_and_licence():
    folders = [p for p in (ROOT / "data").iterdir() if p.is_dir()]
    assert folders
    top = (ROOT / "data" / "README.md").read_text()
    for folder in folders:
        readme = folder / "README.md"
        assert readme.exists(), f"{folder} has no README.md"
        text = readme.read_text().lower()
        assert "licen" in text or "bsd-3-clause" in text, f"{readme} names no licence"
        assert f"| {folder.name}" in top, f"data/README.md has no row for {folder.name}"


def _links(nb_path):
    if nb_path.suffix == ".md":
        text = nb_path.read_text()
    else:
        cells = json.loads(nb_path.read_text())["cells"]
        text = "\n".join("".join(c["source"]) for c in cells if c["cell_type"] == "markdown")
    return re.findall(r"\]\(([^)#\s]+\.(?:ipynb|md))\)", text)


@pytest.mark.parametrize("nb", sorted([*(ROOT / "notebooks").glob("*.ipynb"), *(ROOT / "notebooks").glob("*.md")]),
                         ids=lambda p: p.name)
def test_notebook_links_resolve(nb):
    for link in _links(nb):
        assert (nb.parent / link).exists(), f"{nb.name} links to missing {link}"


def test_index_links_every_chapter():
    linked = set(_links(ROOT / "notebooks" / "00-index.ipynb"))
    chapters = {p.name for p in (ROOT / "notebooks").glob("[0-9][0-9]-*.ipynb")} - {"00-index.ipynb"}
    assert chapters <= linked, f"chapters missing from the index: {sorted(chapters - linked)}"
    # and each with its expected run time, as "(NN-name.ipynb) [≈ N s]"
    cells = json.loads((ROOT / "notebooks" / "00-index.ipynb").read_text())["cells"]
    text = "\n".join("".join(c["source"]) for c in cells if c["cell_type"] == "markdown")
    timed = set(re.findall(r"\]\(([0-9][0-9]-[\w-]+\.ipynb)\) \[≈ \d+ s\]", text))
    assert chapters <= timed, f"chapters without a run time in the index: {sorted(chapters - timed)}"


def test_notebooks_are_stored_with_outputs():
    for nb in (ROOT / "notebooks").glob("*.ipynb"):
        cells = json.loads(nb.read_text())["cells"]
        code = [c for c in cells if c["cell_type"] == "code"]
        assert code and all(c.get("execution_count") for c in code), f"{nb.name} not executed"


@pytest.mark.parametrize("name", list(COMMANDS))
def test_every_command_is_implemented(name):
    module = importlib.import_module(f"labkit.commands.{COMMANDS[name][0]}")
    attr = name.replace("-", "_")
    assert callable(getattr(module, f"add_{attr}_arguments"))
    assert callable(getattr(module, f"run_{attr}"))


def test_ci_runs_the_readme_test_command():
    assert "make test" in (ROOT / ".ci" / "run").read_text()
    readme = (ROOT / "README.md").read_text()
    assert readme.index("make lab") < readme.index("make test") < 400
