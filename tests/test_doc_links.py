"""Every relative link of the README and docs/ resolves: the file exists and, for a link to a
section, the section does (GitHub's anchors: the heading lower-cased, punctuation dropped,
spaces as hyphens, a repeated heading numbered). Reference: the files and headings themselves.
"""

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")), ROOT / "studies" / "README.md"]


def anchors(page):
    """The section anchors of a markdown page, as GitHub makes them."""
    out, seen = set(), {}
    text = re.sub(r"```.*?```", "", page.read_text(encoding="utf-8"), flags=re.S)
    for m in re.finditer(r"^#{1,6}\s+(.*)$", text, re.M):
        a = re.sub(r"[^\w\- ]", "", m.group(1).strip().lower()).replace(" ", "-")
        n = seen.get(a, 0)
        seen[a] = n + 1
        out.add(a if n == 0 else f"{a}-{n}")
    return out


def links(page):
    """The relative links of a page outside code blocks."""
    text = re.sub(r"```.*?```", "", page.read_text(encoding="utf-8"), flags=re.S)
    return [m.group(1) for m in re.finditer(r"\]\(([^)\s]+)\)", text)
            if not m.group(1).startswith(("http://", "https://", "mailto:"))]


def test_anchors_follow_githubs_rule():
    # reference: GitHub's anchor of "## Your data: the cell-data format" and of a repeat
    page = ROOT / "docs" / "guide.md"
    assert "your-data-the-cell-data-format" in anchors(page)


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_relative_link_resolves(page):
    bad = []
    for link in links(page):
        path, _, anchor = link.partition("#")
        target = (page.parent / path).resolve() if path else page
        if not target.exists():
            bad.append(f"{link}: no such file")
        elif anchor and target.suffix == ".md" and anchor not in anchors(target):
            bad.append(f"{link}: no such section")
    assert not bad, bad


def test_the_readme_is_a_landing_page():
    # the release's bar: at most 250 lines; the validation ledger lives in docs/validation.md
    lines = (ROOT / "README.md").read_text(encoding="utf-8").splitlines()
    assert len(lines) <= 250, len(lines)
    assert "## The validation ledger" in (ROOT / "docs" / "validation.md").read_text()
