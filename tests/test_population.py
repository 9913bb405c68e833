"""Population runs: several learners share the budget, one after another (never in lockstep),
the best by its own training episodes is kept, and the run directory works like any other
(evaluate, resume, load_learner)."""

import json

import numpy as np
import pytest

from acrobot_mj.cli import main
from acrobot_mj.envs.vector import AcrobotVectorEnv
from acrobot_mj.train.checkpoint import CheckpointError, load_checkpoint
from acrobot_mj.train.config import TrainConfig
from acrobot_mj.train.episode_log import read_rows
from acrobot_mj.train.evaluate import evaluate
from acrobot_mj.train.learners import HeldOut, learner_seed, train_one
from acrobot_mj.train.lockstep import can_lockstep
from acrobot_mj.train.presets import PRESETS
from acrobot_mj.train.records import recent_median
from acrobot_mj.train.run import Run, RunOptions
from acrobot_mj.train.trainer import load_learner, train

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
    _, kept = train_one(CONFIG.replace(population=1), learner_seed(2, pop["kept"]), Run())
    learner = load_learner(tmp_path)
    assert learner.config == CONFIG and learner.seed == 2
    np.testing.assert_array_equal(learner.agent.w, kept.w)
    assert not list(tmp_path.glob("learner_*/checkpoint.npz"))
    # One figure for the run; the learners' own (drawn on demand by acrobot-mj curves) would
    # cost about half a tuned learner's training each.
    assert (tmp_path / "learning_curve.png").is_file()
    assert not list(tmp_path.glob("learner_*/learning_curve.png"))
    # evaluate's rest episode is the record's greedy run from rest.
    ev = evaluate(tmp_path, HeldOut(episodes=1))
    assert ev["rest"]["length"] == record["greedy_from_rest"]["length"]


def test_population_runs_are_deterministic_and_resume_to_the_same_record(tmp_path):
    first = train(CONFIG, seed=4, out_dir=tmp_path / "a")
    second = train(CONFIG, seed=4)
    resumed = train(
        CONFIG, seed=4, out_dir=tmp_path / "a", options=RunOptions(resume=True)
    )  # finished: trains again
    # Another checkpoint interval changes nothing learned: a finished run resumes with it too.
    other_interval = CONFIG.replace(checkpoint_every=7)
    again = train(other_interval, seed=4, out_dir=tmp_path / "a", options=RunOptions(resume=True))
    assert again["episode_lengths"] == first["episode_lengths"]
    # Interrupted after learner 0 and half of learner 1 (their checkpoints are still there).
    part = tmp_path / "b"
    single = CONFIG.replace(population=1)
    train(single, seed=learner_seed(4, 0), out_dir=part / "learner_0")
    train(single.replace(episodes=2), seed=learner_seed(4, 1), out_dir=part / "learner_1")
    continued = train(CONFIG, seed=4, out_dir=part, options=RunOptions(resume=True))
    for other in (second, resumed, continued):
        for key in ("episode_lengths", "episode_returns", "greedy_from_rest", "population"):
            assert other[key] == first[key], key


def test_population_refuses_bad_sizes_and_lockstep():
    with pytest.raises(ValueError, match="population"):
        TrainConfig(population=0)
    assert not can_lockstep(TrainConfig(population=2))


def test_resume_refuses_another_runs_directory(tmp_path):
    train(CONFIG, seed=4, out_dir=tmp_path / "pop")
    with pytest.raises(CheckpointError, match=r"different config \(\['alpha'\]\)"):
        train(
            CONFIG.replace(alpha=0.5),
            seed=4,
            out_dir=tmp_path / "pop",
            options=RunOptions(resume=True),
        )
    with pytest.raises(CheckpointError, match="seed 4, not 7"):
        train(CONFIG, seed=7, out_dir=tmp_path / "pop", options=RunOptions(resume=True))
    # A one-learner run is not resumed as a population, nor the other way round.
    single = CONFIG.replace(population=1)
    train(single, seed=4, out_dir=tmp_path / "one")
    with pytest.raises(CheckpointError, match="population"):
        train(CONFIG, seed=4, out_dir=tmp_path / "one", options=RunOptions(resume=True))
    with pytest.raises(CheckpointError, match="population"):
        train(single, seed=4, out_dir=tmp_path / "pop", options=RunOptions(resume=True))
    with pytest.raises(ValueError, match="run directory"):
        train(CONFIG, seed=4, options=RunOptions(resume=True))


