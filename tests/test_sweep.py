"""Sweeps: the grid expansion, resume, failing trials, grid points' seeds in lockstep, and a tiny
sweep on a local Ray."""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from acrobot_mj.cli import main
from acrobot_mj.train import lockstep as lockstep_module
from acrobot_mj.train.checkpoint import load_checkpoint
from acrobot_mj.train.lockstep import LOCKSTEP_GROUP_FROM
from acrobot_mj.train.records import CHECKPOINT_FILE
from acrobot_mj.train.run import RunOptions
from acrobot_mj.train.sweep import run_sweep
from acrobot_mj.train.sweep_file import load_sweep, parse_sweep
from tests.conftest import LOOPBACK, listening

TINY = """
preset = "report"
episodes = 2
max_episode_steps = 30
seeds = [0, 1]
[grid]
alpha = [0.1, 0.5]
frame_skip = [1, 4]
"""
ROOT = Path(__file__).resolve().parents[1]
#: Two grid points of two seeds: what most tests need.
SMALL = TINY.replace("frame_skip = [1, 4]", "frame_skip = [4]")


def test_grid_expansion() -> None:
    spec = parse_sweep(TINY)
    trials = spec.trials()
    assert len(trials) == 8  # 2 alphas x 2 frame skips x 2 seeds
    assert trials[0].name == "alpha=0.1__frame_skip=1__seed=0"
    assert [(t.point["alpha"], t.point["frame_skip"], t.seed) for t in trials[:4]] == [
        (0.1, 1, 0),
        (0.1, 1, 1),
        (0.1, 4, 0),
        (0.1, 4, 1),
    ]
    assert {t.config.episodes for t in trials} == {2}
    assert trials[-1].config.alpha == 0.5 and trials[-1].config.max_episode_steps == 30


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("preset = 'best'", "preset"),
        ("seeds = []", "seeds"),
        ("colour = 1", "unknown keys"),
        ("[grid]\nalpah = [0.1]", "grid key 'alpah'"),
        ("[grid]\nalpha = 0.1", "non-empty list"),
        ("[grid]\nalpha = [2.0]", "alpha"),
        ("seeds = [0", "not valid TOML"),
        ("seeds = [-1]", "seeds"),
        ("seeds = [true]", "seeds"),
        ("overrides = 3", "overrides"),
        ("[grid]\nalpha = [0.5, 0.5]", "repeats"),
        ("[grid]\nalpha = [1, 1.0]", "same config"),
        # Values JSON cannot hold, or that cannot be compared: named (were a bare TypeError).
        ("episodes = 1979-05-27", r"episodes value datetime.date\(1979, 5, 27\) is not a number"),
        ("[grid]\nalpha = [[0.1]]", r"grid alpha value \[0.1\] is not a number, string"),
        ("[overrides]\nalpha = {a = 1}", r"alpha value \{'a': 1\} is not a number"),
    ],
)
def test_bad_sweep_files(text, match) -> None:
    with pytest.raises(ValueError, match=match):
        parse_sweep(text)


def test_local_sweep_resumes_and_records_failures(tmp_path, figures) -> None:
    spec = parse_sweep(SMALL)
    summary = run_sweep(spec, tmp_path)
    # The summary figure: each grid point's greedy median with its 25-75 % band over seeds.
    (ax,) = figures["summary.png"].axes
    (line,) = ax.get_lines()
    np.testing.assert_array_equal(line.get_xdata(), range(2))
    np.testing.assert_array_equal(line.get_ydata(), [p["greedy_median"] for p in summary["points"]])
    vertices = ax.collections[0].get_paths()[0].vertices
    assert vertices[:, 1].min() == min(p["greedy_q25"] for p in summary["points"])
    assert vertices[:, 1].max() == max(p["greedy_q75"] for p in summary["points"])
    assert ax.get_xlabel().startswith("grid point") and ax.get_ylabel() == "decisions from rest"
    runs = sorted((tmp_path / "trials").glob("*/run.json"))
    assert len(runs) == 4 and summary["trials"] == 4
    assert all(row["runs"] == 2 == row["held_out_runs"] for row in summary["points"])
    # Every finished trial has its held-out evaluation, and each point's row is their summary.
    row = summary["points"][0]
    evaluations = [
        json.loads((tmp_path / "trials" / f"{row['name']}__seed={s}" / "eval.json").read_text())
        for s in (0, 1)
    ]
    assert row["held_out_median"] == np.median(
        [e["summary"]["length"]["median"] for e in evaluations]
    )
    assert row["distinct_outcomes"]["held_out"] == len(
        {json.dumps(e["actions"]) for e in evaluations}
    )
    # Resume: finished trials are skipped (their files are not rewritten), a missing one reruns.
    stamps = {p: p.stat().st_mtime_ns for p in runs}
    victim = runs[3]
    victim.unlink()
    run_sweep(spec, tmp_path)
    assert victim.exists()
    assert all(p.stat().st_mtime_ns == t for p, t in stamps.items() if p != victim)
    for name in ("summary.json", "summary.md", "summary.png"):
        assert (tmp_path / name).exists()


