"""The chapters' navigation and the index's chapter list, generated from one list.

``notebooks/chapters.toml`` is the list: the chapters in reading order, each with its title,
the short words of its navigation link, its group in the index, its measured run time and a
one-line summary. From it this script writes, as the Python Data Science Handbook's
``tools/add_navigation.py`` does for its chapters:

* each chapter's navigation line — ``[← index](00-index.ipynb) · previous: [...] · next: [...]``
  — in its first cell (under the title) and as its last cell;
* the index's chapter list, grouped as the list says, each entry numbered in its text
  (``**25** · ...``), not by a Markdown ordered list, which renderers renumber.

Only notebooks that ``git status`` shows unmodified are written (other people edit the
chapters' content): the others are listed and left alone. ``--check`` writes nothing and
exits 1 when a notebook's navigation differs from the list. Usage::

    python tools/course_navigation.py [--check] [--force]
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import nbformat

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = ROOT / "notebooks"
LIST = NOTEBOOKS / "chapters.toml"
INDEX = "00-index.ipynb"
NAV_START = "[← index]"
CHAPTERS_HEADING = "## Chapters"
#: the students' pages, named above the chapter list
STUDENT_PAGES = ("Before you start: [what you need to know first](PREREQUISITES.md) · after a chapter: "
                 "[further reading](FURTHER-READING.md).")


def load_chapters(path: Path = LIST) -> list[dict]:
    """The chapters in reading order (each: file, title, short, group, seconds, summary)."""
    with open(path, "rb") as fh:
        chapters = tomllib.load(fh)["chapter"]
    for ch in chapters:
        missing = {"file", "title", "short", "group", "seconds", "summary"} - set(ch)
        if missing:
            raise SystemExit(f"{path}: chapter {ch.get('file', '?')} lacks {', '.join(sorted(missing))}")
    return chapters


def number(chapter: dict) -> str:
    """The chapter's number as its file name gives it ("07")."""
    return chapter["file"][:2]


def nav_line(chapters: list[dict], k: int) -> str:
    """The navigation line of the k-th chapter of the list."""
    parts = [f"{NAV_START}({INDEX})"]
    if k > 0:
        prev = chapters[k - 1]
        parts.append(f"previous: [{number(prev)} · {prev['short']}]({prev['file']})")
    if k + 1 < len(chapters):
        nxt = chapters[k + 1]
        parts.append(f"next: [{number(nxt)} · {nxt['short']} →]({nxt['file']})")
    return " · ".join(parts)


def with_navigation(nb, line: str) -> bool:
    """Put ``line`` under the title of the first cell and as the last cell; True if changed."""
    first = nb.cells[0]
    lines = first.source.split("\n")
    at = [i for i, text in enumerate(lines) if text.startswith(NAV_START)]
    if at:
        new_lines = lines[:at[0]] + [line] + lines[at[0] + 1:]
    else:                                   # under the title, a blank line either side
        new_lines = lines[:1] + ["", line] + ([""] if len(lines) > 1 and lines[1] else []) + lines[1:]
    changed = False
    if "\n".join(new_lines) != first.source:
        first.source = "\n".join(new_lines)
        changed = True
    # a navigation line anywhere between (a closing cell that lost its place as the last
    # one) goes stale: the chapter has one at its top and one at its end
    for cell in nb.cells[1:-1]:
        if cell.cell_type == "markdown" and NAV_START in cell.source:
            kept = "\n".join(text for text in cell.source.split("\n") if not text.startswith(NAV_START))
            kept = kept.rstrip("\n")
            cell.source = kept[:-3].rstrip("\n") if kept.endswith("\n---") else kept   # its rule too
            changed = True
    last = nb.cells[-1]
    tail = last.source.split("\n")
    at = [i for i, text in enumerate(tail) if text.startswith(NAV_START)] if last is not first else []
    if last.cell_type == "markdown" and at:      # the last cell ends the chapter with a navigation line
        tail[at[-1]] = line
        if "\n".join(tail) != last.source:
            last.source = "\n".join(tail)
            changed = True
    else:
        nb.cells.append(nbformat.v4.new_markdown_cell(line))
        changed = True
    return changed


def chapter_list(chapters: list[dict]) -> str:
    """The index's chapter list: groups in order of their first chapter, numbered entries."""
    groups: dict[str, list[dict]] = {}
    for ch in chapters:
        groups.setdefault(ch["group"], []).append(ch)
    out = []
    for name, members in groups.items():
        out += [f"**{name}**", ""]
        for ch in members:
            summary = f" — {ch['summary']}." if ch["summary"] else ""
            out.append(f"* **{number(ch)}** · [{ch['title']}]({ch['file']}) [≈ {ch['seconds']} s]{summary}")
        out.append("")
    return "\n".join(out).rstrip("\n")


def with_index(nb, chapters: list[dict]) -> bool:
    """Replace the chapter list of the index's "Chapters" cell (its text before the list stays)."""
    (cell,) = [c for c in nb.cells if c.cell_type == "markdown" and c.source.startswith(CHAPTERS_HEADING)]
    first_group = re.search(r"^\*\*[^*\n]+\*\*\s*$", cell.source, re.M)
    intro = cell.source[:first_group.start()] if first_group else cell.source.rstrip() + "\n\n"
    intro = intro.replace(STUDENT_PAGES + "\n\n", "")
    new = intro + STUDENT_PAGES + "\n\n" + chapter_list(chapters)
    if new == cell.source:
        return False
    cell.source = new
    return True


def _unmodified(paths: list[Path]) -> set[Path]:
    out = subprocess.run(["git", "status", "--porcelain", "--", *map(str, paths)], cwd=ROOT,
                         capture_output=True, text=True, check=True).stdout
    dirty = {ROOT / line[3:].strip() for line in out.splitlines()}
    return {p for p in paths if p.resolve() not in {d.resolve() for d in dirty}}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--check", action="store_true", help="write nothing; exit 1 if anything differs")
    parser.add_argument("--force", action="store_true", help="also write notebooks git shows modified")
    args = parser.parse_args(argv)
    chapters = load_chapters()
    on_disk = sorted(p.name for p in NOTEBOOKS.glob("[0-9][0-9]-*.ipynb") if p.name != INDEX)
    listed = [ch["file"] for ch in chapters]
    if sorted(listed) != on_disk:
        print(f"chapters.toml and the folder differ: not listed {sorted(set(on_disk) - set(listed))}, "
              f"listed but missing {sorted(set(listed) - set(on_disk))}")
        return 1
    targets = [NOTEBOOKS / INDEX] + [NOTEBOOKS / f for f in listed]
    writable = set(targets) if args.force else _unmodified(targets)
    differ = 0
    for path in targets:
        raw = path.read_text(encoding="utf-8")
        nb = nbformat.reads(raw, as_version=4)
        if path.name == INDEX:
            changed = with_index(nb, chapters)
        else:
            changed = with_navigation(nb, nav_line(chapters, listed.index(path.name)))
        if not changed:
            continue
        differ += 1
        if args.check:
            print(f"{path.name}: navigation differs from chapters.toml")
        elif path not in writable:
            print(f"{path.name}: modified in the work tree by someone else; left alone (run again later)")
        elif path.read_text(encoding="utf-8") != raw:
            print(f"{path.name}: changed while this ran; left alone (run again)")
        else:
            path.write_text(nbformat.writes(nb) + "\n", encoding="utf-8")
            print(f"{path.name}: navigation written")
    return 1 if args.check and differ else 0


if __name__ == "__main__":
    sys.exit(main())
