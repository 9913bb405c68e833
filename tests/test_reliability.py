"""Nothing lost or silently wrong when runs are interrupted, shared, diverge or meet bad input.

The interruption tests send real signals to real ``acrobot-mj`` processes. A child started from a
non-interactive shell's background job inherits SIGINT ignored, and Python then never raises
KeyboardInterrupt, so each child gets SIGINT back at its default before it starts.
"""

from __future__ import annotations

import contextlib
import ctypes
import io
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
import zipfile
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

from acrobot_mj.cli import main
from acrobot_mj.envs.rollout import PolicyActor, run_episode
from acrobot_mj.files import is_sealed, write_json
from acrobot_mj.stops import clear_stop, raise_stop
from acrobot_mj.train.checkpoint import (
    CheckpointError,
    Checkpoints,
    load_checkpoint,
    read_history,
    save_checkpoint,
)
from acrobot_mj.train.config import TrainConfig
from acrobot_mj.train.presets import PRESETS
from acrobot_mj.train.records import CHECKPOINT_FILE, History
from acrobot_mj.train.run import RunOptions
from acrobot_mj.train.sweep_file import parse_sweep
from acrobot_mj.train.trainer import load_learner, train

ROOT = Path(__file__).resolve().parents[1]
#: A Sarsa(lambda) run long enough (several seconds) to be interrupted in the middle.
LONG = ["train", "--preset", "book", "--episodes", "2000", "--no-progress"]


def start(args: list[str], cwd: Path, new_group: bool = False, **env: str) -> subprocess.Popen:
    """``acrobot-mj ARGS`` in a new process, SIGINT at its default (``new_group``: in a process
    group of its own, whose id is its pid)."""
    return subprocess.Popen(
        [sys.executable, "-m", "acrobot_mj_main", *args],
        cwd=cwd,
        env={**os.environ, "PYTHONPATH": str(ROOT), **env},
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
        start_new_session=new_group,
    )


def wait_for(path: Path, timeout: float = 60.0) -> None:
    """Until ``path`` exists (a run's first checkpoint: it is well under way)."""
    deadline = time.monotonic() + timeout
    while not path.exists():
        assert time.monotonic() < deadline, f"{path} never appeared"
        time.sleep(0.05)


def processes_with(text: str) -> list[int]:
    """Pids of the live processes whose command line contains ``text``."""
    pids = []
    for proc in Path("/proc").glob("[0-9]*"):
        try:
            if text in (proc / "cmdline").read_bytes().decode(errors="replace"):
                pids.append(int(proc.name))
        except OSError:
            continue
    return pids


# -- interruption ---------------------------------------------------------------------------


@pytest.fixture(scope="module")
def book_400() -> dict:
    """The run record of the book preset's first 400 episodes, without a break."""
    return train(PRESETS["book"].replace(episodes=400, checkpoint_every=100), seed=0)


