"""The course's pages around the chapters: the prerequisites page's checks work, Binder is complete."""

import re
import tomllib
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def test_the_prerequisites_checks_run_and_give_the_answers_stated(capsys):
    page = (ROOT / "notebooks" / "PREREQUISITES.md").read_text(encoding="utf-8")
    (program,) = re.findall(r"```python\n(.*?)```", page, re.S)
    exec(program, {})
    assert capsys.readouterr().out == "plywood: 5.0 mm/s\n"
    ends = np.array([[0, 0], [10, 0], [10, 5]])
    assert np.hypot(*np.diff(ends, axis=0).T).tolist() == [10.0, 5.0]      # the answer the page gives
    assert "`[10., 5.]`" in page


def test_binder_installs_the_lab_extra_and_what_chapter_13_needs():
    binder = ROOT / "binder"
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"]
    assert "lab" in extras and ".[lab]" in (binder / "postBuild").read_text()
    assert (binder / "postBuild").stat().st_mode & 0o111, "postBuild must be executable"
    assert {"gcc", "make"} <= set((binder / "apt.txt").read_text().split())
    python = (binder / "runtime.txt").read_text().strip()
    required = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["requires-python"]
    assert re.fullmatch(r"python-3\.\d+", python) and int(python.split(".")[1]) >= int(required.split(".")[1])


def test_further_reading_has_a_row_for_every_chapter():
    page = (ROOT / "notebooks" / "FURTHER-READING.md").read_text(encoding="utf-8")
    rows = re.findall(r"^\| (\d\d) [^|]+\| (.+) \|$", page, re.M)
    chapters = tomllib.loads((ROOT / "notebooks" / "chapters.toml").read_text(encoding="utf-8"))["chapter"]
    assert [n for n, _ in rows] == [c["file"][:2] for c in chapters]
    assert all(len(reading.strip()) > 10 for _, reading in rows)