def test_fresh_runs_refuse_a_partial_population_and_force_clears_it(tmp_path):
    out = tmp_path / "run"
    train(CONFIG.replace(population=1), seed=learner_seed(4, 0), out_dir=out / "learner_0")
    with pytest.raises(FileExistsError, match="learner_0"):
        train(CONFIG, seed=4, out_dir=out)
    (out / "learner_5").mkdir()  # left over from a bigger population
    train(CONFIG, seed=4, out_dir=out, options=RunOptions(overwrite=True))
    assert sorted(p.name for p in out.glob("learner_*")) == [f"learner_{k}" for k in range(3)]


def test_interrupt_names_the_learner_and_resume_finishes_the_same(tmp_path):
    calls = []

    def stop(episode, history):
        calls.append(episode)
        if len(calls) == 6:  # learner 1, its second episode
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt, match="learner 1 of 3"):
        train(CONFIG, seed=4, out_dir=tmp_path, options=RunOptions(on_episode=stop))
    resumed = train(CONFIG, seed=4, out_dir=tmp_path, options=RunOptions(resume=True))
    whole = train(CONFIG, seed=4)
    for key in ("episode_lengths", "greedy_from_rest", "population"):
        assert resumed[key] == whole[key], key


# Tabular SARSA. Four learners of eight episodes of at most 400 decisions of 0.2 s; with seed 3
# only learner 2 reaches the goal (its score 372.5, the others 400), so a choice is made. Every
# decision draws from the learner's own stream (epsilon's test).
TABULAR = PRESETS["report"].replace(episodes=8, population=4, max_episode_steps=400, frame_skip=4)
KEYS = (
    "episode_lengths",
    "episode_returns",
    "episode_successes",
    "greedy_from_rest",
    "population",
    "steps",
    "decisions_total",
)


def log_rows(run):
    rows = read_rows(run / "episodes.jsonl", 10**6)
    return [
        {k: row[k] for k in ("episode", "length", "return", "success", "learner")} for row in rows
    ]


def same_run(a, b, ra, rb) -> None:
    """Two population runs are the same: records, the kept agent, the run's log."""
    for key in KEYS:
        assert ra[key] == rb[key], key
    ca, cb = load_checkpoint(a / "checkpoint.npz"), load_checkpoint(b / "checkpoint.npz")
    assert ca[0]["episodes_done"] == cb[0]["episodes_done"]
    assert ca[1].keys() == cb[1].keys()
    assert all(np.array_equal(ca[1][k], cb[1][k]) for k in ca[1])
    assert log_rows(a) == log_rows(b)


def test_populations_go_one_by_one(monkeypatch) -> None:
    # Measured: ten report learners one by one in about half the time of a lockstep group of
    # ten, so a population's learners never share a vector env (lockstep populations were
    # removed).
    built = []
    original = AcrobotVectorEnv.__init__

    def counting(self, *args, **kwargs):
        built.append(kwargs.get("num_envs"))
        original(self, *args, **kwargs)

    monkeypatch.setattr(AcrobotVectorEnv, "__init__", counting)
    record = train(TABULAR, 3)
    assert built == []
    assert len(set(record["population"]["scores"])) > 1  # a real choice was made


def test_a_population_stopped_between_learners_resumes_to_the_same_run(tmp_path) -> None:
    # Learner 0 done and learner 1 half way (their checkpoints there, 2 and 3 none): the
    # learners go on one by one, to the same run (records, kept learner, the run's log).
    whole = train(TABULAR, 4, tmp_path / "whole")
    part = tmp_path / "part"
    single = TABULAR.replace(population=1)
    train(single, learner_seed(4, 0), part / "learner_0")
    train(single.replace(episodes=4), learner_seed(4, 1), part / "learner_1")
    resumed = train(TABULAR, 4, part, options=RunOptions(resume=True))
    same_run(tmp_path / "whole", part, whole, resumed)


def test_a_lockstep_population_is_refused_with_the_reason(tmp_path, capsys) -> None:
    # Lockstep populations were removed (slower than one learner after another): --lockstep
    # without --seeds, with or without a population, is refused in one line that says why.
    for extra in ([], ["--population", "2"]):
        args = ["train", "--preset", "report", "--lockstep", *extra]
        with pytest.raises(SystemExit) as stop:
            main([*args, "--out", str(tmp_path / "r")])
        assert stop.value.code == 2
        err = capsys.readouterr().err
        assert "needs --seeds" in err and "one by one" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "r").exists()
