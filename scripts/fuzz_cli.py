"""Fuzz every command and the public constructors as a hostile user would, and check the
package's promises on each case: a refusal is exit code 2 and one stderr line (naming the
problem, where the case says what to look for), never a traceback, and writes nothing; anything
else succeeds. Cases that run longer than ``--cut`` seconds are cut off and counted apart.

Usage::

    python scripts/fuzz_cli.py                # every case; exit 1 if any broke a promise
    python scripts/fuzz_cli.py --only balance # the cases whose label contains "balance"
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import io
import math
import os
import shutil
import signal
import sys
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

#: Values every option that takes one is given, beside the cases written by hand.
ABSURD = ("", " ", "nan", "inf", "-1", "0", "1e400", "1e-300", "x", "99999999999")
#: A cheap call of each command that every generated case starts from (its options then fuzzed).
BASES: dict[str, list[str]] = {
    "train": ["train", "--preset", "report", "--episodes", "1", "--max-episode-steps", "20"],
    "evaluate": ["evaluate", "fb", "--episodes", "1", "--seconds", "1"],
    "render": ["render", "--policy", "zero", "--steps", "2", "--width", "32", "--height", "32"],
    "balance": ["balance", "--no-video", "--hold", "1", "--out", "b"],
    "demo": ["demo", "--steps", "3"],
    "curves": ["curves", "run", "--out", "c.png"],
}
#: Options not fuzzed with every value: they start long work whatever their value.
SKIP = {"--help", "--version", "--tensorboard", "--peer-python", "--address"}


class CutOff(BaseException):
    """A case that ran past its time."""


@dataclass
class Case:
    """One case: ``argv`` of the command line, or ``call`` of a constructor; ``says``: what a
    refusal must contain ("" : any one line; None: it must succeed; "either": either)."""

    label: str
    argv: list[str] | None = None
    says: str | None = ""
    call: Callable[[], Any] | None = None


def hand_written() -> list[Case]:
    """Cases written by hand: what users tried, and its neighbours; new commands first."""
    ev = ["evaluate", "fb", "--episodes", "1", "--seconds", "2"]
    ol = ["olympics", "funnel", "--scores", "performance", "--out", "o"]
    cases = [
        Case("olympics unknown controller", ["olympics", "nobody", "--out", "o"], "nobody"),
        Case("olympics unknown score", [*ol, "--scores", "speed"], "--scores"),
        Case("olympics empty scores", [*ol, "--scores", ","], "--scores"),
        Case("olympics unknown model", [*ol, "--model", "nobody"], "model must be one of"),
        Case("olympics model without a plan", [*ol, "--model", "gymnasium"], "no planned"),
        Case("olympics jobs 0", [*ol, "--jobs", "0"], "--jobs"),
        Case("olympics out a file", [*ol[:-1], "c.txt"], "exists and is not a folder"),
        Case("olympics no out", ol[:-2], "--out"),
        Case("olympics performance", ol, None),
        Case(
            "evaluate push shorter than a decision",
            [*ev, "--push-every", "0.03", "--push-size", "0.5"],
            "push_every must be at least one decision",
        ),
        Case(
            "evaluate push 1e-300",
            [*ev, "--push-every", "1e-300", "--push-size", "0.5"],
            "push_every must be at least one decision",
        ),
        Case(
            "evaluate push longer than the episode",
            [*ev, "--push-every", "100", "--push-size", "0.5", "--seconds", "10"],
            "lands no push",
        ),
        Case(
            "evaluate push every decision",
            [*ev, "--push-every", "0.05", "--push-size", "0.5"],
            None,
        ),
        Case("evaluate push without size", [*ev, "--push-every", "1"], "pushes need both"),
        Case("evaluate push size without period", [*ev, "--push-size", "1"], "pushes need both"),
        Case(
            "evaluate push size too big",
            [*ev, "--push-every", "1", "--push-size", "1e9"],
            "push_size",
        ),
        Case("evaluate seconds 1e-9", [*ev, "--seconds", "1e-9"], "at least one decision"),
        Case("evaluate seconds negative", [*ev, "--seconds", "-1"], "in (0, 86400]"),
        Case("evaluate seconds 0", [*ev, "--seconds", "0"], "seconds must be > 0"),
        Case("evaluate perturb 1", [*ev, "--perturb", "1"], "perturb"),
        Case(
            "evaluate start noise with uniform",
            [*ev, "--starts", "uniform", "--start-noise", "0.1"],
            "--start-noise is for --starts noise",
        ),
        Case("evaluate no run", ["evaluate", "nothing"], "holds no run"),
        Case("evaluate empty dir", ["evaluate", ""], "holds no run"),
        Case("evaluate a file", ["evaluate", "c.txt"], "holds no run"),
        Case("evaluate minima on balance", [*ev, "--minima"], None),
        Case("balance out empty", ["balance", "--no-video", "--out", ""], "must name a path"),
        Case(
            "balance feedback out empty", ["balance", "--feedback", "--out", ""], "must name a path"
        ),
        Case(
            "balance out /dev/null",
            ["balance", "--no-video", "--out", "/dev/null"],
            "is not a folder",
        ),
        Case("balance out a file", ["balance", "--no-video", "--out", "c.txt"], "is not a folder"),
        Case("balance out below a file", ["balance", "--out", "c.txt/b"], "is not a folder"),
        Case(
            "balance feedback hold 60",
            ["balance", "--feedback", "--hold", "60", "--out", "f2"],
            "give no --optimise or --hold",
        ),
        Case(
            "balance feedback optimise",
            ["balance", "--feedback", "--optimise", "--out", "f2"],
            "give no --optimise or --hold",
        ),
        Case(
            "balance feedback width 100000",
            ["balance", "--feedback", "--width", "100000", "--out", "f2"],
            "width must be in",
        ),
        Case("balance width odd", ["balance", "--width", "101", "--out", "b"], "must be even"),
        Case("balance height 0", ["balance", "--height", "0", "--out", "b"], "must be >= 1"),
        Case(
            "balance into a run",
            ["balance", "--no-video", "--hold", "1", "--out", "fb"],
            "holds a run",
        ),
        Case(
            "balance feedback again",
            ["balance", "--feedback", "--no-video", "--out", "fb"],
            "--force",
        ),
        Case(
            "balance feedback force",
            ["balance", "--feedback", "--no-video", "--force", "--out", "fb"],
            None,
        ),
        Case(
            "balance force without feedback",
            ["balance", "--force", "--out", "b"],
            "--force is for --feedback",
        ),
        Case(
            "balance adaptive without feedback",
            ["balance", "--adaptive", "--out", "b"],
            "--adaptive is an option of --feedback",
        ),
        Case(
            "balance reserve 0",
            ["balance", "--reserve", "0", "--no-video", "--out", "b"],
            "reserve",
        ),
        Case(
            "balance feedback reserve 0.5",
            ["balance", "--feedback", "--reserve", "0.5", "--no-video", "--out", "f2"],
            "reserve",
        ),
        Case(
            "balance hold 1e9",
            ["balance", "--hold", "1e9", "--no-video", "--out", "b"],
            "hold must be in [0.05, 3600]",
        ),
        Case("balance hold 1", ["balance", "--hold", "1", "--no-video", "--out", "b"], None),
        Case(
            "black box decisions 100",
            ["train", "--preset", "black_box", "--decisions", "100", "--out", "bb"],
            "must be >= 900",
        ),
        Case(
            "black box decisions huge",
            ["train", "--preset", "black_box", "--decisions", "99999999999", "--out", "bb"],
            "of memory",
        ),
        Case(
            "black box decisions 1.5",
            ["train", "--preset", "black_box", "--decisions", "1.5", "--out", "bb"],
            "decisions",
        ),
        Case(
            "decisions on a preset without",
            ["train", "--preset", "book", "--decisions", "1000", "--out", "bb"],
            "only the black_box preset takes it",
        ),
        Case(
            "render a run and a policy",
            ["render", "run", "--policy", "zero", "--out", "v.mp4"],
            "not both or neither",
        ),
        Case("render no out", ["render", "--policy", "zero"], "give --out"),
        Case(
            "render out a folder",
            ["render", "--policy", "zero", "--out", "run"],
            "not a regular file",
        ),
        Case(
            "render out not mp4",
            ["render", "--policy", "zero", "--steps", "2", "--out", "v.avi"],
            ".mp4",
        ),
        Case(
            "render out over eval.json",
            [
                "render",
                "fb",
                "--steps",
                "2",
                "--width",
                "32",
                "--height",
                "32",
                "--out",
                "fb/run.mp4",
            ],
            "",
        ),
        Case(
            "render camera nope",
            ["render", "--policy", "zero", "--camera", "nope", "--out", "v.mp4"],
            "camera",
        ),
        Case(
            "render frame skip with a run",
            ["render", "run", "--frame-skip", "2", "--out", "v.mp4"],
            "--frame-skip is for --policy",
        ),
        Case(
            "render live with out",
            ["render", "--policy", "zero", "--live", "--out", "v.mp4"],
            "--live",
        ),
        Case(
            "render feedback run",
            ["render", "fb", "--steps", "3", "--width", "32", "--height", "32", "--out", "v.mp4"],
            None,
        ),
        Case("curves of nothing", ["curves", "nothing", "--out", "c.png"], "holds neither"),
        Case("curves bad suffix", ["curves", "run", "--out", "c.gif"], ""),
        Case("curves of a feedback run", ["curves", "fb", "--out", "c.png"], "either"),
        Case("train resume and force", ["train", "--resume", "--force", "--out", "o"], ""),
        Case("train resume nothing", ["train", "--resume", "--out", "nothing"], ""),
        Case("train out /dev/null", [*BASES["train"], "--out", "/dev/null"], ""),
        Case("train over a run", [*BASES["train"], "--out", "run"], "already holds a run"),
        Case("train unknown preset", ["train", "--preset", "nope"], "invalid choice"),
        Case("sweep missing file", ["sweep", "nothing.toml"], ""),
        Case("sweep a folder", ["sweep", "run"], ""),
        Case(
            "demo json over a run record",
            ["demo", "--steps", "3", "--json", "run/run.json"],
            "is a record of the run",
        ),
        Case("demo json a folder", ["demo", "--steps", "3", "--json", "run"], ""),
        Case("params", ["params"], None),
        Case("no command", [], None),
        Case("unknown command", ["nope"], "invalid choice"),
    ]
    return cases + constructors() + fourth_round() + many_seeds()


def many_seeds() -> list[Case]:
    """The global test over many seeds and its April 2025 draws (``--seeds``,
    ``--global-test``), and the disturbances declared as settings."""
    from acrobot_mj.envs.disturbances import Disturbances, Perturbation
    from acrobot_mj.olympics.protocol import GlobalPolicy
    from acrobot_mj.olympics.run import OlympicsRun, score
    from acrobot_mj.train.learners import HeldOut

    ol = ["olympics", "funnel", "--scores", "performance", "--out", "o"]
    cases = [
        Case(f"olympics --seeds {v!r}", [*ol, "--seeds", v], "--seeds")
        for v in ("0", "-1", "x", "1e400", "2.5", "")
    ]
    cases += [
        Case(f"olympics --global-test {v!r}", [*ol, "--global-test", v], "--global-test")
        for v in ("", "ICRA2025", "april", "current:AR-EAPO", "icra2025:ar-eapo", "icra2025:x:y")
    ]
    return [
        *cases,
        Case("olympics seeds without global", [*ol, "--seeds", "2"], "needs the global score"),
        Case(
            "olympics seeds 10001",
            ["olympics", "funnel", "--scores", "global", "--seeds", "10001", "--out", "o"],
            "global_seeds must be in [1, 10000]",
        ),
        Case(
            "olympics a replayed draw and seeds",
            [*ol[:3], "global", "--global-test", "icra2025:VIMPPI", "--seeds", "2", *ol[4:]],
            "one draw",
        ),
        Case("olympics icra2025 performance", [*ol, "--global-test", "icra2025"], None),
        Case(
            "score global_seeds 0", call=lambda: score("funnel", global_seeds=0), says="[1, 10000]"
        ),
        Case(
            "OlympicsRun global_seeds 1.5",
            call=lambda: OlympicsRun("funnel", global_seeds=1.5),
            says="must be an integer",
        ),
        Case("GlobalPolicy version x", call=lambda: GlobalPolicy(version="x"), says="got 'x'"),
        Case(
            "GlobalPolicy replay today",
            call=lambda: GlobalPolicy(replay="AR-EAPO"),
            says="replay is a draw of the icra2025",
        ),
        Case(
            "GlobalPolicy replay a draw",
            call=lambda: GlobalPolicy(version="icra2025", replay="AR-EAPO").draw(0),
            says=None,
        ),
        Case("Perturbation mass 0", call=lambda: Perturbation(mass_scale=0.0), says="> 0"),
        Case(
            "Perturbation offset text",
            call=lambda: Perturbation(start_offset="abcd"),
            says="start_offset must be 4 numbers",
        ),
        Case(
            "Perturbation offset 1e400",
            call=lambda: Perturbation(start_offset=(1e400, 0, 0, 0)),
            says="start_offset",
        ),
        Case(  # numpy's SeedSequence takes any integer >= 0
            "Perturbation seed 400 digits", call=lambda: Perturbation(seed=10**400), says=None
        ),
        Case("Perturbation noise -1", call=lambda: Perturbation(torque_noise=-1.0), says="noise"),
        Case("Perturbation unknown", call=lambda: Perturbation(mass=2.0), says="mass"),
        Case(
            "Disturbances push_every 1e400",
            call=lambda: Disturbances(push_every=1e400, push_size=0.1),
            says="push_every",
        ),
        Case(
            "Disturbances response 0",
            call=lambda: Disturbances(torque_response=0.0),
            says="torque_response must be > 0",
        ),
        Case(
            "Disturbances velocity noise 400 digits",
            call=lambda: Disturbances(velocity_noise=10**400),
            says="401 digits",
        ),
        Case("HeldOut torque noise 2e3", call=lambda: HeldOut(torque_noise=2e3), says="1000"),
        Case(
            "HeldOut from a record with an unknown key",
            call=lambda: HeldOut.from_dict({"episodes": 3, "pushes": 2}),
            says="unknown evaluation settings ['pushes']",
        ),
    ]


#: Model files the fourth round reads (fixtures writes them): name, text.
MODEL_FILES = {
    "huge_torque.json": '{"max_torque": 2e10}',
    "big_torque.json": '{"max_torque": 9e9}',
    "tiny_mass.json": '{"m1": 1e-300}',
    "light.json": '{"m2": 1e-12, "I2": 1e-12}',
    "long.json": '{"l1": 1e300}',
    "digits.json": '{"m1": 1' + "0" * 400 + "}",
    "digits_damping.json": '{"damping": [1' + "0" * 400 + ", 0]}",
    "empty.toml": "",
    "empty.json": "{}",
    "upper.JSON": '{"m1": 2.0}',
    "wild.json": '{"g": 1e6, "dt": 1.0, "max_vel1": null, "max_vel2": null}',
    "no_limits.json": '{"max_vel1": null, "max_vel2": null}',
    "mine.json": '{"m2": 1.5}',
}


def fourth_round() -> list[Case]:
    """The fourth reliability round's cases: model files read where they are refused, the
    disturbance wrappers on any env and after a copy, olympics' folders and sizes that cannot
    finish."""
    import copy
    import pickle

    import gymnasium as gym

    from acrobot_mj.envs.disturbances import Pushed
    from acrobot_mj.envs.model_error import ModelError
    from acrobot_mj.envs.motor import Motor
    from acrobot_mj.envs.sensor import Sensor
    from acrobot_mj.train.feedback_run import FeedbackConfig

    refusals = {
        "huge_torque.json": "max_torque must be in",
        "big_torque.json": "max_torque must be in",
        "tiny_mass.json": "m1 must be in",
        "light.json": "m2 must be in",
        "long.json": "l1 must be in",
        "digits.json": "an integer of 401 digits",
        "digits_damping.json": "an integer of 401 digits",
        "empty.toml": "not empty",
        "empty.json": "not empty",
        "nothing.json": "is not found",
        "folder.json": "is a folder",  # olympics, evaluate: a folder is a run, "not a readable"
        "loop.json": "symbolic links",
    }
    cases = []
    for name, says in refusals.items():
        for command in (
            ["params"],
            ["demo", "--steps", "3"],
            ["train", "--episodes", "1", "--max-episode-steps", "5", "--out", "t"],
            ["olympics", "funnel", "--scores", "performance", "--out", "o"],
            ["balance", "--feedback", "--no-video", "--out", "f3"],
            ["evaluate", "funnel", "--out", "e", "--episodes", "1", "--seconds", "1"],
        ):
            run_too = name == "folder.json" and command[0] in ("olympics", "evaluate")
            expected = "is not a readable trained run" if run_too else says
            cases.append(
                Case(f"{command[0]} --model {name}", [*command, "--model", name], expected)
            )
    for name in ("upper.JSON", "no_limits.json", "mine.json"):
        cases.append(Case(f"params --model {name}", ["params", "--model", name], None))
        cases.append(Case(f"demo --model {name}", ["demo", "--steps", "3", "--model", name], None))
    cases += [
        Case(
            "demo a diverging model", ["demo", "--steps", "5", "--model", "wild.json"], "non-finite"
        ),
        Case(
            "train 2**63 steps",
            ["train", "--max-episode-steps", str(2**63), "--out", "t"],
            "in [1, 1000000]",
        ),
        Case(
            "train 1e30 episodes",
            ["train", "--episodes", "1" + "0" * 30, "--out", "t"],
            "an integer of 31",
        ),
        Case(
            "train population 1e5",
            ["train", "--population", "100000", "--out", "t"],
            "in [1, 10000]",
        ),
        Case(
            "train on a file, evaluated",
            [
                "train",
                "--model",
                "mine.json",
                "--episodes",
                "1",
                "--max-episode-steps",
                "5",
                "--out",
                "t",
            ],
            None,
        ),
        Case(
            "olympics below a file",
            ["olympics", "funnel", "--out", "c.txt/o"],
            "exists and is not a folder",
        ),
        Case("olympics empty controller", ["olympics", "", "--out", "o"], "must name a path"),
        Case(
            "olympics a folder as model",
            ["olympics", "funnel", "--model", "run", "--out", "o"],
            "not a controller run",
        ),
        Case("olympics seed -1", ["olympics", "funnel", "--seed", "-1", "--out", "o"], "--seed"),
        Case(
            "olympics scores twice",
            ["olympics", "funnel", "--scores", "performance,performance", "--out", "o"],
            None,
        ),
    ]

    def olympics() -> gym.Env:
        return gym.make("acrobot_mj/Acrobot-v0", model="ai_olympics", continuous=True)

    def gymnasium() -> gym.Env:
        return gym.make("Acrobot-v1")

    wrappers = {
        "Motor": lambda env: Motor(env, response=0.3),
        "Sensor": lambda env: Sensor(env, delay=0.01, sigma=0.1),
        "ModelError": lambda env: ModelError(env, {"m2": 0.7}),
        "Pushed": Pushed,
    }
    for name, wrap in wrappers.items():
        cases.append(Case(f"{name} on Acrobot-v1", call=lambda w=wrap: w(gymnasium())))
        cases.append(
            Case(f"{name} deep-copied", call=lambda w=wrap: copy.deepcopy(w(olympics())), says=None)
        )
        cases.append(
            Case(
                f"{name} pickled",
                call=lambda w=wrap: pickle.loads(pickle.dumps(w(olympics()))),
                says=None,
            )
        )

    def pendubot() -> gym.Env:
        return gym.make("acrobot_mj/Acrobot-v0", model="ai_olympics_pendubot", continuous=True)

    cases += [
        Case(
            "Motor on the pendubot", call=lambda: Motor(pendubot(), response=0.5).reset(), says=None
        ),
        Case(
            "two ModelErrors, an inertia 0 between",
            call=lambda: ModelError(
                ModelError(olympics(), {"I2": 0.6255677234174437 * 0.25569305436052964**2}),
                {"I2": 0.05},
            ),
            says=None,
        ),
        Case("Sensor sigma None", call=lambda: Sensor(olympics(), sigma=None), says="got None"),
        Case(
            "Sensor delay 400 digits",
            call=lambda: Sensor(olympics(), delay=10**400),
            says="401 digits",
        ),
        Case("Sensor mode vel", call=lambda: Sensor(olympics(), delay=0.01, mode="vel"), says=None),
        Case(
            "Sensor mode pos",
            call=lambda: Sensor(olympics(), mode="pos"),
            says="mode must be one of",
        ),
        Case(
            "Motor sigma 400 digits",
            call=lambda: Motor(olympics(), sigma=10**400),
            says="401 digits",
        ),
        Case(
            "Motor response 0",
            call=lambda: Motor(olympics(), response=0.0),
            says="response must be in",
        ),
        Case("Motor response 3", call=lambda: Motor(olympics(), response=3.0), says="response"),
        Case(
            "Motor pulses wrong shape",
            call=lambda: Motor(olympics(), pulses=np.ones(3)),
            says="pulses",
        ),
        Case(
            "Motor pulses nan",
            call=lambda: Motor(olympics(), pulses=np.full((2, 3), np.nan)),
            says="finite",
        ),
        Case("Motor rng -1", call=lambda: Motor(olympics(), rng=-1), says="seed must be >= 0"),
        Case("Motor rng string", call=lambda: Motor(olympics(), rng="1"), says="rng must be"),
        Case(
            "ModelError unknown",
            call=lambda: ModelError(olympics(), {"mass": 1.0}),
            says="unknown model parameters",
        ),
        Case(
            "ModelError 400 digits",
            call=lambda: ModelError(olympics(), {"m2": 10**400}),
            says="401 digits",
        ),
        Case(
            "ModelError not a mapping", call=lambda: ModelError(olympics(), [1.0]), says="mapping"
        ),
        Case(
            "ModelError m2 0",
            call=lambda: ModelError(olympics(), {"m2": 0.0}),
            says="m2 must be > 0",
        ),
        Case(
            "ModelError gear 0",
            call=lambda: ModelError(olympics(), {"m2": 1.0}, gear_ratio=0.0),
            says="gear_ratio",
        ),
        Case(
            "Pushed without a time limit",
            call=lambda: Pushed(olympics().unwrapped),
            says="time limit",
        ),
        Case(
            "FeedbackConfig reserve 400 digits",
            call=lambda: FeedbackConfig(reserve=10**400),
            says="401 digits",
        ),
        Case(
            "FeedbackConfig model a folder",
            call=lambda: FeedbackConfig(model="folder.json"),
            says="is a folder",
        ),
    ]
    return cases


def constructors() -> list[Case]:
    """The public constructors, each given what a user might."""
    import gymnasium as gym

    from acrobot_mj.control.lqr import NullRegion, discrete_model
    from acrobot_mj.envs.disturbances import Disturbances
    from acrobot_mj.train.black_box import BlackBoxConfig
    from acrobot_mj.train.config import TrainConfig
    from acrobot_mj.train.feedback_run import FeedbackConfig
    from acrobot_mj.train.learners import HeldOut

    a, b = discrete_model()
    heights = "acrobot_mj/Acrobot-v0"
    balance = "acrobot_mj/AcrobotBalance-v0"

    def make(env_id: str, **kwargs: Any) -> Callable[[], Any]:
        return lambda: gym.make(env_id, **kwargs).close()

    def vec(**kwargs: Any) -> Callable[[], Any]:
        return lambda: gym.make_vec(heights, vectorization_mode="vector_entry_point", **kwargs)

    cases = [
        Case("NullRegion string A", call=lambda: NullRegion("x", b, 1.0)),
        Case("NullRegion stable A", call=lambda: NullRegion(0.5 * np.eye(4), b, 1.0)),
        Case("NullRegion 1-D b", call=lambda: NullRegion(a, b[:, 0], 1.0)),
        Case("NullRegion negative directions", call=lambda: NullRegion(a, b, 1.0, -3)),
        Case("NullRegion nan limit", call=lambda: NullRegion(a, b, math.nan)),
        Case("NullRegion the acrobot's", call=lambda: NullRegion(a, b, 1.0), says=None),
        Case("Disturbances negative period", call=lambda: Disturbances(-1.0, 0.5)),
        Case("Disturbances string size", call=lambda: Disturbances(1.0, "big")),
        Case("Disturbances perturb 2", call=lambda: Disturbances(perturb=2.0)),
        Case(
            "push steps of a short period",
            call=lambda: Disturbances(0.01, 0.5).push_steps(100, 1, 0.05),
        ),
        Case("HeldOut episodes 0", call=lambda: HeldOut(episodes=0)),
        Case("HeldOut episodes 1.5", call=lambda: HeldOut(episodes=1.5)),
        Case("HeldOut starts grid", call=lambda: HeldOut(starts_from="grid")),
        Case("HeldOut seconds string", call=lambda: HeldOut(seconds="10")),
        Case("HeldOut seed -1", call=lambda: HeldOut(seed=-1)),
        Case("HeldOut seconds 1", call=lambda: HeldOut(seconds=1.0), says=None),
        Case("FeedbackConfig reserve 0.5", call=lambda: FeedbackConfig(reserve=0.5)),
        Case("FeedbackConfig seconds 0", call=lambda: FeedbackConfig(seconds=0.0)),
        Case("FeedbackConfig discrete string", call=lambda: FeedbackConfig(discrete="yes")),
        Case("FeedbackConfig from unknown keys", call=lambda: FeedbackConfig.from_dict({"x": 1})),
        Case("BlackBoxConfig decisions 99", call=lambda: BlackBoxConfig(decisions=99)),
        Case(
            "BlackBoxConfig horizons backwards",
            call=lambda: BlackBoxConfig(horizons=(800, 440, 40)),
        ),
        Case("BlackBoxConfig harmonics 9", call=lambda: BlackBoxConfig(harmonics=9)),
        Case("TrainConfig unknown key", call=lambda: TrainConfig.from_dict({"bogus": 1})),
        Case("TrainConfig alpha nan", call=lambda: TrainConfig(alpha=math.nan)),
        Case("env frame_skip 0", call=make(heights, frame_skip=0)),
        Case("env frame_skip string", call=make(heights, frame_skip="2")),
        Case("env integrator rk5", call=make(heights, integrator="rk5")),
        Case("env render_mode foo", call=make(heights, render_mode="foo")),
        Case("env width 0", call=make(heights, width=0)),
        Case("env width huge", call=make(heights, width=10**9)),
        Case("env camera 3", call=make(heights, camera=3)),
        Case("env continuous string", call=make(heights, continuous="yes")),
        Case("env observation pixels", call=make(heights, observation="pixels")),
        Case("env task nope", call=make(heights, task="nope")),
        Case("env goal height string", call=make(heights, goal_height="high")),
        Case("balance env tolerance -1", call=make(balance, tolerance=-1.0)),
        Case("balance env rgb_array", call=make(balance, render_mode="rgb_array"), says=None),
        Case("vector num_envs 0", call=vec(num_envs=0)),
        Case("vector num_envs huge", call=vec(num_envs=10**12)),
        Case("vector num_envs string", call=vec(num_envs="4")),
    ]
    return cases


def generated() -> list[Case]:
    """Every option of every command given each of ``ABSURD``: refused in one line, or done."""
    from acrobot_mj.cli import build_parser

    parser = build_parser()
    commands = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    cases = []
    for name, base in BASES.items():
        sub = commands.choices[name]
        for action in sub._actions:
            flags = [f for f in action.option_strings if f.startswith("--")]
            if not flags or flags[0] in SKIP or action.nargs == 0:
                continue
            for value in ABSURD:
                cases.append(
                    Case(f"{name} {flags[0]}={value!r}", [*base, flags[0], value], "either")
                )
    return cases


def snapshot(folder: Path) -> dict[str, str]:
    """Every file below ``folder`` and the digest of its bytes."""
    return {
        str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(folder.rglob("*"))
        if not p.is_symlink() and p.is_file() and p.name != ".lock"
    }


def fixtures(folder: Path) -> None:
    """The runs the cases read: ``fb`` (state feedback), ``run`` (a tiny agent), a text file."""
    from acrobot_mj.train.feedback_run import FeedbackConfig
    from acrobot_mj.train.presets import PRESETS
    from acrobot_mj.train.trainer import train

    train(FeedbackConfig(), seed=0, out_dir=folder / "fb")
    train(PRESETS["report"].replace(episodes=2, max_episode_steps=30), 0, folder / "run")
    (folder / "c.txt").write_text("not a folder\n")
    for name, text in MODEL_FILES.items():
        (folder / name).write_text(text)
    (folder / "folder.json").mkdir()
    (folder / "loop.json").symlink_to("loop.json")


def _alarm(signum: int, frame: Any) -> None:
    raise CutOff


def run_case(case: Case, folder: Path, cut: float) -> tuple[str, str]:
    """``("held" | "broke" | "cut", why)``."""
    from acrobot_mj.cli import main

    before = snapshot(folder)
    out, err = io.StringIO(), io.StringIO()
    code: int | None = 0
    error: BaseException | None = None
    signal.signal(signal.SIGALRM, _alarm)
    signal.setitimer(signal.ITIMER_REAL, cut)
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            if case.argv is not None:
                try:
                    code = main(case.argv)
                except SystemExit as stop:
                    code = stop.code if isinstance(stop.code, int) else 2
            else:
                assert case.call is not None
                try:
                    case.call()
                except (ValueError, TypeError) as refused:
                    error, code = refused, 2
    except CutOff:
        return "cut", f"ran past {cut:g} s"
    except Exception as raised:  # a traceback: broken whatever the case
        return "broke", f"raised {type(raised).__name__}: {raised}"
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
    text = err.getvalue() if error is None else f"{type(error).__name__}: {error}\n"
    if "Traceback" in text:
        return "broke", "a traceback"
    if code == 0:
        if case.says not in (None, "either"):
            return "broke", f"succeeded; expected a refusal saying {case.says!r}"
        return "held", "succeeded"
    if code != 2:
        return "broke", f"exit code {code}: {text.strip()[:200]}"
    if case.says is None:
        return "broke", f"refused: {text.strip()[:200]}"
    if text.count("\n") != 1:
        return "broke", f"{text.count(chr(10))} lines: {text[:300]!r}"
    if case.says not in ("", "either") and case.says not in text:
        return "broke", f"says {text.strip()!r}, not {case.says!r}"
    if snapshot(folder) != before:
        changed = set(snapshot(folder).items()) ^ set(before.items())
        return "broke", f"refused but wrote {sorted({n for n, _ in changed})}"
    return "held", text.strip()


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--only", default="", help="the cases whose label contains this")
    p.add_argument("--cut", type=float, default=20.0, help="seconds a case may run")
    p.add_argument("--verbose", action="store_true", help="a line for every case")
    args = p.parse_args(argv)
    cases = [c for c in hand_written() + generated() if args.only in c.label]
    counts = {"held": 0, "broke": 0, "cut": 0}
    with tempfile.TemporaryDirectory() as tmp:
        template = Path(tmp) / "template"
        fixtures(template)
        home = Path.cwd()
        for case in cases:
            folder = Path(tmp) / "case"
            shutil.rmtree(folder, ignore_errors=True)
            shutil.copytree(template, folder, symlinks=True)
            os.chdir(folder)
            try:
                outcome, why = run_case(case, folder, args.cut)
            finally:
                os.chdir(home)
            counts[outcome] += 1
            if outcome != "held" or args.verbose:
                print(f"{outcome:5}  {case.label}: {why}", flush=True)
    print(
        f"{len(cases)} cases: {counts['held']} held, {counts['broke']} broke a promise, "
        f"{counts['cut']} cut off after {args.cut:g} s"
    )
    return 1 if counts["broke"] else 0


if __name__ == "__main__":
    sys.exit(main())
