"""Swing up and balance in the MuJoCo env: the model-based controller of :mod:`acrobot_mj.control`
(a trajectory to upright at rest, TVLQR along it, then the saturated LQR; sigma-delta for
``Discrete(3)`` torques) run closed loop on ``acrobot_mj/AcrobotBalance-v0``, with what it did
at every physics step.

Balanced means within the task's tolerance (0.05 rad in both angles) from the end of the swing-up
to the end of the run; the hold time is how long that lasted. :func:`robustness` runs it under
start offsets, model errors and torque noise it was not designed for.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from acrobot_mj.control.lqr import SigmaDelta, SwingUpController
from acrobot_mj.control.trajopt import Trajectory
from acrobot_mj.envs.rollout import run_episode
from acrobot_mj.envs.tasks import Balance
from acrobot_mj.files import versions, write_json
from acrobot_mj.report.video import RenderSettings, record_episode

INTEGRATOR_OF = {"semi_implicit_euler": "euler", "rk4": "rk4"}


@dataclass(frozen=True)
class Perturbation:
    """What the controller does not know: an offset of the start state [rad, rad/s], link
    masses and inertias scaled in MuJoCo's model, and Gaussian torque noise on the elbow
    [N m], drawn from ``seed``."""

    start_offset: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    mass_scale: float = 1.0
    inertia_scale: float = 1.0
    torque_noise: float = 0.0
    seed: int = 0


class BalanceActor:
    """The controller as an actor of the episode loop; it records every physics step's state
    (at full precision, from the env) and the torque MuJoCo applied."""

    def __init__(
        self, env: gym.Env, controller: SwingUpController, discrete: bool, noise: Any = None
    ) -> None:
        self.env, self.controller = env.unwrapped, controller
        self.modulator = SigmaDelta() if discrete else None
        self.noise = noise  # a generator and a standard deviation, or None
        self.states: list[list[float]] = []
        self.torques: list[float] = []

    def _act(self) -> Any:
        k, x = len(self.torques), self.env.state
        u = self.controller(k, x)
        if self.noise is not None:
            rng, sigma = self.noise
            self.env.data.qfrc_applied[1] = sigma * rng.standard_normal()
        if self.modulator is not None:
            return self.modulator(u)
        return np.array([u], dtype=np.float32)

    def begin(self, obs: np.ndarray) -> Any:
        self.states.append(self.env.state.tolist())
        return self._act()

    def observe(self, reward: float, obs: np.ndarray, terminated: bool, truncated: bool) -> Any:
        self.states.append(self.env.state.tolist())
        self.torques.append(float(self.env.data.ctrl[0]))
        return None if terminated or truncated else self._act()


def balance_env(trajectory: Trajectory, discrete: bool, hold: float, **kwargs: Any) -> gym.Env:
    """The balance task's env for a swing-up along ``trajectory`` and ``hold`` seconds more."""
    steps = trajectory.steps + math.ceil(hold / trajectory.dt - 1e-9)
    return gym.make(
        Balance.env_id,
        continuous=not discrete,
        integrator=INTEGRATOR_OF[trajectory.method],
        max_episode_steps=steps,
        **kwargs,
    )


def perturb(env: gym.Env, perturbation: Perturbation) -> None:
    """Scale the links' masses and inertias in the env's MuJoCo model."""
    model = env.unwrapped.model
    for name in ("link1", "link2"):
        body = model.body(name).id
        model.body_mass[body] *= perturbation.mass_scale
        model.body_inertia[body] *= perturbation.inertia_scale


def closed_loop(
    trajectory: Trajectory,
    discrete: bool = False,
    hold: float = 60.0,
    perturbation: Perturbation = Perturbation(),
    env: gym.Env | None = None,
    record: Any = None,
) -> dict[str, Any]:
    """Run the controller on the balance env (``env``, or one made for ``trajectory`` and
    ``hold``); ``record(env, actor)`` runs the episode instead of the plain loop (videos).
    Returns the task's assessment (:meth:`Balance.assess`) with the per-step ``torques`` and
    ``states``."""
    env = env or balance_env(trajectory, discrete, hold)
    perturb(env, perturbation)
    rng = np.random.default_rng(perturbation.seed)
    noise = (rng, perturbation.torque_noise) if perturbation.torque_noise > 0 else None
    actor = BalanceActor(env, SwingUpController(trajectory), discrete, noise)
    offset = np.asarray(perturbation.start_offset, dtype=float)

    def start(obs: np.ndarray, info: dict[str, Any]) -> None:
        if offset.any():
            state = env.unwrapped.state + offset
            env.unwrapped.set_state(state[:2], state[2:])

    if record is None:
        run_episode(env, actor, seed=perturbation.seed, on_reset=start)
    else:
        record(env, actor, start)
    task = env.unwrapped.task
    result = task.assess(np.array(actor.states), trajectory.dt, trajectory.steps)
    return {**result, "torques": actor.torques, "states": actor.states}


