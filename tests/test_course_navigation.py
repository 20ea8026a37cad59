"""The course's navigation: generated from notebooks/chapters.toml, and every link leads somewhere."""

import re
import sys
from pathlib import Path
from urllib.parse import unquote

import nbformat
import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))
import course_navigation as nav  # noqa: E402

NOTEBOOKS = ROOT / "notebooks"
LINK = re.compile(r"\[[^\]]*\]\(([^)\s]+)\)")


def _chapters(n):
    return [dict(file=f"{k:02d}-c{k}.ipynb", title=f"Chapter {k}", short=f"c{k}", group=g,
                 seconds=5, summary=f"about {k}") for k, g in zip(range(1, n + 1), "AABBA")]


def test_the_chain_has_no_gap_and_the_ends_link_one_way():
    ch = _chapters(3)
    assert nav.nav_line(ch, 0) == "[← index](00-index.ipynb) · next: [02 · c2 →](02-c2.ipynb)"
    assert nav.nav_line(ch, 1) == ("[← index](00-index.ipynb) · previous: [01 · c1](01-c1.ipynb) · "
                                   "next: [03 · c3 →](03-c3.ipynb)")
    assert nav.nav_line(ch, 2) == "[← index](00-index.ipynb) · previous: [02 · c2](02-c2.ipynb)"


def test_navigation_replaces_the_old_line_keeps_the_rule_and_adds_a_missing_last_cell():
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_markdown_cell("# 07 · Title\n\n[← index](00-index.ipynb) · see also: x\n\nText."),
                nbformat.v4.new_markdown_cell("---\n[← index](00-index.ipynb) · old")]
    assert nav.with_navigation(nb, "[← index](00-index.ipynb) · NEW")
    assert nb.cells[0].source == "# 07 · Title\n\n[← index](00-index.ipynb) · NEW\n\nText."
    assert nb.cells[1].source == "---\n[← index](00-index.ipynb) · NEW"
    assert not nav.with_navigation(nb, "[← index](00-index.ipynb) · NEW")      # idempotent
    ending = nbformat.v4.new_notebook()          # the take-aways and the navigation in one cell
    ending.cells = [nbformat.v4.new_markdown_cell("# 09 · T"),
                    nbformat.v4.new_markdown_cell("## What to take away\n\n* x\n\n---\n[← index](00-index.ipynb) · old")]
    assert nav.with_navigation(ending, "[← index](00-index.ipynb) · NEW") and len(ending.cells) == 2
    assert ending.cells[1].source == "## What to take away\n\n* x\n\n---\n[← index](00-index.ipynb) · NEW"
    bare = nbformat.v4.new_notebook()
    bare.cells = [nbformat.v4.new_markdown_cell("# 08 · T\nText."), nbformat.v4.new_code_cell("1")]
    assert nav.with_navigation(bare, "[← index](00-index.ipynb)")
    assert bare.cells[0].source == "# 08 · T\n\n[← index](00-index.ipynb)\n\nText."
    assert bare.cells[-1].source == "[← index](00-index.ipynb)" and len(bare.cells) == 3
    # a closing line that is no longer in the last cell (a navigation cell came after it) goes:
    # chapter 14 showed two closing lines, the older naming another title
    stale = nbformat.v4.new_notebook()
    stale.cells = [nbformat.v4.new_markdown_cell("# 14 · T\n\n[← index](00-index.ipynb) · old"),
                   nbformat.v4.new_markdown_cell("## What to take away\n\n* x\n\n---\n[← index](00-index.ipynb) · old"),
                   nbformat.v4.new_markdown_cell("[← index](00-index.ipynb) · old")]
    assert nav.with_navigation(stale, "[← index](00-index.ipynb) · NEW")
    assert stale.cells[1].source == "## What to take away\n\n* x"
    assert [c.source for c in (stale.cells[0], stale.cells[2])] == ["# 14 · T\n\n[← index](00-index.ipynb) · NEW",
                                                                   "[← index](00-index.ipynb) · NEW"]
    assert not nav.with_navigation(stale, "[← index](00-index.ipynb) · NEW")


def test_index_entries_carry_their_own_numbers_in_list_order():
    text = nav.chapter_list(_chapters(5))
    # groups in order of their first chapter; chapter 5 (group A) is listed under A, by number
    assert text.index("**A**") < text.index("**B**")
    assert re.findall(r"\*\*(\d\d)\*\*", text) == ["01", "02", "05", "03", "04"]
    assert not re.search(r"^\d+\. ", text, re.M), "no Markdown ordered list (renderers renumber it)"


def test_the_index_list_is_rewritten_once_keeping_its_introduction():
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_markdown_cell("## Chapters\n\nIntro text.\n\n**A**\n\n1. [old](01-c1.ipynb)\n25. [x](x.ipynb)")]
    assert nav.with_index(nb, _chapters(2))
    text = nb.cells[0].source
    assert text.startswith("## Chapters\n\nIntro text.\n\n" + nav.STUDENT_PAGES)
    assert "[old]" not in text and "* **02** · [Chapter 2](02-c2.ipynb)" in text
    assert not nav.with_index(nb, _chapters(2))


def test_the_list_holds_every_chapter_once():
    listed = [c["file"] for c in nav.load_chapters()]
    assert len(listed) == len(set(listed))
    assert sorted(listed) == sorted(p.name for p in NOTEBOOKS.glob("[0-9][0-9]-*.ipynb")
                                    if p.name != "00-index.ipynb")


def test_the_chapters_navigation_is_the_lists():
    # tools/course_navigation.py writes it; this fails when a chapter or the index was edited by hand
    assert nav.main(["--check"]) == 0


def _documents():
    for path in sorted(NOTEBOOKS.glob("*.ipynb")):
        for k, cell in enumerate(nbformat.read(path, as_version=4).cells):
            if cell.cell_type == "markdown":
                yield path, f"cell {k}", cell.source
    for path in [NOTEBOOKS / "TEACHING.md", ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
        if path.exists():
            yield path, "", path.read_text(encoding="utf-8")


def test_every_relative_link_leads_to_a_file():
    broken = []
    for path, where, text in _documents():
        text = re.sub(r"```.*?```", "", text, flags=re.S)          # code blocks hold no links
        for target in LINK.findall(text):
            if re.match(r"[a-z]+:", target) or target.startswith("#"):
                continue                      # web addresses and anchors in the same page
            file = unquote(target.split("#", 1)[0])
            if not (path.parent / file).exists():
                broken.append(f"{path.relative_to(ROOT)} {where}: {target}")
    assert not broken, "links to nothing:\n" + "\n".join(broken)


@pytest.mark.parametrize("path", sorted(NOTEBOOKS.glob("[0-9][0-9]-*.ipynb")), ids=lambda p: p.name)
def test_links_into_chapters_name_a_heading_that_exists(path):
    # an anchor into a chapter (#2-arcs-by-r) must match one of its headings as Jupyter makes them
    headings = set()
    for cell in nbformat.read(path, as_version=4).cells:
        if cell.cell_type == "markdown":
            for h in re.findall(r"^#+\s+(.*)$", cell.source, re.M):
                headings.add(re.sub(r"\s", "-", h.strip()))
    for source, where, text in _documents():
        for target in LINK.findall(text):
            if target.startswith(path.name + "#"):
                anchor = unquote(target.split("#", 1)[1])
                assert anchor in headings, f"{source.name} {where}: {target} names no heading of {path.name}"
