"""Training loops, run records, checkpoints, resume, seeds in lockstep and a real learning
test."""

from __future__ import annotations

import json

import numpy as np
import pytest

from acrobot_mj.agents import DivergenceError
from acrobot_mj.envs.wrappers import make_gymnasium_acrobot
from acrobot_mj.train.checkpoint import CheckpointError, load_checkpoint, save_checkpoint
from acrobot_mj.train.config import TrainConfig, parse_value
from acrobot_mj.train.evaluate import evaluate, evaluate_learner
from acrobot_mj.train.learners import DEFAULT, AgentLearner, HeldOut, make_env
from acrobot_mj.train.presets import PRESETS
from acrobot_mj.train.records import CHECKPOINT_FILE
from acrobot_mj.train.run import Run, RunOptions
from acrobot_mj.train.seeds import train_seeds
from acrobot_mj.train.trainer import load_learner, train
from tests.conftest import lockstep_interrupted_and_resumed

#: What a resumed or lockstep run must reproduce exactly (wall_seconds aside).
RECORD_KEYS = (
    "episode_lengths",
    "episode_returns",
    "episode_successes",
    "steps",
    "greedy_from_rest",
)
TINY_BOOK = PRESETS["book"].replace(episodes=6, checkpoint_every=2)


def test_checkpoint_round_trip(tmp_path) -> None:
    arrays = {"w": np.arange(6.0).reshape(2, 3), "name": np.array("x"), "n": np.array(3)}
    save_checkpoint(tmp_path / "c.npz", arrays, {"seed": 1, "list": [1, 2]})
    meta, loaded = load_checkpoint(tmp_path / "c.npz")
    assert meta == {"seed": 1, "list": [1, 2]}
    assert loaded.keys() == arrays.keys()
    for key in arrays:
        np.testing.assert_array_equal(loaded[key], arrays[key])


def _good_checkpoint(tmp_path):
    path = tmp_path / "c.npz"
    save_checkpoint(path, {"w": np.linspace(0, 1, 1000)}, {"seed": 1})
    return path, path.read_bytes()


def test_truncated_checkpoint_is_refused(tmp_path) -> None:
    path, data = _good_checkpoint(tmp_path)
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(CheckpointError, match=r"c\.npz.*truncated or corrupt"):
        load_checkpoint(path)


def test_tampered_checkpoint_is_refused(tmp_path) -> None:
    path, _ = _good_checkpoint(tmp_path)
    # Rewrite the file with one value changed but the old checksum kept.
    with np.load(path) as npz:
        payload = {k: npz[k] for k in npz.files}
    payload["w"] = payload["w"].copy()
    payload["w"][10] += 1.0
    with open(path, "wb") as f:
        np.savez(f, **payload)
    with pytest.raises(CheckpointError, match="checksum"):
        load_checkpoint(path)


