"""CLI smoke tests of train and evaluate with tiny budgets."""

from __future__ import annotations

import json

import pytest

from acrobot_mj.cli import main
from acrobot_mj.train import lockstep as lockstep_module
from acrobot_mj.train.lockstep import LOCKSTEP_GROUP_FROM, can_lockstep, lockstep_pays
from acrobot_mj.train.presets import PRESETS


def test_train_and_evaluate_report_preset(tmp_path, capsys) -> None:
    out = tmp_path / "run"
    argv = [
        "train",
        "--preset",
        "report",
        "--episodes",
        "2",
        "--max-episode-steps",
        "30",
        "--out",
        str(out),
        "--seed",
        "3",
    ]
    assert main(argv) == 0
    assert "trained 2 episodes (60 decisions" in capsys.readouterr().out
    record = json.loads((out / "run.json").read_text())
    assert record["seed"] == 3 and record["config"]["alpha"] == 0.5
    assert record["config"]["max_episode_steps"] == 30
    assert main(["evaluate", str(out), "--episodes", "2"]) == 0
    assert json.loads((out / "eval.json").read_text())["episode_lengths"] == [30, 30]


def test_overrides_reach_the_config(tmp_path) -> None:
    out = tmp_path / "run"
    main(
        [
            "train",
            "--preset",
            "book",
            "--episodes",
            "1",
            "--alpha",
            "0.1/48",
            "--lam",
            "0.5",
            "--subset-tilings",
            "false",
            "--out",
            str(out),
        ]
    )
    config = json.loads((out / "run.json").read_text())["config"]
    assert config["alpha"] == 0.1 / 48 and config["lam"] == 0.5
    assert config["subset_tilings"] is False and config["episodes"] == 1


def test_seeds_write_one_record_per_seed_and_a_summary(tmp_path, capsys) -> None:
    out = tmp_path / "many"
    main(
        [
            "train",
            "--preset",
            "book",
            "--episodes",
            "2",
            "--max-episode-steps",
            "100",
            "--seeds",
            "2",
            "--seed",
            "5",
            "--out",
            str(out),
        ]
    )
    assert "2 seeds" in capsys.readouterr().out
    summary = json.loads((out / "summary.json").read_text())
    assert summary["seeds"] == [5, 6] and summary["runs"] == ["seed_5", "seed_6"]
    for seed in (5, 6):
        assert json.loads((out / f"seed_{seed}" / "run.json").read_text())["seed"] == seed


def test_resume_continues_a_run(tmp_path, capsys) -> None:
    out = tmp_path / "run"
    main(["train", "--preset", "book", "--episodes", "2", "--out", str(out)])
    main(["train", "--preset", "book", "--episodes", "4", "--out", str(out), "--resume"])
    assert len(json.loads((out / "run.json").read_text())["episode_lengths"]) == 4


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["train", "--alpha", "fast"], "config alpha needs a float"),
        (["train", "--algorithm", "dqn"], "algorithm must be one of"),
        (["train", "--resume", "--out", "nowhere"], "checkpoint not found"),
        (["evaluate", "nowhere"], "'nowhere' holds no run (no run.json or checkpoint.npz)"),
        (["evaluate", ""], "'' holds no run"),  # and no .lock is created in the cwd
        # Removed: the kernel choice (one compiled Sarsa(lambda)) and lockstep populations.
        (["train", "--preset", "book", "--kernel", "numba"], "unrecognized arguments: --kernel"),
        (["train", "--population", "3", "--lockstep"], "--lockstep trains several seeds together"),
        (["train", "--population", "2", "--seeds", "2", "--lockstep"], "one learner per run"),
        (["train", "--preset", "book", "--seeds", "2", "--lockstep"], "got sarsa_lambda"),
    ],
)
def test_bad_arguments_give_a_clear_error(argv, message, tmp_path, monkeypatch, capsys) -> None:
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / ".lock").exists() and not (tmp_path / "nowhere").exists()


def test_corrupt_checkpoint_gives_a_clear_error(tmp_path, capsys) -> None:
    out = tmp_path / "run"
    main(["train", "--preset", "book", "--episodes", "1", "--out", str(out)])
    (out / "checkpoint.npz").write_bytes(b"garbage")
    with pytest.raises(SystemExit):
        main(["evaluate", str(out)])
    assert "truncated or corrupt" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("group_from", "asked", "lockstep"),
    [(LOCKSTEP_GROUP_FROM, [], None), (LOCKSTEP_GROUP_FROM, ["--lockstep"], 2), (2, [], 2)],
)
def test_report_seeds_run_in_lockstep_from_a_group_size(
    tmp_path, monkeypatch, group_from, asked, lockstep
) -> None:
    # Tabular SARSA's seeds go in lockstep by default only in groups of LOCKSTEP_GROUP_FROM or
    # more (smaller ones are faster one per process): two seeds one by one, unless the
    # threshold is two, or lockstep is asked for (whatever the group's size).
    assert LOCKSTEP_GROUP_FROM > 2
    monkeypatch.setattr(lockstep_module, "LOCKSTEP_GROUP_FROM", group_from)
    out = tmp_path / "many"
    tiny = ["--preset", "report", "--episodes", "2", "--max-episode-steps", "50"]
    main(["train", *tiny, "--seeds", "2", *asked, "--out", str(out)])
    record = json.loads((out / "seed_1" / "run.json").read_text())
    assert record.get("lockstep") == lockstep and record["episode_lengths"] == [50, 50]
    assert main(["evaluate", str(out / "seed_1"), "--episodes", "1"]) == 0


