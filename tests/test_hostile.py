"""What a hostile but realistic user tried on the new commands: each case is one
clear line or an exact result, nothing silently dropped, nothing written where refused."""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from acrobot_mj.cli import main
from acrobot_mj.envs.disturbances import Disturbances
from acrobot_mj.train.feedback_run import FeedbackConfig
from acrobot_mj.train.records import EVAL_FILE
from acrobot_mj.train.trainer import train


@pytest.fixture
def exits():
    """Run the CLI, returning its exit code instead of raising SystemExit."""

    def run(argv: list[str]) -> int:
        try:
            return main(argv)
        except SystemExit as stop:
            return int(stop.code or 0)

    return run


@pytest.fixture(scope="module")
def feedback_run(tmp_path_factory) -> Path:
    run = tmp_path_factory.mktemp("hostile") / "feedback"
    train(FeedbackConfig(), seed=0, out_dir=run)
    return run


def one_line(capsys) -> str:
    """The one line a refused command wrote on stderr."""
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    return err


# -- pushes land where the docs say ---------------------------------------------------------


def test_every_multiple_of_the_period_is_one_push_at_its_decision() -> None:
    # Decisions of 0.2 s (4 physics steps of 0.05 s), 30 of them: one push a multiple of 0.2 s.
    assert Disturbances(0.2, 0.1).push_steps(120, 4, 0.05) == list(range(4, 120, 4))
    # Every 0.25 s: the first decision at or after 0.25, 0.5, 0.75, ... (0.4, 0.6, 0.8, 1.0)
    assert Disturbances(0.25, 0.1).push_steps(24, 4, 0.05) == [8, 12, 16, 20]
    # A decision of 0.15 s (3 steps of 0.05 s, not exact in floats) takes 0.15 as its own.
    assert Disturbances(0.15, 0.1).push_steps(12, 3, 0.05) == [3, 6, 9]


@pytest.mark.parametrize("period", [0.03, 1e-300, 0.2 - 1e-6])
def test_a_period_shorter_than_a_decision_is_refused_at_once(period) -> None:
    with pytest.raises(ValueError, match=r"push_every must be at least one decision \(0.2 s\)"):
        Disturbances(period, 0.5).push_steps(10**9, 4, 0.05)


def test_a_period_that_lands_no_push_is_refused() -> None:
    says = "push_every 100 s lands no push within an episode of 10 s"
    with pytest.raises(ValueError, match=says):
        Disturbances(100.0, 0.5).push_steps(200, 1, 0.05)
    with pytest.raises(ValueError, match="lands no push"):  # at the episode's end: none lands
        Disturbances(10.0, 0.5).push_steps(200, 1, 0.05)


@pytest.mark.parametrize(
    ("argv", "says"),
    [
        (["--push-every", "0.03"], "push_every must be at least one decision (0.05 s), got 0.03"),
        (["--push-every", "1e-300"], "push_every must be at least one decision (0.05 s)"),
        (["--push-every", "100", "--seconds", "10"], "lands no push within an episode of 10 s"),
        (["--seconds", "1e-9"], "seconds must be at least one decision of this run (0.05 s)"),
        (["--seconds", "-1"], "config seconds must be in (0, 86400], got -1"),
    ],
)
def test_evaluate_refuses_what_it_cannot_do_before_any_episode(
    feedback_run, argv, says, exits, capsys
) -> None:
    (feedback_run / EVAL_FILE).unlink(missing_ok=True)
    base = ["evaluate", str(feedback_run), "--episodes", "1", "--seconds", "2"]
    pushes = [] if "--push-every" not in argv else ["--push-size", "0.5"]
    assert exits([*base, *pushes, *argv]) == 2
    assert says in one_line(capsys)
    assert not (feedback_run / EVAL_FILE).exists()


def test_a_push_every_decision_pushes_every_decision(feedback_run, exits, capsys) -> None:
    argv = ["evaluate", str(feedback_run), "--episodes", "1", "--seconds", "2"]
    assert exits([*argv, "--push-every", "0.05", "--push-size", "0.5"]) == 0
    assert "of 39 pushes recovered from" in capsys.readouterr().out
    record = json.loads((feedback_run / EVAL_FILE).read_text())
    assert [k for k, *_ in record["pushes"][0]] == list(range(1, 40))  # 40 decisions, not at 0
    assert np.all(np.abs(np.array(record["pushes"][0])[:, 1:]) <= 0.5)
    os.remove(feedback_run / EVAL_FILE)


# -- balance: outputs checked before any work, runs replaced on purpose -----------------------

ROOT = Path(__file__).resolve().parents[1]


