"""The Stable-Baselines3 examples (examples/) import and run at a tiny budget; skipped where
stable_baselines3 is not installed (the package does not depend on it: the `examples` extra)."""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("stable_baselines3", reason="the examples need stable-baselines3 (extra)")

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def load(name: str):
    sys.path.insert(0, str(EXAMPLES))
    try:
        spec = importlib.util.spec_from_file_location(name, EXAMPLES / f"{name}.py")
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
    finally:
        sys.path.remove(str(EXAMPLES))
    return module


@pytest.mark.slow
@pytest.mark.parametrize("name", ["ppo_acrobot", "dqn_acrobot", "sac_acrobot"])
def test_an_example_trains_and_writes_a_replayable_record(name, tmp_path, capsys) -> None:
    record = load(name).main(
        ["--steps", "500", "--seed", "0", "--episodes", "2", "--out", str(tmp_path)]
    )
    line = capsys.readouterr().out.strip().splitlines()[-1]
    assert "held-out median" in line and "successes" in line
    stored = json.loads((tmp_path / "eval.json").read_text())
    assert stored["episode_lengths"] == record["episode_lengths"]
    assert len(stored["start_states"]) == len(stored["actions"]) == 2
    assert [len(a) for a in stored["actions"]] == stored["episode_lengths"]
    assert stored["summary"]["episodes"] == 2 and stored["steps_asked"] == 500
    assert stored["training_decisions"] >= 500


def test_the_helper_replays_a_record_exactly() -> None:
    helper = load("heldout_sb3")
    from acrobot_mj.train.learners import HeldOut

    def act(obs):  # a fixed law: pump against the shoulder's velocity
        return 0 if obs[4] > 0 else 2

    record = helper.evaluate_heldout(act, protocol=HeldOut(episodes=3))
    assert (
        record["start_states"] == HeldOut(episodes=3).starts(record["rest"]["start_state"]).tolist()
    )
    env = helper.make_env(start_noise=0.0)
    for start, actions, length in zip(
        record["start_states"], record["actions"], record["episode_lengths"], strict=True
    ):
        env.reset(options={"state": start})
        for action in actions:
            *_, terminated, truncated, _ = env.step(action)
        assert len(actions) == length and (terminated or truncated)


def test_the_package_does_not_import_the_examples() -> None:
    package = EXAMPLES.parent / "acrobot_mj"
    for path in package.rglob("*.py"):
        assert "heldout_sb3" not in path.read_text() and "examples." not in path.read_text()


@pytest.mark.slow
def test_the_balance_example_trains_and_writes_a_replayable_record(tmp_path, capsys) -> None:
    module = load("sac_balance")
    record = module.main(
        ["--steps", "300", "--seed", "0", "--episodes", "2", "--out", str(tmp_path)]
    )
    assert "held-out starts" in capsys.readouterr().out.strip().splitlines()[-1]
    stored = json.loads((tmp_path / "eval.json").read_text())
    assert stored["protocol"]["start_noise"] == 0.01 and stored["summary"]["episodes"] == 2
    env = module.make_env(0.0)
    for start, actions, total in zip(
        stored["start_states"], stored["actions"], stored["episode_returns"], strict=True
    ):
        env.reset(options={"state": np.array(start)})
        replayed = sum(env.step(np.array([a], dtype=np.float32))[1] for a in actions)
        assert replayed == pytest.approx(total, abs=1e-9)  # the same sum, maybe in another order
    assert record["episode_returns"] == stored["episode_returns"]


#: The zoo's scripts other than train take no --gym-packages: this imports the package first.
ZOO = (
    "import acrobot_mj, runpy; runpy.run_module('rl_zoo3.{}', run_name='__main__', alter_sys=True)"
)


@pytest.mark.slow
def test_the_rl_zoo_trains_with_the_shipped_hyperparameters_and_records_a_video(tmp_path):
    pytest.importorskip("rl_zoo3", reason="the RL Baselines3 Zoo (examples extra)")
    import subprocess

    conf = Path(__file__).resolve().parents[1] / "acrobot_mj" / "zoo" / "ppo.yml"
    env = ["--algo", "ppo", "--env", "acrobot_mj/AcrobotRL-v0"]
    train = [
        sys.executable,
        "-m",
        "rl_zoo3.train",
        *env,
        "--gym-packages",
        "acrobot_mj",
        "-conf",
        str(conf),
        "-n",
        "4096",
        "--seed",
        "0",
        "-f",
        "logs",
        "--eval-freq",
        "-1",
    ]
    done = subprocess.run(train, cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "Using 'default' hyperparameters" not in done.stdout  # the shipped ones
    assert "('n_envs', 16)" in done.stdout and "('gae_lambda', 0.94)" in done.stdout
    video = [sys.executable, "-c", ZOO.format("record_video"), *env, "-f", "logs", "-n", "20"]
    done = subprocess.run(video, cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    assert len(list((tmp_path / "logs").rglob("*.mp4"))) == 1
    enjoy = [
        sys.executable,
        "-c",
        ZOO.format("enjoy"),
        *env,
        "-f",
        "logs",
        "-n",
        "50",
        "--no-render",
        "--deterministic",
    ]
    done = subprocess.run(enjoy, cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]


@pytest.mark.slow
def test_an_sb3_policy_is_scored_end_to_end(tmp_path, capsys) -> None:
    """A SAC policy trained on the continuous RL id with ``model="ai_olympics"`` (a tiny budget)
    is scored by ``acrobot-mj olympics policy.zip``: the record names it and holds a whole
    performance episode (10 s of 0.002 s steps)."""
    record = load("sb3_olympics").main(
        ["--steps", "150", "--out", str(tmp_path), "--scores", "performance"]
    )
    assert record["model"] == {"name": "ai_olympics", "entry": str(tmp_path / "policy.zip")}
    assert record["performance"]["episode"]["steps"] == 5000
    assert "trained in" in capsys.readouterr().out


def test_a_policy_of_another_acrobot_is_refused(tmp_path, capsys) -> None:
    from stable_baselines3 import SAC

    from acrobot_mj.cli import main

    with gym.make("acrobot_mj/AcrobotBalanceRLContinuous-v0") as env:  # the report's acrobot
        SAC("MlpPolicy", env, seed=0).save(tmp_path / "report.zip")
    argv = ["olympics", str(tmp_path / "report.zip"), "--out", str(tmp_path / "o")]
    with pytest.raises(SystemExit):
        main([*argv, "--env", "acrobot_mj/AcrobotBalanceRLContinuous-v0"])
    err = capsys.readouterr().err.strip()
    assert "is another acrobot than the one scored" in err and "\n" not in err
