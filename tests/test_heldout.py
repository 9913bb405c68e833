"""The evaluation protocol: held-out starts no training sees, eval.json that replays, per-start
minima that are real swing-ups, and selection that cannot depend on the evaluation."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest

from acrobot_mj.cli import main
from acrobot_mj.envs.rollout import SequenceActor, run_episode
from acrobot_mj.physics.dynamics import HANGING
from acrobot_mj.train.evaluate import STORED, compute_minima, stored_minima
from acrobot_mj.train.learners import DEFAULT, HELDOUT_BRANCH, HeldOut, episode_seed, make_env
from acrobot_mj.train.presets import PRESETS
from acrobot_mj.train.seeds import train_seeds
from acrobot_mj.train.trainer import train

BOOK = PRESETS["book"]
#: A tiny book learner: a few episodes, short ones.
TINY = BOOK.replace(episodes=4, max_episode_steps=150)


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    run = tmp_path_factory.mktemp("heldout") / "run"
    train(TINY, seed=0, out_dir=run)
    return run


def test_held_out_starts_are_their_own_stream() -> None:
    starts = DEFAULT.starts(HANGING)
    assert starts.shape == (100, 4)
    np.testing.assert_array_equal(starts, HeldOut().starts(HANGING))  # the same every time
    assert np.all(np.abs(starts - HANGING) <= 0.05) and len(np.unique(starts, axis=0)) == 100
    assert not np.array_equal(starts, HeldOut(seed=1).starts(HANGING))
    # Disjoint by construction: evaluation draws from a spawned branch of the seed tree, which
    # training never creates; a training episode seeded with the protocol's seed value (0), or
    # any other, starts elsewhere.
    branch = np.random.default_rng(np.random.SeedSequence(0, spawn_key=(HELDOUT_BRANCH,)))
    np.testing.assert_array_equal(starts, HANGING + branch.uniform(-0.05, 0.05, (100, 4)))
    env = make_env(BOOK)
    trained_from = np.array(
        [
            env.reset(seed=episode_seed(seed, k), options={"start_noise": 0.05})[0]
            for seed in range(5)
            for k in range(50)
        ]
    )
    gaps = np.abs(trained_from[:, None, :] - starts[None, :, :]).max(axis=2)
    assert gaps.min() > 1e-6  # no held-out start is a training start


def test_protocol_refuses_bad_settings() -> None:
    with pytest.raises(ValueError, match=r"start_noise must be in \[0, 1\], got 2"):
        HeldOut(start_noise=2.0)
    with pytest.raises(ValueError, match="episodes must be >= 1"):
        HeldOut(episodes=0)
    with pytest.raises(TypeError, match="seed must be an integer"):
        HeldOut(seed=1.5)


def test_evaluate_twice_gives_the_same_record_and_its_actions_replay(trained, capsys) -> None:
    args = ["evaluate", str(trained), "--episodes", "6", "--start-noise", "0.1", "--seed", "7"]
    assert main(args) == 0
    first = (trained / "eval.json").read_text()
    assert "6 held-out starts" in capsys.readouterr().out
    assert main(args) == 0
    record = json.loads(first)
    assert json.loads((trained / "eval.json").read_text()) | {"versions": None} == record | {
        "versions": None
    }
    assert record["protocol"] == {"episodes": 6, "start_noise": 0.1, "seed": 7}
    assert "minima" not in record  # none stored for this protocol
    # Replayed open loop from the recorded start states in a fresh env: the same lengths.
    env = gym.make(BOOK.env_id, max_episode_steps=TINY.max_episode_steps)
    for state, actions, length, success in zip(
        record["start_states"],
        record["actions"],
        record["episode_lengths"],
        record["episode_successes"],
        strict=True,
    ):
        episode = run_episode(env, SequenceActor(actions), options={"state": state})
        assert (episode.length, episode.success) == (length, success)
    summary = record["summary"]["length"]
    assert summary["median"] == np.median(record["episode_lengths"])


def test_evaluate_refuses_bad_protocol_settings_in_one_line(trained, capsys) -> None:
    with pytest.raises(SystemExit) as stop:
        main(["evaluate", str(trained), "--start-noise", "2"])
    assert stop.value.code == 2
    assert "start_noise must be in [0, 1], got 2" in capsys.readouterr().err


def test_stored_minima_are_swing_ups_in_the_env() -> None:
    stored = json.loads(STORED.read_text())
    env = make_env(BOOK)
    assert stored_minima(env, DEFAULT) == [s["decisions"] for s in stored["starts"]]
    assert stored_minima(env, HeldOut(seed=1)) is None  # another protocol: none apply
    assert stored_minima(make_env(BOOK.replace(frame_skip=2)), DEFAULT) is None
    np.testing.assert_array_equal(
        np.array([s["state"] for s in stored["starts"]]), DEFAULT.starts(HANGING)
    )
    # Each stored sequence, played in the MuJoCo env from its start, reaches the goal on exactly
    # its last decision (so each minimum is a real swing-up, an upper bound on the true one).
    for entry in stored["starts"][::10]:
        episode = run_episode(
            env, SequenceActor(entry["actions"]), options={"state": entry["state"]}
        )
        assert episode.success and episode.length == entry["decisions"] == len(entry["actions"])


@pytest.mark.slow
def test_stored_minima_are_the_search_result() -> None:
    # Recomputed from two of the stored starts (about 4 s each): the same decisions and actions.
    stored = json.loads(STORED.read_text())["starts"]
    picked = [stored[0], stored[57]]
    found = compute_minima(make_env(BOOK), np.array([s["state"] for s in picked]), 1000)
    assert found == [{"decisions": s["decisions"], "actions": s["actions"]} for s in picked]


def test_the_held_out_starts_cannot_change_which_learner_a_population_keeps(tmp_path) -> None:
    config = TINY.replace(population=3, episodes=3, start_noise=0.1)
    a = train_seeds(config, [0, 1], tmp_path / "a", protocol=HeldOut(episodes=3, seed=1))
    b = train_seeds(config, [0, 1], tmp_path / "b", protocol=HeldOut(episodes=4, seed=2))
    for seed in (0, 1):
        runs = [
            json.loads((d / f"seed_{seed}" / "run.json").read_text())
            for d in (tmp_path / "a", tmp_path / "b")
        ]
        assert runs[0]["population"] == runs[1]["population"]
        assert runs[0]["episode_lengths"] == runs[1]["episode_lengths"]
    assert a["held_out"]["protocol"] != b["held_out"]["protocol"]


def test_seed_summaries_count_distinct_greedy_behaviours(tmp_path) -> None:
    # The book learner's only randomness is its tie-breaks: seeds collapse onto few behaviours.
    summary = train_seeds(
        TINY.replace(episodes=2), [0, 1, 2, 3], tmp_path, protocol=HeldOut(episodes=3)
    )
    evaluations = [json.loads((tmp_path / f"seed_{s}" / "eval.json").read_text()) for s in range(4)]
    held = summary["held_out"]
    assert held["distinct_outcomes"]["from_rest"] == len(
        {tuple(e["rest"]["actions"]) for e in evaluations}
    )
    assert held["distinct_outcomes"]["held_out"] == len(
        {json.dumps(e["actions"]) for e in evaluations}
    )
    assert held["median_length"]["max"] == max(
        e["summary"]["length"]["median"] for e in evaluations
    )
    assert summary["decisions"]["min"] == min(
        json.loads((tmp_path / f"seed_{s}" / "run.json").read_text())["steps"] for s in range(4)
    )
