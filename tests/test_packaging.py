"""The MJCF loads from a source checkout and from an installed (non-editable) wheel, which
carries the PEP 561 ``py.typed`` marker, the license and the command's entry point; the sdist
carries the docs, examples, changelog and license."""

from __future__ import annotations

import os
import subprocess
import sys
import tarfile
import zipfile
from pathlib import Path

import pytest

import acrobot_mj
from acrobot_mj.envs.assets import load_model, models_dir

ROOT = Path(__file__).resolve().parents[1]


def test_models_found_in_the_source_checkout() -> None:
    # Run from the checkout (editable install or PYTHONPATH): the top-level models/ is used.
    if Path(acrobot_mj.__file__).resolve().parent != ROOT / "acrobot_mj":
        pytest.skip("acrobot_mj is not imported from this checkout")
    assert models_dir() == ROOT / "models"
    for name in ("scene.xml", "acrobot.xml"):
        load_model(models_dir() / name)


@pytest.mark.slow
def test_the_sdist_carries_the_docs_examples_changelog_and_license(tmp_path: Path) -> None:
    pip = [sys.executable, "-m", "hatchling", "build", "-t", "sdist", "-d", str(tmp_path)]
    subprocess.run(pip, check=True, cwd=ROOT, capture_output=True)
    (sdist,) = tmp_path.glob("acrobot_mj-*.tar.gz")
    with tarfile.open(sdist) as archive:
        names = {n.split("/", 1)[1] for n in archive.getnames() if "/" in n}
    for name in (
        "LICENSE",
        "CHANGELOG.md",
        "README.md",
        "docs/conf.py",
        "docs/index.md",
        "acrobot_mj_main.py",
        "models/acrobot.xml",
    ):
        assert name in names, name
    assert any(n.startswith("examples/") and n.endswith(".py") for n in names)
    assert not [n for n in names if "_build" in n or "__pycache__" in n]


@pytest.mark.slow
def test_models_load_from_an_installed_wheel(tmp_path: Path) -> None:
    wheels, target = tmp_path / "wheels", tmp_path / "site"
    pip = [sys.executable, "-m", "pip", "--disable-pip-version-check", "-q"]
    subprocess.run(
        [*pip, "wheel", "--no-deps", "--no-build-isolation", "-w", str(wheels), str(ROOT)],
        check=True,
        cwd=tmp_path,
    )
    (wheel,) = wheels.glob("acrobot_mj-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    assert "acrobot_mj/models/acrobot.xml" in names and "acrobot_mj/models/scene.xml" in names
    assert "acrobot_mj/py.typed" in names  # PEP 561: type checkers read the package's hints
    entry_points = next(n for n in names if n.endswith("entry_points.txt"))
    assert "acrobot-mj = acrobot_mj_main:main" in zipfile.ZipFile(wheel).read(entry_points).decode()
    assert "acrobot_mj_main.py" in names  # the entry point, outside the package
    metadata = zipfile.ZipFile(wheel).read(next(n for n in names if n.endswith("/METADATA")))
    assert b"License-Expression: MIT" in metadata
    assert any(n.endswith("licenses/LICENSE") for n in names)

    subprocess.run(
        [*pip, "install", "--no-deps", "--target", str(target), str(wheel)],
        check=True,
        cwd=tmp_path,
    )
    probe = (
        "import acrobot_mj, gymnasium as gym; from acrobot_mj.envs.assets import models_dir;"
        "env = gym.make('acrobot_mj/Acrobot-v0'); env.reset(seed=0); env.step(2);"
        "from acrobot_mj.control.trajopt import shipped;"
        "print(acrobot_mj.__file__); print(models_dir()); print(shipped('reserve').steps)"
    )
    # cwd is the temporary folder and PYTHONPATH only the install target, so nothing can come
    # from the checkout (the dependencies still come from this interpreter's site-packages).
    env = {**os.environ, "PYTHONPATH": str(target)}
    out = subprocess.run(
        [sys.executable, "-c", probe],
        check=True,
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
    ).stdout.split()
    assert Path(out[0]).is_relative_to(target)
    assert Path(out[1]) == target / "acrobot_mj" / "models"
    assert int(out[2]) > 300  # the shipped trajectories travel in the wheel, and pass their check
