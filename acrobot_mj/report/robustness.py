"""How robust the swing-up-and-balance controller is: start offsets, model errors and torque
noise it was not designed for, with continuous and with {-1, 0, +1} torques, each row a closed
loop in the MuJoCo env (:func:`acrobot_mj.report.balance.closed_loop`)."""

from __future__ import annotations

from typing import Any

from acrobot_mj.control.trajectory import Trajectory
from acrobot_mj.report.balance import Perturbation, closed_loop

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
