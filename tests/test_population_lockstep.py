"""Populations in lockstep: a run's learners trained together on one vector env give the run
they give one after another (records, kept learner, checkpoint, log), stop and resume exactly,
and a lockstep that cannot be is refused with the reason."""

import json

import numpy as np
import pytest

from acrobot_mj.cli import main
from acrobot_mj.envs.vector import AcrobotVectorEnv
from acrobot_mj.train.checkpoint import load_checkpoint
from acrobot_mj.train.episode_log import read_rows
from acrobot_mj.train.population import learner_seed
from acrobot_mj.train.presets import PRESETS
from acrobot_mj.train.trainer import train

# Tabular SARSA. Four learners of eight episodes of at most 400 decisions
# of 0.2 s; with seed 3 only learner 2 reaches the goal (its score 372.5, the others 400), so a
# choice is made. Every decision draws from the learner's own stream (epsilon's test).
TABULAR = PRESETS["report"].replace(episodes=8, population=4, max_episode_steps=400, frame_skip=4)
KEYS = ("episode_lengths", "episode_returns", "episode_successes", "greedy_from_rest",
        "population", "steps", "decisions_total")  # fmt: skip


def log_rows(run):
    rows = read_rows(run / "episodes.jsonl", 10**6)
    return [
        {k: row[k] for k in ("episode", "length", "return", "success", "learner")} for row in rows
    ]


def unread(arrays):
    """A checkpoint's arrays with the random stream's block cut to its unread draws (a lockstep
    group keeps those alone, a single agent the block and its position: the same stream)."""
    arrays = dict(arrays)
    block, position = arrays.pop("stream.block"), int(arrays.pop("stream.next"))
    arrays["stream.unread"] = block[position:]
    return arrays


def same_run(a, b, ra, rb) -> None:
    """Two population runs are the same: records, the kept agent, the run's log."""
    for key in KEYS:
        assert ra[key] == rb[key], key
    ca, cb = load_checkpoint(a / "checkpoint.npz"), load_checkpoint(b / "checkpoint.npz")
    assert ca[0]["episodes_done"] == cb[0]["episodes_done"]
    sa, sb = unread(ca[1]), unread(cb[1])
    assert sa.keys() == sb.keys()
    assert all(np.array_equal(sa[k], sb[k]) for k in sa)
    assert log_rows(a) == log_rows(b)


@pytest.mark.parametrize(
    ("config", "seed"),
    [
        (TABULAR, 3),
        # test_population's learners, compiled: with seed 2 their scores differ.
        (
            PRESETS["book"].replace(
                kernel="numba", episodes=4, population=3, max_episode_steps=400
            ),
            2,
        ),
    ],
    ids=["tabular", "compiled"],
)
def test_a_lockstep_population_is_the_one_by_one_run(tmp_path, config, seed) -> None:
    apart = train(config, seed, tmp_path / "apart", lockstep=False)
    together = train(config, seed, tmp_path / "together", lockstep=True)
    same_run(tmp_path / "apart", tmp_path / "together", apart, together)
    learner = json.loads((tmp_path / "together" / "learner_1" / "run.json").read_text())
    assert learner["lockstep"] == config.population and learner["seed"] == learner_seed(seed, 1)
    assert not list((tmp_path / "together").glob("learner_*/checkpoint.npz"))
    assert not list((tmp_path / "together").glob("learner_*/learning_curve.png"))
    assert len(set(together["population"]["scores"])) > 1  # a real choice was made


def test_populations_go_one_by_one_unless_told(tmp_path, monkeypatch) -> None:
    # Measured: ten report learners one by one in about half the time of a lockstep group of
    # ten, so lockstep is asked for, never assumed.
    built = []
    original = AcrobotVectorEnv.__init__

    def counting(self, *args, **kwargs):
        built.append(kwargs.get("num_envs"))
        original(self, *args, **kwargs)

    monkeypatch.setattr(AcrobotVectorEnv, "__init__", counting)
    train(TABULAR, 0)
    assert built == []
    train(TABULAR, 0, lockstep=True)
    assert built == [4]  # one vector env of the four learners


def test_a_lockstep_population_stopped_resumes_to_the_same_run(tmp_path, monkeypatch) -> None:
    whole = train(TABULAR, 5, tmp_path / "whole")
    steps = {"left": 1500}  # part of the way: 8 episodes of up to 400 steps, all at once
    original = AcrobotVectorEnv.step

    def stopping(self, actions):
        steps["left"] -= 1
        if steps["left"] == 0:
            raise KeyboardInterrupt
        return original(self, actions)

    monkeypatch.setattr(AcrobotVectorEnv, "step", stopping)
    with pytest.raises(KeyboardInterrupt, match="4 learners trained in lockstep"):
        train(TABULAR, 5, tmp_path / "split", lockstep=True)
    monkeypatch.setattr(AcrobotVectorEnv, "step", original)
    saved = [load_checkpoint(tmp_path / "split" / f"learner_{k}" / "checkpoint.npz")[0]
             for k in range(4)]  # fmt: skip
    assert 0 < sum(m["episodes_done"] for m in saved) < 32
    resumed = train(TABULAR, 5, tmp_path / "split", resume=True, lockstep=True)
    same_run(tmp_path / "whole", tmp_path / "split", whole, resumed)


def test_a_population_stopped_one_by_one_resumes_one_by_one(tmp_path) -> None:
    # Learner 0 done and learner 1 half way (their checkpoints there, 2 and 3 none): a lockstep
    # group cannot take that up, so the learners go on one by one, to the same run.
    whole = train(TABULAR, 4, tmp_path / "whole")
    part = tmp_path / "part"
    single = TABULAR.replace(population=1)
    train(single, learner_seed(4, 0), part / "learner_0")
    train(single.replace(episodes=4), learner_seed(4, 1), part / "learner_1")
    resumed = train(TABULAR, 4, part, resume=True, lockstep=True)
    same_run(tmp_path / "whole", part, whole, resumed)


def test_a_lockstep_that_cannot_be_is_refused(tmp_path, capsys) -> None:
    numpy_book = PRESETS["book"].replace(episodes=1, population=2)
    with pytest.raises(ValueError, match="lockstep training needs an algorithm"):
        train(numpy_book, 0, lockstep=True)
    with pytest.raises(ValueError, match="takes no env, on_episode or judge"):
        train(TABULAR, 0, on_episode=lambda *a: None, lockstep=True)
    with pytest.raises(ValueError, match="population is 1"):
        train(TABULAR.replace(population=1), 0, lockstep=True)
    with pytest.raises(ValueError, match="model-based"):
        train(PRESETS["tuned"].replace(population=2), 0, lockstep=True)
    with pytest.raises(SystemExit):
        main(["train", "--preset", "report", "--lockstep", "--out", str(tmp_path / "r")])
    err = capsys.readouterr().err
    assert "needs --seeds or --population" in err and len(err.strip().splitlines()) == 1
    args = ["train", "--preset", "report", "--episodes", "2", "--max-episode-steps", "50"]
    assert main([*args, "--population", "2", "--lockstep", "--out", str(tmp_path / "p")]) == 0
    record = json.loads((tmp_path / "p" / "learner_0" / "run.json").read_text())
    assert record["lockstep"] == 2
