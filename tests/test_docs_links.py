"""Every relative link in README.md, docs/ and examples/ names a file that exists, and every
#anchor a heading of that file (GitHub's heading ids)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = sorted([ROOT / "README.md", ROOT / "BENCHMARKS.md", *(ROOT / "docs").glob("*.md"),
                *(ROOT / "examples").glob("*/README.md")])
LINK = re.compile(r"\]\(([^)\s]+)\)")


def prose_lines(text: str):
    """The lines of a markdown text outside its code fences."""
    fenced = False
    for line in text.splitlines():
        if line.lstrip().startswith("```"):
            fenced = not fenced
        elif not fenced:
            yield line


def heading_ids(text: str) -> set[str]:
    """The ids GitHub gives a page's headings: lower case, punctuation dropped, spaces to
    hyphens, a repeated id suffixed -1, -2, ...; headings inside code fences are not headings."""
    ids, seen = set(), {}
    for line in prose_lines(text):
        if match := re.match(r"#{1,6}\s+(.*?)\s*#*\s*$", line):
            base = re.sub(r"[^\w\- ]", "", match.group(1).lower()).replace(" ", "-")
            n = seen.get(base, 0)
            seen[base] = n + 1
            ids.add(base if n == 0 else f"{base}-{n}")
    return ids


def page_links(page: Path) -> list[str]:
    """The page's link targets outside code fences, web addresses left out."""
    return [t for line in prose_lines(page.read_text(encoding="utf-8")) for t in LINK.findall(line)
            if not re.match(r"[a-z]+:", t)]


def test_heading_ids_follow_github():
    text = "# A title\n## Balanced class weights (`--class-weight balanced`)\n```\n# not a heading\n```\n" \
           "## The stairwell's side\n## A title\n"
    assert heading_ids(text) == {"a-title", "balanced-class-weights---class-weight-balanced",
                                 "the-stairwells-side", "a-title-1"}


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_relative_links_resolve(page):
    broken = []
    for target in page_links(page):
        path, _, anchor = target.partition("#")
        file = (page.parent / path).resolve() if path else page
        if not file.exists():
            broken.append(f"{target}: no file {file.relative_to(ROOT) if file.is_relative_to(ROOT) else file}")
        elif anchor and file.suffix == ".md" and anchor not in heading_ids(file.read_text(encoding="utf-8")):
            broken.append(f"{target}: no heading with that id")
    assert not broken, f"{page.relative_to(ROOT)}: " + "; ".join(broken)