@pytest.mark.slow
@pytest.mark.parametrize(("sig", "code"), [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_an_interrupted_run_saves_and_resumes_to_the_same_result(
    tmp_path, sig, code, book_400
) -> None:
    # Interrupted soon after its first checkpoint (episode 100 of 5000), then resumed to 400
    # episodes: the same run as 400 episodes without a break.
    args = ["train", "--preset", "book", "--checkpoint-every", "100", "--no-progress"]
    child = start([*args, "--episodes", "5000", "--out", "run"], tmp_path)
    wait_for(tmp_path / "run" / "checkpoint.npz")
    child.send_signal(sig)
    _, err = child.communicate(timeout=60)
    assert child.returncode == code, err
    assert "checkpoint saved" in err and "--resume" in err
    record = json.loads((tmp_path / "run" / "run.json").read_text())
    assert record["interrupted"] is True and 100 <= record["episodes_done"] < 400
    assert not list((tmp_path / "run").glob(".*.tmp"))  # no half-written file left
    resume = [*args, "--episodes", "400", "--out", str(tmp_path / "run"), "--resume"]
    assert main(resume) == 0
    resumed = json.loads((tmp_path / "run" / "run.json").read_text())
    for key in ("episode_lengths", "episode_returns", "greedy_from_rest"):
        assert resumed[key] == book_400[key], key


@pytest.mark.slow
def test_a_stop_at_any_moment_leaves_the_state_of_its_last_episode(tmp_path) -> None:
    # A stop raised between a weight update and its record left weights that no uninterrupted
    # run has (5 of 13 stops, up to 2.6e-5 apart), or run.json one episode ahead of the
    # checkpoint. Stops now land between episodes: the checkpoint is the uninterrupted run's.
    # Each stop lands a while after the run's first checkpoint (training under way, however
    # slow the machine is to start it: fixed delays from the launch once landed before it).
    checked = 0
    for i, delay in enumerate((0.0, 0.2, 0.4, 0.6, 0.8, 1.0)):
        out = tmp_path / f"run{i}"
        child = start([*LONG, "--episodes", "3000", "--seed", "5", "--out", str(out)], tmp_path)
        wait_for(out / CHECKPOINT_FILE)
        time.sleep(delay)
        child.send_signal(signal.SIGINT if i % 2 else signal.SIGTERM)
        child.communicate(timeout=60)
        if not (out / CHECKPOINT_FILE).exists():
            continue  # stopped before training began
        meta, arrays = load_checkpoint(out / CHECKPOINT_FILE)
        done = meta["episodes_done"]
        assert json.loads((out / "run.json").read_text())["episodes_done"] == done
        if done == 0:
            continue
        train(
            PRESETS["book"].replace(episodes=done),
            5,
            tmp_path / "alone",
            options=RunOptions(overwrite=True),
        )
        alone = load_checkpoint(tmp_path / "alone" / CHECKPOINT_FILE)[1]
        for key in ("w", "stream.block", "stream.next"):
            np.testing.assert_array_equal(arrays[key], alone[key], err_msg=f"{key} at {delay} s")
        checked += 1
    assert checked >= 3  # most stops landed in training


@pytest.mark.slow
@pytest.mark.parametrize("stop", [signal.SIGINT, signal.SIGTERM])
def test_a_stop_during_the_greedy_run_after_training_writes_the_record(tmp_path, stop) -> None:
    """The greedy episode from rest after training (here a million decisions, about 20 s) once
    held every stop to its end (with 1e9 decisions only SIGKILL stopped it, leaving no
    run.json). Now it stops within 2 s (one second of it the learning curve's figure), the run
    recorded as interrupted, and --resume runs the greedy episode again."""
    args = ["train", "--episodes", "1", "--max-episode-steps", "1000000", "--no-progress"]
    child = start([*args, "--out", "r"], tmp_path)
    wait_for(tmp_path / "r" / CHECKPOINT_FILE)  # trained: the greedy episode has begun
    time.sleep(1.0)
    stopped = time.monotonic()
    child.send_signal(stop)
    _, err = child.communicate(timeout=30)
    assert time.monotonic() - stopped < 4.0, err  # 2 s on an idle machine; loaded, twice that
    assert child.returncode == (130 if stop == signal.SIGINT else 143), err
    assert "continue with --resume" in err and err.count("\n") == 1, err
    assert json.loads((tmp_path / "r" / "run.json").read_text())["interrupted"] is True


@pytest.mark.slow
def test_an_interrupted_run_of_several_seeds_resumes_every_seed(tmp_path) -> None:
    # Ctrl-C while seed 1 of 3 trains (1,000 episodes, about 2 s a seed): seed 0 is done, seed 2
    # never started. --resume finishes the run, each seed as the uninterrupted run of that seed.
    args = ["train", "--preset", "book", "--seeds", "3", "--episodes", "1000", "--no-progress"]
    child = start([*args, "--out", "multi"], tmp_path)
    wait_for(tmp_path / "multi" / "seed_1" / "checkpoint.npz")
    child.send_signal(signal.SIGINT)
    _, err = child.communicate(timeout=60)
    assert child.returncode == 130 and "--resume" in err, err
    assert not (tmp_path / "multi" / "seed_2" / "checkpoint.npz").exists()
    assert main([*args, "--out", str(tmp_path / "multi"), "--resume"]) == 0
    for seed in range(3):
        record = json.loads((tmp_path / "multi" / f"seed_{seed}" / "run.json").read_text())
        alone = train(PRESETS["book"].replace(episodes=1000), seed)
        for key in ("episode_lengths", "episode_returns", "greedy_from_rest"):
            assert record[key] == alone[key], (seed, key)
    assert json.loads((tmp_path / "multi" / "summary.json").read_text())["seeds"] == [0, 1, 2]


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_a_stop_at_any_moment_of_the_start_is_one_line_and_its_exit_code(tmp_path, sig) -> None:
    # From the first instant (the package loads for about a second, numba's cache after it) to
    # the first episodes: never a traceback, never a stop lost (a signal that lands while numba
    # loads compiled code is raised in a C callback that drops it), and the signal's exit code.
    # Before Python runs the command's first line, the signal's default ends it, silently.
    for i, delay in enumerate((0.0, 0.2, 0.5, 0.8, 1.1, 1.4, 1.8)):
        child = start([*LONG, "--out", f"run{i}"], tmp_path)
        time.sleep(delay)
        child.send_signal(sig)
        _, err = child.communicate(timeout=60)
        quiet = child.returncode == -sig and err == ""
        assert quiet or (child.returncode == 128 + sig and len(err.splitlines()) == 1), (delay, err)


def test_a_stop_dropped_in_a_c_callback_is_raised_at_the_next_episode(monkeypatch) -> None:
    # ctypes reports an exception raised in a callback and drops it (numba's cache loader is one):
    # the stop is kept, and the episode loop raises it before its next episode.
    dropped = []
    monkeypatch.setattr(sys, "unraisablehook", dropped.append)
    callback = ctypes.CFUNCTYPE(None)(lambda: raise_stop(KeyboardInterrupt("dropped")))
    callback()
    assert len(dropped) == 1  # it did not propagate
    env = gym.make("acrobot_mj/Acrobot-v0")
    try:
        with pytest.raises(KeyboardInterrupt, match="dropped"):
            run_episode(env, PolicyActor(lambda obs: 1))
    finally:
        clear_stop()
    assert run_episode(env, PolicyActor(lambda obs: 1), max_steps=3).length == 3


@pytest.mark.slow
def test_seeds_in_worker_processes_stop_save_and_refuse_a_trainer_inside(tmp_path) -> None:
    # --seeds 2 --jobs 2: a worker per seed. A trainer pointed at a seed's directory is refused
    # (the driver holds the run), and a Ctrl-C to the whole process group (as a terminal sends
    # it) stops the run without a traceback, each seed saved as interrupted.
    args = [*LONG, "--episodes", "20000", "--seeds", "2", "--jobs", "2", "--out", "multi"]
    child = start(args, tmp_path, new_group=True)
    for k in (0, 1):
        wait_for(tmp_path / "multi" / f"seed_{k}" / "checkpoint.npz")
    inside = tmp_path / "multi" / "seed_1"
    other = _cli(
        ["train", "--preset", "book", "--episodes", "1", "--force", "--out", str(inside)], tmp_path
    )
    assert other.returncode == 2 and len(other.stderr.splitlines()) == 1, other.stderr
    assert "is inside" in other.stderr and f"pid {child.pid}" in other.stderr
    stopped = time.monotonic()
    os.killpg(child.pid, signal.SIGINT)
    _, err = child.communicate(timeout=60)
    assert time.monotonic() - stopped < 10 and child.returncode == 130, err
    assert "Traceback" not in err and "--resume" in err
    for k in (0, 1):
        record = json.loads((tmp_path / "multi" / f"seed_{k}" / "run.json").read_text())
        assert record["interrupted"] is True and record["episodes_done"] < 20000
    time.sleep(1)
    assert processes_with(str(tmp_path / "multi")) == []  # no worker left behind


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_the_balance_command_stops_within_seconds_while_it_optimises(tmp_path, sig) -> None:
    pytest.importorskip("casadi")
    child = start(["balance", "--no-video", "--reserve", "0.5", "--out", "b"], tmp_path)
    time.sleep(4)  # the package and CasADi loaded, IPOPT at work
    stopped = time.monotonic()
    child.send_signal(sig)
    _, err = child.communicate(timeout=60)
    assert time.monotonic() - stopped < 5, err  # the docs promise about a second
    assert child.returncode == 128 + sig and len(err.strip().splitlines()) == 1, err


@pytest.mark.slow
@pytest.mark.parametrize(("sig", "moment"), [(signal.SIGINT, 8.0), (signal.SIGTERM, 3.0)])
def test_the_swing_up_search_stopped_from_its_group_ends_within_2_s_in_one_line(
    tmp_path, sig, moment
) -> None:
    # A terminal's stop reaches the workers too: they ran the CLI's stop handler while idle in
    # the pool's queue (two tracebacks), and the stop took 13-25 s or hung.
    pytest.importorskip("casadi")
    out = str(tmp_path / "search")
    child = start(["balance", "--no-video", "--reserve", "0.5", "--out", out], tmp_path, True)
    try:
        time.sleep(moment)
        stopped = time.monotonic()
        os.killpg(child.pid, sig)
        _, err = child.communicate(timeout=60)
    finally:  # a hung driver and its workers do not outlive the test
        with contextlib.suppress(ProcessLookupError):
            os.killpg(child.pid, signal.SIGKILL)
    assert time.monotonic() - stopped < 2, err
    assert child.returncode == 128 + sig and len(err.strip().splitlines()) == 1, err
    assert "Traceback" not in err
    time.sleep(0.5)
    assert processes_with(out) == []  # no worker left behind


def _double(x: int, seconds: float) -> int:
    time.sleep(seconds)
    return 2 * x


def _die(code: int) -> None:
    os._exit(code)


def _deaf(seconds: float) -> None:
    """As a call in C code: no stop handler runs until it returns."""
    signal.pthread_sigmask(signal.SIG_BLOCK, [signal.SIGUSR1, signal.SIGTERM])
    time.sleep(seconds)


class _Alarm(Exception):
    pass


def _alarm(signum, frame) -> None:
    raise _Alarm


def test_a_pool_maps_in_order_and_a_worker_that_dies_fails_only_its_call() -> None:
    from concurrent.futures.process import BrokenProcessPool

    from acrobot_mj.pool import WorkerPool

    with WorkerPool(2) as pool:
        assert list(pool.map(_double, [(1, 0.3), (2, 0.0), (3, 0.0)])) == [2, 4, 6]
        futures = list(pool.run(_die, [(3,)]))
        with pytest.raises(BrokenProcessPool, match="exit code 3"):
            futures[0].result()
        # The other worker holds no lock the dead one took: the pool goes on.
        assert list(pool.map(_double, [(4, 0.0), (5, 0.0)])) == [8, 10]


def test_a_terminating_pool_stops_calls_stuck_in_c_code_at_once() -> None:
    from acrobot_mj.pool import WorkerPool

    before = signal.signal(signal.SIGALRM, _alarm)
    pool = WorkerPool(2, terminate=True)
    stopped = time.monotonic()
    try:
        signal.setitimer(signal.ITIMER_REAL, 0.5)
        with pytest.raises(_Alarm), pool:
            list(pool.map(_deaf, [(30.0,), (30.0,)]))
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, before)
    assert time.monotonic() - stopped < 2
    assert all(not w.process.is_alive() for w in pool._workers)


def test_a_lockstep_resume_starts_a_seed_that_never_reached_a_checkpoint(tmp_path) -> None:
    # Seed 0 stopped after 2 of 4 episodes, seed 1 never started: resumed together, both end as
    # the uninterrupted lockstep run of both (their Q tables equal, bit for bit).
    from acrobot_mj.train.lockstep import train_lockstep

    config = PRESETS["report"].replace(episodes=4)
    train_lockstep(config, [0, 1], tmp_path / "whole")
    train_lockstep(config.replace(episodes=2), [0], tmp_path / "part")
    assert not (tmp_path / "part" / "seed_1").exists()
    train_lockstep(config, [0, 1], tmp_path / "part", options=RunOptions(resume=True))
    for seed in (0, 1):
        mine, theirs = (
            load_checkpoint(tmp_path / run / f"seed_{seed}" / CHECKPOINT_FILE)
            for run in ("part", "whole")
        )
        assert mine[0]["episodes_done"] == theirs[0]["episodes_done"] == 4
        assert mine[1].keys() == theirs[1].keys()
        assert all(np.array_equal(mine[1][k], theirs[1][k]) for k in mine[1])


@pytest.mark.slow
def test_a_resume_killed_after_adding_episodes_leaves_a_usable_run(tmp_path, exits) -> None:
    # A finished 2-episode run, evaluated; resumed to 20,000 episodes and killed (-9) once its
    # checkpoint has moved on. run.json said "interrupted": false with the old config, and
    # evaluate and render refused the run (the configs disagreed); eval.json was stale.
    run = tmp_path / "run"
    assert exits(["train", "--preset", "book", "--episodes", "2", "--out", str(run)]) == 0
    assert exits(["evaluate", str(run), "--episodes", "1"]) == 0
    args = ["train", "--preset", "book", "--episodes", "20000", "--no-progress", "--resume"]
    child = start([*args, "--out", "run"], tmp_path)
    deadline = time.monotonic() + 60
    while load_checkpoint(run / "checkpoint.npz")[0]["episodes_done"] == 2:
        assert time.monotonic() < deadline, "the resumed run never saved a checkpoint"
        time.sleep(0.05)
    child.kill()
    child.communicate(timeout=30)
    record = json.loads((run / "run.json").read_text())
    assert record["interrupted"] is True and record["config"]["episodes"] == 20000
    assert not (run / "eval.json").exists()  # it evaluated the 2-episode agent
    assert exits(["evaluate", str(run), "--episodes", "1"]) == 0
    assert exits(["render", str(run), "--steps", "3", "--out", str(tmp_path / "v.mp4")]) == 0


def test_training_again_removes_the_evaluation_of_what_it_replaces(trained, exits) -> None:
    assert exits(["evaluate", str(trained), "--episodes", "1"]) == 0
    assert is_sealed(json.loads((trained / "eval.json").read_text()))  # edits can be told
    args = ["train", "--preset", "book", "--episodes", "1", "--out", str(trained)]
    assert exits([*args, "--force"]) == 0  # another preset over the run: eval.json was stale
    assert not (trained / "eval.json").exists()
    assert exits(["evaluate", str(trained), "--episodes", "1"]) == 0
    assert exits([*args[:4], "3", "--out", str(trained), "--resume"]) == 0  # more episodes
    assert not (trained / "eval.json").exists()


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), -float("inf")])
def test_no_record_holds_nan_or_infinity(tmp_path, bad) -> None:
    # Strict JSON readers refuse them: a record refuses them, and nothing is left behind.
    with pytest.raises(ValueError, match=r"NaN|infinit"):
        write_json(tmp_path / "r.json", {"summary": {"median": bad}})
    assert list(tmp_path.iterdir()) == []


