"""Watching runs: the episode log streamed as episodes end, one progress bar over all learners
(on a terminal or when asked, never on a pipe otherwise), and TensorBoard scalars."""

from __future__ import annotations

import fcntl
import json
import os
import select
import struct
import subprocess
import sys
import termios
from pathlib import Path

import pytest

from acrobot_mj.cli import main
from acrobot_mj.train.episode_log import EpisodeLog, read_rows
from acrobot_mj.train.lockstep import train_lockstep
from acrobot_mj.train.presets import PRESETS
from acrobot_mj.train.records import History
from acrobot_mj.train.run import RunOptions
from acrobot_mj.train.trainer import train

ROOT = Path(__file__).resolve().parents[1]
#: A run of a second or so: tabular SARSA, 30 short episodes.
TINY = ["--episodes", "30", "--max-episode-steps", "40"]
HISTORY_KEYS = ("episode_lengths", "episode_returns", "episode_successes")


def log_lists(rows: list[dict]) -> dict[str, list]:
    return {
        "episode_lengths": [r["length"] for r in rows],
        "episode_returns": [r["return"] for r in rows],
        "episode_successes": [r["success"] for r in rows],
    }


# -- the episode log ----------------------------------------------------------------------


def test_each_episode_is_on_disk_when_it_ends_not_at_the_next_checkpoint(tmp_path) -> None:
    seen = []

    def look(episode: int, history: History) -> None:
        # Read by another handle, as another process would: the line is flushed already,
        # although the next checkpoint (every 100 episodes) is far away.
        rows = read_rows(tmp_path / "episodes.jsonl", 10**6)
        seen.append(len(rows))
        assert rows[-1]["episode"] == episode and rows[-1]["length"] == history.episode_lengths[-1]

    config = PRESETS["report"].replace(episodes=5, max_episode_steps=30, checkpoint_every=100)
    record = train(config, seed=0, out_dir=tmp_path, options=RunOptions(on_episode=look))
    assert seen == [1, 2, 3, 4, 5]
    rows = read_rows(tmp_path / "episodes.jsonl", 10**6)
    assert log_lists(rows) == {key: record[key] for key in HISTORY_KEYS}
    times = [r["wall_seconds"] for r in rows]
    assert times == sorted(times) and times[0] >= 0 and "learner" not in rows[0]


def test_starting_again_cuts_the_log_back_atomically_keeping_the_first_lines(tmp_path) -> None:
    path = tmp_path / "episodes.jsonl"
    log, history = EpisodeLog(path), History()
    log.start(history)
    for k in range(4):
        history.add(10 + k, -1.0, False)
        log.append(k, 10 + k, -1.0, False)
    log.close()
    with open(path, "a") as f:
        f.write('{"episode": 4, "len')  # a kill in the middle of a line
    before = path.read_bytes().splitlines(keepends=True)
    kept = History(history.episode_lengths[:2], history.episode_returns[:2], [False, False])
    log.start(kept)  # resumed from a checkpoint after episode 2
    log.append(2, 99, -2.0, True)
    log.close()
    lines = path.read_bytes().splitlines(keepends=True)
    assert lines[:2] == before[:2]  # the same bytes: times and all
    assert [json.loads(line)["episode"] for line in lines] == [0, 1, 2]
    assert json.loads(lines[2])["length"] == 99
    assert json.loads(lines[2])["wall_seconds"] >= json.loads(lines[1])["wall_seconds"]
    assert [p.name for p in tmp_path.iterdir()] == ["episodes.jsonl"]  # no temporary left


def test_lockstep_and_population_logs_name_their_learners(tmp_path) -> None:
    config = PRESETS["report"].replace(episodes=3, max_episode_steps=20)
    records = train_lockstep(config, [0, 4], tmp_path / "lock")
    for i, (seed, record) in enumerate(zip([0, 4], records, strict=True)):
        rows = read_rows(tmp_path / "lock" / f"seed_{seed}" / "episodes.jsonl", 100)
        assert [r["learner"] for r in rows] == [i] * 3
        assert log_lists(rows) == {key: record[key] for key in HISTORY_KEYS}
    seen = []

    def look(episode: int, history: History) -> None:  # the run's own log, while it trains
        seen.append(len(read_rows(tmp_path / "pop" / "episodes.jsonl", 100)))

    pop = config.replace(population=3)
    record = train(pop, seed=1, out_dir=tmp_path / "pop", options=RunOptions(on_episode=look))
    assert seen == list(range(1, 10))
    rows = read_rows(tmp_path / "pop" / "episodes.jsonl", 100)
    assert [r["episode"] for r in rows] == list(range(9))
    assert [r["learner"] for r in rows] == [0, 0, 0, 1, 1, 1, 2, 2, 2]
    assert log_lists(rows) == {key: record[key] for key in HISTORY_KEYS}
    times = [r["wall_seconds"] for r in rows]  # one clock through the learners
    assert times == sorted(times)


