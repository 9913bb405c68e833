"""Population runs: several learners share the budget, the best by its own training episodes
is kept, and the run directory works like any other (evaluate, resume, load_agent)."""

import json

import numpy as np
import pytest

from acrobot_mj.train.checkpoint import CheckpointError
from acrobot_mj.train.config import TrainConfig
from acrobot_mj.train.evaluate import evaluate
from acrobot_mj.train.heldout import Protocol
from acrobot_mj.train.learner import train_agent
from acrobot_mj.train.population import learner_seed
from acrobot_mj.train.presets import PRESETS
from acrobot_mj.train.rundir import load_agent
from acrobot_mj.train.stats import recent_median
from acrobot_mj.train.trainer import train

# Three learners of four episodes of at most 400 decisions: with seed 2 their scores differ
# (about 377, 389 and 327) and the last one is kept, so picking the first would fail.
CONFIG = PRESETS["book"].replace(episodes=4, population=3, max_episode_steps=400)


def test_learners_are_ranked_by_the_median_of_their_last_20_episodes():
    lengths = [1000] * 5 + list(range(20))  # the last 20: 0 .. 19, median 9.5
    assert recent_median(lengths) == 9.5
    assert recent_median([7, 9]) == 8.0


def test_learner_seeds_differ_and_are_fixed():
    seeds = [learner_seed(5, k) for k in range(4)]
    assert len(set(seeds)) == 4
    assert seeds == [learner_seed(5, k) for k in range(4)]
    assert learner_seed(6, 0) not in seeds


def test_population_run_keeps_the_best_learner(tmp_path):
    record = train(CONFIG, seed=2, out_dir=tmp_path)
    pop = record["population"]
    assert pop["learners"] == 3 and len(pop["seeds"]) == 3
    # The top-level lists are every learner's episodes in order.
    assert len(record["episode_lengths"]) == record["episodes_done"] == 12
    subs = [json.loads((tmp_path / f"learner_{k}" / "run.json").read_text()) for k in range(3)]
    assert record["episode_lengths"] == [n for s in subs for n in s["episode_lengths"]]
    assert record["steps"] == sum(s["steps"] for s in subs)
    scores = [recent_median(s["episode_lengths"]) for s in subs]
    assert pop["scores"] == scores
    assert len(set(scores)) == 3
    assert pop["kept"] == int(np.argmin(scores)) != 0
    # The top-level checkpoint is the kept learner's agent (trained again here, alone); the
    # learners' own checkpoints are gone.
    _, kept = train_agent(CONFIG.replace(population=1), learner_seed(2, pop["kept"]), None)
    config, seed, agent = load_agent(tmp_path)
    assert config == CONFIG and seed == 2
    np.testing.assert_array_equal(agent.w, kept.w)
    assert not list(tmp_path.glob("learner_*/checkpoint.npz"))
    # One figure for the run; the learners' own (drawn on demand by acrobot-mj curves) would
    # cost about half a tuned learner's training each.
    assert (tmp_path / "learning_curve.png").is_file()
    assert not list(tmp_path.glob("learner_*/learning_curve.png"))
    # evaluate's rest episode is the record's greedy run from rest.
    ev = evaluate(tmp_path, Protocol(episodes=1))
    assert ev["rest"]["length"] == record["greedy_from_rest"]["length"]


def test_population_runs_are_deterministic_and_resume_to_the_same_record(tmp_path):
    first = train(CONFIG, seed=4, out_dir=tmp_path / "a")
    second = train(CONFIG, seed=4)
    resumed = train(CONFIG, seed=4, out_dir=tmp_path / "a", resume=True)  # finished: trains again
    # Another checkpoint interval changes nothing learned: a finished run resumes with it too.
    other_interval = CONFIG.replace(checkpoint_every=7)
    again = train(other_interval, seed=4, out_dir=tmp_path / "a", resume=True)
    assert again["episode_lengths"] == first["episode_lengths"]
    # Interrupted after learner 0 and half of learner 1 (their checkpoints are still there).
    part = tmp_path / "b"
    single = CONFIG.replace(population=1)
    train(single, seed=learner_seed(4, 0), out_dir=part / "learner_0")
    train(single.replace(episodes=2), seed=learner_seed(4, 1), out_dir=part / "learner_1")
    continued = train(CONFIG, seed=4, out_dir=part, resume=True)
    for other in (second, resumed, continued):
        for key in ("episode_lengths", "episode_returns", "greedy_from_rest", "population"):
            assert other[key] == first[key], key


def test_population_refuses_bad_sizes_and_lockstep():
    with pytest.raises(ValueError, match="population"):
        TrainConfig(population=0)
    assert not TrainConfig(population=2).lockstep


def test_resume_refuses_another_runs_directory(tmp_path):
    train(CONFIG, seed=4, out_dir=tmp_path / "pop")
    with pytest.raises(CheckpointError, match=r"different config \(\['alpha'\]\)"):
        train(CONFIG.replace(alpha=0.5), seed=4, out_dir=tmp_path / "pop", resume=True)
    with pytest.raises(CheckpointError, match="seed 4, not 7"):
        train(CONFIG, seed=7, out_dir=tmp_path / "pop", resume=True)
    # A one-learner run is not resumed as a population, nor the other way round.
    single = CONFIG.replace(population=1)
    train(single, seed=4, out_dir=tmp_path / "one")
    with pytest.raises(CheckpointError, match="population"):
        train(CONFIG, seed=4, out_dir=tmp_path / "one", resume=True)
    with pytest.raises(CheckpointError, match="population"):
        train(single, seed=4, out_dir=tmp_path / "pop", resume=True)
    with pytest.raises(ValueError, match="run directory"):
        train(CONFIG, seed=4, resume=True)


def test_fresh_runs_refuse_a_partial_population_and_force_clears_it(tmp_path):
    out = tmp_path / "run"
    train(CONFIG.replace(population=1), seed=learner_seed(4, 0), out_dir=out / "learner_0")
    with pytest.raises(FileExistsError, match="learner_0"):
        train(CONFIG, seed=4, out_dir=out)
    (out / "learner_5").mkdir()  # left over from a bigger population
    train(CONFIG, seed=4, out_dir=out, overwrite=True)
    assert sorted(p.name for p in out.glob("learner_*")) == [f"learner_{k}" for k in range(3)]


def test_interrupt_names_the_learner_and_resume_finishes_the_same(tmp_path):
    calls = []

    def stop(episode, history):
        calls.append(episode)
        if len(calls) == 6:  # learner 1, its second episode
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt, match="learner 1 of 3"):
        train(CONFIG, seed=4, out_dir=tmp_path, on_episode=stop)
    resumed = train(CONFIG, seed=4, out_dir=tmp_path, resume=True)
    whole = train(CONFIG, seed=4)
    for key in ("episode_lengths", "greedy_from_rest", "population"):
        assert resumed[key] == whole[key], key
