"""Compiled Sarsa(lambda) in lockstep (``kernel = "numba"``): K learners on one vector env,
each identical to its single-learner run (records, weights, random state), through
checkpoints and resume, split over processes, and stopped with its seed named on divergence."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("numba", reason="lockstep Sarsa(lambda) is compiled (the fast extra)")

from acrobot_mj.agents.lockstep_lambda import LockstepSarsaLambda
from acrobot_mj.agents.protocol import DivergenceError
from acrobot_mj.agents.registry import make_features
from acrobot_mj.train.checkpoint import load_checkpoint
from acrobot_mj.train.lockstep import train_lockstep
from acrobot_mj.train.presets import PRESETS
from acrobot_mj.train.rundir import CHECKPOINT_FILE
from acrobot_mj.train.seeds import train_seeds
from acrobot_mj.train.trainer import train
from tests.conftest import lockstep_interrupted_and_resumed

RECORD_KEYS = ("episode_lengths", "episode_returns", "episode_successes", "steps",
               "greedy_from_rest")  # fmt: skip
BOOK = PRESETS["book"].replace(kernel="numba")
SEEDS = [0, 3, 7]


def checkpoint_arrays(run_dir):
    return load_checkpoint(run_dir / CHECKPOINT_FILE)[1]


def assert_same_runs(runs, dirs, singles, single_dirs) -> None:
    for run, d, single, sd in zip(runs, dirs, singles, single_dirs, strict=True):
        for key in RECORD_KEYS:
            assert run[key] == single[key], key
        mine, theirs = checkpoint_arrays(d), checkpoint_arrays(sd)
        assert mine.keys() == theirs.keys()
        for name in mine:  # weights and the random stream's state: bit for bit
            np.testing.assert_array_equal(mine[name], theirs[name], err_msg=name)


@pytest.mark.parametrize(
    "config",
    [
        # The book's learner: ties at zero weights (Python finishes those), the goal's terminal
        # update, one-call greedy decisions.
        BOOK.replace(episodes=8),
        # Exploration (every decision drawn in Python), accumulating traces with no cutoff (the
        # trace room grows), truncation at 150 decisions, start noise: the other paths.
        BOOK.replace(
            episodes=5,
            epsilon=0.1,
            traces="accumulating",
            trace_cutoff=0.0,
            max_episode_steps=150,
            start_noise=0.05,
        ),
    ],
)
def test_lockstep_learners_equal_single_learners(config, tmp_path) -> None:
    assert config.lockstep
    runs = train_lockstep(config, SEEDS, tmp_path / "lock")
    singles = [train(config, seed=s, out_dir=tmp_path / f"single{s}") for s in SEEDS]
    dirs = [tmp_path / "lock" / f"seed_{s}" for s in SEEDS]
    assert_same_runs(runs, dirs, singles, [tmp_path / f"single{s}" for s in SEEDS])
    assert all(r["lockstep"] == 3 for r in runs)
    if config.epsilon == 0.0:
        assert sum(sum(r["episode_successes"]) for r in runs) >= 20  # terminal updates ran


def test_the_numpy_reference_agrees_with_the_lockstep_group(tmp_path) -> None:
    # numpy learners are not run in lockstep (one process per seed is faster for them); the
    # group must still equal them, as the compiled single learner does.
    config = BOOK.replace(episodes=4)
    runs = train_lockstep(config, [1, 2], tmp_path / "lock")
    for seed, run in zip([1, 2], runs, strict=True):
        ref = train(config.replace(kernel="numpy"), seed=seed, out_dir=tmp_path / f"np{seed}")
        assert run["episode_lengths"] == ref["episode_lengths"]
        np.testing.assert_array_equal(
            checkpoint_arrays(tmp_path / "lock" / f"seed_{seed}")["w"],
            checkpoint_arrays(tmp_path / f"np{seed}")["w"],
        )
    assert not config.replace(kernel="numpy").lockstep


def test_lockstep_checkpoints_and_resume_exactly(tmp_path, monkeypatch) -> None:
    config, seeds = BOOK.replace(episodes=9, checkpoint_every=2), [0, 5]
    whole, resumed = lockstep_interrupted_and_resumed(config, seeds, tmp_path, monkeypatch, 2500)
    dirs = [tmp_path / "split" / f"seed_{s}" for s in seeds]
    assert_same_runs(resumed, dirs, whole, [tmp_path / "whole" / f"seed_{s}" for s in seeds])


def test_seeds_over_processes_are_lockstep_groups_with_the_same_runs(tmp_path) -> None:
    config = BOOK.replace(episodes=3)
    seeds = [0, 1, 2, 3, 4]
    split = train_seeds(config, seeds, tmp_path / "two", jobs=2, protocol=None)
    together = train_seeds(config, seeds, tmp_path / "one", jobs=1, protocol=None)
    assert split["decisions"] == together["decisions"] and split["seeds"] == seeds
    for s in seeds:
        a, b = (checkpoint_arrays(tmp_path / run / f"seed_{s}") for run in ("two", "one"))
        np.testing.assert_array_equal(a["w"], b["w"])


def test_a_diverging_learner_in_a_group_is_named_and_checkpointed(tmp_path) -> None:
    with pytest.raises(DivergenceError, match=r"diverged in episode 1 of seed 4 .*alpha=1"):
        train_lockstep(BOOK.replace(alpha=1.0, episodes=3), [4], tmp_path)
    assert load_checkpoint(tmp_path / "seed_4" / CHECKPOINT_FILE)[0]["episodes_done"] == 0


def test_memory_per_learner_lets_100_tuned_learners_fit_in_2_gb() -> None:
    # The tuned preset's tile coding (1,260,900 weights): 8 bytes of weight and 4 of trace
    # position per weight, and trace room that grows only with the live traces.
    config = PRESETS["tuned"].replace(kernel="numba")
    group = LockstepSarsaLambda(make_features(config), config, [0, 1])
    arrays = (group.w, group.position, group.pairs, group.values, group.active, group.next)
    per_learner = sum(a.nbytes for a in arrays) / 2
    assert group.w.shape == (2, 1_260_900)
    assert 100 * per_learner < 2e9, per_learner


def test_bad_learn_calls_are_refused() -> None:
    group = LockstepSarsaLambda(make_features(BOOK), BOOK, [0, 1])
    ids = np.array([0, 1])
    with pytest.raises(RuntimeError, match="begin_episodes"):
        group.learn(ids, np.zeros(2), np.zeros((2, 4)), np.zeros(2, bool), np.zeros(2, bool))
    with pytest.raises(ValueError, match="tile codes"):
        LockstepSarsaLambda(make_features(PRESETS["report"]), BOOK, [0])