def test_flipped_byte_is_refused(tmp_path) -> None:
    path, data = _good_checkpoint(tmp_path)
    damaged = bytearray(data)
    damaged[len(damaged) // 2] ^= 0xFF  # inside the array data
    path.write_bytes(bytes(damaged))
    with pytest.raises(CheckpointError):
        load_checkpoint(path)


def test_other_files_and_versions_are_refused(tmp_path) -> None:
    other = tmp_path / "other.npz"
    np.savez(other, w=np.zeros(3))
    with pytest.raises(CheckpointError, match="lacks"):
        load_checkpoint(other)
    text = tmp_path / "text.npz"
    text.write_text("not a zip")
    with pytest.raises(CheckpointError, match="truncated or corrupt"):
        load_checkpoint(text)
    with pytest.raises(FileNotFoundError, match="missing"):
        load_checkpoint(tmp_path / "missing.npz")
    path, _ = _good_checkpoint(tmp_path)
    with np.load(path) as npz:
        payload = {k: npz[k] for k in npz.files}
    payload["version"] = np.array(99)
    with open(path, "wb") as f:
        np.savez(f, **payload)
    with pytest.raises(CheckpointError, match="version 99"):
        load_checkpoint(path)


def test_interrupted_write_leaves_the_old_checkpoint(tmp_path, monkeypatch) -> None:
    path, before = _good_checkpoint(tmp_path)

    def crash(file, **arrays):
        file.write(b"PK\x03\x04 half a zip")
        raise OSError("disk full")

    monkeypatch.setattr(np, "savez", crash)
    with pytest.raises(OSError, match="disk full"):
        save_checkpoint(path, {"w": np.zeros(5)}, {"seed": 2})
    assert path.read_bytes() == before  # untouched, still loadable
    assert load_checkpoint(path)[0] == {"seed": 1}
    assert [p.name for p in tmp_path.iterdir()] == ["c.npz"]  # no temporary file left


def test_train_writes_run_record_checkpoint_and_curve(tmp_path) -> None:
    record = train(TINY_BOOK, seed=0, out_dir=tmp_path)
    saved = json.loads((tmp_path / "run.json").read_text())
    assert saved == json.loads(json.dumps(record))
    assert saved["config"]["algorithm"] == "sarsa_lambda" and saved["seed"] == 0
    assert {"mujoco", "gymnasium", "numpy", "acrobot_mj"} <= saved["versions"].keys()
    for key in ("episode_lengths", "episode_returns", "episode_successes"):
        assert len(saved[key]) == 6
    # Book rewards: -1 on every step, the goal step too.
    assert saved["episode_returns"] == [-float(n) for n in saved["episode_lengths"]]
    assert (tmp_path / "learning_curve.png").read_bytes()[:4] == b"\x89PNG"
    learner = load_learner(tmp_path)
    assert learner.config == TINY_BOOK and learner.seed == 0
    # Evaluate: held-out starts of the protocol, and the run's greedy episode from rest apart.
    result = evaluate(tmp_path, HeldOut(episodes=3))
    assert json.loads((tmp_path / "eval.json").read_text()) == json.loads(json.dumps(result))
    assert result["protocol"] == {"episodes": 3, "start_noise": 0.05, "seed": 0}
    assert len(result["start_states"]) == len(result["actions"]) == 3
    assert [len(a) for a in result["actions"]] == result["episode_lengths"]
    rest = {k: result["rest"][k] for k in ("length", "return", "success")}
    assert rest == record["greedy_from_rest"]


def test_resume_after_interrupt_matches_an_uninterrupted_run(tmp_path) -> None:
    whole = train(TINY_BOOK, seed=4, out_dir=tmp_path / "whole")

    def stop(episode, history):
        if episode == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        train(TINY_BOOK, seed=4, out_dir=tmp_path / "split", options=RunOptions(on_episode=stop))
    meta, _ = load_checkpoint(tmp_path / "split" / CHECKPOINT_FILE)
    assert meta["episodes_done"] == 3
    resumed = train(TINY_BOOK, seed=4, out_dir=tmp_path / "split", options=RunOptions(resume=True))
    for key in RECORD_KEYS:
        assert resumed[key] == whole[key]
    a = load_checkpoint(tmp_path / "whole" / CHECKPOINT_FILE)[1]
    b = load_checkpoint(tmp_path / "split" / CHECKPOINT_FILE)[1]
    np.testing.assert_array_equal(a["w"], b["w"])


def test_resume_refuses_a_different_config_or_seed(tmp_path) -> None:
    train(TINY_BOOK, seed=1, out_dir=tmp_path)
    with pytest.raises(CheckpointError, match="alpha"):
        train(
            TINY_BOOK.replace(alpha=0.1), seed=1, out_dir=tmp_path, options=RunOptions(resume=True)
        )
    with pytest.raises(CheckpointError, match="seed"):
        train(TINY_BOOK, seed=2, out_dir=tmp_path, options=RunOptions(resume=True))
    # More episodes than before is what resume is for.
    more = train(
        TINY_BOOK.replace(episodes=8), seed=1, out_dir=tmp_path, options=RunOptions(resume=True)
    )
    assert more["episodes_done"] == 8
    # And checkpoints at other intervals: they change nothing learned.
    whole = train(TINY_BOOK.replace(episodes=10), seed=1)
    later = TINY_BOOK.replace(episodes=10, checkpoint_every=5)
    resumed = train(later, seed=1, out_dir=tmp_path, options=RunOptions(resume=True))
    assert resumed["episode_lengths"] == whole["episode_lengths"]


def test_trains_on_gymnasiums_acrobot_too() -> None:
    # Any env with Discrete(3) actions and (q1, q2, dq1, dq2) observations works.
    config = PRESETS["report"].replace(episodes=2, max_episode_steps=50)
    record = train(config, seed=0, env=make_gymnasium_acrobot(max_episode_steps=50))
    assert record["episode_lengths"] == [50, 50]


def test_train_refuses_envs_with_other_spaces() -> None:
    import gymnasium as gym

    with pytest.raises(ValueError, match="Box of shape"):
        train(PRESETS["report"].replace(episodes=1), seed=0, env=gym.make("Acrobot-v1"))
    with pytest.raises(ValueError, match="Discrete"):
        train(PRESETS["report"].replace(episodes=1), seed=0, env=gym.make("Pendulum-v1"))


def test_train_seeds_summary(tmp_path) -> None:
    # Three held-out episodes a seed (the protocol's 100 take seconds; test_heldout checks them).
    summary = train_seeds(
        TINY_BOOK.replace(episodes=3),
        [0, 1],
        tmp_path,
        protocol=HeldOut(episodes=3),
        options=RunOptions(jobs=1),
    )
    assert summary["seeds"] == [0, 1]
    assert (tmp_path / "seed_0" / "run.json").exists() and (tmp_path / "summary.json").exists()
    per_seed = [json.loads((tmp_path / f"seed_{s}" / "run.json").read_text()) for s in (0, 1)]
    assert summary["successes"]["median"] == np.median(
        [sum(r["episode_successes"]) for r in per_seed]
    )
    assert summary["greedy_from_rest_length"]["max"] == max(
        r["greedy_from_rest"]["length"] for r in per_seed
    )


def test_config_overrides_are_typed_and_checked() -> None:
    assert {
        k: parse_value(k, v)
        for k, v in [("alpha", "0.2/48"), ("episodes", "3"), ("subset_tilings", "false")]
    } == {
        "alpha": 0.2 / 48,
        "episodes": 3,
        "subset_tilings": False,
    }
    with pytest.raises(ValueError, match="unknown config key 'alpah'"):
        parse_value("alpah", "0.1")
    with pytest.raises(ValueError, match="episodes needs an int"):
        parse_value("episodes", "many")
    with pytest.raises(ValueError, match="algorithm"):
        TrainConfig(algorithm="no_such_algorithm")
    with pytest.raises(ValueError, match="tabular"):
        TrainConfig(algorithm="sarsa", features="tiles")
    with pytest.raises(TypeError, match="episodes"):
        TrainConfig(episodes=2.5)
    assert TrainConfig.from_dict(PRESETS["book"].to_dict()) == PRESETS["book"]


def test_start_noise_schedule() -> None:
    config = PRESETS["book"].replace(start_noise=0.2, noise_until=0.8)  # 0 by episode 400
    assert [config.start_noise_at(e) for e in (0, 200, 400, 499)] == [0.2, 0.1, 0.0, 0.0]
    assert PRESETS["book"].start_noise_at(123) == 0.0
    constant = PRESETS["book"].replace(start_noise=0.05)
    assert constant.start_noise_at(0) == constant.start_noise_at(499) == 0.05
    with pytest.raises(ValueError, match="noise_until"):
        PRESETS["book"].replace(noise_until=1.5)


def test_noisy_training_starts_follow_the_schedule_and_the_seed() -> None:
    import gymnasium as gym

    class Starts(gym.Wrapper):
        def __init__(self, env):
            super().__init__(env)
            self.starts = []

        def reset(self, **kwargs):
            obs, info = self.env.reset(**kwargs)
            self.starts.append(obs)  # only the first reset of the greedy run has no noise
            return obs, info

    config = PRESETS["model_free"].replace(
        episodes=5, max_decisions=0, max_episode_steps=5, start_noise=0.2, noise_until=0.8
    )
    runs = []
    for seed in (1, 1, 2):
        env = Starts(make_env(config))
        train(config, seed=seed, env=env)
        runs.append(np.array(env.starts))
    hanging = np.array([-np.pi / 2, 0.0, 0.0, 0.0])
    noise = np.abs(runs[0][:5] - hanging).max(axis=1)
    # U(-s, s) with s = 0.2, 0.15, 0.1, 0.05, 0 for episodes 0..4; then the greedy run at rest.
    assert np.all(noise <= [0.2, 0.15, 0.1, 0.05, 0.0]) and np.all(noise[:4] > 0)
    np.testing.assert_array_equal(runs[0][5], hanging)
    np.testing.assert_array_equal(runs[0], runs[1])  # same seed, same starts
    assert not np.array_equal(runs[0], runs[2])


@pytest.mark.slow
def test_book_preset_learns_the_swing_up() -> None:
    # A real learning test (a few seconds). Measured over seeds 0-5 after 60 episodes: 57-60
    # episodes reach the goal, the median of the last 10 is 84-109 decisions and the greedy
    # policy swings up from rest in 84-111. The bounds (55, 150, 150) leave room for platform
    # differences; an agent that does not learn acts at random (all-zero weights, random ties)
    # and from rest reaches the goal in 2 of 10 tries within 1000 decisions, after 586 or more.
    for seed in range(3):
        record = train(PRESETS["book"].replace(episodes=60), seed=seed)
        assert sum(record["episode_successes"]) >= 55
        assert np.median(record["episode_lengths"][-10:]) < 150
        assert record["greedy_from_rest"]["success"]
        assert record["greedy_from_rest"]["length"] < 150


@pytest.mark.slow
def test_model_free_preset_generalises_within_the_budget() -> None:
    # The full model_free preset (one learner, exactly 48,000 decisions, about 5 s). Measured
    # over training seeds 300-399 on the 100 held-out starts: per-seed medians 65-92, 39 of 100
    # at 76 or less; seed 301 lands in the 65 family (65 from rest and held out), so the bound
    # of 70 fails only if the learner, its budget or the protocol changed, not by bad luck.
    learner = AgentLearner(PRESETS["model_free"], 301)
    record = learner.learn(Run())
    assert record["steps"] == 48_000 and record["decisions_total"] == 48_000 + 65
    assert record["greedy_from_rest"] == {"length": 65, "return": -65.0, "success": True}
    held_out = evaluate_learner(learner, DEFAULT)
    assert held_out["summary"]["length"]["median"] <= 70
    assert held_out["summary"]["successes"] >= 95  # the worst of the 100 measured seeds: 95


@pytest.mark.slow
def test_tuned_preset_learns_in_its_model_and_swings_up_near_the_minimum(tmp_path) -> None:
    # The full tuned preset (1,000 env decisions, 10 learners of 48,000 simulated ones, about
    # 40 s). Measured over seeds 300-319: held-out medians 65-78, 14 of 20 within 1.15 times the
    # per-start minimum of 63 (72.45); seed 300 gets 65 held out and from rest, so the bound of
    # 70 fails only if the identification, the learners or their selection changed.
    record = train(PRESETS["tuned"], seed=300, out_dir=tmp_path)
    assert record["model"]["data_decisions"] == 1000 and record["steps"] == 480_000
    assert record["decisions_total"] == 1000 + record["greedy_from_rest"]["length"] <= 1100
    held_out = evaluate(tmp_path)
    assert held_out["summary"]["length"]["median"] <= 70
    assert held_out["minima"]["ratio"]["median"] <= 1.15
    assert held_out["summary"]["successes"] >= 98  # the worst of the 20 measured seeds: 98


@pytest.mark.parametrize(
    "config",
    [
        PRESETS["report"].replace(episodes=3, max_episode_steps=200),
        # 0.2 s decisions reach the goal (terminal updates), with a start-noise schedule.
        pytest.param(
            PRESETS["report"].replace(episodes=25, frame_skip=4, start_noise=0.05, noise_until=0.5),
            marks=pytest.mark.slow,
        ),
    ],
)
def test_lockstep_learners_equal_single_learners(config, tmp_path) -> None:
    # Stated and tested: identical, not just alike in distribution (same streams, same resets,
    # same arithmetic), so the records and the learned tables agree exactly.
    from acrobot_mj.train.lockstep import train_lockstep

    seeds = [0, 3, 7]
    lockstep = train_lockstep(config, seeds, tmp_path / "lock")
    for seed, record in zip(seeds, lockstep, strict=True):
        single = train(config, seed=seed, out_dir=tmp_path / f"single{seed}")
        for key in RECORD_KEYS:
            assert record[key] == single[key], key
        a = load_checkpoint(tmp_path / "lock" / f"seed_{seed}" / CHECKPOINT_FILE)[1]["q"]
        b = load_checkpoint(tmp_path / f"single{seed}" / CHECKPOINT_FILE)[1]["q"]
        np.testing.assert_array_equal(a, b)
    if config.frame_skip == 4:
        assert sum(sum(r["episode_successes"]) for r in lockstep) > 20  # terminal updates ran


@pytest.mark.slow
def test_seeds_stopped_in_lockstep_resume_one_by_one(tmp_path) -> None:
    # Runs started in lockstep (the default for small groups before) resume one by one (the
    # default now), and the reverse, to the runs trained whole either way.
    from acrobot_mj.train.seeds import train_seeds

    config = PRESETS["report"].replace(episodes=6, max_episode_steps=150, frame_skip=4)
    seeds, short = [0, 2], config.replace(episodes=3)
    whole = train_seeds(
        config, seeds, tmp_path / "whole", protocol=None, options=RunOptions(lockstep=False)
    )
    for first, then in [(True, False), (False, True)]:
        out = tmp_path / f"from_{first}"
        train_seeds(short, seeds, out, protocol=None, options=RunOptions(lockstep=first))
        resumed = train_seeds(
            config, seeds, out, protocol=None, options=RunOptions(resume=True, lockstep=then)
        )
        assert (
            resumed["decisions"] == whole["decisions"]
            and resumed["successes"] == whole["successes"]
        )
        for s in seeds:
            a, b = (
                json.loads((d / f"seed_{s}" / "run.json").read_text())
                for d in (out, tmp_path / "whole")
            )
            for key in RECORD_KEYS:
                assert a[key] == b[key], key
            np.testing.assert_array_equal(
                load_checkpoint(out / f"seed_{s}" / CHECKPOINT_FILE)[1]["q"],
                load_checkpoint(tmp_path / "whole" / f"seed_{s}" / CHECKPOINT_FILE)[1]["q"],
            )


def test_seeds_need_at_least_one(tmp_path) -> None:
    from acrobot_mj.train.seeds import train_seeds

    with pytest.raises(ValueError, match="at least one seed"):
        train_seeds(PRESETS["report"], [], tmp_path)


def test_lockstep_refuses_sarsa_lambda() -> None:
    # Lockstep Sarsa(lambda) was removed (slower than one process per seed): asked for, it is
    # refused in one line that says so.
    from acrobot_mj.train.lockstep import train_lockstep

    with pytest.raises(ValueError, match="tabular") as refused:
        train_lockstep(PRESETS["book"], [0, 1])
    assert "one process per seed" in str(refused.value)
    assert len(str(refused.value).splitlines()) == 1


@pytest.mark.slow
def test_lockstep_checkpoints_and_resume_exactly(tmp_path, monkeypatch) -> None:
    config = PRESETS["report"].replace(episodes=12, frame_skip=4, checkpoint_every=3)
    whole, resumed = lockstep_interrupted_and_resumed(config, [0, 5], tmp_path, monkeypatch, 1500)
    for a, b in zip(whole, resumed, strict=True):
        for key in RECORD_KEYS:
            assert a[key] == b[key], key


@pytest.mark.slow
def test_seeds_over_processes_are_lockstep_groups_with_the_same_runs(tmp_path) -> None:
    # With jobs processes, each trains one lockstep group of the seeds: the same runs as one
    # group of them all.
    config = PRESETS["report"].replace(episodes=3, frame_skip=4, max_episode_steps=300)
    seeds = [0, 1, 2, 3, 4]
    split = train_seeds(
        config, seeds, tmp_path / "two", protocol=None, options=RunOptions(jobs=2, lockstep=True)
    )
    together = train_seeds(
        config, seeds, tmp_path / "one", protocol=None, options=RunOptions(jobs=1, lockstep=True)
    )
    assert split["decisions"] == together["decisions"] and split["seeds"] == seeds
    for s in seeds:
        a, b = (
            load_checkpoint(tmp_path / run / f"seed_{s}" / CHECKPOINT_FILE)[1]
            for run in ("two", "one")
        )
        np.testing.assert_array_equal(a["q"], b["q"])
        record = json.loads((tmp_path / "two" / f"seed_{s}" / "run.json").read_text())
        assert record["lockstep"] == (3 if s % 2 == 0 else 2)  # seeds dealt out in turn


@pytest.mark.filterwarnings("ignore:overflow encountered:RuntimeWarning")
def test_a_diverging_learner_in_a_group_is_named_and_checkpointed(tmp_path) -> None:
    # Rewards that overflow a float: the group stops at the first episode that ends, naming
    # the learner's seed and the cause; its checkpoint keeps the state before that episode.
    from acrobot_mj.train.lockstep import train_lockstep

    config = PRESETS["report"].replace(step_reward=-1e308, episodes=3, max_episode_steps=20)
    checkpoint = tmp_path / "seed_4" / CHECKPOINT_FILE
    with pytest.raises(
        DivergenceError,
        match=r"diverged in episode 1 of seed 4 .*step_reward "
        rf"-1e\+308.*; {checkpoint} keeps the state after episode 0$",
    ):
        train_lockstep(config, [4], tmp_path)
    assert load_checkpoint(tmp_path / "seed_4" / CHECKPOINT_FILE)[0]["episodes_done"] == 0
