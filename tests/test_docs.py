"""The docs site: every page short enough to read in a few minutes, and the site built strictly
(warnings are errors, every cross-reference resolves), as CI builds it."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
PAGES = sorted(p for p in DOCS.rglob("*.md") if "_build" not in p.relative_to(DOCS).parts)
#: The most words a page may hold (the aim is about 1,500).
MAX_WORDS = 1600


def test_the_docs_have_pages() -> None:
    names = {str(p.relative_to(DOCS)) for p in PAGES}
    assert {"index.md", "results.md", "envs/acrobot.md", "explain/layout.md"} <= names


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(DOCS)))
def test_every_page_is_short(page: Path) -> None:
    words = len(page.read_text().split())  # as `wc -w` counts them
    assert words <= MAX_WORDS, f"{page.relative_to(ROOT)}: {words} words (at most {MAX_WORDS})"


def test_the_pages_cite_no_old_flat_paths() -> None:
    # The pages moved into envs/, guide/ and explain/; a link to a flat page is stale.
    moved = "task|design|learning|learning-from-rest|speed|balance|balance-learned|examples"
    moved += "|vector-env|sweeps|validation|videos|reliability|testing|layout"
    stale = re.compile(rf"docs/({moved})\.md\b")
    hits = [
        f"{p.relative_to(ROOT)}: {m.group(0)}" for p in PAGES for m in stale.finditer(p.read_text())
    ]
    assert hits == []


@pytest.mark.slow
def test_the_site_builds_strictly(tmp_path: Path) -> None:
    pytest.importorskip("sphinx")
    pytest.importorskip("myst_parser")
    pytest.importorskip("furo")
    from sphinx.cmd.build import build_main

    out = tmp_path / "html"
    status = build_main(
        [
            "-W",
            "--keep-going",
            "-n",
            "-q",
            "-E",
            "-b",
            "html",
            str(DOCS),
            str(out),
            "-d",
            str(tmp_path / "doctrees"),
        ]
    )
    assert status == 0, "sphinx-build -W -n failed: see the warnings above"
    assert (out / "index.html").exists() and (out / "api" / "envs.html").exists()


#: Every Markdown page a reader follows links in: the README, the changelog and the docs.
LINKED = [ROOT / "README.md", ROOT / "CHANGELOG.md", *PAGES]
LINK = re.compile(r"(?<!!)\[[^\]]*\]\(([^)\s]+)\)|!\[[^\]]*\]\(([^)\s]+)\)")


def anchors(page: Path) -> set[str]:
    """The anchors of ``page``'s headings down to level 3, as MyST makes them
    (``myst_heading_anchors = 3`` in docs/conf.py) and GitHub does: lower case, punctuation
    but ``-`` and ``_`` dropped, spaces as ``-``."""
    found, fenced = set(), False
    for line in page.read_text().splitlines():
        fenced ^= line.startswith("```")
        heading = re.match(r"(#{1,3}) (.*)", line)
        if heading and not fenced:
            title = heading.group(2).strip().lower()
            found.add(re.sub(r"[^\w\- ]", "", title).replace(" ", "-"))
    return found


def test_every_relative_link_and_anchor_resolves() -> None:
    """MyST cannot check links outside docs/ (the conf.py suppresses its warning for those), so
    the strict build passed with broken anchors (README's to a replan section, CHANGELOG's to a
    black-box section, a page that moved): every link is checked here."""
    broken = []
    for page in LINKED:
        text = re.sub(r"```.*?```", "", page.read_text(), flags=re.S)  # code is not links
        for match in LINK.finditer(text):
            target = match.group(1) or match.group(2)
            if re.match(r"[a-z]+:", target):  # https:, mailto:
                continue
            path, _, anchor = target.partition("#")
            linked = (page.parent / path).resolve() if path else page
            if not linked.exists():
                broken.append(f"{page.relative_to(ROOT)}: {target} (no such file)")
            elif anchor and linked.suffix == ".md" and anchor not in anchors(linked):
                broken.append(f"{page.relative_to(ROOT)}: {target} (no such heading)")
    assert broken == [], "\n".join(broken)


def test_the_link_check_sees_a_broken_anchor(tmp_path: Path) -> None:
    page = tmp_path / "page.md"
    page.write_text("# Title\n\n## Global policy (simulation_v3)\n\n```\n# not a heading\n```\n")
    assert anchors(page) == {"title", "global-policy-simulation_v3"}
