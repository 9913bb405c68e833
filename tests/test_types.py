"""The typed public API: mypy passes the package, and a type checker catches a misspelt keyword
in a user's script (the envs' keyword options are a TypedDict, not ``**kwargs: Any``)."""

from __future__ import annotations

import inspect
import re
from pathlib import Path

import pytest

from acrobot_mj.envs.acrobot import AcrobotEnv, EnvOptions
from acrobot_mj.envs.tasks import TASKS, TaskOptions
from acrobot_mj.envs.vector import AcrobotVectorEnv
from tests.plugins.tip_height import TipHeight

ROOT = Path(__file__).resolve().parents[1]

#: A user's script: two misspelt keywords (lines 4 and 6), then calls that are right.
USER_SCRIPT = """\
import acrobot_mj
from acrobot_mj.envs.vector import AcrobotVectorEnv

env = acrobot_mj.AcrobotEnv(frame_skp=4)

AcrobotVectorEnv(2, frame_skp=4)

good = acrobot_mj.AcrobotEnv(4, "rk4", task="balance", tolerance=0.1, start_noise=0.1)
vec = AcrobotVectorEnv(2, frame_skip=4, goal_height=0.5, backend="analytic", nthread=1)
obs, info = good.reset(seed=0)
"""

#: The library's main functions, each called with one misspelt keyword (lines 9 to 15).
LIBRARY_SCRIPT = """\
import numpy as np

from acrobot_mj.physics import dynamics
from acrobot_mj.physics.integrators import simulate
from acrobot_mj.train.config import TrainConfig
from acrobot_mj.train.evaluate import evaluate
from acrobot_mj.train.trainer import load_learner, train

TrainConfig(episods=5)
train(TrainConfig(), 0, out_dri="runs/x")
load_learner(run_dri="runs/x")
evaluate("runs/x", minimia="none")
dynamics.forward_dynamics(np.zeros(2), np.zeros(2), tua=0.0)
dynamics.total_energy(np.zeros(2), np.zeros(2), parms=None)
simulate(np.zeros(4), np.zeros(3), methd="rk4")
record = train(TrainConfig(episodes=5), 0, "runs/x")
evaluate("runs/x", minima="none")
"""


def _errors(report: str, name: str) -> list[tuple[int, str]]:
    """``(line, message)`` of each mypy error in file ``name``."""
    found = re.findall(rf"^{re.escape(name)}:(\d+): error: (.*)$", report, re.MULTILINE)
    return [(int(line), message) for line, message in found]


@pytest.fixture(scope="module")
def user_report(tmp_path_factory: pytest.TempPathFactory) -> str:
    """mypy's report on the two scripts, run outside the checkout (the installed package)."""
    api = pytest.importorskip("mypy.api")
    folder = tmp_path_factory.mktemp("user")
    (folder / "user.py").write_text(USER_SCRIPT)
    (folder / "library.py").write_text(LIBRARY_SCRIPT)
    (folder / "mypy.ini").write_text("[mypy]\n")  # not the checkout's configuration
    with pytest.MonkeyPatch.context() as patch:
        patch.chdir(folder)
        stdout, stderr, _ = api.run(
            [
                "--config-file",
                "mypy.ini",
                "--cache-dir",
                "cache",
                "--no-error-summary",
                "user.py",
                "library.py",
            ]
        )
    assert not stderr, stderr
    return stdout


@pytest.mark.slow
def test_a_misspelt_env_keyword_is_a_type_error(user_report: str) -> None:
    errors = _errors(user_report, "user.py")
    assert [line for line, _ in errors] == [4, 6], user_report
    for _, message in errors:
        assert 'Unexpected keyword argument "frame_skp"' in message, user_report
    assert "AcrobotEnv" in errors[0][1] and "AcrobotVectorEnv" in errors[1][1]


@pytest.mark.slow
def test_a_misspelt_keyword_of_the_main_functions_is_a_type_error(user_report: str) -> None:
    errors = _errors(user_report, "library.py")
    assert [line for line, _ in errors] == list(range(9, 16)), user_report
    for (_, message), word in zip(
        errors, ["episods", "out_dri", "run_dri", "minimia", "tua", "parms", "methd"], strict=True
    ):
        assert f'Unexpected keyword argument "{word}"' in message, user_report


@pytest.mark.slow
def test_mypy_passes_the_package(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    api = pytest.importorskip("mypy.api")
    monkeypatch.chdir(ROOT)  # pyproject.toml's [tool.mypy]: the package, its few exceptions
    stdout, stderr, status = api.run(["--cache-dir", str(tmp_path / "cache")])
    assert status == 0 and not stderr, stdout + stderr
    assert stdout.startswith("Success:"), stdout


def test_the_typed_options_name_every_keyword_the_envs_take() -> None:
    """TaskOptions: start_noise and each built-in task's options; EnvOptions: those and every
    keyword of AcrobotEnv but render_mode (the vector env's own)."""
    builtin = [TASKS["height_goal"], TASKS["balance"]]
    task_keys = TaskOptions.__required_keys__ | TaskOptions.__optional_keys__
    assert task_keys == {"start_noise"}.union(*(task.options for task in builtin))
    own = [
        p.name
        for p in inspect.signature(AcrobotEnv).parameters.values()
        if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)
    ]
    env_keys = EnvOptions.__required_keys__ | EnvOptions.__optional_keys__
    assert env_keys == task_keys | (set(own) - {"render_mode"})
    assert not EnvOptions.__required_keys__


class HighTip(TipHeight):
    """The test plugin's task with an option of its own (not in TaskOptions)."""

    options = ("threshold",)

    def __init__(
        self, links: tuple[float, float], start_noise: float = 0.0, threshold: float = 1.5
    ) -> None:
        super().__init__(links, start_noise)
        self.threshold = threshold


def test_a_task_of_ones_own_takes_its_own_options_at_run_time() -> None:
    """A type checker refuses a keyword outside TaskOptions (hence the ignores); the envs still
    pass it on to the task."""
    env = AcrobotEnv(task=HighTip, threshold=1.0)  # type: ignore[call-arg]
    vec = AcrobotVectorEnv(2, task=HighTip, threshold=1.0)  # type: ignore[call-arg]
    assert isinstance(env.task, HighTip) and isinstance(vec.task, HighTip)
    assert env.task.threshold == vec.task.threshold == 1.0
    with pytest.raises(TypeError, match=r"unknown arguments \['threshhold'\]"):
        AcrobotEnv(task=HighTip, threshhold=1.0)  # type: ignore[call-arg]
    env.close()
    vec.close()