def _trial_records(out) -> dict:
    keys = ("episode_lengths", "episode_returns", "greedy_from_rest", "lockstep")
    runs = sorted((out / "trials").glob("*/run.json"))
    return {p.parent.name: {k: json.loads(p.read_text()).get(k) for k in keys} for p in runs}


@pytest.mark.slow
def test_a_grid_points_seeds_go_in_lockstep_from_a_group_size_or_when_asked(
    tmp_path, monkeypatch
) -> None:
    # Two seeds a point: one by one at the default threshold, together when it is two or when
    # asked; the same records and weights either way.
    assert LOCKSTEP_GROUP_FROM > 2
    spec = parse_sweep(SMALL)
    summaries = {"apart": run_sweep(spec, tmp_path / "apart", options=RunOptions(jobs=1))}
    summaries["asked"] = run_sweep(spec, tmp_path / "asked", options=RunOptions(lockstep=True))
    monkeypatch.setattr(lockstep_module, "LOCKSTEP_GROUP_FROM", 2)
    summaries["threshold"] = run_sweep(spec, tmp_path / "threshold")
    apart = _trial_records(tmp_path / "apart")
    assert len(apart) == 4 and {r["lockstep"] for r in apart.values()} == {None}
    for way in ("asked", "threshold"):
        together = _trial_records(tmp_path / way)
        assert together.keys() == apart.keys(), way
        for name, record in together.items():
            assert record["lockstep"] == 2  # each point's seeds
            assert {**record, "lockstep": None} == apart[name], (way, name)
            weights = [
                load_checkpoint(tmp_path / run / "trials" / name / CHECKPOINT_FILE)[1]["q"]
                for run in (way, "apart")
            ]
            np.testing.assert_array_equal(*weights)  # bit for bit
    for summary in summaries.values():
        assert all(row["runs"] == 2 for row in summary["points"])


#: Tabular SARSA has a lockstep form, Sarsa(lambda) none (one process per seed is faster).
MIXED = SMALL.replace("alpha = [0.1, 0.5]", 'algorithm = ["sarsa", "sarsa_lambda"]')
MIXED = MIXED.replace("frame_skip = [4]\n", "")


@pytest.mark.parametrize(
    ("options", "says"),
    [
        ({"address": "auto"}, "--address is for --backend ray, not local"),
        ({"ray_num_cpus": 2}, "--num-cpus is for --backend ray, not local"),
        (
            {"backend": "ray", "options": RunOptions(jobs=2)},
            "--jobs is for --backend local, not ray",
        ),
        # Nothing listens on port 1: refused at once (Ray retried for over 300 s).
        ({"backend": "ray", "address": "127.0.0.1:1"}, "no Ray cluster answers at 127.0.0.1:1"),
        # A cluster has its own CPUs: once ignored, now refused.
        (
            {"backend": "ray", "address": "auto", "ray_num_cpus": 2},
            "--num-cpus sizes a local Ray instance: give no --address",
        ),
    ],
)
def test_a_sweep_refuses_options_of_the_other_backend(tmp_path, options, says) -> None:
    with pytest.raises((ValueError, ConnectionError), match=says):
        run_sweep(parse_sweep(SMALL), tmp_path / "s", **options)
    assert not (tmp_path / "s").exists()  # nothing written


