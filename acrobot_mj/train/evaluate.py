"""Evaluating and rendering any run: greedy episodes from held-out starts (``eval.json``, each
episode's start state and actions, replayable; see docs/guide/evaluate.md), compared per start with
a beam search's minimum time (``heldout_minima.json``), and a video of the episode from rest."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any, cast

import gymnasium as gym
import numpy as np

from acrobot_mj.control.search import Beam, min_time_search
from acrobot_mj.envs.disturbances import Pushed
from acrobot_mj.envs.links import model_parameters, set_model_parameters
from acrobot_mj.envs.motor import Motor
from acrobot_mj.envs.rollout import FROM_REST, Hooks, acrobot_of, run_episode
from acrobot_mj.envs.sensor import Sensor
from acrobot_mj.envs.tasks import HeightGoal
from acrobot_mj.files import sealed, versions, write_json
from acrobot_mj.physics.integrators import ENV_INTEGRATORS, steps_in
from acrobot_mj.physics.params import REPORT
from acrobot_mj.report.video import RenderSettings, record_episode, watch, write_video_record
from acrobot_mj.train.config import TrainConfig
from acrobot_mj.train.controller_run import ControlledLearner
from acrobot_mj.train.learners import MOTOR, PERTURB, PUSHES, SENSOR, HeldOut, Learner
from acrobot_mj.train.lock import RunLock, check_not_held
from acrobot_mj.train.records import CHECKPOINT_FILE, EVAL_FILE, RUN_FILE, History, spread
from acrobot_mj.train.trainer import load_learner

MINIMA = ("stored", "compute", "none")
STORED = Path(__file__).with_name("heldout_minima.json")
#: The analytic model's integrator for each of the env's.
_RENDER = RenderSettings()
#: What eval.json lists per held-out episode besides the results (pushes and parameters where
#: the protocol pushes or perturbs).
PER_EPISODE = {
    "actions": "actions",
    "torques": "torques",
    "final_states": "final_state",
    "pushes": "pushes",
    "parameters": "parameters",
}


def run_lock(run_dir: str | Path, command: str) -> RunLock:
    """The lock of a run directory to read; nothing is created where there is no run."""
    path = Path(run_dir)
    if not str(run_dir).strip() or not any(
        (path / n).exists() for n in (RUN_FILE, CHECKPOINT_FILE)
    ):
        if str(run_dir).strip():
            check_not_held(path)  # a run being created: its owner named
        raise FileNotFoundError(
            f"{str(run_dir)!r} holds no run (no {RUN_FILE} or "
            f"{CHECKPOINT_FILE}): give a directory written by acrobot-mj "
            "train"
        )
    return RunLock(path, command, create=False)


def evaluate(
    run_dir: str | Path, protocol: HeldOut | dict | None = None, minima: str = "stored"
) -> dict[str, Any]:
    """Greedy episodes of a run from the held-out starts of ``protocol`` (default: its
    learner's; a dict changes some of its settings) and from rest; writes and returns
    ``eval.json``. ``minima``: compare with ``"stored"`` per-start minima where they apply,
    ``"compute"`` them otherwise, or ``"none"``. Locks the run directory; one that cannot be
    written (a read-only mount) is evaluated without writing ``eval.json``."""
    with run_lock(run_dir, "evaluate") as lock:
        return evaluate_run(run_dir, protocol, minima, write=not lock.read_only)


def evaluate_run(
    run_dir: str | Path,
    protocol: HeldOut | dict | None = None,
    minima: str = "stored",
    write: bool = True,
) -> dict[str, Any]:
    """:func:`evaluate` for a caller that holds the lock (of the run or of one above it);
    ``write``: ``eval.json`` too."""
    if minima not in MINIMA:
        raise ValueError(f"minima must be one of {MINIMA}, got {minima!r}")
    learner = load_learner(run_dir)
    config = learner.config
    if minima == "compute" and isinstance(config, TrainConfig) and config.model is not None:
        raise ValueError(f"--minima: {NOT_THE_REPORTS} (model {config.model!r})")
    if protocol is None or isinstance(protocol, dict):
        protocol = dataclasses.replace(learner.protocol, **(protocol or {}))
    record = {
        "run": str(run_dir),
        "run_seed": learner.seed,
        **({"kind": learner.kind} if learner.kind else {}),
        "config": learner.config.to_dict(),
        "versions": versions(),
        **evaluate_learner(learner, protocol, minima),
    }
    record = sealed(record)  # a sweep tells an edited copy
    if write:
        write_json(Path(run_dir) / EVAL_FILE, record)
    return record


def evaluate_controlled(
    learner: ControlledLearner, out: str | Path, protocol: HeldOut | dict | None = None
) -> dict[str, Any]:
    """:func:`evaluate_learner` of a controller that is not a run, written to ``out``'s
    ``eval.json`` (the folder made where it is missing), naming the controller and the
    acrobot."""
    if protocol is None or isinstance(protocol, dict):
        protocol = dataclasses.replace(learner.protocol, **(protocol or {}))
    record = {
        "controller": learner.name,
        "model": learner.model.to_dict(),
        "versions": versions(),
        **evaluate_learner(learner, protocol, "none"),
    }
    record = sealed(record)
    Path(out).mkdir(parents=True, exist_ok=True)
    write_json(Path(out) / EVAL_FILE, record)
    return record


def evaluate_learner(learner: Learner, protocol: HeldOut, minima: str = "stored") -> dict:
    """The held-out evaluation of ``learner`` (see the module docstring)."""
    env = episode_env(learner, protocol)
    disturbances, nominal = protocol.disturbances(), model_parameters(env)
    try:
        kicks = disturbances.push_steps(env.physics_steps, env.frame_skip, env.physics_dt)
        rest = play(env, learner, 0, dict(FROM_REST), seed=learner.seed)
        starts = protocol.starts(np.array(rest["start_state"]))
        episodes = []
        for k, start in enumerate(starts):
            parameters = disturbances.perturbed(nominal, protocol.stream(PERTURB, k))
            set_model_parameters(env, parameters)
            pushed = disturbed(env, protocol, k)
            pushed.begin(kicks, disturbances.push_size, protocol.stream(PUSHES, k))
            episode = play(pushed, learner, k + 1, {"state": start})
            episode["parameters"] = parameters
            episodes.append(episode)
        set_model_parameters(env, nominal)
        task = acrobot_of(env).task
        other = task.name == "height_goal" and acrobot_of(env).params != REPORT
        history = History()
        for e in episodes:
            history.add(e["length"], e["return"], e["success"])
        absent = {"pushes": disturbances.push_every is None, "parameters": not disturbances.perturb}
        per_episode = {k: v for k, v in PER_EPISODE.items() if not absent.get(k)}
        record = {
            "protocol": protocol.to_dict(),
            "physics": {"frame_skip": env.frame_skip, "integrator": acrobot_of(env).integrator},
            "summary": {
                task.score.quantity: spread(task.score.values(history.to_dict())),
                "successes": sum(history.episode_successes),
                "episodes": len(history),
                **task.summarise([e["assessment"] for e in episodes], spread),
            },
            "rest": {
                **{k: v for k, v in rest.items() if k not in ("assessment", "pushes")},
                **rest["assessment"],
            },
            "start_states": starts.tolist(),
            **{name: [e[key] for e in episodes] for name, key in per_episode.items()},
            **history.to_dict(),
            **{key: [e["assessment"][key] for e in episodes] for key in rest["assessment"]},
        }
        references = (
            None
            if protocol.starts_from != "noise"
            else (references_for(env, protocol, starts, minima))
        )
    finally:
        env.close()
    if references is not None:
        record["minima"] = compare(history.episode_lengths, references)
    elif other and protocol.starts_from == "noise" and minima != "none":
        record["no_minima"] = NOT_THE_REPORTS
    return record


def episode_env(learner: Learner, protocol: HeldOut) -> Pushed:
    """``learner``'s env for ``protocol``'s episodes: ``seconds`` long where it says, pushed
    where it pushes."""
    env = learner.env()
    if protocol.seconds is not None:
        dt = acrobot_of(env).dt
        env.close()
        if protocol.seconds < dt * (1.0 - 1e-9):  # steps_in's tolerance
            raise ValueError(
                f"seconds must be at least one decision of this run ({dt:g} s), "
                f"got {protocol.seconds:g}"
            )
        env = learner.env(max_episode_steps=steps_in(protocol.seconds, dt))
    return Pushed(env)


def disturbed(env: Pushed, protocol: HeldOut, k: int) -> Pushed:
    """``env`` for held-out episode ``k`` under ``protocol``'s motor
    (:class:`~acrobot_mj.envs.motor.Motor`) and sensor (:class:`~acrobot_mj.envs.sensor.Sensor`,
    its delay the protocol's ``"posvel"``), their noise drawn from the episode's streams;
    ``env`` itself where it has neither."""
    d = protocol.disturbances()
    if not (d.motored or d.sensed):
        return env
    inner = env.env
    if d.motored:
        inner = Motor(inner, d.torque_response, d.torque_noise, rng=protocol.stream(MOTOR, k))
    if d.sensed:
        sigma = (0.0, 0.0, d.velocity_noise, d.velocity_noise)
        inner = Sensor(inner, d.delay, sigma, rng=protocol.stream(SENSOR, k))
    return Pushed(inner)


def motor_of(env: gym.Env) -> Motor | None:
    """The :class:`~acrobot_mj.envs.motor.Motor` among ``env``'s wrappers, if any."""
    while isinstance(env, gym.Wrapper):
        if isinstance(env, Motor):
            return env
        env = env.env
    return None


def play(env: Pushed, learner: Learner, episode: int, options: dict, seed: int | None = None):
    """Greedy episode ``episode`` of ``learner`` from ``env.reset(seed, options)``: its
    actions, its torque at every physics step (the applied one under a motor), the pushes it
    took and its assessment."""
    acrobot, actions, torques, states = acrobot_of(env), [], [], []

    def on_step(action: Any, *_: Any) -> None:
        actions.append(float(action[0]) if isinstance(action, np.ndarray) else int(action))
        torques.extend([float(acrobot.data.ctrl[0])] * acrobot.frame_skip)
        states.append(acrobot.state)

    result = run_episode(
        env,
        learner.actor(env, episode),
        seed,
        options,
        hooks=Hooks(lambda *_: states.append(acrobot.state), on_step),
    )
    motor = motor_of(env)
    if motor is not None:
        torques = np.repeat(motor.applied[:, motor.dof], acrobot.frame_skip).tolist()
    kicks = [int(k) // acrobot.frame_skip for k, *_ in env.pushes]
    assessment = acrobot.task.assess(np.array(states), acrobot.dt, learner.swing_up, kicks)
    return {
        "start_state": states[0].tolist(),
        "length": result.length,
        "return": result.episode_return,
        "success": result.success,
        "actions": actions,
        "torques": torques,
        "final_state": states[-1].tolist(),
        "pushes": env.pushes,
        "assessment": assessment,
    }


def distinct_outcomes(evaluations: list[dict[str, Any]]) -> dict[str, int]:
    """How many distinct greedy behaviours several runs' evaluations show: runs that take the
    same actions from rest (``from_rest``), or from every held-out start (``held_out``), count
    once."""
    return {
        "from_rest": len({tuple(e["rest"]["actions"]) for e in evaluations}),
        "held_out": len({tuple(map(tuple, e["actions"])) for e in evaluations}),
    }


def render_run(
    run_dir: str | Path, out: str | Path, settings: RenderSettings = _RENDER
) -> dict[str, Any]:
    """A video of a run's greedy episode from rest, on the run's own env."""
    with run_lock(run_dir, "render"):
        learner = load_learner(run_dir)
    record = render_learner(learner, out, settings)
    record.update(run=str(run_dir), run_seed=learner.seed, policy=learner.describes)
    write_video_record(record)
    return record


def render_controlled(
    learner: ControlledLearner, out: str | Path, settings: RenderSettings = _RENDER
) -> dict[str, Any]:
    """A video of a controller's episode from rest (not a run's), and its record."""
    record = render_learner(learner, out, settings)
    record.update(controller=learner.name, policy=learner.describes)
    write_video_record(record)
    return record


def balance_controlled(
    learner: ControlledLearner, out: str | Path, settings: RenderSettings | None = None
) -> dict[str, Any]:
    """``acrobot-mj balance CONTROLLER``: the controller's episode from hanging at rest on its
    acrobot's balance task (120 s, as ``evaluate`` runs it), each decision's action and torque
    and the task's assessment in ``out/balance.json``; with ``settings``, a video of the same
    episode (``out/swing_up.mp4``)."""
    out = Path(out)
    env = episode_env(learner, learner.protocol)
    try:
        episode = play(env, learner, 0, dict(FROM_REST), seed=learner.seed)
    finally:
        env.close()
    video = None if settings is None else render_controlled(learner, out / "swing_up.mp4", settings)
    record = {
        "command": "balance",
        "controller": learner.name,
        "model": learner.model.to_dict(),
        "versions": versions(),
        **episode,
        "video": None if video is None else video["video"],
    }
    write_json(out / "balance.json", record)
    return record


def render_learner(
    learner: Learner, out: str | Path, settings: RenderSettings = _RENDER
) -> dict[str, Any]:
    """A video of ``learner``'s greedy episode from rest on its own env, and what happened."""
    env = learner.env(render_mode="rgb_array", **settings.env_kwargs())
    try:
        states: list[np.ndarray] = []

        def keep(*_: Any) -> None:  # each frame's state
            states.append(acrobot_of(env).state)

        record = record_episode(
            env,
            learner.actor(env, 0),
            out,
            settings,
            reset_options=dict(FROM_REST),
            hooks=Hooks(keep, keep),
        )
        record.update(
            acrobot_of(env).task.assess(np.array(states), acrobot_of(env).dt, learner.swing_up)
        )
    finally:
        env.close()
    return record


def watch_run(run_dir: str | Path, settings: RenderSettings = _RENDER) -> dict[str, Any]:
    """A run's greedy episode from rest, live in MuJoCo's viewer window at real time."""
    with run_lock(run_dir, "render"):
        learner = load_learner(run_dir)
    return watch_learner(learner, settings)


def watch_learner(learner: Learner, settings: RenderSettings = _RENDER) -> dict[str, Any]:
    """``learner``'s greedy episode from rest, live in MuJoCo's viewer window at real time."""
    env = learner.env(render_mode="human", camera=settings.camera)
    return watch(env, learner.actor(env, 0), settings, dict(FROM_REST))


#: Why an evaluation of another acrobot has no per-start minima (its record's ``no_minima``).
NOT_THE_REPORTS = "per-start minima exist for the report's acrobot only (the search steps it)"


def env_settings(env: gym.Env) -> dict[str, Any] | None:
    """What the minimum-time search depends on in ``env`` (None: not a height-goal task, or not
    the report's acrobot, whose analytic model the search steps)."""
    acrobot = acrobot_of(env)
    if acrobot.task.name != "height_goal" or acrobot.params != REPORT:
        return None
    task = cast(HeightGoal, acrobot.task)
    return {
        "frame_skip": acrobot.frame_skip,
        "integrator": acrobot.integrator,
        "goal_height": task.goal_height,
    }


def compute_minima(
    env: gym.Env, starts: np.ndarray, max_decisions: int, width: int = 20_000
) -> list[dict[str, Any]]:
    """The beam search from each start on ``env``'s settings: decisions (None if the goal was
    not reached within ``max_decisions``) and actions."""
    settings = env_settings(env)
    if settings is None:
        raise ValueError(
            f"per-start minima exist for the height goal only, not {acrobot_of(env).task.name!r}"
        )
    results = [
        min_time_search(
            frame_skip=settings["frame_skip"],
            beam=Beam(width),
            method=ENV_INTEGRATORS[settings["integrator"]],
            max_decisions=max_decisions,
            goal_height=settings["goal_height"],
            start=start,
        )
        for start in np.asarray(starts, dtype=np.float64)
    ]
    return [{"decisions": r.decisions, "actions": r.actions} for r in results]


def stored_minima(env: gym.Env, protocol: HeldOut) -> list[int] | None:
    """The stored per-start minima if they are for ``protocol`` and ``env``'s settings."""
    stored = json.loads(STORED.read_text())
    if stored["protocol"] != protocol.to_dict() or stored["env"] != env_settings(env):
        return None
    return [entry["decisions"] for entry in stored["starts"]]


def references_for(env: gym.Env, protocol: HeldOut, starts: np.ndarray, minima: str):
    """The per-start minima an evaluation compares with (None: none apply, or none asked)."""
    if minima == "none" or env_settings(env) is None:
        return None
    stored = stored_minima(env, protocol)
    if stored is not None or minima == "stored":
        return stored
    steps = env.spec.max_episode_steps if env.spec is not None else None
    return [m["decisions"] for m in compute_minima(env, starts, 1000 if steps is None else steps)]


def compare(lengths: list[int], minima: list[int | None]) -> dict[str, Any]:
    """Learned / minimum per start (starts without a reference are left out, and counted)."""
    if len(lengths) != len(minima):
        raise ValueError(f"{len(lengths)} episodes but {len(minima)} per-start minima")
    pairs = [(n, m) for n, m in zip(lengths, minima, strict=True) if m]
    return {
        "per_start": minima,
        "minimum": spread([m for _, m in pairs]),
        "ratio": spread([n / m for n, m in pairs]),
        "without_reference": len(lengths) - len(pairs),
    }