@contextlib.contextmanager
def held_by_another(directory: Path, command: str = "evaluate"):
    """``directory``'s lock held by another live process while the block runs."""
    code = (
        "import sys, time; from acrobot_mj.train.lock import RunLock\n"
        f"with RunLock({str(directory)!r}, {command!r}):\n"
        "    print('held', flush=True); time.sleep(60)\n"
    )
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    env.pop("ACROBOT_MJ_LOCK_OWNERS", None)
    child = subprocess.Popen(
        [sys.executable, "-c", code], stdout=subprocess.PIPE, text=True, env=env
    )
    try:
        assert child.stdout is not None and child.stdout.readline() == "held\n"
        yield child.pid
    finally:
        child.kill()
        child.communicate(timeout=30)


@pytest.mark.parametrize("feedback", [[], ["--feedback"]])
@pytest.mark.parametrize(
    ("out", "says"),
    [
        ("", "argument --out: must name a path, got ''"),
        (" ", "argument --out: must name a path"),
        ("/dev/null", "--out /dev/null: /dev/null exists and is not a folder"),
        ("/dev/null/b", "--out /dev/null/b: /dev/null exists and is not a folder"),
    ],
)
def test_balance_refuses_an_output_that_cannot_be_a_folder(
    feedback, out, says, tmp_path, exits, capsys
) -> None:
    os.chdir(tmp_path)
    assert exits(["balance", *feedback, "--no-video", "--out", out]) == 2
    assert says in one_line(capsys)
    assert not (tmp_path / "runs").exists()


@pytest.mark.parametrize("feedback", [[], ["--feedback"]])
@pytest.mark.parametrize(
    ("argv", "says"),
    [
        (["--width", "100000"], "width must be in [1, "),
        (["--width", "101"], "an MP4's width and height must be even, got 101 x 480"),
        (["--height", "99999"], "height must be in [1, "),
    ],
)
def test_balance_refuses_a_video_it_cannot_write_before_any_work(
    feedback, argv, says, tmp_path, exits, capsys
) -> None:
    out = tmp_path / "b"
    assert exits(["balance", *feedback, "--out", str(out), *argv]) == 2
    assert says in one_line(capsys)
    assert not out.exists()


@pytest.mark.parametrize("hold", ["60", "5"])
def test_feedback_takes_no_hold_not_even_the_default(hold, tmp_path, exits, capsys) -> None:
    assert exits(["balance", "--feedback", "--hold", hold, "--out", str(tmp_path / "f")]) == 2
    says = "for as long as an episode lasts (evaluate --seconds): give no --optimise or --hold"
    assert says in one_line(capsys)
    assert not (tmp_path / "f").exists()


def test_a_feedback_run_is_replaced_only_with_force(tmp_path, exits, capsys) -> None:
    out = tmp_path / "f"
    argv = ["balance", "--feedback", "--no-video", "--out", str(out)]
    assert exits(argv) == 0
    before = (out / "run.json").read_bytes()
    assert exits(argv) == 2
    assert "already holds a run (run.json)" in one_line(capsys)
    assert exits([*argv, "--force"]) == 0
    assert json.loads((out / "run.json").read_bytes())["config"] == json.loads(before)["config"]
    assert exits(["balance", "--force", "--no-video", "--out", str(tmp_path / "p")]) == 2
    assert "--force is for --feedback" in one_line(capsys)


def test_balance_never_writes_into_a_run(feedback_run, exits, capsys) -> None:
    before = {p.name: p.read_bytes() for p in feedback_run.iterdir() if p.is_file()}
    assert exits(["balance", "--no-video", "--hold", "1", "--out", str(feedback_run)]) == 2
    assert "holds a run (run.json): balance writes its own folder" in one_line(capsys)
    assert {p.name: p.read_bytes() for p in feedback_run.iterdir() if p.is_file()} == before


@pytest.mark.parametrize(
    "argv",
    [
        ["balance", "--no-video", "--hold", "1"],
        ["balance", "--hold", "1", "--width", "64", "--height", "64"],
        ["balance", "--feedback", "--no-video", "--force"],
    ],
)
def test_balance_takes_the_lock_of_its_folder(argv, tmp_path, exits, capsys) -> None:
    out = tmp_path / "b"
    out.mkdir()
    with held_by_another(out) as pid:
        assert exits([*argv, "--out", str(out)]) == 2
        assert f"is in use by pid {pid}" in one_line(capsys)
    assert sorted(p.name for p in out.iterdir()) == [".lock"]


