"""Swing up and balance in MuJoCo: the controller of :mod:`acrobot_mj.control` closed loop on
``acrobot_mj/AcrobotBalance-v0``, and its :func:`robustness` to what it does not know. Balanced:
within the task's tolerance (0.05 rad) from the end of the swing-up to the end of the run."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from acrobot_mj.control.feedback import Feedback
from acrobot_mj.control.lqr import SigmaDelta, SwingUpController
from acrobot_mj.control.trajopt import Trajectory, min_time, shipped
from acrobot_mj.envs.rollout import acrobot_of, run_episode
from acrobot_mj.envs.tasks import Balance
from acrobot_mj.files import versions, write_json
from acrobot_mj.report.video import RenderSettings, record_episode

INTEGRATOR_OF = {"semi_implicit_euler": "euler", "rk4": "rk4"}


@dataclass(frozen=True)
class Perturbation:
    """What the controller does not know: a start offset [rad, rad/s], link masses and inertias
    scaled in MuJoCo's model, and Gaussian torque noise on the elbow [N m] drawn from ``seed``."""

    start_offset: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    mass_scale: float = 1.0
    inertia_scale: float = 1.0
    torque_noise: float = 0.0
    seed: int = 0


class BalanceActor:
    """The controller as an episode-loop actor (a clocked one, ``u = pi(k, x)``, is told the
    physics step); records each step's state and applied torque."""

    def __init__(self, env: gym.Env, controller: SwingUpController | Feedback,
                 discrete: bool, noise: Any = None, observed: bool = False) -> None:  # fmt: skip
        self.env = acrobot_of(env)
        # observed: the controller sees the observation (angles wrapped), not MuJoCo's state.
        self.observed = observed
        self.obs: np.ndarray | None = None
        # A state feedback has a memory of its own for this episode, and hears each torque.
        self.feedback: Feedback | None = None
        if isinstance(controller, SwingUpController):
            clocked = controller
            self.controller: Any = lambda x: clocked(len(self.torques), x)
        else:
            self.controller = self.feedback = controller.fresh()
        self.modulator = SigmaDelta() if discrete else None
        self.noise = noise  # a generator and a standard deviation, or None
        self.states: list[list[float]] = []
        self.torques: list[float] = []

    def _act(self) -> Any:
        u = self.controller(self.obs if self.observed else self.env.state)
        if self.noise is not None:
            rng, sigma = self.noise
            self.env.data.qfrc_applied[1] = sigma * rng.standard_normal()
        return np.array([u], dtype=np.float32) if self.modulator is None else self.modulator(u)

    def begin(self, obs: np.ndarray) -> Any:
        self.obs = np.asarray(obs, dtype=np.float64)
        self.states.append(self.env.state.tolist())
        return self._act()

    def observe(self, reward: float, obs: np.ndarray, terminated: bool, truncated: bool) -> Any:
        self.obs = np.asarray(obs, dtype=np.float64)
        self.states.append(self.env.state.tolist())
        self.torques.append(float(self.env.data.ctrl[0]))
        if self.feedback is not None:
            self.feedback.record(self.torques[-1])
        return None if terminated or truncated else self._act()


def balance_env(trajectory: Trajectory, discrete: bool, hold: float, **kwargs: Any) -> gym.Env:
    """The balance task's env for a swing-up along ``trajectory`` and ``hold`` seconds more
    (unless ``kwargs`` give ``max_episode_steps``)."""
    steps = trajectory.steps + math.ceil(hold / trajectory.dt - 1e-9)
    kwargs.setdefault("max_episode_steps", steps)
    return gym.make(Balance.env_id, continuous=not discrete,
                    integrator=INTEGRATOR_OF[trajectory.method], **kwargs)  # fmt: skip


def closed_loop(trajectory: Trajectory, discrete: bool = False, hold: float = 60.0,
                perturbation: Perturbation = Perturbation(), env: gym.Env | None = None,
                record: Any = None) -> dict[str, Any]:  # fmt: skip
    """:meth:`~acrobot_mj.envs.tasks.Balance.assess` of the controller on ``env``, with per-step
    ``torques`` and ``states``; ``record(env, actor, *, on_reset)`` runs the episode instead
    (videos)."""
    env = env or balance_env(trajectory, discrete, hold)
    model = acrobot_of(env).model
    for name in ("link1", "link2"):
        model.body_mass[model.body(name).id] *= perturbation.mass_scale
        model.body_inertia[model.body(name).id] *= perturbation.inertia_scale
    rng = np.random.default_rng(perturbation.seed)
    noise = (rng, perturbation.torque_noise) if perturbation.torque_noise > 0 else None
    actor = BalanceActor(env, SwingUpController(trajectory), discrete, noise)
    offset = np.asarray(perturbation.start_offset, dtype=float)

    def start(obs: np.ndarray, info: dict[str, Any]) -> None:
        if offset.any():
            state = acrobot_of(env).state + offset
            acrobot_of(env).set_state(state[:2], state[2:])

    record = record or functools.partial(run_episode, seed=perturbation.seed)
    record(env, actor, on_reset=start)
    result = acrobot_of(env).task.assess(np.array(actor.states), trajectory.dt, trajectory.steps)
    return {**result, "torques": actor.torques, "states": actor.states}