def complete_lines(path: Path) -> list[dict]:
    """The episode log's complete lines (a line a kill cut short is not one)."""
    lines = path.read_bytes().splitlines(keepends=True)
    return [json.loads(line) for line in lines if line.endswith(b"\n")]


@pytest.mark.slow
def test_a_killed_run_keeps_every_logged_episode_and_resumes_without_duplicates(tmp_path):
    args = ["train", "--preset", "book", "--checkpoint-every", "100", "--no-progress"]
    child = start([*args, "--episodes", "5000", "--out", "run"], tmp_path)
    log, checkpoint = tmp_path / "run" / "episodes.jsonl", tmp_path / "run" / "checkpoint.npz"
    wait_for(checkpoint)
    # The log grows while the run goes on, episode by episode, between checkpoints.
    seen = [len(complete_lines(log))]
    deadline = time.monotonic() + 60
    while seen[-1] < 130 or len(seen) < 3:
        assert time.monotonic() < deadline, f"the log stopped growing at {seen[-1]} lines"
        time.sleep(0.05)
        if len(complete_lines(log)) > seen[-1]:
            seen.append(len(complete_lines(log)))
    child.kill()  # kill -9: nothing saved on the way out
    child.communicate(timeout=30)
    assert child.returncode == -signal.SIGKILL
    before = complete_lines(log)
    counted = load_checkpoint(checkpoint)[0]["episodes_done"]
    # Lines appeared between checkpoints (written every 100 episodes), not 100 at a time.
    assert any(n % 100 for n in seen), seen
    assert counted % 100 == 0 and counted <= len(before)
    assert [row["episode"] for row in before] == list(range(len(before)))
    with open(log, "a") as f:
        f.write('{"episode": 99999, "len')  # as if killed in the middle of a line
    # The half line does not break reading back the episodes the checkpoint counts.
    meta = load_checkpoint(checkpoint)[0]
    assert read_history(checkpoint, meta).episode_lengths == [r["length"] for r in before[:counted]]
    inode = log.stat().st_ino
    episodes = counted + 150  # past every episode logged before the kill
    assert episodes > len(before)
    resume = [*args, "--episodes", str(episodes), "--out", str(tmp_path / "run"), "--resume"]
    assert main(resume) == 0
    after = complete_lines(log)
    assert log.read_bytes().endswith(b"\n")  # the half line is gone
    assert log.stat().st_ino != inode  # cut back by writing a new file and renaming it
    assert [row["episode"] for row in after] == list(range(episodes))  # each once, in order
    assert after[:counted] == before[:counted]  # the counted lines kept as they were
    # The episodes the kill lost from the checkpoint ran again, to the same results.
    same = ("length", "return", "success")
    for old, new in zip(before[counted:], after[counted : len(before)], strict=True):
        assert [old[k] for k in same] == [new[k] for k in same]
    record = json.loads((tmp_path / "run" / "run.json").read_text())
    assert record["episode_lengths"] == [row["length"] for row in after]
    assert record["episode_returns"] == [row["return"] for row in after]
    assert record["episode_successes"] == [row["success"] for row in after]


#: Four Sarsa(lambda) trials of a few seconds each, two at a time, checkpointed early (every 10
#: episodes: a trial is well under way at its first).
SWEEP = """
preset = "book"
episodes = 400
checkpoint_every = 10
seeds = [0, 1, 2, 3]
[grid]
lam = [0.9]
"""


@pytest.mark.slow
def test_ctrl_c_stops_a_sweep_promptly_and_a_rerun_finishes_it(tmp_path) -> None:
    (tmp_path / "s.toml").write_text(SWEEP)
    args = ["sweep", "s.toml", "--jobs", "2", "--out", "sw"]
    child = start(args, tmp_path)
    wait_for(tmp_path / "sw" / "trials" / "lam=0.9__seed=0" / "checkpoint.npz")
    stopped = time.monotonic()
    child.send_signal(signal.SIGINT)
    _, err = child.communicate(timeout=60)
    # The docs promise about a second; 10 s leaves room for a loaded machine. The counts below
    # show that the queued trials did not run.
    assert time.monotonic() - stopped < 10
    assert child.returncode == 130, err
    assert "sweep interrupted" in err and "unfinished" in err
    summary = json.loads((tmp_path / "sw" / "summary.json").read_text())
    assert summary["unfinished"] == 4  # two were running, two queued and cancelled
    trials = tmp_path / "sw" / "trials"
    running = [json.loads(p.read_text()) for p in trials.glob("*/run.json")]
    assert len(running) == 2 and all(r["interrupted"] for r in running)  # saved, unfinished
    assert len(list(trials.glob("*/checkpoint.npz"))) == 2
    time.sleep(1)
    assert processes_with(str(tmp_path / "sw")) == []  # no worker left behind
    # Again: the interrupted trials continue from their checkpoints, and say so.
    again = start(args, tmp_path)
    _, err = again.communicate(timeout=300)
    assert again.returncode == 0, err
    assert "running lam=0.9__seed=0 again: its record says it stopped after" in err
    summary = json.loads((tmp_path / "sw" / "summary.json").read_text())
    assert summary["unfinished"] == 0 and summary["points"][0]["runs"] == 4


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
@pytest.mark.parametrize("to_group", [False, True], ids=["driver", "group"])
def test_a_sweep_with_idle_workers_stops_at_once_without_tracebacks(tmp_path, sig, to_group):
    # One trial and --jobs 4: three workers idle. Interrupting an idle worker inside the pool's
    # queue hung the pool (4 of 6 tries, a Ctrl-C to the driver) and printed its traceback.
    (tmp_path / "one.toml").write_text('preset = "report"\nepisodes = 2000\nseeds = [0]\n')
    args = ["sweep", "one.toml", "--jobs", "4", "--out", "hj", "--no-progress"]
    child = start(args, tmp_path, new_group=True)
    wait_for(tmp_path / "hj" / "trials" / "base__seed=0" / "checkpoint.npz")
    (os.killpg if to_group else os.kill)(child.pid, sig)
    _, err = child.communicate(timeout=60)  # a hang fails here; a stop takes about 1 s
    assert child.returncode == 128 + sig, err
    assert "Traceback" not in err and "sweep interrupted" in err, err
    time.sleep(1)
    assert processes_with(str(tmp_path / "hj")) == []  # no worker left behind
    # The running trial saved what it had, as interrupted: its workers stopped, not died.
    record = json.loads((tmp_path / "hj" / "trials" / "base__seed=0" / "run.json").read_text())
    assert record["interrupted"] is True and 0 < record["episodes_done"] < 2000


@pytest.mark.slow
def test_a_sweep_leaves_a_trial_directory_another_process_trains_in(tmp_path, capsys) -> None:
    # The sweep wrote its error.json into the other run's directory, where it stayed.
    from acrobot_mj.train.sweep import run_sweep

    trial = tmp_path / "sw" / "trials" / "base__seed=0"
    child = start([*LONG, "--out", str(trial)], tmp_path)
    try:
        wait_for(trial / "checkpoint.npz")
        spec = parse_sweep('preset = "report"\nepisodes = 2\nseeds = [0]\n')
        summary = run_sweep(spec, tmp_path / "sw", options=RunOptions(jobs=1))
        assert "sweep: trial base__seed=0 left unfinished:" in capsys.readouterr().err
        assert summary["unfinished"] == 1 and not (trial / "error.json").exists()
    finally:
        child.kill()
        child.communicate(timeout=30)


