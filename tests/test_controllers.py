"""The one controller interface: its pieces (a chain of fallbacks, a switch, a held decision, a
timed controller), the entries' registry on every shipped model, and controllers brought from
elsewhere: a law in double_pendulum's convention scores to the bit as the same law written
against the interface, through ``olympics module:attribute``; bad sources are refused in one
line."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

from acrobot_mj.cli import main
from acrobot_mj.control.controller import (
    Combined,
    Controller,
    EnergyRemoval,
    Fallbacks,
    Held,
    Timed,
)
from acrobot_mj.olympics import entries, sources
from acrobot_mj.olympics.episodes import Conditions, episode
from acrobot_mj.olympics.plants import equations
from acrobot_mj.olympics.run import score
from acrobot_mj.olympics.sources import Source
from acrobot_mj.physics.models import MODELS

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


class Constant(Controller):
    """``torque`` everywhere; it covers the states whose first angle is below ``below``."""

    def __init__(self, torque: float, below: float = np.inf) -> None:
        self.torque, self.below, self.resets, self.heard = torque, below, 0, list[float]()

    def reset(self, seed: int | None = None) -> None:
        self.resets += 1

    def act(self, x: np.ndarray, t: float) -> float:
        return self.torque

    def applied(self, torque: float) -> None:
        self.heard.append(torque)

    def covers(self, x: np.ndarray) -> bool:
        return bool(x[0] < self.below)


def test_a_chain_of_fallbacks_asks_the_first_that_covers() -> None:
    chain = Fallbacks([Constant(1.0, below=0.0), Constant(2.0, below=1.0), Constant(3.0)])
    assert [chain.act(np.array([q, 0, 0, 0]), 0.0) for q in (-1.0, 0.5, 2.0)] == [1.0, 2.0, 3.0]
    chain.reset()
    assert [law.resets for law in chain.laws] == [1, 1, 1]
    with pytest.raises(ValueError, match="at least one law"):
        Fallbacks([])


def test_a_combined_controller_switches_as_double_pendulums() -> None:
    first, second = Constant(1.0), Constant(2.0)
    combined = Combined(
        first, second, to_second=lambda x, t: t >= 1.0, to_first=lambda x, t: x[0] > 5
    )
    x = np.zeros(4)
    assert [combined.act(x, t) for t in (0.0, 0.5, 1.0, 2.0)] == [1.0, 1.0, 2.0, 2.0]
    assert combined.act(np.array([6.0, 0, 0, 0]), 3.0) == 1.0  # and back
    combined.applied(0.5)
    assert first.heard == second.heard == [0.5]  # both hear the plant
    combined.reset()
    assert combined.active == 0 and first.resets == second.resets == 1


def test_energy_removal_works_against_the_elbow() -> None:
    removal = EnergyRemoval(damping=2.0, limit=1.0)
    # -clip(2 N m s/rad x dq2, -1, 1): by hand.
    assert removal.act(np.array([0, 0, 0, 0.25]), 0.0) == -0.5
    assert removal.act(np.array([0, 0, 0, -3.0]), 0.0) == 1.0


def test_a_held_controller_refuses_a_bad_period() -> None:
    with pytest.raises(ValueError, match="every must be a whole number of calls >= 1, got 0"):
        Held(Constant(1.0), 1.0, every=0)


def test_a_timed_controller_passes_everything_on_and_sums_up_its_calls() -> None:
    inner = Constant(1.5, below=0.0)
    timed = Timed(inner)
    x = np.array([-0.1, 0.2, 0.3, 0.4])
    assert [timed.act(x, 0.0) for _ in range(3)] == [1.5] * 3 and len(timed.seconds) == 3
    timed.applied(0.5)
    timed.reset()
    assert inner.heard == [0.5] and inner.resets == 1 and timed.covers(x)
    assert not timed.covers(np.array([0.1, 0, 0, 0]))
    timed.seconds = [0.001] * 97 + [0.003, 0.004, 0.005]  # [s]
    calls = timed.summary(0.002)
    assert calls["calls"] == 100 and calls["over_step"] == pytest.approx(0.03)
    assert calls["median_ms"] == pytest.approx(1.0) and calls["max_ms"] == pytest.approx(5.0)
    assert calls["p99_ms"] == pytest.approx(4.01)  # numpy's linear: 98.01 of 0 to 99
    with pytest.raises(ValueError, match="no call was timed"):
        Timed(inner).summary(0.002)


@pytest.mark.parametrize("model", sorted(MODELS))
@pytest.mark.parametrize("name", sorted(entries.ENTRIES))
def test_every_entry_is_built_or_refused_in_one_line_on_every_shipped_model(name, model) -> None:
    """As the docs' table says (:func:`~acrobot_mj.olympics.entries.support_table`)."""
    entry = entries.ENTRIES[name]
    row = next(r for r in entries.support_table().splitlines() if r.startswith(f"| `{name}` |"))
    cell = row.strip("| ").split(" | ")[1 + list(MODELS).index(model)]
    try:
        entry.check(model)
    except ValueError as error:
        assert "\n" not in str(error) and repr(model) in str(error) and cell != "runs"
        return
    assert cell == "runs"
    if name == "funnel":  # the cheap one is built here; the others' builds are the olympics tests'
        assert isinstance(entry.build(equations(model)), Controller)