def test_evaluate_of_a_run_being_created_names_its_owner(tmp_path, exits, capsys) -> None:
    out = tmp_path / "new"
    out.mkdir()
    with held_by_another(out, "train") as pid:
        assert exits(["evaluate", str(out)]) == 2
        assert f"is in use by pid {pid}" in one_line(capsys)
    assert exits(["evaluate", str(out)]) == 2  # nobody's: it holds no run
    assert "holds no run" in one_line(capsys)


@pytest.mark.slow
def test_a_stop_while_the_feedback_video_renders_says_the_run_is_whole(tmp_path) -> None:
    child = subprocess.Popen(
        [sys.executable, "-m", "acrobot_mj_main", "balance", "--feedback", "--out", "f"],
        cwd=tmp_path,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + 60
    while not (tmp_path / "f" / "run.json").exists():
        assert time.monotonic() < deadline and child.poll() is None
        time.sleep(0.05)
    time.sleep(1.0)  # rendering
    child.send_signal(signal.SIGINT)
    _, err = child.communicate(timeout=30)
    assert child.returncode == 130
    assert err.strip().splitlines() == [
        "acrobot-mj balance: interrupted while rendering the video; the run in f is whole: "
        "evaluate or render it, or build it again with --force"
    ]
    assert not (tmp_path / "f" / "swing_up.mp4").exists()
    assert not list((tmp_path / "f").glob(".*.tmp*"))  # no half-encoded video left


# -- sizes and types ----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("decisions", "says"),
    [
        (
            "100",
            "config decisions must be >= 900 with 4 harmonics and form best (the fit's 810 terms",
        ),
        ("899", "config decisions must be >= 900"),
        ("99999999999", "the black box's fit of 99,999,999,999 decisions needs"),
    ],
)
def test_black_box_sizes_are_refused_before_any_work(
    decisions, says, tmp_path, exits, capsys
) -> None:
    out = tmp_path / "bb"
    assert (
        exits(["train", "--preset", "black_box", "--decisions", decisions, "--out", str(out)]) == 2
    )
    assert says in one_line(capsys)
    assert not out.exists()


@pytest.mark.parametrize("harmonics", [1, 4, pytest.param(8, marks=pytest.mark.slow)])
def test_the_fewest_decisions_fit_the_library(harmonics) -> None:
    from acrobot_mj.identify.library import LibraryModel
    from acrobot_mj.train.black_box import fewest_decisions, fitted_share

    least = fewest_decisions(harmonics)
    n = fitted_share(least)
    rng = np.random.default_rng(harmonics)
    states = rng.uniform(-1.0, 1.0, (n, 4))
    LibraryModel.fit(states, rng.uniform(-1.0, 1.0, n), states + 0.01, harmonics)
    with pytest.raises(ValueError, match="cannot fit"):
        k = fitted_share(least - 1)
        LibraryModel.fit(states[:k], np.zeros(k), states[:k], harmonics)


@pytest.mark.parametrize(
    ("change", "error", "says"),
    [
        ({"a": "x"}, TypeError, "A must be an array of real numbers, got 'x'"),
        ({"b": [[1.0], ["y"], [0.0], [0.0]]}, TypeError, "b must be an array of real numbers"),
        ({"directions": -5}, ValueError, "directions must be >= 2, got -5"),
        ({"directions": 2.5}, TypeError, "directions must be an integer"),
        ({"a": 0.5 * np.eye(4)}, ValueError, "needs A with exactly two unstable modes"),
        ({"b": np.zeros(4)}, ValueError, "A must be (n, n) and b (n, 1), got (4, 4) and (4,)"),
        ({"b": np.zeros((4, 1))}, ValueError, "b moves no unstable mode of A"),
        ({"limit": 0.0}, ValueError, "limit must be > 0 N m, got 0"),
        ({"limit": float("nan")}, ValueError, "limit must be finite"),
        ({"a": np.full((4, 4), np.inf)}, ValueError, "A must be finite"),
    ],
)
def test_null_region_refuses_bad_input_in_one_line(change, error, says) -> None:
    from acrobot_mj.control.lqr import NullRegion, discrete_model

    a, b = discrete_model()
    given = {"a": a, "b": b, "limit": 1.0, "directions": 720, **change}
    with pytest.raises(error) as refused:
        NullRegion(**given)
    assert says in str(refused.value) and "\n" not in str(refused.value)


def test_evaluate_refuses_more_starts_than_memory_holds(feedback_run, exits, capsys) -> None:
    assert exits(["evaluate", str(feedback_run), "--episodes", "99999999999"]) == 2
    assert "99,999,999,999 held-out starts needs" in one_line(capsys)