def test_the_lockstep_default_follows_the_group_size() -> None:
    report, book = PRESETS["report"], PRESETS["book"]
    assert not lockstep_pays(report, LOCKSTEP_GROUP_FROM - 1)
    assert lockstep_pays(report, LOCKSTEP_GROUP_FROM)
    # Sarsa(lambda) has no lockstep form (one process per seed is faster): never, at any size.
    assert not can_lockstep(book) and not lockstep_pays(book, 1000)


def test_curves_of_several_seed_runs(tmp_path, capsys) -> None:
    for name in ("a", "b"):
        main(
            [
                "train",
                "--preset",
                "report",
                "--episodes",
                "3",
                "--max-episode-steps",
                "50",
                "--seeds",
                "2",
                "--out",
                str(tmp_path / name),
            ]
        )
    out = tmp_path / "curves.png"
    assert (
        main(["curves", str(tmp_path / "a"), str(tmp_path / "b"), "--out", str(out), "--minimum"])
        == 0
    )
    assert out.read_bytes()[:4] == b"\x89PNG"
    one = tmp_path / "one.svg"  # one run's directory: its own curve
    assert main(["curves", str(tmp_path / "a" / "seed_0"), "--out", str(one)]) == 0
    assert one.read_text().count("<path") > 0
    with pytest.raises(SystemExit):
        main(["curves", str(tmp_path), "--out", str(out)])
    err = capsys.readouterr().err
    assert "holds neither summary.json nor run.json" in err and len(err.strip().splitlines()) == 1


def test_refuses_to_overwrite_a_run(tmp_path, capsys) -> None:
    out = tmp_path / "run"
    main(["train", "--preset", "book", "--episodes", "1", "--out", str(out)])
    with pytest.raises(SystemExit):
        main(["train", "--preset", "book", "--episodes", "1", "--out", str(out)])
    assert "already holds a run" in capsys.readouterr().err
    assert main(["train", "--preset", "book", "--episodes", "1", "--out", str(out), "--force"]) == 0


def test_greedy_from_rest_agrees_across_train_evaluate_and_render(tmp_path) -> None:
    # The same tie-breaking stream for the run's greedy episode, evaluate's rest episode and the
    # video, for any seed (the report preset has many ties: untouched cells are all zero).
    for seed in (1, 2):
        out = tmp_path / f"r{seed}"
        main(
            [
                "train",
                "--preset",
                "report",
                "--frame-skip",
                "4",
                "--episodes",
                "30",
                "--seed",
                str(seed),
                "--out",
                str(out),
            ]
        )
        record = json.loads((out / "run.json").read_text())
        main(["evaluate", str(out), "--episodes", "1"])
        evaluation = json.loads((out / "eval.json").read_text())
        assert evaluation["rest"]["length"] == record["greedy_from_rest"]["length"]


def test_a_run_keeps_the_acrobot_of_its_model_file(tmp_path, monkeypatch, capsys) -> None:
    """A run trained on a model file carries its parameters: edited (3 N m instead of 1), moved
    away from, or deleted, evaluate runs on the acrobot it was trained on (it once read the
    file again and gave +-3 N m torques); a controller run is compared the same way."""
    from acrobot_mj.olympics.sources import same_acrobot
    from acrobot_mj.train.config import TrainConfig

    monkeypatch.chdir(tmp_path)
    (tmp_path / "mine.json").write_text(json.dumps({"max_torque": 1.0, "m2": 1.5}))
    argv = ["train", "--preset", "report", "--model", "mine.json", "--episodes", "2"]
    assert main([*argv, "--max-episode-steps", "20", "--out", "r", "--no-progress"]) == 0
    record = json.loads((tmp_path / "r" / "run.json").read_text())
    assert record["config"]["model_table"]["m2"] == 1.5
    (tmp_path / "mine.json").write_text(json.dumps({"max_torque": 3.0, "m2": 1.5}))
    config = TrainConfig.from_dict(record["config"])
    assert (
        config.acrobot.params.max_torque == 1.0 and config.env_kwargs()["model"] == config.acrobot
    )
    with pytest.raises(ValueError, match=r"trained on the model 'mine.json', not 'mine.json'"):
        same_acrobot(record, "mine.json", "r")
    (tmp_path / "mine.json").unlink()
    (tmp_path / "elsewhere").mkdir()
    monkeypatch.chdir(tmp_path / "elsewhere")
    assert main(["evaluate", "../r", "--episodes", "2"]) == 0
    assert "held-out starts" in capsys.readouterr().out
    assert TrainConfig.from_dict(record["config"]).replace(model="report").model_table is None