def test_the_docs_list_every_entry_against_every_shipped_model() -> None:
    page = Path(__file__).resolve().parent.parent / "docs" / "guide" / "controllers.md"
    assert entries.support_table() in page.read_text()


@pytest.fixture
def examples_on_path():
    sys.path.insert(0, str(EXAMPLES))
    yield
    sys.path.remove(str(EXAMPLES))


@pytest.mark.slow
def test_their_convention_and_ours_give_the_same_torques_and_scores(examples_on_path) -> None:
    """The law of examples/double_pendulum_style.py in both shapes: the performance episode's
    torques equal to the bit, so every score equal; and its global episode too."""
    theirs = score(Source("double_pendulum_style:theirs"), scores=("performance", "global"))
    ours = score(Source("double_pendulum_style:ours"), scores=("performance", "global"))
    for part in ("performance", "global"):
        assert theirs[part]["episode"]["torques"] == ours[part]["episode"]["torques"]
        assert theirs[part]["score"] == ours[part]["score"]
    # The law swings up: measured 0.0799 (up at 4.45 s); not a zero against a zero.
    assert theirs["performance"]["success"] and theirs["performance"]["score"] > 0.05


def test_the_cli_scores_module_attribute(examples_on_path, tmp_path, capsys) -> None:
    out = tmp_path / "o"
    argv = ["olympics", "double_pendulum_style:theirs", "--scores", "performance", "--out"]
    assert main([*argv, str(out), "--no-progress"]) == 0
    record = json.loads((out / "olympics.json").read_text())
    assert record["model"]["entry"] == "double_pendulum_style:theirs"
    assert "performance 0.080" in capsys.readouterr().out


def test_their_controller_is_initialised_before_each_episode(examples_on_path) -> None:
    built = sources.build(Source("double_pendulum_style:theirs"), "ai_olympics")
    built.act(np.zeros(4), 0.0)
    assert built.theirs.calls == 1  # type: ignore[attr-defined]
    built.reset()  # init(): its own counter back to 0
    assert built.theirs.calls == 0  # type: ignore[attr-defined]
    # An episode runs a copy: 0.1 s, 50 steps of 0.002 s.
    assert len(episode(built, "ai_olympics", 0.1, Conditions(), 0).U) == 50


@pytest.mark.parametrize(
    ("name", "words"),
    [
        ("no_such_module_here:thing", "cannot import the controller no_such_module_here:thing"),
        ("double_pendulum_style:nothing", "has no attribute 'nothing'"),
        ("double_pendulum_style:LEVEL", "is float: neither an acrobot_mj Controller"),
        ("double_pendulum_style:law", r"law called with the model: law\(\) missing"),
        ("nowhere/policy.zip", "no policy file at nowhere/policy.zip"),
    ],
)
def test_bad_sources_are_refused_in_one_line(name, words, examples_on_path) -> None:
    with pytest.raises((ValueError, TypeError), match=words) as error:
        sources.build(Source(name), "ai_olympics")
    assert "\n" not in str(error.value)


