"""The course as a website, from the student edition: ``make book``.

The builder is MkDocs with mkdocs-jupyter (notebooks rendered by nbconvert, the Material
theme), a well-kept pair that builds offline: the chapters' formulas are typeset by a local
copy of MathJax (the ``jupyter-server-mathjax`` package's), and the theme loads no web fonts.

Steps: the student edition of every chapter (answers and appendices out) is written into
``OUT/src``, the index becomes the home page, links between chapters are pointed at their
pages (``02-arcs-ijk-vs-r.ipynb`` → ``02-arcs-ijk-vs-r.html``) and links to files the site does
not hold (the teacher's guide, the repository's README) keep their words only; the site's
navigation is generated from ``notebooks/chapters.toml`` (the list the chapters' own
navigation comes from); ``mkdocs build`` writes ``OUT/site``. Usage::

    python tools/course_book.py [OUT]      # default build/book
"""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import nbformat

from labkit.course import write_student_edition

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = ROOT / "notebooks"
sys.path.insert(0, str(Path(__file__).resolve().parent))
from course_navigation import load_chapters  # noqa: E402

PAGES_MD = ("PREREQUISITES.md", "FURTHER-READING.md")
#: the configuration jupyter-server-mathjax ships (TeX input, HTML-CSS output)
MATHJAX_CONFIG = "?config=TeX-AMS-MML_HTMLorMML-full,Safe"
_LINK = re.compile(r"(!?)\[([^\]]*)\]\(([^)\s]+)\)")


def _page_name(target: str) -> str:
    """Where a source link points in the site (00-index.ipynb → index.html, x.ipynb → x.html)."""
    path, _, anchor = target.partition("#")
    if path == "00-index.ipynb":
        path = "index.html"
    elif path.endswith((".ipynb", ".md")):
        path = path.rsplit(".", 1)[0] + ".html"
    return path + (f"#{anchor}" if anchor else "")


def _relink(text: str, present: set) -> str:
    def one(m):
        bang, words, target = m.groups()
        if bang or re.match(r"[a-z]+:", target) or target.startswith("#"):
            return m.group(0)
        page = _page_name(target)
        if page.split("#")[0] not in present:
            return words                                   # a file the site does not hold
        return f"[{words}]({page})"
    return _LINK.sub(one, text)


def prepare(out: Path) -> Path:
    """Write the site's sources (student edition, pages, MathJax) and mkdocs.yml; return the yml."""
    src = out / "src"
    if src.exists():
        shutil.rmtree(src)
    notebooks = write_student_edition(NOTEBOOKS, src)
    for name in PAGES_MD:
        shutil.copy(NOTEBOOKS / name, src / name)
    (src / "00-index.ipynb").rename(src / "index.ipynb")
    present = {"index.html"} | {p.stem + ".html" for p in src.glob("*.ipynb")} \
        | {Path(n).stem + ".html" for n in PAGES_MD} | {p.name for p in src.iterdir()}
    for path in [src / "index.ipynb"] + [p for p in notebooks if p.name != "00-index.ipynb"]:
        nb = nbformat.read(path, as_version=4)
        for cell in nb.cells:
            if cell.cell_type == "markdown":
                cell.source = _relink(cell.source, present)
        nbformat.write(nb, path)
    for name in PAGES_MD:
        page = src / name
        page.write_text(_relink(page.read_text(encoding="utf-8"), present), encoding="utf-8")
    import jupyter_server_mathjax

    shutil.copytree(Path(jupyter_server_mathjax.__file__).parent / "static", src / "mathjax")
    groups: dict[str, list] = {}
    for ch in load_chapters():
        groups.setdefault(ch["group"], []).append(f'      - "{ch["file"][:2]} · {ch["title"]}": {ch["file"]}')
    nav = ["nav:", "  - Home: index.ipynb", "  - Before you start: PREREQUISITES.md"]
    for name, items in groups.items():
        nav += [f'  - "{name}":'] + items
    nav += ["  - Further reading: FURTHER-READING.md"]
    yml = out / "mkdocs.yml"
    yml.write_text("\n".join([
        "site_name: labkit — a laser CNC course",
        "docs_dir: src",
        "site_dir: site",
        "use_directory_urls: false",
        "theme:",
        "  name: material",
        "  font: false                 # no web fonts: the site works offline",
        "  features: [navigation.footer]",
        "plugins:",
        "  - search",
        "  - mkdocs-jupyter:",
        "      execute: false          # the stored outputs (the chapters are run by nbval)",
        f"      custom_mathjax_url: mathjax/MathJax.js{MATHJAX_CONFIG}",
        *nav, ""]), encoding="utf-8")
    return yml


def build(out) -> Path:
    """Build the site into ``OUT/site``; returns that folder."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    yml = prepare(out)
    import os

    env = dict(os.environ, NO_MKDOCS_2_WARNING="1")       # Material's notice about its successor
    subprocess.run([sys.executable, "-m", "mkdocs", "build", "--quiet", "-f", str(yml)], check=True, env=env)
    return out / "site"


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    site = build(argv[0] if argv else ROOT / "build" / "book")
    print(f"the course website is in {site} (open {site / 'index.html'})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
