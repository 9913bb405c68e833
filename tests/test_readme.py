"""The README's Python examples run as printed (they are the package's public face)."""

from __future__ import annotations

import re
from pathlib import Path

README = (Path(__file__).resolve().parents[1] / "README.md").read_text()


def test_the_readme_python_examples_run(capsys, tmp_path, monkeypatch) -> None:
    blocks = re.findall(r"```python\n(.*?)```", README, re.S)
    assert len(blocks) >= 3
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}  # one session, as a reader runs them in order
    for block in blocks:
        exec(compile(block, "README.md", "exec"), namespace)
    # The first example's printed result, as its comment says.
    assert capsys.readouterr().out.startswith("96 100.0 {'tip_height': 1.357")