def test_options_and_envs_go_only_where_they_belong(tmp_path, capsys) -> None:
    with pytest.raises(ValueError, match="options are for an entry"):
        Source("somewhere:thing", {"mpc": True})
    with pytest.raises(ValueError, match=r"--env and --env-kwargs are for a \.zip policy"):
        Source("funnel", env="acrobot_mj/AcrobotRL-v0")
    with pytest.raises(ValueError, match="a controller must be named"):
        Source("  ")
    argv = ["olympics", "funnel", "--option", "speed=3", "--out", str(tmp_path / "o")]
    with pytest.raises(SystemExit):
        main(argv)
    err = capsys.readouterr().err.strip()
    assert "the funnel entry has no option 'speed'; it has ['mpc']" in err and "\n" not in err


def test_evaluate_and_render_take_a_controller(tmp_path, capsys) -> None:
    """``evaluate funnel --model ai_olympics --out DIR``: its held-out episodes on that acrobot
    (uniform starts), recorded with the controller's name and the acrobot's parameters;
    ``render`` the same controller."""
    out = tmp_path / "ev"
    argv = ["evaluate", "funnel", "--model", "ai_olympics", "--out", str(out), "--episodes", "2"]
    assert main([*argv, "--seconds", "6"]) == 0
    assert "2 held-out starts (uniform): 2 caught their balance" in capsys.readouterr().out
    record = json.loads((out / "eval.json").read_text())
    assert record["controller"] == "funnel" and record["model"]["max_torque"] == 6.0
    assert record["model"]["max_vel1"] is None  # no velocity limit: JSON holds no infinity
    assert record["balanced_at_end"] == [True, True]
    video = tmp_path / "funnel.mp4"
    argv = ["render", "funnel", "--model", "ai_olympics", "--steps", "50", "--out", str(video)]
    assert main([*argv, "--no-progress"]) == 0
    assert video.stat().st_size > 0
    shown = json.loads(video.with_suffix(".json").read_text())
    assert shown["controller"] == "funnel"
    # Steps of 0.002 s drawn one in ten: 50 fps, the reset frame and steps 10, 20, ..., 50.
    assert shown["fps"] == 50.0 and shown["frames"] == 6


def test_balance_takes_a_controller(examples_on_path, tmp_path, capsys) -> None:
    """``balance CONTROLLER``: its 120 s from hanging on the report's acrobot (2,400 decisions
    of 0.05 s), every torque and the balance measures in balance.json; the plan's options
    refused with it."""
    out = tmp_path / "b"
    argv = ["balance", "double_pendulum_style:ours", "--no-video", "--out", str(out)]
    assert main(argv) == 0
    assert "from hanging: NOT balanced at the end" in capsys.readouterr().out  # an LQR alone
    record = json.loads((out / "balance.json").read_text())
    assert record["controller"] == "double_pendulum_style:ours" and record["video"] is None
    assert record["model"]["max_torque"] == 1.0 and len(record["actions"]) == 2400
    assert record["start_state"] == pytest.approx([-np.pi / 2, 0.0, 0.0, 0.0])
    assert record["assessment"]["balanced_at_end"] is False
    for extra, words in (
        (["--hold", "3"], "--hold: options of the planned swing-up"),
        (["--feedback"], "--feedback: options of the planned swing-up"),
    ):
        with pytest.raises(SystemExit):
            main(argv + extra)
        assert words in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["balance", "--option", "mpc=true", "--out", str(out)])
    assert "are for a CONTROLLER" in capsys.readouterr().err


def test_a_controller_needs_an_acrobot_and_a_folder_and_a_run_takes_neither(
    tmp_path, capsys
) -> None:
    for argv, words in (
        (["evaluate", "funnel", "--model", "ai_olympics"], "is a controller: give --out"),
        (["render", "funnel", "--out", str(tmp_path / "v.mp4")], "give --model"),
    ):
        with pytest.raises(SystemExit):
            main(argv)
        err = capsys.readouterr().err.strip()
        assert words in err and "\n" not in err
