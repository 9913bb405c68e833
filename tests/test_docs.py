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