@pytest.mark.slow
def test_workers_stop_with_a_killed_sweep_driver(tmp_path) -> None:
    (tmp_path / "s.toml").write_text(SWEEP.replace("episodes = 400", "episodes = 5000"))
    child = start(["sweep", "s.toml", "--jobs", "2", "--out", "sw"], tmp_path)
    trial = tmp_path / "sw" / "trials" / "lam=0.9__seed=0"
    wait_for(trial / "checkpoint.npz")
    # The sweep holds its running trial's directory: --force does not take it.
    other = _cli(
        ["train", "--preset", "book", "--episodes", "1", "--force", "--out", str(trial)], tmp_path
    )
    assert other.returncode == 2 and "in use by" in other.stderr, other.stderr
    assert len(other.stderr.splitlines()) == 1
    child.kill()  # kill -9: the driver cannot tell anyone
    child.communicate(timeout=30)
    deadline = time.monotonic() + 30
    while processes_with(str(tmp_path / "sw")) and time.monotonic() < deadline:
        time.sleep(0.2)
    assert processes_with(str(tmp_path / "sw")) == []
    # Each of the two running workers saved what it had before it went.
    runs = list((tmp_path / "sw" / "trials").glob("*/run.json"))
    assert len(runs) == 2 and all(json.loads(r.read_text())["interrupted"] for r in runs)


# -- one owner per run directory -----------------------------------------------------------


@pytest.mark.slow
def test_two_trainers_on_one_directory_one_is_refused(tmp_path) -> None:
    first = start([*LONG, "--episodes", "300", "--out", "run"], tmp_path)
    wait_for(tmp_path / "run" / ".lock")
    time.sleep(0.5)
    second = start([*LONG, "--seed", "1", "--episodes", "300", "--force", "--out", "run"], tmp_path)
    _, err2 = second.communicate(timeout=120)
    _, err1 = first.communicate(timeout=120)
    assert first.returncode == 0, err1
    assert second.returncode == 2 and f"is in use by pid {first.pid}" in err2  # --force too
    assert f"on {socket.gethostname()} (train, since " in err2  # the lock's record, named
    learner = load_learner(tmp_path / "run")  # run.json and checkpoint agree
    assert learner.seed == 0 and learner.config.episodes == 300


def test_a_dead_owners_lock_and_temporaries_are_taken_over(tmp_path, capsys) -> None:
    run = tmp_path / "run"
    run.mkdir()
    dead = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True
    ).stdout.strip()
    (run / ".lock").write_text(json.dumps({"pid": int(dead), "host": "h", "started": 0}))
    (run / f".checkpoint.npz.{dead}.tmp").write_bytes(b"half a zip")
    (run / f".vid.{dead}.tmp.mp4").write_bytes(b"a killed render's video")
    (run / f".vid.{os.getpid()}.tmp.mp4").write_bytes(b"a live process's: kept")
    (run / ".notes.tmp.txt").write_bytes(b"no pid: not ours, kept")
    config = PRESETS["report"].replace(episodes=2, max_episode_steps=20)
    train(config, seed=0, out_dir=run)
    assert f"taking over {run} from pid {dead}" in capsys.readouterr().err
    assert not list(run.glob(".*.tmp")) and (run / ".lock").read_text() == ""
    kept = {p.name for p in run.glob(".*.tmp.*")}
    assert kept == {f".vid.{os.getpid()}.tmp.mp4", ".notes.tmp.txt"}


# -- divergence ----------------------------------------------------------------------------