def test_a_lockstep_sweep_refuses_what_cannot_go_in_lockstep(tmp_path, capsys) -> None:
    match = r"grid point algorithm=sarsa_lambda: lockstep training needs"
    with pytest.raises(ValueError, match=match):
        run_sweep(parse_sweep(MIXED), tmp_path / "a", options=RunOptions(lockstep=True))
    with pytest.raises(ValueError, match="lockstep sweeps run on the local backend"):
        run_sweep(
            parse_sweep(SMALL), tmp_path / "b", backend="ray", options=RunOptions(lockstep=True)
        )
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()  # nothing written
    sweep = tmp_path / "mixed.toml"
    sweep.write_text(MIXED)
    with pytest.raises(SystemExit) as stop:  # the CLI: one line, exit 2
        main(["sweep", str(sweep), "--lockstep", "--out", str(tmp_path / "c")])
    err = capsys.readouterr().err
    assert stop.value.code == 2 and "grid point algorithm=sarsa_lambda" in err
    assert len(err.strip().splitlines()) == 1 and not (tmp_path / "c").exists()


def test_a_failing_trial_is_recorded_and_the_others_finish(tmp_path, monkeypatch) -> None:
    # Sarsa(lambda) trials run one by one (jobs=1: in this process); make seed 1 fail in its own.
    sweep = tmp_path / "s.toml"
    sweep.write_text(
        'preset = "book"\nepisodes = 1\nmax_episode_steps = 50\nseeds = [0, 1, 2]\n'
        "[grid]\nlam = [0.9]\n"
    )
    spec = load_sweep(sweep)
    import acrobot_mj.train.sweep as sweep_module

    original = sweep_module.run_trial

    def flaky(config, seed, run_dir):
        if seed == 1:
            config = {**config, "alpha": -1.0}  # refused by TrainConfig: a real failure
        return original(config, seed, run_dir)

    monkeypatch.setattr(sweep_module, "run_trial", flaky)
    summary = sweep_module.run_sweep(spec, tmp_path / "out", options=RunOptions(jobs=1))
    trials = tmp_path / "out" / "trials"
    error = json.loads((trials / "lam=0.9__seed=1" / "error.json").read_text())
    assert "alpha" in error["error"]
    assert (trials / "lam=0.9__seed=0" / "run.json").exists()
    assert (trials / "lam=0.9__seed=2" / "run.json").exists()
    assert summary["points"][0]["failed_seeds"] == [1] and summary["points"][0]["runs"] == 2


@pytest.mark.slow
def test_tiny_sweep_on_a_local_ray_instance(tmp_path) -> None:
    if importlib.util.find_spec("ray") is None:
        pytest.skip("needs the ray extra")
    sweep = tmp_path / "tiny.toml"
    sweep.write_text(SMALL)
    out = tmp_path / "ray"
    # The command as a user runs it, watched from outside: what listens while Ray runs.
    command = ["sweep", str(sweep), "--backend", "ray", "--num-cpus", "2", "--out", str(out)]
    before, seen = listening(), set()
    child = subprocess.Popen(
        [sys.executable, "-m", "acrobot_mj_main", *command],
        cwd=tmp_path,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    while child.poll() is None:
        seen |= listening() - before
        time.sleep(0.1)
    stdout, stderr = child.communicate()
    assert child.returncode == 0, stderr[-2000:]
    assert "4 trials" in stdout
    # Ray's servers (GCS, raylet, workers) listened on every interface: 127.0.0.1 only now.
    assert seen and all(address.startswith(LOOPBACK) for address in seen), seen
    runs = sorted((out / "trials").glob("*/run.json"))
    assert len(runs) == 4  # one run record per trial
    assert {json.loads(p.read_text())["seed"] for p in runs} == {0, 1}
    # Evaluated on the workers (no checkpoints come back), written by the driver.
    for run in runs:
        evaluation = json.loads(run.with_name("eval.json").read_text())
        assert evaluation["run"] == str(run.parent) and len(evaluation["start_states"]) == 100
        assert not run.with_name("checkpoint.npz").exists()


def test_a_changed_sweep_does_not_reuse_another_sweeps_trials(tmp_path) -> None:
    one = 'preset = "report"\nepisodes = 2\nmax_episode_steps = 30\nseeds = [0]\n'  # one trial
    run_sweep(parse_sweep(one), tmp_path, options=RunOptions(jobs=1))
    changed = parse_sweep(one.replace("episodes = 2", "episodes = 3"))
    with pytest.raises(ValueError, match="another sweep's trial"):
        run_sweep(changed, tmp_path)
