"""The chapter times in TEACHING.md: counted from the chapters at stated rates, and current."""

import sys
from pathlib import Path

import nbformat

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))
import course_times as ct  # noqa: E402


def test_counts_of_a_hand_made_chapter(tmp_path):
    nb = nbformat.v4.new_notebook()
    solution = nbformat.v4.new_code_cell("# Solution 1\nprint(42)")
    solution.metadata["tags"] = ["solution"]
    appendix = nbformat.v4.new_markdown_cell("## Appendix — for researchers\nmany words " * 50)
    appendix.metadata["tags"] = ["appendix"]
    nb.cells = [nbformat.v4.new_markdown_cell("# Title\n\nOne two three, [four five](x.ipynb).\n```\nnot prose\n```"),
                nbformat.v4.new_code_cell("x = 1"),
                nbformat.v4.new_code_cell("interact(f, a=(0, 1))"),
                solution, appendix]
    path = tmp_path / "01-x.ipynb"
    nbformat.write(nb, path)
    counts = ct.chapter_counts(path)
    # "Title" + five words (the link counts its words, the code block none); the appendix is not
    # in the student edition
    assert counts == dict(words=6, code_cells=2, widgets=1, exercises=1)
    study, work = ct.minutes(counts)
    assert study == 6 / 120 + 2 * 1.0 + 3.0 and work == 8.0


def test_teaching_md_holds_the_current_times():
    # every chapter's total in TEACHING.md within 5 minutes of its count today (chapters change
    # a little with every edit; a bigger change means the table should be generated again:
    # tools/course_times.py --markdown)
    import re

    stated = {m.group(1): int(m.group(2)) for m in re.finditer(
        r"^\| (\d\d) \|(?: [^|]* \|){6} (\d+) \|$", (ROOT / "notebooks" / "TEACHING.md").read_text(), re.M)}
    now = {r["chapter"][:2]: r["total_min"] for r in ct.table(sorted((ROOT / "notebooks").glob("[0-9][0-9]-*.ipynb"))[1:])}
    assert stated.keys() == now.keys()
    off = {k: (stated[k], now[k]) for k in now if abs(stated[k] - now[k]) > 5}
    assert not off, f"TEACHING.md's chapter times (stated, counted now) are stale: {off}"
