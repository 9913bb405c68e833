"""Golden runs: the numbers of whole training runs, recorded before the package was reorganised
(``tests/fixtures/golden_runs.json`` says with which commands), must come out identical, and run
directories written then (``tests/fixtures/run_dirs/``) must still load, evaluate and resume.

Exact equality, no tolerance: training is deterministic given the seed, and the reorganisation
changed no arithmetic, so any difference is a change of behaviour.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from acrobot_mj.train.config import TrainConfig
from acrobot_mj.train.evaluate import evaluate
from acrobot_mj.train.learners import HeldOut
from acrobot_mj.train.presets import PRESETS, TUNED_0_2
from acrobot_mj.train.run import RunOptions
from acrobot_mj.train.seeds import train_seeds
from acrobot_mj.train.trainer import load_learner, train

FIXTURES = Path(__file__).parent / "fixtures"
GOLDEN = json.loads((FIXTURES / "golden_runs.json").read_text())
LISTS = ("episode_lengths", "episode_returns", "episode_successes")


def _same_run(record: dict, golden: dict) -> None:
    for key in (*LISTS, "steps", "episodes_done", "seed", "greedy_from_rest"):
        assert record[key] == golden[key], key


@pytest.mark.slow
def test_book_preset_seed_0_is_unchanged() -> None:
    _same_run(train(PRESETS["book"], seed=0), GOLDEN["book_seed0"])


@pytest.mark.slow
def test_tuned_preset_seed_0_is_unchanged() -> None:
    # The 0.2.0 tuned preset (the golden run's; the preset has changed since).
    record = train(TUNED_0_2, seed=0)
    _same_run(record, GOLDEN["tuned_seed0"])
    # Since 0.3.0 the learners make no greedy runs (nothing used them): the rest is unchanged.
    golden = dict(GOLDEN["tuned_seed0"]["population"])
    del golden["greedy_from_rest_lengths"]
    assert record["population"] == golden


@pytest.mark.slow
def test_report_preset_three_seeds_in_lockstep_are_unchanged(tmp_path) -> None:
    # Frame skip 4, where the report's SARSA reaches the goal: at frame skip 1 every episode of
    # its 200 runs 1000 steps, which any learner that never succeeds would reproduce.
    config = PRESETS["report"].replace(frame_skip=4, episodes=50)
    train_seeds(
        config, [0, 1, 2], tmp_path, protocol=None, options=RunOptions(lockstep=True)
    )  # no evaluation
    for seed, golden in enumerate(GOLDEN["report_fs4_seeds3"]):
        _same_run(json.loads((tmp_path / f"seed_{seed}" / "run.json").read_text()), golden)


@pytest.mark.parametrize("name", ["report_fs4", "booksmall"])
def test_run_directories_written_before_still_load_and_evaluate(name, tmp_path) -> None:
    # Written by the version before the reorganisation (tabular SARSA at frame_skip 4, 30
    # episodes; Sarsa(lambda) with one 6x6x8x8 tiling, 5 episodes): the checkpoint loads, its
    # config reads back (without the evaluation fields configs had then), and evaluating it
    # gives the greedy episode from rest written then (its eval.json's episode 0; that
    # version's other episodes drew their noisy starts from another protocol).
    run = tmp_path / name
    shutil.copytree(FIXTURES / "run_dirs" / name, run)
    old_eval = json.loads((run / "eval.json").read_text())
    learner = load_learner(run)
    config, seed = learner.config, learner.seed
    # Every setting that applies reads back as written; the old record's values for settings
    # that do not apply (it wrote defaults for them) read as not set.
    applied = {k: v for k, v in config.to_dict().items() if v is not None and k != "task"}
    for new in ("max_decisions", "identify_decisions"):  # new in 0.3.0, read as 0 (off)
        assert applied.pop(new) == 0
    # kernel (new in 0.3.0, the numpy learner as then) is retired: not a setting, and a record
    # that holds it reads as not set.
    assert "kernel" not in config.to_dict()
    assert TrainConfig.from_dict({**old_eval["config"], "kernel": "numpy"}) == config
    assert applied == {k: old_eval["config"][k] for k in applied}
    assert None in config.to_dict().values() and seed == 0
    assert {"eval_episodes", "eval_noise"} <= old_eval["config"].keys()
    record = evaluate(run, HeldOut(episodes=2))
    rest = record["rest"]
    assert [rest["length"], rest["return"], rest["success"]] == [old_eval[k][0] for k in LISTS]
    greedy = json.loads((run / "run.json").read_text())["greedy_from_rest"]
    assert rest["length"] == greedy["length"]


def test_a_checkpoint_written_before_resumes_to_the_same_run(tmp_path) -> None:
    # The 30-episode run resumed to 50 episodes is seed 0 of the 50-episode lockstep golden run.
    run = tmp_path / "run"
    shutil.copytree(FIXTURES / "run_dirs" / "report_fs4", run)
    config = PRESETS["report"].replace(frame_skip=4, episodes=50)
    record = train(config, seed=0, out_dir=run, options=RunOptions(resume=True))
    _same_run(record, GOLDEN["report_fs4_seeds3"][0])
