"""A new task and a new agent each need only their own file and one registration call
(``tests/plugins/``): with nothing else changed, the env, the vector env, training, population
selection, summaries, checkpoints, evaluation and videos all work with them."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from acrobot_mj.agents import Agent
from acrobot_mj.envs.spaces import observation_space
from acrobot_mj.report.video import RenderSettings
from acrobot_mj.train.config import TrainConfig
from acrobot_mj.train.evaluate import evaluate, render_run
from acrobot_mj.train.learners import HeldOut
from acrobot_mj.train.presets import PRESETS
from acrobot_mj.train.run import RunOptions
from acrobot_mj.train.seeds import train_seeds
from acrobot_mj.train.trainer import train
from tests.plugins import q_learning  # noqa: F401  registers the algorithm q_learning
from tests.plugins.tip_height import TipHeight

#: A few short episodes of the report's learner on the new task.
ON_TIP_HEIGHT = PRESETS["report"].replace(
    task="tip_height", frame_skip=4, max_episode_steps=40, episodes=6
)


def test_the_new_task_is_a_registered_env_with_its_own_rules() -> None:
    env = gym.make(TipHeight.env_id)
    assert env.spec.max_episode_steps == 200
    check_env(env.unwrapped, skip_render_check=True)
    _, info = env.reset(seed=0)
    assert info == {"tip_height": -2.0, "is_success": False}
    steps, truncated = 0, False
    while not truncated:
        _, reward, terminated, truncated, info = env.step(2)
        steps += 1
        assert reward == info["tip_height"] and not terminated
    assert steps == 200  # no termination: only the TimeLimit ends it
    with pytest.raises(TypeError, match=r"unknown arguments \['goal_reward'\].*tip_height"):
        gym.make(TipHeight.env_id, goal_reward=5.0)  # a height-goal option, not this task's


def test_the_vector_env_runs_the_new_task_as_the_single_env_does() -> None:
    n = 3
    vec = gym.make_vec(TipHeight.env_id, num_envs=n, max_episode_steps=30)
    singles = [gym.make(TipHeight.env_id, max_episode_steps=30) for _ in range(n)]
    obs, _ = vec.reset(seed=5)
    single_obs = [env.reset(seed=5 + k)[0] for k, env in enumerate(singles)]
    rng, pending = np.random.default_rng(1), [False] * n
    for _ in range(70):  # two truncations and their autoresets each
        actions = rng.integers(0, 3, n)
        obs, reward, terminated, truncated, info = vec.step(actions)
        for k, env in enumerate(singles):
            if pending[k]:
                single_obs[k], _ = env.reset()
                expected, pending[k] = (0.0, False, False), False
            else:
                single_obs[k], r, te, tr, _ = env.step(int(actions[k]))
                expected, pending[k] = (r, te, tr), te or tr
            np.testing.assert_array_equal(obs[k], single_obs[k])
            # The reward is the tip height: np.sin in the vector env, math.sin in the single
            # one, which may differ in the last bit (heights are O(1) m).
            assert reward[k] == pytest.approx(expected[0], abs=1e-15)
            assert (terminated[k], truncated[k]) == expected[1:]
    assert set(info) == {"tip_height", "_tip_height", "is_success", "_is_success"}


def test_config_options_follow_the_task() -> None:
    # The height goal's reward fields do not apply to the new task.
    assert ON_TIP_HEIGHT.step_reward is None and ON_TIP_HEIGHT.goal_reward is None
    assert "goal_reward" not in ON_TIP_HEIGHT.env_kwargs()
    with pytest.raises(ValueError, match="goal_reward has no effect with task='tip_height'"):
        ON_TIP_HEIGHT.replace(goal_reward=-1.0)
    with pytest.raises(ValueError, match="config task must be one of"):
        TrainConfig(task="balance_on_one_hand")


def test_training_selection_and_summaries_ask_the_new_task(tmp_path) -> None:
    # Higher returns are better for this task: the population keeps the highest score.
    record = train(ON_TIP_HEIGHT.replace(population=3), seed=0, out_dir=tmp_path / "pop")
    pop = record["population"]
    assert pop["kept"] == int(np.argmax(pop["scores"])) and len(set(pop["scores"])) > 1
    assert pop["rule"] == "highest median of the last 20 training episodes"
    summary = train_seeds(
        ON_TIP_HEIGHT, [0, 1], tmp_path / "seeds", options=RunOptions(lockstep=True)
    )
    assert {"last20_median_return", "greedy_from_rest_return"} <= set(summary)
    runs = [json.loads((tmp_path / "seeds" / r / "run.json").read_text()) for r in summary["runs"]]
    assert [r["lockstep"] for r in runs] == [2, 2]  # lockstep SARSA on the new task's vector env
    assert summary["greedy_from_rest_return"]["max"] == max(
        r["greedy_from_rest"]["return"] for r in runs
    )
    settings = RenderSettings(width=64, height=64, max_steps=5)
    video = render_run(tmp_path / "pop", tmp_path / "pop.mp4", settings)
    assert video["frames"] == 6


def test_built_in_and_new_agents_follow_the_agent_protocol() -> None:
    for name in ("sarsa", "sarsa_lambda", "q_learning"):
        config = PRESETS["report"].replace(algorithm=name)
        assert isinstance(config.make_agent(0, observation_space()), Agent), name


def test_the_new_agent_trains_checkpoints_resumes_and_evaluates(tmp_path) -> None:
    config = PRESETS["report"].replace(
        algorithm="q_learning", epsilon=0.1, frame_skip=4, max_episode_steps=60, episodes=6
    )
    whole = train(config, seed=3, out_dir=tmp_path / "whole")
    train(config.replace(episodes=3), seed=3, out_dir=tmp_path / "half")
    resumed = train(config, seed=3, out_dir=tmp_path / "half", options=RunOptions(resume=True))
    for key in ("episode_lengths", "episode_returns", "greedy_from_rest"):
        assert resumed[key] == whole[key], key
    assert (
        evaluate(tmp_path / "whole", HeldOut(episodes=2))["rest"]["length"]
        == (whole["greedy_from_rest"]["length"])
    )
    # Its hyperparameters are the ones its spec declares: lam does not apply to it.
    with pytest.raises(ValueError, match="lam has no effect with algorithm='q_learning'"):
        config.replace(lam=0.9)
    with pytest.raises(ValueError, match=r"needs features in \['grid'\]"):
        config.replace(features="tiles")