def test_a_diverging_learner_stops_with_the_cause_and_a_finite_checkpoint(tmp_path, exits, capsys):
    out = tmp_path / "run"
    code = exits(["train", "--preset", "book", "--alpha", "0.2", "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2
    assert "sarsa_lambda diverged in episode" in err and "alpha=0.2 is per weight" in err
    assert "48 features are active" in err and len(err.strip().splitlines()) == 1
    # The checkpoint is the last finite state: it loads (agents refuse non-finite values).
    config = load_learner(out).config
    assert load_checkpoint(out / "checkpoint.npz")[0]["episodes_done"] >= 1
    assert config.alpha == 0.2 and not (out / "run.json").exists()
    assert err.strip().endswith(
        f"; {out / 'checkpoint.npz'} keeps the state after episode "
        f"{load_checkpoint(out / 'checkpoint.npz')[0]['episodes_done']}"
    )


@pytest.mark.parametrize("target", ["run.json", "missing.json"])  # a loop; a dangling link
def test_a_run_json_that_is_a_broken_link_is_refused_not_skipped(trained, target, exits, capsys):
    # A symlink loop made run.json "not exist", so the check of the checkpoint against it was
    # skipped and the run evaluated as if it had no record.
    (trained / "run.json").unlink()
    (trained / "run.json").symlink_to(target)
    assert exits(["evaluate", str(trained), "--episodes", "1"]) == 2
    err = capsys.readouterr().err.strip()
    assert f"{trained / 'run.json'} is not a readable run record" in err, err
    assert len(err.splitlines()) == 1 and not (trained / "eval.json").exists()


def test_a_diverging_population_names_the_learner_and_its_checkpoint(tmp_path, exits, capsys):
    # It named only the learner's own seed (drawn from the run's) and "the checkpoint", which
    # is the learner's, not the run's (there is none at the top until the population ends).
    out = tmp_path / "run"
    args = ["train", "--preset", "book", "--population", "3", "--alpha", "0.2"]
    assert exits([*args, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert "error: learner 0 of 3 of run seed 0: sarsa_lambda diverged in episode" in err, err
    checkpoint = out / "learner_0" / "checkpoint.npz"
    assert f"; {checkpoint} keeps the state after episode" in err and checkpoint.exists()
    assert not (out / "checkpoint.npz").exists() and len(err.splitlines()) == 1


@pytest.fixture
def exits(monkeypatch):
    """Run the CLI, returning its exit code instead of raising SystemExit."""

    def run(argv: list[str]) -> int:
        try:
            return main(argv)
        except SystemExit as stop:
            return stop.code

    return run


def test_rewards_that_overflow_are_divergence_not_infinity_in_json(tmp_path, exits, capsys):
    code = exits(["train", "--step-reward=-1e308", "--episodes", "3", "--out", str(tmp_path / "r")])
    assert code == 2 and "the rewards (step_reward -1e+308" in capsys.readouterr().err
    # The checkpoint kept (before the first episode) and every record are strict JSON.
    meta, _ = load_checkpoint(tmp_path / "r" / "checkpoint.npz")
    json.dumps(meta, allow_nan=False)
    for path in [*tmp_path.rglob("*.json"), *tmp_path.rglob("*.jsonl")]:
        assert "Infinity" not in path.read_text() and "NaN" not in path.read_text()


def test_a_diverging_trial_is_a_failed_trial_in_a_sweep(tmp_path) -> None:
    from acrobot_mj.train.sweep import run_sweep

    spec = parse_sweep('preset = "book"\nepisodes = 40\nseeds = [0]\n[grid]\nalpha = [0.2]\n')
    summary = run_sweep(spec, tmp_path, options=RunOptions(jobs=1))
    error = json.loads((tmp_path / "trials" / "alpha=0.2__seed=0" / "error.json").read_text())
    assert error["error"].startswith("DivergenceError: sarsa_lambda diverged")
    assert summary["points"][0]["failed_seeds"] == [0] and summary["points"][0]["runs"] == 0
    # No value is null in the file (not NaN, which strict JSON readers refuse, nor 0).
    text = (tmp_path / "summary.json").read_text()
    assert '"held_out_median": null' in text and "NaN" not in text


# -- records: atomic, strict, never in the wrong place ---------------------------------------


@pytest.fixture
def trained(tmp_path) -> Path:
    run = tmp_path / "run"
    train(PRESETS["report"].replace(episodes=2, max_episode_steps=30), seed=0, out_dir=run)
    return run


@pytest.mark.parametrize(
    ("edit", "commands", "says"),
    [
        ({"config": "x"}, ["evaluate", "render", "curves"], "config must be a JSON object"),
        ({"config": ["x"]}, ["evaluate", "curves"], "config must be a JSON object"),
        ({"episode_lengths": None}, ["curves"], "a run record lacks 'episode_lengths'"),
        ({"seed": "0"}, ["evaluate"], "is for seed 0 but {run}/run.json records seed '0'"),
        ({"interrupted": "no"}, ["evaluate", "render"], "bad ['interrupted']"),
        ({"episodes_done": 99}, ["evaluate"], "bad ['episode_lengths']"),  # 2 episodes
        ({"episode_lengths": [float("nan"), 30]}, ["evaluate"], "bad ['episode_lengths']"),
    ],
)
def test_a_hand_edited_run_record_is_one_line_not_a_traceback(
    trained, edit, commands, says, exits, capsys
) -> None:
    record = json.loads((trained / "run.json").read_text())
    record.update(edit)
    record = {k: v for k, v in record.items() if v is not None}
    (trained / "run.json").write_text(json.dumps(record))
    out = {
        "render": ["--out", str(trained.parent / "x.mp4")],
        "curves": ["--out", str(trained.parent / "x.png")],
    }
    for command in commands:
        assert exits([command, str(trained), *out.get(command, [])]) == 2, command
        err = capsys.readouterr().err.strip()
        assert says.format(run=trained) in err and len(err.splitlines()) == 1, err
        assert command != "curves" or "run.json" in err or str(trained) in err


@pytest.mark.parametrize(
    ("edit", "says"),
    [
        ({"length": -7}, "length -7 is not a whole number of decisions"),
        ({"length": 1e30}, "length 1e+30 is not a whole number"),
        ({"length": 29}, "episodes take 59 decisions, but"),  # one decision less: 30 -> 29
        ({"return": "x"}, "return 'x' is not a finite number"),
        ('{"return": NaN}', "is not a finite number"),
        ('{"return": 1e999}', "is not a finite number"),
        ({"success": "false"}, "success 'false' is not true or false"),
        ("[" * 100_000 + "]" * 100_000, "nested too deeply"),  # was a RecursionError
    ],
)
def test_a_hand_edited_episode_log_is_refused_on_resume(trained, edit, says, exits, capsys):
    log = trained / "episodes.jsonl"
    lines = log.read_text().splitlines()
    row = json.loads(lines[1])
    if isinstance(edit, str) and edit.startswith('{"return"'):  # a number json.dumps won't write
        edit = json.dumps(row).replace(f'"return": {json.dumps(row["return"])}', edit[1:-1])
    lines[1] = json.dumps({**row, **edit}) if isinstance(edit, dict) else edit
    log.write_text("\n".join(lines) + "\n")
    args = ["train", "--preset", "report", "--episodes", "3", "--max-episode-steps", "30"]
    assert exits([*args, "--out", str(trained), "--resume"]) == 2
    err = capsys.readouterr().err.strip()
    assert f"{log} cannot give the episodes" in err or f"{log}'s episodes" in err, err
    assert says in err and len(err.splitlines()) == 1, err


@pytest.mark.parametrize(
    "command",
    [
        ["demo", "--steps", "5", "--json", "{run}/run.json"],
        ["demo", "--steps", "5", "--json", "{run}/checkpoint.npz"],
        ["demo", "--steps", "5", "--json", "{run}/episodes.jsonl"],
        ["demo", "--steps", "5", "--json", "{run}/eval.json"],
        ["demo", "--steps", "5", "--json", "{run}/summary.json"],
        ["demo", "--steps", "5", "--json", "{run}/trajectory.json"],
        ["curves", "{run}", "--out", "{run}/learning_curve.png"],
    ],
)
def test_no_command_writes_over_a_runs_own_records(trained, command, exits, capsys) -> None:
    before = {p.name: p.read_bytes() for p in trained.iterdir() if p.is_file()}
    assert exits([part.format(run=trained) for part in command]) == 2
    err = capsys.readouterr().err.strip()
    assert "is a record of the run in" in err and len(err.splitlines()) == 1, err
    assert {p.name: p.read_bytes() for p in trained.iterdir() if p.is_file()} == before


@pytest.mark.slow
def test_no_command_writes_into_a_run_that_is_training(tmp_path, exits, capsys) -> None:
    train(PRESETS["report"].replace(episodes=2, max_episode_steps=30), 0, tmp_path / "other")
    child = start([*LONG, "--out", "run"], tmp_path)
    try:
        wait_for(tmp_path / "run" / "checkpoint.npz")
        other = str(tmp_path / "other")
        for command in (
            ["render", "--policy", "zero", "--steps", "5", "--out", "{run}/x.mp4"],
            ["demo", "--steps", "5", "--json", "{run}/notes.json"],
            ["curves", other, "--out", "{run}/other.png"],
        ):
            code = exits([part.format(run=tmp_path / "run") for part in command])
            err = capsys.readouterr().err.strip()
            assert code == 2 and "is in use by" in err and len(err.splitlines()) == 1, err
        assert not {"x.mp4", "x.json", "notes.json", "other.png"} & set(
            os.listdir(tmp_path / "run")
        )
        # Reading it is refused too: its checkpoint and run.json change as it trains.
        for command in (["evaluate", "{run}"], ["render", "{run}", "--out", "{other}/v.mp4"]):
            code = exits([part.format(run=tmp_path / "run", other=other) for part in command])
            err = capsys.readouterr().err.strip()
            assert code == 2 and "is in use by" in err and len(err.splitlines()) == 1, err
        assert not (tmp_path / "run" / "eval.json").exists()
    finally:
        child.kill()
        child.communicate(timeout=30)


@pytest.mark.parametrize("name", ["run.mp4", "eval.mp4", "summary.mp4"])
def test_render_never_replaces_a_runs_own_records(trained, name, exits, capsys) -> None:
    assert exits(["evaluate", str(trained), "--episodes", "1"]) == 0  # writes eval.json
    (trained / "summary.json").write_text("{}")  # as a multi-seed run would have
    before = {p.name: p.read_bytes() for p in trained.iterdir() if p.is_file()}
    code = exits(["render", str(trained), "--out", str(trained / name), "--steps", "2"])
    assert code == 2 and "is not a video record" in capsys.readouterr().err
    assert {p.name: p.read_bytes() for p in trained.iterdir() if p.is_file()} == before


def test_render_may_replace_its_own_video_but_no_strip_it_did_not_write(trained, exits, capsys):
    args = ["render", str(trained), "--steps", "2", "--width", "64", "--height", "64"]
    assert exits([*args, "--out", str(trained / "v.mp4"), "--strip", str(trained / "s.png")]) == 0
    assert exits([*args, "--out", str(trained / "v.mp4"), "--strip", str(trained / "s.png")]) == 0
    curve = str(trained / "learning_curve.png")
    assert exits([*args, "--out", str(trained / "w.mp4"), "--strip", curve]) == 2
    assert "no video's strip" in capsys.readouterr().err


def test_evaluate_refuses_a_checkpoint_that_is_not_the_recorded_run(trained, exits, capsys):
    record = json.loads((trained / "run.json").read_text())
    (trained / "run.json").write_text(json.dumps({**record, "seed": 7}))
    assert exits(["evaluate", str(trained)]) == 2
    assert "is for seed 0 but" in capsys.readouterr().err
    config = {**record["config"], "alpha": 0.25}
    (trained / "run.json").write_text(json.dumps({**record, "config": config}))
    assert exits(["render", str(trained), "--out", str(trained / "v.mp4")]) == 2
    assert "disagree on the config (alpha: 0.5 vs 0.25)" in capsys.readouterr().err


ONE_TRIAL = 'preset = "report"\nepisodes = 2\nmax_episode_steps = 20\nseeds = [0]\n'


@pytest.fixture(scope="module")
def one_trial_sweep(tmp_path_factory) -> Path:
    """A finished sweep of one trial (copied by each test that damages it)."""
    from acrobot_mj.train.sweep import run_sweep

    out = tmp_path_factory.mktemp("sweep")
    run_sweep(parse_sweep(ONE_TRIAL), out)
    return out


@pytest.mark.parametrize("bad", ["", "[]", '{"config": 5}', '{"config": {"alpha": "x"}}'])
def test_a_sweep_reruns_unreadable_trial_records_and_says_so(
    one_trial_sweep, tmp_path, bad, capsys
) -> None:
    from acrobot_mj.train.sweep import run_sweep

    spec = parse_sweep(ONE_TRIAL)
    shutil.copytree(one_trial_sweep, tmp_path, dirs_exist_ok=True)
    record = tmp_path / "trials" / "base__seed=0" / "run.json"
    record.write_text(bad)  # e.g. a full disk left it empty
    summary = run_sweep(spec, tmp_path)
    assert "running base__seed=0 again: its record" in capsys.readouterr().err
    assert summary["points"][0]["runs"] == 1 and json.loads(record.read_text())["seed"] == 0


@pytest.mark.parametrize("bad", ["", "[]", '{"summ', '{"summary": []}', '{"summary": {}}'])
def test_a_sweep_evaluates_again_where_a_trials_evaluation_is_unreadable(
    one_trial_sweep, tmp_path, bad, capsys
) -> None:
    from acrobot_mj.train.sweep import run_sweep

    shutil.copytree(one_trial_sweep, tmp_path, dirs_exist_ok=True)
    evaluation = tmp_path / "trials" / "base__seed=0" / "eval.json"
    expected = json.loads(evaluation.read_text())["summary"]
    evaluation.write_text(bad)  # truncated, or edited by hand
    summary = run_sweep(parse_sweep(ONE_TRIAL), tmp_path)
    err = capsys.readouterr().err
    assert f"evaluating base__seed=0 again: {evaluation} is not as it was written" in err
    assert json.loads(evaluation.read_text())["summary"] == expected  # the same, evaluated again
    assert summary["points"][0]["held_out_runs"] == 1


def test_a_sweep_evaluates_again_where_a_trials_evaluation_was_edited(
    one_trial_sweep, tmp_path, capsys
) -> None:
    # A hand-edited median in a trial's eval.json (of the right trial and protocol) entered the
    # summary; eval.json now carries the digest of its contents.
    from acrobot_mj.files import is_sealed
    from acrobot_mj.train.sweep import run_sweep

    shutil.copytree(one_trial_sweep, tmp_path, dirs_exist_ok=True)
    evaluation = tmp_path / "trials" / "base__seed=0" / "eval.json"
    record = json.loads(evaluation.read_text())
    assert is_sealed(record)
    true_median = record["summary"]["length"]["median"]
    record["summary"]["length"]["median"] = 1.0
    evaluation.write_text(json.dumps(record))
    summary = run_sweep(parse_sweep(ONE_TRIAL), tmp_path)
    assert f"{evaluation} is not as it was written" in capsys.readouterr().err
    assert summary["points"][0]["held_out_median"] == true_median != 1.0
    assert is_sealed(json.loads(evaluation.read_text()))


def _mount_tmpfs(path: Path, options: str) -> None:
    path.mkdir()
    result = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(path)], capture_output=True, text=True
    )
    if result.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here ({result.stderr.strip()}): needs root")


@pytest.fixture
def small_disk(tmp_path):
    disk = tmp_path / "disk"
    _mount_tmpfs(disk, "size=48k")
    yield disk
    subprocess.run(["umount", str(disk)], check=False)


def test_a_full_disk_loses_no_record_and_says_so_in_one_line(small_disk, exits, capsys):
    # A run too big for the disk (its checkpoint is ~800 kB): one line naming the problem, and
    # no half-written or empty record left behind.
    code = exits(["train", "--preset", "book", "--episodes", "1", "--out", str(small_disk / "r")])
    err = capsys.readouterr().err
    assert code == 2 and "No space left on device" in err and len(err.strip().splitlines()) == 1
    left = {p.name: p.stat().st_size for p in (small_disk / "r").iterdir()}
    assert set(left) <= {".lock", "episodes.jsonl"}  # no checkpoint, run.json or temporary
    assert left.get("episodes.jsonl", 1) > 0
    code = exits(["render", "--policy", "pump", "--out", str(small_disk / "v.mp4")])
    assert code == 2 and "cannot write the video" in capsys.readouterr().err
    assert not list(small_disk.glob("*.mp4")) and not list(small_disk.glob(".*.tmp.mp4"))


def test_a_full_disk_during_evaluate_or_curves_is_one_line_and_leaves_nothing(
    tmp_path, exits, capsys
) -> None:
    # A small run on a disk filled up after it was trained: the evaluation record and the
    # figure cannot be written; each says so in one line, naming the file, and leaves nothing.
    disk = tmp_path / "disk"
    _mount_tmpfs(disk, "size=400k")
    try:
        run = disk / "run"
        train(PRESETS["report"].replace(episodes=2, max_episode_steps=30), 0, run)
        filler = disk / "filler"
        with open(filler, "wb", buffering=0) as f, contextlib.suppress(OSError):
            while True:  # until the disk is full
                f.write(b"x" * 4096)
        before = sorted(p.name for p in run.iterdir())
        curves = ["curves", str(run), "--out", str(run / "c.png")]
        for argv, name in [
            (["evaluate", str(run), "--episodes", "2"], "eval.json"),
            (curves, "c.png"),
        ]:
            assert exits(argv) == 2
            err = capsys.readouterr().err.strip()
            assert f"cannot write {run / name}" in err and len(err.splitlines()) == 1, err
            assert sorted(p.name for p in run.iterdir()) == before  # no record, no temporary
    finally:
        subprocess.run(["umount", str(disk)], check=False)


def test_a_read_only_folder_gives_one_line(tmp_path, exits, capsys) -> None:
    folder = tmp_path / "ro"
    _mount_tmpfs(folder, "ro")
    try:
        code = exits(["render", "--policy", "zero", "--steps", "2", "--out", str(folder / "v.mp4")])
        assert code == 2
        assert "its folder is on a read-only file system" in capsys.readouterr().err
    finally:
        subprocess.run(["umount", str(folder)], check=False)


def test_a_run_on_a_read_only_mount_renders_elsewhere_and_evaluates(tmp_path, exits, capsys):
    # The lock could not be created there, so render and evaluate refused; reading needs no
    # lock where no process can write. The evaluation is printed, and says it was not written.
    folder = tmp_path / "mount"
    _mount_tmpfs(folder, "rw")
    try:
        train(PRESETS["report"].replace(episodes=1, max_episode_steps=5), 0, folder / "run")
        (folder / "run" / ".lock").unlink()  # as a run copied onto read-only media has none
        subprocess.run(["mount", "-o", "remount,ro", str(folder)], check=True)
        out = tmp_path / "v.mp4"
        assert exits(["render", str(folder / "run"), "--steps", "2", "--out", str(out)]) == 0
        assert out.stat().st_size > 0
        capsys.readouterr()
        assert exits(["evaluate", str(folder / "run"), "--episodes", "2"]) == 0
        said = capsys.readouterr().out
        assert "2 held-out starts" in said and said.strip().endswith("is read-only"), said
        assert not (folder / "run" / "eval.json").exists()
    finally:
        subprocess.run(["umount", str(folder)], check=False)


def test_a_fifo_named_like_a_lock_neither_hangs_nor_is_taken(tmp_path) -> None:
    # A FIFO named .lock in a parent hung train --out parent/sub (reading it blocks).
    (tmp_path / "parent").mkdir()
    os.mkfifo(tmp_path / "parent" / ".lock")
    args = ["train", "--preset", "report", "--episodes", "1", "--max-episode-steps", "5"]
    done = _cli([*args, "--out", "parent/sub"], tmp_path)  # times out at 120 s if it hangs
    assert done.returncode == 0, done.stderr
    done = _cli([*args, "--out", "parent"], tmp_path)  # the directory's own lock: refused
    assert done.returncode == 2 and len(done.stderr.splitlines()) == 1, done.stderr
    assert done.stderr.strip().endswith(
        "parent/.lock is not a lock file: remove it, or choose another directory"
    )
    (tmp_path / "folder" / ".lock").mkdir(parents=True)  # a folder: never read, nor taken
    assert _cli([*args, "--out", "folder/sub"], tmp_path).returncode == 0
    done = _cli([*args, "--out", "folder"], tmp_path)
    assert done.returncode == 2 and len(done.stderr.splitlines()) == 1, done.stderr
    assert "folder/.lock is not a lock file" in done.stderr


# -- GL only when rendering -----------------------------------------------------------------


def _cli(args: list[str], cwd: Path, **env: str) -> subprocess.CompletedProcess:
    clean = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "ACROBOT_MJ_GL_PROBLEM")}
    return subprocess.run(
        [sys.executable, "-m", "acrobot_mj_main", *args],
        cwd=cwd,
        env={**clean, "PYTHONPATH": str(ROOT), **env},
        capture_output=True,
        text=True,
        timeout=120,
    )


