"""The design's hard edges (scripts/check_architecture.py): they hold for the package, and the
checker finds each kind of violation in a small package made to break them."""

from __future__ import annotations

import importlib.util
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location(
    "check_architecture", ROOT / "scripts" / "check_architecture.py"
)
checker = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(checker)


def test_the_package_keeps_its_hard_edges() -> None:
    assert checker.check_package(ROOT) + checker.check_text(ROOT) == []


#: A path outside the repository and a tracker's word, assembled so this file cites neither.
OUTSIDE = "." + "./sha" + "red/DES" + "IGN.md"
TRACKER = "iss" + "ue"


def _write(root: Path, files: dict[str, str]) -> None:
    for name, text in files.items():
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(textwrap.dedent(text))


def test_the_checker_finds_every_kind_of_violation(tmp_path) -> None:
    many = ", ".join(f"a{i}" for i in range(7))
    _write(
        tmp_path,
        {
            "acrobot_mj/__init__.py": "",
            "acrobot_mj/physics/__init__.py": "",
            # A cycle through an import inside a function, and a physics module importing the
            # simulator and a higher layer.
            "acrobot_mj/physics/a.py": "import mujoco\nfrom acrobot_mj.envs import b\n",
            "acrobot_mj/envs/__init__.py": "",
            "acrobot_mj/envs/b.py": (
                "def f():\n    from acrobot_mj.physics import a\n"
                "    from acrobot_mj.physics.a import _hidden\n"
                "    return other._state\n"
            ),
            "acrobot_mj/envs/wide.py": (
                f"def g(self, {many}, *, named=1):\n    return a0\n"
                f"def k({many}):  # kernel (numba): arrays by position\n    return a0\n"
            ),
            "acrobot_mj/envs/big.py": "x = 1\n" * 501,
            "acrobot_mj/envs/long.py": "def h():\n" + "    x = 1\n" * 60,
            # Text citing a file outside the repository, and a tracker (assembled, so that this
            # file does not cite them itself).
            "README.md": f"See {OUTSIDE}.\nAs the {TRACKER} says.\n",
        },
    )
    problems = "\n".join(checker.check_package(tmp_path) + checker.check_text(tmp_path))
    assert "import cycle: acrobot_mj.envs.b -> acrobot_mj.physics.a" in problems
    assert "imports the simulator mujoco" in problems
    assert "imports acrobot_mj.envs.b (layer 3): imports go down the layers only" in problems
    assert "imports private names ['_hidden']" in problems
    assert "reads the private attribute other._state" in problems
    assert "g() takes 8 parameters" in problems  # self aside, keyword-only ones counted
    assert "h() is 61 lines (at most 60)" in problems
    assert "big.py: 501 lines" in problems
    assert f"README.md:1: cites '{OUTSIDE[:9]}'" in problems
    assert f"README.md:2: cites '{TRACKER}'" in problems
    assert len(problems.splitlines()) == 10  # and nothing else


def _layout_paths() -> list[str]:
    """The paths of the layout tree in docs/explain/layout.md (names in the first 24 columns, two
    spaces of indentation per level; lines with nothing there continue a description)."""
    text = (ROOT / "docs" / "explain" / "layout.md").read_text()
    block = text.split("# Layout", 1)[1].split("```", 2)[1]
    paths, parents = [], []
    for line in block.splitlines():
        name = line[:24].strip()
        if not name:
            continue
        depth = (len(line) - len(line.lstrip())) // 2
        parents = parents[:depth]
        path = "".join(parents) + name.split()[0]
        paths.append(path)
        if path.endswith("/"):
            parents.append(name.split()[0])
    return paths


def test_the_readme_layout_matches_the_code() -> None:
    listed = _layout_paths()
    missing = [path for path in listed if not (ROOT / path).exists()]
    assert missing == [], f"docs/explain/layout.md lists paths that do not exist: {missing}"
    modules = sorted(str(p.relative_to(ROOT)) for p in (ROOT / "acrobot_mj").rglob("*.py"))
    # Package __init__ files other than the root's, the registry's and the CLI's hold only
    # a docstring or re-exports; every other module must be listed.
    quiet = {f"acrobot_mj/{pkg}/__init__.py" for pkg in ("physics", "identify", "control", "envs")}
    quiet |= {"acrobot_mj/report/__init__.py", "acrobot_mj/train/__init__.py"}
    unlisted = [m for m in modules if m not in listed and m not in quiet]
    assert unlisted == [], f"modules missing from docs/explain/layout.md: {unlisted}"