def load_trajectory(
    reserve: float, cache: Any = None, optimise: bool = False, progress: bool = False
) -> tuple:
    """The swing-up for nominal torques ``|u| <= reserve`` N m, and where it came from: the
    package's (1.0 and 0.8), a cached one in ``cache`` (re-checked), or a new optimisation
    (which needs CasADi, and minutes)."""
    from acrobot_mj.control.trajopt import shipped

    if not (isinstance(reserve, (int, float)) and 0.0 < reserve <= 1.0):
        raise ValueError(f"the torque reserve must be in (0, 1] N m, got {reserve!r}")
    names = {1.0: "min_time", 0.8: "reserve"}
    if not optimise and float(reserve) in names:
        return shipped(names[float(reserve)]), f"shipped ({names[float(reserve)]})"
    if not optimise and cache is not None and cache.is_file():
        trajectory = Trajectory.load(cache)
        if trajectory.u_max == reserve:
            return trajectory, f"cached ({cache})"
    from acrobot_mj.control.trajopt import min_time

    trajectory = min_time(float(reserve), progress=progress)
    if cache is not None:
        trajectory.save(cache)
    return trajectory, "optimised now"


def run_balance(
    out: Path,
    *,
    discrete: bool = False,
    reserve: float = 0.8,
    hold: float = 60.0,
    optimise: bool = False,
    video: bool = True,
    size: tuple[int, int] = (480, 480),
    progress: bool = False,
) -> dict[str, Any]:
    """``acrobot-mj balance``: the swing-up for ``reserve``, the closed loop in MuJoCo for
    ``hold`` seconds after it, ``out/balance.json`` (with the per-step torques and states) and,
    with ``video``, ``out/swing_up.mp4`` and a strip ``out/swing_up.png``."""
    if not (isinstance(hold, (int, float)) and 0.0 < hold <= 3600.0):
        raise ValueError(f"the hold time must be in (0, 3600] s, got {hold!r}")
    out = Path(out)
    trajectory, source = load_trajectory(reserve, out / "trajectory.json", optimise, progress)
    record_video = None
    if video:
        env = balance_env(trajectory, discrete, hold, render_mode="rgb_array", width=size[0],
                          height=size[1])  # fmt: skip

        def record_video(env: gym.Env, actor: BalanceActor, start: Any) -> None:
            settings = RenderSettings(*size, strip=out / "swing_up.png")
            record_episode(env, actor, out / "swing_up.mp4", settings, on_reset=start)
    else:
        env = balance_env(trajectory, discrete, hold)
    try:
        result = closed_loop(trajectory, discrete, hold, env=env, record=record_video)
    finally:
        env.close()
    record = {
        "command": "balance",
        "discrete": discrete,
        "reserve": reserve,
        "hold_requested_seconds": hold,
        "trajectory": {
            "source": source,
            "steps": trajectory.steps,
            "seconds": trajectory.seconds,
            "u_max": trajectory.u_max,
            "method": trajectory.method,
            "residual": trajectory.residual(),
        },
        "versions": versions(),
        **result,
        "video": str(out / "swing_up.mp4") if video else None,
    }
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


def robustness(
    trajectories: dict[str, Trajectory], hold: float = 60.0, cases=CASES
) -> list[dict[str, Any]]:
    """One row per case, trajectory and torque kind: balanced or not, the hold time and the
    largest error during the hold."""
    rows = []
    for label, perturbation in cases:
        for name, trajectory in trajectories.items():
            for discrete in (False, True):
                result = closed_loop(trajectory, discrete, hold, perturbation)
                rows.append(
                    {
                        "case": label,
                        "trajectory": name,
                        "torques": "{-1, 0, +1}" if discrete else "continuous",
                        **{
                            k: result[k]
                            for k in ("balanced", "hold_seconds", "max_error_during_hold")
                        },
                    }
                )
    return rows


def table(rows: list[dict[str, Any]]) -> str:
    """The rows as a Markdown table."""
    lines = [
        "| case | trajectory | torques | balanced | hold [s] | largest error in the hold [rad] |",
        "|---|---|---|---|---|---|",
    ]
    for r in rows:
        error = r["max_error_during_hold"]
        lines.append(
            f"| {r['case']} | {r['trajectory']} | {r['torques']} | "
            f"{'yes' if r['balanced'] else 'no'} | {r['hold_seconds']:.1f} | "
            f"{'-' if error is None else f'{error:.2g}'} |"
        )
    return "\n".join(lines) + "\n"