def test_a_resumed_population_rebuilds_its_log_without_duplicates(tmp_path) -> None:
    calls = []

    def stop(episode: int, history: History) -> None:
        calls.append(episode)
        if len(calls) == 5:  # learner 1, its second episode
            raise KeyboardInterrupt

    config = PRESETS["report"].replace(episodes=3, max_episode_steps=20, population=3)
    with pytest.raises(KeyboardInterrupt, match="learner 1 of 3"):
        train(config, seed=2, out_dir=tmp_path, options=RunOptions(on_episode=stop))
    log = tmp_path / "episodes.jsonl"
    before = read_rows(log, 100)
    assert [(r["episode"], r["learner"]) for r in before] == [
        (0, 0),
        (1, 0),
        (2, 0),
        (3, 1),
        (4, 1),
    ]
    with open(log, "a") as f:
        f.write('{"episode": 5, "le')  # a kill in the middle of a line
    record = train(config, seed=2, out_dir=tmp_path, options=RunOptions(resume=True))
    rows = read_rows(log, 100)
    assert log.read_bytes().endswith(b"\n")
    assert rows[:5] == before  # rebuilt from the learners' logs: the same lines
    assert [r["episode"] for r in rows] == list(range(9))
    assert [r["learner"] for r in rows] == [0, 0, 0, 1, 1, 1, 2, 2, 2]
    assert log_lists(rows) == {key: record[key] for key in HISTORY_KEYS}


# -- the progress bar ---------------------------------------------------------------------


def _cli(args: list[str], cwd: Path, **kwargs) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "acrobot_mj_main", *args],
        cwd=cwd,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        text=True,
        timeout=300,
        **kwargs,
    )


@pytest.mark.slow
def test_no_bar_on_a_pipe_unless_asked(tmp_path) -> None:
    quiet = _cli(["train", *TINY, "--out", "a"], tmp_path, capture_output=True)
    assert quiet.returncode == 0 and quiet.stderr == ""  # no bar, nothing else either
    loud = _cli(["train", *TINY, "--out", "b", "--progress"], tmp_path, capture_output=True)
    assert loud.returncode == 0, loud.stderr
    assert "sarsa seed 0: 100%|" in loud.stderr and "30/30" in loud.stderr
    assert "0 successes" in loud.stderr and "median 40 decisions (last 20)" in loud.stderr


def _on_a_terminal(args: list[str], cwd: Path) -> tuple[int, str]:
    """Run the CLI with its stderr (and stdout) on a pseudo-terminal: the exit code and what
    the terminal showed."""
    leader, follower = os.openpty()
    # A new pseudo-terminal is 0 x 0; a real one has a size (tqdm fits its bar to it).
    fcntl.ioctl(follower, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 160, 0, 0))
    child = subprocess.Popen(
        [sys.executable, "-m", "acrobot_mj_main", *args],
        cwd=cwd,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        stdin=subprocess.DEVNULL,
        stdout=follower,
        stderr=follower,
    )
    os.close(follower)
    shown = b""
    while True:
        ready, _, _ = select.select([leader], [], [], 300)
        assert ready, "the command showed nothing for 300 s"
        try:
            chunk = os.read(leader, 4096)
        except OSError:  # EIO: the child closed the terminal
            break
        if not chunk:
            break
        shown += chunk
    os.close(leader)
    return child.wait(timeout=60), shown.decode(errors="replace")


@pytest.mark.slow
def test_a_terminal_gets_one_bar_over_every_learner(tmp_path) -> None:
    code, shown = _on_a_terminal(
        ["train", *TINY, "--seeds", "3", "--lockstep", "--out", "s"], tmp_path
    )
    assert code == 0, shown
    # Lockstep: one bar of all three learners' 90 episodes, not learner 0's 30.
    assert "lockstep sarsa x3: 100%|" in shown and "90/90" in shown, shown
    assert "\r" in shown  # redrawn in place
    code, shown = _on_a_terminal(["train", *TINY, "--out", "r", "--no-progress"], tmp_path)
    assert code == 0 and "%|" not in shown  # turned off on a terminal too


@pytest.mark.slow
def test_seeds_in_worker_processes_share_one_bar_read_from_their_logs(tmp_path) -> None:
    args = ["train", "--preset", "book", "--episodes", "10", "--max-episode-steps", "50"]
    args += ["--seeds", "2", "--jobs", "2"]
    done = _cli([*args, "--out", "s", "--progress"], tmp_path, capture_output=True)
    assert done.returncode == 0, done.stderr
    assert "sarsa_lambda x2 seeds, 2 processes: 100%|" in done.stderr and "20/20" in done.stderr