def load_trajectory(reserve: float, cache: Any = None, optimise: bool = False,
                    progress: bool = False) -> tuple:  # fmt: skip
    """The swing-up for ``|u| <= reserve`` N m and where it came from: the package's (1.0, 0.8),
    one cached in ``cache``, or a new optimisation (CasADi, under a minute)."""
    if not (isinstance(reserve, (int, float)) and 0.0 < reserve <= 1.0):
        raise ValueError(f"the torque reserve must be in (0, 1] N m, got {reserve!r}")
    name = {1.0: "min_time", 0.8: "reserve"}.get(float(reserve))
    if not optimise and name:
        return shipped(name), f"shipped ({name})"
    if not optimise and cache is not None and cache.is_file():
        trajectory = Trajectory.load(cache)
        if trajectory.u_max == reserve:
            return trajectory, f"cached ({cache})"
    trajectory = min_time(float(reserve), progress=progress)
    if cache is not None:
        trajectory.save(cache)
    return trajectory, "optimised now"


def run_balance(out: Path, *, discrete: bool = False, reserve: float = 0.8, hold: float = 60.0,
                optimise: bool = False, video: bool = True, size: tuple[int, int] = (480, 480),
                progress: bool = False) -> dict[str, Any]:  # fmt: skip
    """``acrobot-mj balance``: the closed loop for ``hold`` s after the swing-up, written to
    ``out/balance.json`` and, with ``video``, ``out/swing_up.mp4`` and ``out/swing_up.png``."""
    if not (isinstance(hold, (int, float)) and 0.0 < hold <= 3600.0):
        raise ValueError(f"the hold time must be in (0, 3600] s, got {hold!r}")
    out = Path(out)
    trajectory, source = load_trajectory(reserve, out / "trajectory.json", optimise, progress)
    screen = {"render_mode": "rgb_array", "width": size[0], "height": size[1]} if video else {}
    env = balance_env(trajectory, discrete, hold, **screen)
    path, settings = out / "swing_up.mp4", RenderSettings(*size, strip=out / "swing_up.png")
    recorder = functools.partial(record_episode, path=path, settings=settings) if video else None
    try:
        result = closed_loop(trajectory, discrete, hold, env=env, record=recorder)
    finally:
        env.close()
    fields = ("steps", "seconds", "u_max", "method")
    about = {"source": source, **{k: getattr(trajectory, k) for k in fields}}
    record = {
        "command": "balance", "discrete": discrete, "reserve": reserve,
        "hold_requested_seconds": hold, "trajectory": {**about, "residual": trajectory.residual()},
        "versions": versions(), **result, "video": str(path) if video else None,
    }  # fmt: skip
    write_json(out / "balance.json", record)
    return record


#: The rows: what is changed, and by how much.
CASES: tuple[tuple[str, Perturbation], ...] = (
    ("nominal", Perturbation()),
    ("q1 + 1e-6 rad at the start", Perturbation(start_offset=(1e-6, 0, 0, 0))),
    ("q1 + 1e-4 rad at the start", Perturbation(start_offset=(1e-4, 0, 0, 0))),
    ("q1 + 1e-3 rad at the start", Perturbation(start_offset=(1e-3, 0, 0, 0))),
    ("q1 + 1e-2 rad at the start", Perturbation(start_offset=(1e-2, 0, 0, 0))),
    ("link masses + 1 %", Perturbation(mass_scale=1.01)),
    ("link masses - 1 %", Perturbation(mass_scale=0.99)),
    ("link inertias + 1 %", Perturbation(inertia_scale=1.01)),
    ("link inertias - 1 %", Perturbation(inertia_scale=0.99)),
    ("torque noise, 0.01 N m", Perturbation(torque_noise=0.01)),
    ("torque noise, 0.05 N m", Perturbation(torque_noise=0.05)),
)


def robustness(trajectories: dict[str, Trajectory], hold: float = 60.0,
               cases=CASES) -> list[dict[str, Any]]:  # fmt: skip
    """Balanced, hold time and largest error per case, trajectory and torque kind."""
    rows, keys = [], ("balanced", "hold_seconds", "max_error_during_hold")
    for label, perturbation in cases:
        for name, trajectory in trajectories.items():
            for discrete in (False, True):
                result = closed_loop(trajectory, discrete, hold, perturbation)
                kind = "{-1, 0, +1}" if discrete else "continuous"
                rows.append({"case": label, "trajectory": name, "torques": kind,
                             **{k: result[k] for k in keys}})  # fmt: skip
    return rows


def table(rows: list[dict[str, Any]]) -> str:
    """The rows as a Markdown table."""
    lines = [
        "| case | trajectory | torques | balanced | hold [s] | largest error in the hold [rad] |",
        "|---|---|---|---|---|---|",
    ]
    for r in rows:
        error = "-" if r["max_error_during_hold"] is None else f"{r['max_error_during_hold']:.2g}"
        balanced = "yes" if r["balanced"] else "no"
        lines.append(f"| {r['case']} | {r['trajectory']} | {r['torques']} | {balanced} | "
                     f"{r['hold_seconds']:.1f} | {error} |")  # fmt: skip
    return "\n".join(lines) + "\n"
