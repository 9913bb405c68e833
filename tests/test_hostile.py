"""What a hostile but realistic user tried on the new commands: each case is one
clear line or an exact result, nothing silently dropped, nothing written where refused."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest

from acrobot_mj.cli import main
from acrobot_mj.envs.disturbances import Disturbances
from acrobot_mj.train.feedback_run import FeedbackConfig
from acrobot_mj.train.records import EVAL_FILE
from acrobot_mj.train.trainer import train


@pytest.fixture
def exits():
    """Run the CLI, returning its exit code instead of raising SystemExit."""

    def run(argv: list[str]) -> int:
        try:
            return main(argv)
        except SystemExit as stop:
            return int(stop.code or 0)

    return run


@pytest.fixture(scope="module")
def feedback_run(tmp_path_factory) -> Path:
    run = tmp_path_factory.mktemp("hostile") / "feedback"
    train(FeedbackConfig(), seed=0, out_dir=run)
    return run


def one_line(capsys) -> str:
    """The one line a refused command wrote on stderr."""
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    return err


# -- pushes land where the docs say ---------------------------------------------------------


def test_every_multiple_of_the_period_is_one_push_at_its_decision() -> None:
    # Decisions of 0.2 s (4 physics steps of 0.05 s), 30 of them: one push a multiple of 0.2 s.
    assert Disturbances(0.2, 0.1).push_steps(120, 4, 0.05) == list(range(4, 120, 4))
    # Every 0.25 s: the first decision at or after 0.25, 0.5, 0.75, ... (0.4, 0.6, 0.8, 1.0)
    assert Disturbances(0.25, 0.1).push_steps(24, 4, 0.05) == [8, 12, 16, 20]
    # A decision of 0.15 s (3 steps of 0.05 s, not exact in floats) takes 0.15 as its own.
    assert Disturbances(0.15, 0.1).push_steps(12, 3, 0.05) == [3, 6, 9]


@pytest.mark.parametrize("period", [0.03, 1e-300, 0.2 - 1e-6])
def test_a_period_shorter_than_a_decision_is_refused_at_once(period) -> None:
    with pytest.raises(ValueError, match=r"push_every must be at least one decision \(0.2 s\)"):
        Disturbances(period, 0.5).push_steps(10**9, 4, 0.05)


def test_a_period_that_lands_no_push_is_refused() -> None:
    says = "push_every 100 s lands no push within an episode of 10 s"
    with pytest.raises(ValueError, match=says):
        Disturbances(100.0, 0.5).push_steps(200, 1, 0.05)
    with pytest.raises(ValueError, match="lands no push"):  # at the episode's end: none lands
        Disturbances(10.0, 0.5).push_steps(200, 1, 0.05)


@pytest.mark.parametrize(
    ("argv", "says"),
    [
        (["--push-every", "0.03"], "push_every must be at least one decision (0.05 s), got 0.03"),
        (["--push-every", "1e-300"], "push_every must be at least one decision (0.05 s)"),
        (["--push-every", "100", "--seconds", "10"], "lands no push within an episode of 10 s"),
        (["--seconds", "1e-9"], "seconds must be at least one decision of this run (0.05 s)"),
        (["--seconds", "-1"], "config seconds must be in (0, 86400], got -1"),
    ],
)
def test_evaluate_refuses_what_it_cannot_do_before_any_episode(
    feedback_run, argv, says, exits, capsys
) -> None:
    (feedback_run / EVAL_FILE).unlink(missing_ok=True)
    base = ["evaluate", str(feedback_run), "--episodes", "1", "--seconds", "2"]
    pushes = [] if "--push-every" not in argv else ["--push-size", "0.5"]
    assert exits([*base, *pushes, *argv]) == 2
    assert says in one_line(capsys)
    assert not (feedback_run / EVAL_FILE).exists()


def test_a_push_every_decision_pushes_every_decision(feedback_run, exits, capsys) -> None:
    argv = ["evaluate", str(feedback_run), "--episodes", "1", "--seconds", "2"]
    assert exits([*argv, "--push-every", "0.05", "--push-size", "0.5"]) == 0
    assert "of 39 pushes recovered from" in capsys.readouterr().out
    record = json.loads((feedback_run / EVAL_FILE).read_text())
    assert [k for k, *_ in record["pushes"][0]] == list(range(1, 40))  # 40 decisions, not at 0
    assert np.all(np.abs(np.array(record["pushes"][0])[:, 1:]) <= 0.5)
    os.remove(feedback_run / EVAL_FILE)