def test_a_followed_log_that_is_cut_back_is_counted_again(tmp_path, capsys) -> None:
    from acrobot_mj.bars import EpisodeBar
    from acrobot_mj.files import write_text
    from acrobot_mj.train.monitor import LogFollower

    def lines(n: int, length: int) -> str:
        row = {"length": length, "return": -1.0, "success": True}
        return "".join(json.dumps({"episode": k, **row}) + "\n" for k in range(n))

    log = tmp_path / "episodes.jsonl"
    bar = EpisodeBar(10, "follow", True, "episodes", 20)
    follower = LogFollower([log, tmp_path / "not_yet.jsonl"], bar)
    log.write_text(lines(6, 30) + '{"episode": 6, "len')  # the last line still being written
    follower.poll()
    assert (bar.bar.n, bar.successes) == (6, 6)
    write_text(log, lines(4, 50))  # a resume cut it back: a new file
    follower.poll()
    assert (bar.bar.n, bar.successes) == (4, 4) and list(bar.recent)[-4:] == [50] * 4
    with open(log, "a") as f:
        f.write(lines(5, 50).splitlines(keepends=True)[4])
    follower.poll()
    assert bar.bar.n == 5
    bar.close()
    capsys.readouterr()


@pytest.mark.slow
def test_a_sweep_shows_a_bar_over_its_trials_when_asked(tmp_path) -> None:
    sweep = 'preset = "report"\nepisodes = 2\nmax_episode_steps = 20\nseeds = [0, 1]\n'
    (tmp_path / "s.toml").write_text(sweep)
    done = _cli(
        ["sweep", "s.toml", "--jobs", "1", "--out", "sw", "--progress"],
        tmp_path,
        capture_output=True,
    )
    assert done.returncode == 0, done.stderr
    assert "sweep sw: 100%|" in done.stderr and "2/2" in done.stderr


def test_a_steps_bar_names_each_step_and_is_silent_when_off(capsys) -> None:
    from acrobot_mj.bars import Steps

    steps = Steps(2, "validate", True, unit="checks")
    steps.done("cross-check")
    steps.done("balance")
    steps.close()
    err = capsys.readouterr().err
    assert "validate: 100%|" in err and "2/2" in err and "balance" in err
    off = Steps(2, "validate", False)
    off.done("cross-check")
    off.close()
    assert capsys.readouterr().err == ""


def test_render_shows_a_bar_of_its_frames_when_asked(tmp_path, capsys) -> None:
    args = ["render", "--policy", "zero", "--steps", "3", "--width", "32", "--height", "32"]
    assert main([*args, "--out", str(tmp_path / "v.mp4"), "--progress"]) == 0
    err = capsys.readouterr().err
    assert "render: 100%|" in err and "4/4" in err  # 4 frames: the reset's and 3 steps'
    assert main([*args, "--out", str(tmp_path / "w.mp4")]) == 0  # pytest's stderr: no terminal
    assert "%|" not in capsys.readouterr().err


# -- TensorBoard --------------------------------------------------------------------------


def test_tensorboard_without_the_extra_is_one_line_naming_it(tmp_path, monkeypatch, capsys):
    for name in ("tensorboardX", "torch", "torch.utils.tensorboard"):
        monkeypatch.setitem(sys.modules, name, None)  # import fails, as if not installed
    args = ["train", *TINY, "--out", str(tmp_path / "r"), "--tensorboard", str(tmp_path / "tb")]
    try:
        code = main(args)
    except SystemExit as stop:
        code = stop.code
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert "pip install acrobot-mj[tensorboard]" in err
    assert not (tmp_path / "r" / "run.json").exists() and not (tmp_path / "tb").exists()


def _scalars(folder: Path) -> dict[str, list[tuple[int, float]]]:
    """The scalars of the event files in ``folder`` (TFRecord framing, parsed here)."""
    from tensorboardX.proto.event_pb2 import Event

    scalars: dict[str, list[tuple[int, float]]] = {}
    for path in sorted(folder.glob("events.out.tfevents.*")):
        data = path.read_bytes()
        at = 0
        while at < len(data):
            (size,) = struct.unpack("<Q", data[at : at + 8])
            event = Event.FromString(data[at + 12 : at + 12 + size])
            at += 12 + size + 4  # length, its CRC, the record, its CRC
            for value in event.summary.value:
                scalars.setdefault(value.tag, []).append((event.step, value.simple_value))
    return scalars


def test_tensorboard_gets_every_episode_of_every_learner(tmp_path) -> None:
    pytest.importorskip("tensorboardX")
    config = PRESETS["report"].replace(episodes=4, max_episode_steps=25, population=2)
    record = train(
        config, seed=3, out_dir=tmp_path / "r", options=RunOptions(tensorboard=tmp_path / "tb")
    )
    for k in range(2):
        scalars = _scalars(tmp_path / "tb" / f"learner_{k}")
        own = slice(4 * k, 4 * k + 4)
        assert scalars["episode/length"] == list(enumerate(record["episode_lengths"][own]))
        assert scalars["episode/return"] == list(enumerate(record["episode_returns"][own]))
        successes = [float(s) for s in record["episode_successes"][own]]
        assert scalars["episode/success"] == list(enumerate(successes))