@pytest.mark.slow
@pytest.mark.parametrize(
    ("gl", "display", "says"),
    [
        ("nonsense", "", "MUJOCO_GL='nonsense' is not a backend MuJoCo knows"),
        ("glfw", "", "no display"),
        # A display no X server serves: GLFW's own warnings (4 lines before) are in the one line.
        ("glfw", ":99", "MUJOCO_GL=glfw does not work ((65550) b'X11: Failed to open display"),
    ],
)
def test_a_broken_gl_choice_fails_only_rendering(tmp_path, gl, display, says) -> None:
    env = {"MUJOCO_GL": gl, **({"DISPLAY": display} if display else {})}
    assert _cli(["params"], tmp_path, **env).returncode == 0
    trained = _cli(
        ["train", "--episodes", "1", "--max-episode-steps", "5", "--out", "r"], tmp_path, **env
    )
    assert trained.returncode == 0, trained.stderr
    rendered = _cli(
        ["render", "--policy", "zero", "--steps", "2", "--out", "v.mp4"], tmp_path, **env
    )
    assert rendered.returncode == 2 and says in rendered.stderr
    assert len(rendered.stderr.strip().splitlines()) == 1
    assert "tried egl" in rendered.stderr and "(it works here)" in rendered.stderr


def test_a_missing_gl_library_is_reported_where_rendering_is_asked(monkeypatch) -> None:
    from acrobot_mj.envs import gl

    # Fake probes: a real EGL probe in this process would close the display MuJoCo renders on.
    monkeypatch.setitem(gl.PROBES, "osmesa", lambda: "libOSMesa cannot be loaded (test)")
    monkeypatch.setitem(gl.PROBES, "egl", lambda: None)
    monkeypatch.setattr(gl, "ATTEMPTS", {})
    monkeypatch.setattr(gl, "CHOICE", gl.CHOICE)
    monkeypatch.setattr(gl, "PROBLEM", gl.PROBLEM)
    monkeypatch.setenv("MUJOCO_GL", "osmesa")
    monkeypatch.delenv("ACROBOT_MJ_GL_PROBLEM", raising=False)
    # Left as it is, MUJOCO_GL=osmesa without the library makes `import mujoco` crash; MuJoCo is
    # told to do without GL instead, and the reason is kept for rendering (and child processes).
    assert gl.configure_gl() is None
    assert os.environ["MUJOCO_GL"] == "disable"
    assert "libOSMesa cannot be loaded (test)" in os.environ["ACROBOT_MJ_GL_PROBLEM"]
    with pytest.raises(gl.GLBackendError, match="MUJOCO_GL=osmesa cannot work here") as error:
        gl.make_renderer(None, 8, 8)
    assert "set MUJOCO_GL=egl (it works here)" in str(error.value)
    assert gl.configure_gl() is None and gl.CHOICE == "broken"  # a child sees the same


