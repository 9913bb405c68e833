"""The Python examples of the README and of the docs pages run as printed (they are the
package's public face)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()
DOCS = ROOT / "docs"
#: Every page of the docs site, in every folder (the built site in docs/_build aside).
PAGES = sorted(p for p in DOCS.rglob("*.md") if "_build" not in p.relative_to(DOCS).parts)


def _blocks(text: str) -> list[str]:
    return re.findall(r"```python\n(.*?)```", text, re.S)


def test_the_readme_python_examples_run(capsys, tmp_path, monkeypatch) -> None:
    blocks = _blocks(README)
    assert len(blocks) >= 2
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}  # one session, as a reader runs them in order
    for block in blocks:
        exec(compile(block, "README.md", "exec"), namespace)
    # The first example's printed result, as its comment says.
    assert capsys.readouterr().out.startswith("96 100.0 {'tip_height': 1.357")


@pytest.mark.parametrize(
    "page", [p for p in PAGES if _blocks(p.read_text())], ids=lambda p: str(p.relative_to(DOCS))
)
def test_the_docs_python_examples_run(page, tmp_path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    namespace: dict = {"__name__": "docs"}  # one session per page, in order
    for block in _blocks(page.read_text()):
        exec(
            compile("import gymnasium as gym\nimport acrobot_mj\n" + block, str(page), "exec"),
            namespace,
        )


def test_the_readme_links_to_pages_that_exist() -> None:
    for text, base in [(README, ROOT)] + [(p.read_text(), p.parent) for p in PAGES]:
        for target in re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", text):
            if not target.startswith("http"):
                assert (base / target).exists(), target
