"""A run's experience budget: ``max_decisions`` caps the learning decisions exactly (split
between a population's learners), resumes exactly, and the records count every decision."""

from __future__ import annotations

import json

import pytest

from acrobot_mj.train.config import TrainConfig
from acrobot_mj.train.lockstep import can_lockstep
from acrobot_mj.train.presets import PRESETS
from acrobot_mj.train.run import RunOptions
from acrobot_mj.train.sweep import complete
from acrobot_mj.train.trainer import train

#: Episodes enough that the cap, not the episodes, ends the run.
CAPPED = PRESETS["book"].replace(episodes=1000, max_decisions=3000, max_episode_steps=400)


def test_the_cap_is_met_exactly_and_the_last_episode_is_cut() -> None:
    record = train(CAPPED, seed=0)
    assert record["steps"] == sum(record["episode_lengths"]) == 3000
    assert record["episodes_done"] < 1000 and CAPPED.finished(record)
    uncapped = train(CAPPED.replace(max_decisions=0, episodes=record["episodes_done"]), seed=0)
    # The same episodes until the cut: the cap changes nothing before it.
    assert uncapped["episode_lengths"][:-1] == record["episode_lengths"][:-1]
    assert record["episode_lengths"][-1] < uncapped["episode_lengths"][-1]
    # The record counts the greedy run from rest on top of the learning decisions.
    assert record["decisions_total"] == 3000 + record["greedy_from_rest"]["length"]


def test_a_population_splits_the_cap_and_its_learners_make_no_greedy_runs(tmp_path) -> None:
    config = CAPPED.replace(population=3, max_decisions=4000)
    record = train(config, seed=1, out_dir=tmp_path)
    learners = [json.loads((tmp_path / f"learner_{k}" / "run.json").read_text()) for k in range(3)]
    assert [r["steps"] for r in learners] == [1333] * 3  # 4000 // 3 each
    assert all("greedy_from_rest" not in r and r["decisions_total"] == 1333 for r in learners)
    assert record["steps"] == 3999 and config.finished(record)
    assert record["decisions_total"] == 3999 + record["greedy_from_rest"]["length"]


def test_a_capped_run_resumes_to_the_same_record(tmp_path) -> None:
    whole = train(CAPPED, seed=2)
    stop_after = 5

    def interrupt(episode, history):
        if episode + 1 == stop_after:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        train(
            CAPPED.replace(checkpoint_every=1),
            seed=2,
            out_dir=tmp_path,
            options=RunOptions(on_episode=interrupt),
        )
    resumed = train(
        CAPPED.replace(checkpoint_every=1),
        seed=2,
        out_dir=tmp_path,
        options=RunOptions(resume=True),
    )
    for key in ("episode_lengths", "episode_returns", "steps", "greedy_from_rest"):
        assert resumed[key] == whole[key], key
    assert complete(resumed, CAPPED.replace(checkpoint_every=1))


def test_bad_caps_are_refused_and_capped_runs_do_not_run_in_lockstep() -> None:
    with pytest.raises(ValueError, match=r"max_decisions must be 0 \(no cap\) or >= population"):
        PRESETS["book"].replace(max_decisions=-1)
    with pytest.raises(ValueError, match=r">= population \(10\)"):
        PRESETS["book"].replace(population=10, max_decisions=5)
    assert can_lockstep(TrainConfig()) and not can_lockstep(TrainConfig(max_decisions=100))