# -- absurd values and small things ---------------------------------------------------------


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (
            ["train", "--frame-skip", "10000000000"],
            "frame_skip must be in [1, 1000] (0.05 s physics steps per decision), got 10000000000",
        ),
        (
            ["train", "--frame-skip", "0"],
            "frame_skip must be in [1, 1000] (0.05 s physics steps per decision), got 0",
        ),
        (["train", "--seed", "-1"], "argument --seed: a seed must be an integer >= 0, got -1"),
        (["evaluate", "x", "--seed", "-3"], "argument --seed: a seed must be an integer >= 0"),
    ],
)
def test_absurd_values_are_refused_with_their_range(argv, message, tmp_path, exits, capsys):
    os.chdir(tmp_path)
    assert exits(argv) == 2 and message in capsys.readouterr().err


def test_the_env_refuses_an_absurd_frame_skip() -> None:
    from acrobot_mj.envs.acrobot import AcrobotEnv

    with pytest.raises(ValueError, match=r"frame_skip must be in \[1, 1000\]"):
        AcrobotEnv(frame_skip=10**12)
    with pytest.raises(ValueError, match="seed must be >= 0, got -1"):
        train(PRESETS["report"], seed=-1)


def test_checkpoints_stay_small_and_count_their_lines_of_the_episode_log(tmp_path) -> None:
    # Snapshots note the history's length instead of copying it, and saves append only the new
    # episodes to episodes.jsonl: the cost of an episode does not grow with the run. What a
    # checkpoint covers is still the history at its snapshot, not what came after.
    history = History()
    checkpoints = Checkpoints(tmp_path / "c.npz", TrainConfig(), seed=0)
    checkpoints.start(history)
    for k in range(3):
        history.add(5 + k, -5.0 - k, False)
        checkpoints.snapshot(lambda: {}, history)
        checkpoints.save()
    history.add(9, -9.0, True)  # the next episode, not yet snapshotted
    checkpoints.save()
    meta, _ = load_checkpoint(tmp_path / "c.npz")
    assert meta["episodes_done"] == 3 and "history" not in meta
    lines = (tmp_path / "episodes.jsonl").read_text().splitlines()
    assert [json.loads(line)["length"] for line in lines] == [5, 6, 7]
    assert read_history(tmp_path / "c.npz", meta).episode_lengths == [5, 6, 7]
    # A log with fewer lines than its checkpoint counts is refused, naming both.
    (tmp_path / "episodes.jsonl").write_text(lines[0] + "\n")
    with pytest.raises(CheckpointError, match=r"holds 1 episodes, but .*c\.npz was saved after 3"):
        read_history(tmp_path / "c.npz", meta)


def test_a_lockstep_checkpoint_missing_arrays_is_refused_not_a_traceback(tmp_path) -> None:
    from acrobot_mj.train.checkpoint import save_checkpoint
    from acrobot_mj.train.lockstep import train_lockstep

    config = PRESETS["report"].replace(episodes=2, max_episode_steps=20)
    train_lockstep(config, [0, 1], tmp_path)
    path = tmp_path / "seed_1" / "checkpoint.npz"
    meta, arrays = load_checkpoint(path)
    del arrays["stream.block"]
    save_checkpoint(path, arrays, meta)
    with pytest.raises(CheckpointError, match=r"seed_1/checkpoint.npz does not fit its agent"):
        train_lockstep(
            config.replace(episodes=3), [0, 1], tmp_path, options=RunOptions(resume=True)
        )


def test_curves_of_a_summary_without_runs_is_a_clear_error(tmp_path, exits, capsys) -> None:
    (tmp_path / "s").mkdir()
    (tmp_path / "s" / "summary.json").write_text(json.dumps({"config": {}, "runs": []}))
    assert exits(["curves", str(tmp_path / "s"), "--out", str(tmp_path / "c.png")]) == 2
    assert "lists no runs" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("alpha = 0.1\n[grid]\nalpha = [0.2, 0.3]\n", "alpha is set at the top level and swept"),
        ("[overrides]\nalpha = 0.1\n[grid]\nalpha = [0.2]\n", "alpha is set in [overrides] and"),
        ("alpha = 0.1\n[overrides]\nalpha = 0.2\n", "alpha is set at the top level and in"),
    ],
)
def test_a_sweep_key_given_twice_is_refused(text, message) -> None:
    with pytest.raises(ValueError, match=message.replace("[", r"\[").replace("]", r"\]")):
        parse_sweep(text)


def test_the_resume_hint_only_where_a_checkpoint_was_saved(tmp_path, monkeypatch, exits, capsys):
    # A Ctrl-C before the first checkpoint said "continue with --resume", which then failed.
    from acrobot_mj.cli import learning

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt("interrupted while starting")

    monkeypatch.setattr(learning, "train", interrupted)
    args = ["train", "--preset", "book", "--out", str(tmp_path / "run")]
    assert exits(args) == 130
    err = capsys.readouterr().err.strip()
    assert err == "acrobot-mj train: interrupted while starting", err
    monkeypatch.undo()
    train(PRESETS["report"].replace(episodes=1, max_episode_steps=5), 0, tmp_path / "run")
    monkeypatch.setattr(learning, "train", interrupted)
    assert exits([*args, "--resume"]) == 130
    assert capsys.readouterr().err.strip().endswith("; continue with --resume")


# -- the second fuzz round ------------------------------------------------------------------


def test_records_are_never_renamed_over_a_pipe_or_a_folder(tmp_path, exits, capsys) -> None:
    # demo --json /dev/null (as root) replaced the device with a regular file.
    os.mkfifo(tmp_path / "pipe")
    (tmp_path / "folder").mkdir()
    for target in ("pipe", "folder", ""):
        with pytest.raises(SystemExit) as stop:
            main(["demo", "--steps", "2", "--json", str(tmp_path / target) if target else ""])
        assert stop.value.code == 2
        err = capsys.readouterr().err.strip().splitlines()[-1]
        assert "argument --json" in err and ("not a regular file" in err or "name a file" in err)
    assert (tmp_path / "pipe").is_fifo() and (tmp_path / "folder").is_dir()
    with pytest.raises(IsADirectoryError, match="not a regular file"):
        write_json(tmp_path / "pipe", {})  # the library refuses too


def test_video_sizes_and_options_a_run_ignores_are_refused(trained, tmp_path, exits, capsys):
    out = str(tmp_path / "v.mp4")
    for argv, says in [
        (["render", "--policy", "pump", "--width", "17", "--out", out], "must be even, got 17"),
        (["render", str(trained), "--frame-skip", "2", "--out", out], "--frame-skip is for"),
    ]:
        assert exits(argv) == 2
        err = capsys.readouterr().err.strip()
        assert says in err and len(err.splitlines()) == 1, err
    assert not Path(out).exists()


