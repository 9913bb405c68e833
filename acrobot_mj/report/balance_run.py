"""``acrobot-mj balance``: a swing-up (shipped, cached or optimised now) followed closed loop in
MuJoCo (:func:`~acrobot_mj.envs.control_loop.closed_loop`), written to ``balance.json`` and a
video; and its :func:`robustness` to what it does not know."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from acrobot_mj.control.trajopt import Trajectory, min_time, shipped
from acrobot_mj.envs.control_loop import (
    balance_env,
    closed_loop,
    discrete_setting,
    hold_setting,
    reserve_setting,
)
from acrobot_mj.envs.disturbances import Perturbation
from acrobot_mj.envs.rollout import Hooks
from acrobot_mj.files import versions, write_json
from acrobot_mj.report.video import RenderSettings, record_episode, write_video_record
from acrobot_mj.settings import Settings, checked


def load_trajectory(
    reserve: float, cache: Any = None, optimise: bool = False, progress: bool = False
) -> tuple:
    """The swing-up for ``|u| <= reserve`` N m and where it came from: the package's (1.0, 0.8),
    one cached in ``cache``, or a new optimisation (CasADi, under a minute)."""
    reserve = checked(BalanceRun, "reserve", reserve)
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


@dataclass(frozen=True)
class BalanceRun(Settings):
    """What ``acrobot-mj balance`` runs: ``discrete`` torques ({-1, 0, +1} N m) or continuous,
    the swing-up for ``|u| <= reserve`` N m (``optimise``: a new one, not the shipped or cached
    one), ``hold`` [s] of balance after it, and with ``video`` a video of ``size`` (width,
    height) [pixels]."""

    discrete: bool = discrete_setting()
    reserve: float = reserve_setting()
    hold: float = hold_setting()
    optimise: bool = False
    video: bool = True
    size: tuple[int, int] = (480, 480)


def run_balance(
    out: Path, settings: BalanceRun = BalanceRun(), progress: bool = False
) -> dict[str, Any]:
    """``acrobot-mj balance``: the closed loop for ``settings.hold`` s after the swing-up, written
    to ``out/balance.json`` and, with ``settings.video``, ``out/swing_up.mp4`` and
    ``out/swing_up.png``; ``progress``: a bar on stderr where a swing-up is optimised."""
    discrete, reserve, hold = settings.discrete, settings.reserve, settings.hold
    video, size = settings.video, settings.size
    out = Path(out)
    cache = out / "trajectory.json"
    trajectory, source = load_trajectory(reserve, cache, settings.optimise, progress)
    screen = {"render_mode": "rgb_array", "width": size[0], "height": size[1]} if video else {}
    env = balance_env(trajectory, discrete, hold, **screen)
    path, render = out / "swing_up.mp4", RenderSettings(*size, strip=out / "swing_up.png")

    def filmed(env: Any, actor: Any, *, hooks: Hooks) -> None:
        write_video_record(record_episode(env, actor, path, render, hooks=hooks))

    try:
        result = closed_loop(trajectory, discrete, hold, env=env, record=filmed if video else None)
    finally:
        env.close()
    fields = ("steps", "seconds", "u_max", "method")
    about = {"source": source, **{k: getattr(trajectory, k) for k in fields}}
    record = {
        "command": "balance",
        "discrete": discrete,
        "reserve": reserve,
        "hold_requested_seconds": hold,
        "trajectory": {**about, "residual": trajectory.residual()},
        "versions": versions(),
        **result,
        "video": str(path) if video else None,
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
    """Balanced, hold time and largest error per case, trajectory and torque kind."""
    rows, keys = [], ("balanced", "hold_seconds", "max_error_during_hold")
    for label, perturbation in cases:
        for name, trajectory in trajectories.items():
            for discrete in (False, True):
                result = closed_loop(trajectory, discrete, hold, perturbation)
                kind = "{-1, 0, +1}" if discrete else "continuous"
                rows.append(
                    {
                        "case": label,
                        "trajectory": name,
                        "torques": kind,
                        **{k: result[k] for k in keys},
                    }
                )
    return rows


def robustness_table(rows: list[dict[str, Any]]) -> str:
    """The rows as a Markdown table."""
    lines = [
        "| case | trajectory | torques | balanced | hold [s] | largest error in the hold [rad] |",
        "|---|---|---|---|---|---|",
    ]
    for r in rows:
        error = "-" if r["max_error_during_hold"] is None else f"{r['max_error_during_hold']:.2g}"
        balanced = "yes" if r["balanced"] else "no"
        lines.append(
            f"| {r['case']} | {r['trajectory']} | {r['torques']} | {balanced} | "
            f"{r['hold_seconds']:.1f} | {error} |"
        )
    return "\n".join(lines) + "\n"