def _forged(run: Path, change) -> Path:
    """The run's checkpoint changed by ``change(meta, arrays)``, its checksum made good again."""
    meta, arrays = load_checkpoint(run / CHECKPOINT_FILE)
    change(meta, arrays)
    save_checkpoint(run / CHECKPOINT_FILE, arrays, meta)
    return run


@pytest.mark.parametrize(
    ("change", "says"),
    [
        (lambda m, a: a.update(q=a["q"].astype(np.float32)), "q holds float32 values"),
        (lambda m, a: a.update(q=a["q"].astype(np.complex128)), "q holds complex128 values"),
        (lambda m, a: a.update(q=a["q"].astype(np.int8)), "q holds int8 values"),
        (lambda m, a: m.update(episodes_done=-3), "bad or missing ['episodes_done']"),
        (lambda m, a: m.update(agent="evil"), "is of agent 'evil'"),
    ],
)
def test_a_resealed_checkpoint_of_the_wrong_kind_is_refused(trained, change, says, exits, capsys):
    # Each was accepted: weights cast to float64 (a ComplexWarning, or wrapped int8 values that
    # then trained on), a negative episode count, an unknown agent.
    _forged(trained, change)
    assert exits(["evaluate", str(trained), "--episodes", "1"]) == 2
    err = capsys.readouterr().err.strip()
    assert says in err and len(err.splitlines()) == 1, err


def test_a_checkpoint_declaring_a_huge_array_is_refused_before_allocating(trained, exits, capsys):
    # A few kilobytes whose header declares 3 x 4e9 floats: numpy allocated 89 GiB and failed.
    path = trained / CHECKPOINT_FILE
    members = {}
    with zipfile.ZipFile(path) as archive:
        for info in archive.infolist():
            members[info.filename] = archive.read(info)
    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        header, {"descr": "<f8", "fortran_order": False, "shape": (3, 4_000_000_000)}
    )
    members["q.npy"] = header.getvalue() + members["q.npy"][len(header.getvalue()) :]
    with zipfile.ZipFile(path, "w") as archive:
        for name, data in members.items():
            archive.writestr(name, data)
    assert exits(["evaluate", str(trained)]) == 2
    err = capsys.readouterr().err.strip()
    assert "q.npy declares 96,000,000,000 bytes" in err and len(err.splitlines()) == 1, err


@pytest.mark.parametrize(
    "command",
    [
        ["evaluate", "{run}"],
        ["curves", "{run}", "--out", "{out}"],
        ["render", "{run}", "--out", "{out}.mp4"],
    ],
)
def test_a_record_nested_too_deeply_is_one_line(trained, tmp_path, command, exits, capsys):
    # Valid JSON 200,000 levels deep: Python's parser raised RecursionError.
    text = (trained / "run.json").read_text().rstrip()[:-1]
    (trained / "run.json").write_text(text + ', "deep": ' + "[" * 200_000 + "]" * 200_000 + "}")
    argv = [part.format(run=trained, out=tmp_path / "c.png") for part in command]
    assert exits(argv) == 2
    err = capsys.readouterr().err.strip()
    assert "nested too deeply" in err and len(err.splitlines()) == 1, err


@pytest.mark.parametrize(
    ("record", "argv"),
    [
        ("run.json", ["evaluate", "{run}", "--episodes", "1"]),
        (
            "episodes.jsonl",
            [
                "train",
                "--preset",
                "report",
                "--episodes",
                "3",
                "--max-episode-steps",
                "30",
                "--out",
                "{run}",
                "--resume",
            ],
        ),
    ],
)
def test_a_pipe_in_place_of_a_record_is_one_line_not_a_hang(trained, record, argv, capsys):
    # Reading a FIFO waits for a writer forever: evaluate and the resume hung.
    (trained / record).unlink()
    os.mkfifo(trained / record)
    done = _cli([part.format(run=trained) for part in argv], trained.parent)  # 120 s if it hangs
    assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1, done.stderr
    assert f"{record} exists and is not a regular file" in done.stderr


@pytest.mark.slow
def test_a_video_cut_short_by_a_full_disk_is_not_left_as_the_video(tmp_path, exits, capsys):
    # ffmpeg ended the file early without an error: the truncated video was renamed into place,
    # and the record beside it failed with an errno that named no file.
    disk = tmp_path / "disk"
    _mount_tmpfs(disk, "size=1200k")
    try:
        out = disk / "p.mp4"
        argv = ["render", "--policy", "pump", "--width", "1920", "--height", "1080"]
        assert exits([*argv, "--out", str(out)]) == 2
        err = capsys.readouterr().err.strip()
        assert err.endswith(f"cannot write the video {out}: no space left on the device"), err
        assert list(disk.iterdir()) == []  # neither the video nor its record nor a temporary
    finally:
        subprocess.run(["umount", str(disk)], check=False)


def test_training_replaces_no_file_of_someone_elses_and_no_stale_summary(tmp_path, exits, capsys):
    # A folder holding a user's learning_curve.png (no run): it was overwritten, and a user's
    # eval.json deleted. One seed of a --seeds run trained again: its summary stayed, stale.
    folder = tmp_path / "mine"
    folder.mkdir()
    (folder / "learning_curve.png").write_text("precious")
    args = ["train", "--preset", "report", "--episodes", "2", "--max-episode-steps", "20"]
    assert exits([*args, "--out", str(folder)]) == 2
    err = capsys.readouterr().err.strip()
    assert "holds learning_curve.png but no run" in err and len(err.splitlines()) == 1, err
    assert (folder / "learning_curve.png").read_text() == "precious"
    multi = tmp_path / "multi"
    assert exits([*args, "--seeds", "2", "--out", str(multi)]) == 0
    assert (multi / "summary.json").exists()
    assert exits([*args, "--seed", "7", "--force", "--out", str(multi / "seed_1")]) == 0
    assert not (multi / "summary.json").exists() and not (multi / "learning_curve.png").exists()
    assert exits([*args, "--seeds", "2", "--out", str(multi), "--resume"]) == 2  # seed 7 found


def test_seeds_beyond_memory_or_open_files_are_refused_at_once(tmp_path, exits, capsys) -> None:
    # --seeds 1e9 grew to 13 GB and did not stop on Ctrl-C; 300 seeds in lockstep under
    # `ulimit -n 200` failed with "Too many open files" (a lock and a log each).
    args = ["train", "--preset", "report", "--episodes", "1", "--max-episode-steps", "5"]
    assert exits([*args, "--seeds", "1000000000", "--out", str(tmp_path / "big")]) == 2
    err = capsys.readouterr().err.strip()
    assert "--seeds 1000000000 needs" in err and "of memory" in err, err
    import resource

    limit = lambda: resource.setrlimit(resource.RLIMIT_NOFILE, (200, 200))  # noqa: E731
    argv = [
        sys.executable,
        "-m",
        "acrobot_mj_main",
        *args,
        "--seeds",
        "300",
        "--lockstep",
        "--out",
        str(tmp_path / "many"),
    ]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    done = subprocess.run(
        argv, cwd=tmp_path, env=env, preexec_fn=limit, capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1, done.stderr
    assert "300 seeds in lockstep keep 600 files open; this process may open 200" in done.stderr


def test_empty_paths_huge_vector_envs_and_binary_sweep_files_are_one_line(tmp_path, exits, capsys):
    # --out '' fell back to the default run directory; --tensorboard '' wrote into the current
    # folder; AcrobotVectorEnv(10**9) said "std::bad_alloc"; a binary sweep file named no file.
    from acrobot_mj.envs.vector import AcrobotVectorEnv

    os.chdir(tmp_path)
    for flag in ("--out", "--tensorboard"):
        with pytest.raises(SystemExit) as stop:
            main(["train", "--episodes", "1", flag, ""])
        assert stop.value.code == 2 and "must name a path, got ''" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(ValueError, match=r"num_envs=1000000000 needs .* of memory"):
        AcrobotVectorEnv(10**9)
    (tmp_path / "s.toml").write_bytes(b"\xff\xfe seeds")
    assert exits(["sweep", str(tmp_path / "s.toml")]) == 2
    err = capsys.readouterr().err.strip()
    assert "s.toml is not a TOML file (not UTF-8 text" in err and len(err.splitlines()) == 1, err


def test_a_complex_start_state_is_refused_not_cast(recwarn) -> None:
    # reset(options={"state": complex}) warned ComplexWarning and dropped the imaginary parts.
    env = gym.make("acrobot_mj/Acrobot-v0")
    with pytest.raises(ValueError, match="'state' must be 4 numbers"):
        env.reset(options={"state": np.array([1 + 2j, 0, 0, 0])})
    assert not [w for w in recwarn if "Complex" in type(w.message).__name__]
