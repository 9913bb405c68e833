"""``acrobot-mj validate``: the hand-derived dynamics checked against MuJoCo
(:mod:`.crosscheck`), and the physics references the learners are compared with
(:mod:`.references`).

:func:`validate` writes ``validation.json``, PNG figures and ``validation.md`` (a short report
that embeds them) and returns the JSON document.
"""

from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from acrobot_mj.bars import Steps
from acrobot_mj.control.trajopt import shipped
from acrobot_mj.files import __version__, write_json, write_text
from acrobot_mj.physics import dynamics, integrators
from acrobot_mj.physics.dynamics import HANGING
from acrobot_mj.physics.params import REPORT
from acrobot_mj.report.balance import CASES, closed_loop, robustness, table
from acrobot_mj.report.crosscheck import METHODS, cross_check, integrator_study, linearisation
from acrobot_mj.report.plots import Series, line_plot
from acrobot_mj.report.references import controllers, minimum_time

SCHEMA_VERSION = 1


def phase_figures(actions_fs4: list[int], out: Path) -> list[str]:
    """The zero-torque flow in (q1, dq1) (in the spirit of the report's Fig. 2) and the
    minimum-time swing-up in phase space."""
    series = []
    for offset in (0.3, 0.8, 1.4, 2.2, 3.0):
        x0 = np.array([-np.pi / 2 + offset, 0.0, 0.0, 0.0])
        xs = integrators.simulate(x0, np.zeros(200), "rk4", replace(REPORT, dt=0.02), False)
        series.append(Series(f"released at q1 = -pi/2 + {offset}", xs[:, 0], xs[:, 2]))
    # The flow (dq1, ddq1) on the slice q2 = 0, dq2 = 0, scaled to a fixed arrow length.
    q1, dq1 = np.meshgrid(np.linspace(-np.pi, np.pi / 2, 15), np.linspace(-4.5, 4.5, 11))
    q = np.stack([q1.ravel(), np.zeros(q1.size)], 1)
    dq = np.stack([dq1.ravel(), np.zeros(q1.size)], 1)
    ddq1 = dynamics.forward_dynamics(q, dq, 0.0)[:, 0]
    # Equal arrow lengths on screen: normalise by the axes' spans (about 4.7 rad, 9 rad/s).
    u, v = dq1.ravel() / 4.7, ddq1 / 9.0
    norm = np.hypot(u, v) + 1e-12
    field = np.stack([q1.ravel(), dq1.ravel(), 0.05 * 4.7 * u / norm, 0.05 * 9.0 * v / norm], 1)
    line_plot(
        out / "phase_portrait.png",
        series,
        "Zero-torque flow: arrows (dq1, ddq1) at "
        "q2 = dq2 = 0; lines released from rest, q2 = 0 (10 s)",
        "q1 [rad] (unwrapped)",
        "dq1 [rad/s]",
        arrows=field,
    )
    x, xs = HANGING.copy(), [HANGING.copy()]
    for action in actions_fs4:
        for _ in range(4):
            x = integrators.step_states(x, np.array([-1.0, 0.0, 1.0])[action])
            xs.append(x)
    xs = np.array(xs)
    line_plot(
        out / "swing_up_phase.png",
        [
            Series("shoulder (q1, dq1)", xs[:, 0], xs[:, 2]),
            Series("elbow (q2, dq2)", xs[:, 1], xs[:, 3]),
        ],
        f"Minimum-time swing-up ({len(actions_fs4)} decisions of 0.2 s) in phase space",
        "angle [rad]",
        "angular velocity [rad/s]",
    )
    return ["phase_portrait.png", "swing_up_phase.png"]


def validate(
    out: str | Path = "runs/validation", quick: bool = False, progress: bool = False
) -> dict[str, Any]:
    """Run every check and write ``validation.json``, the figures and ``validation.md``
    (``progress``: a bar over the checks on stderr)."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    report: dict[str, Any] = {
        "schema_version": SCHEMA_VERSION,
        "quick": quick,
        "versions": {"acrobot_mj": __version__, "mujoco": mujoco.__version__},
    }
    steps = Steps(7, "validate", progress, unit="checks")
    try:
        report["cross_check"] = cross_check(
            n_states=50 if quick else 200, n_trajectories=1 if quick else 3
        )
        steps.done("cross-check")
        report["integrators"] = integrator_study(
            seconds=20.0 if quick else 100.0, reference_substeps=10 if quick else 50, out=out
        )
        steps.done("integrators")
        report["linearisation"] = linearisation()
        steps.done("linearisation")
        report["controllers"] = controllers(quick)
        steps.done("controllers")
        minimum = report["minimum_time"] = minimum_time(quick)
        steps.done("minimum time")
        report["min_time_steps_frame_skip_1"] = minimum["min_time_steps_frame_skip_1"]
        report["min_time_decisions_frame_skip_4"] = minimum["min_time_decisions_frame_skip_4"]
        report["figures"] = [
            "energy_drift.png",
            *phase_figures(minimum["actions_frame_skip_4"], out),
        ]
        steps.done("figures")
        report["balance"] = balance_section(report, quick)
        steps.done("balance")
    finally:
        steps.close()
    report["wall_seconds"] = time.perf_counter() - started
    write_json(out / "validation.json", report)
    write_text(out / "validation.md", markdown(report))
    return report


def balance_section(report: dict[str, Any], quick: bool) -> dict[str, Any]:
    """Swing-up AND balance: the shipped trajectories to upright at rest, their closed loops in
    MuJoCo, the robustness rows (a few with ``quick``), and what the bounds above mean."""
    trajectories = {"min_time": shipped("min_time"), "reserve": shipped("reserve")}
    loops = {
        f"{name}, {'{-1, 0, +1}' if discrete else 'continuous'}": {
            k: v
            for k, v in closed_loop(trajectories[name], discrete).items()
            if k not in ("torques", "states")
        }
        for name, discrete in (("min_time", False), ("reserve", False), ("reserve", True))
    }
    cases = CASES[:1] + CASES[3:4] + CASES[5:6] if quick else CASES
    basin = report["controllers"]["lqr"]["q1_basin_rad"][1]
    bound = report["controllers"]["bound_any_controller_q1_rad"]
    return {
        "trajectories": {
            name: {
                "steps": t.steps,
                "seconds": t.seconds,
                "u_max": t.u_max,
                "full_torque_fraction": float(np.mean(np.abs(t.torques) > 0.999 * t.u_max)),
                "residual": t.residual(),
            }
            for name, t in trajectories.items()
        },
        "min_time_note": "found by acrobot_mj.control.trajopt.min_time's multi-start search: "
        "an upper bound on the minimum time to upright at rest",
        "closed_loop": loops,
        "robustness": robustness(trajectories, cases=cases),
        "bounds_mean": f"the {bound:.3f} rad bound and the {basin:.4f} rad LQR basin are pure "
        "q1 offsets of a state at rest from upright, not the states a swing-up reaches: "
        "following a trajectory to upright at rest with TVLQR, the acrobot arrives with errors "
        "of 1e-9 rad (continuous torques) or 1e-2 rad ({-1, 0, +1}), well inside both",
    }


def summary_rows(report: dict[str, Any]) -> list[tuple[str, str]]:
    """The headline numbers, as (what, value) rows."""
    return _model_rows(report) + _reference_rows(report)


def _model_rows(report: dict[str, Any]) -> list[tuple[str, str]]:
    """The analytic model against MuJoCo, the integrators and the linearisation."""
    cc, lin = report["cross_check"], report["linearisation"]
    drift = report["integrators"]["energy_drift"]
    gap = max(row["max_eigenvalue_gap"] for row in lin["equilibria"].values())
    return [
        ("mass matrix vs mj_fullM (max rel. error)", f"{cc['relative']['mass_matrix']:.1e}"),
        ("bias forces vs qfrc_bias", f"{cc['relative']['bias_forces']:.1e}"),
        ("accelerations vs qacc", f"{cc['relative']['accelerations']:.1e}"),
        (
            "accelerations, report's eq. (2) as printed",
            f"{cc['relative']['accelerations_eq2_as_printed']:.2f}",
        ),
        (
            "one step, Euler / RK4 (max abs. error)",
            f"{cc['one_step']['euler']:.1e} / {cc['one_step']['rk4']:.1e}",
        ),
        (
            "1000-step trajectories, Euler / RK4",
            f"{cc['trajectory_1000']['euler']:.1e} / {cc['trajectory_1000']['rk4']:.1e}",
        ),
        (
            f"energy drift over {report['integrators']['seconds']:g} s (0.5 rad swing): "
            "explicit / semi-implicit Euler / RK4 [J]",
            " / ".join(f"{drift[m]['max_abs_J'][0]:.2g}" for m in METHODS),
        ),
        ("eigenvalues, analytic vs mjd_transitionFD (max gap)", f"{gap:.1e}"),
        ("controllability rank at upright", str(lin["controllability_rank_upright"])),
    ]


def _reference_rows(report: dict[str, Any]) -> list[tuple[str, str]]:
    """The controllers, the bounds, the minimum times and the balance."""
    ctl, mt, balance = report["controllers"], report["minimum_time"], report["balance"]
    return [
        (
            "energy pumping from rest: steps to the goal",
            f"{ctl['energy_pumping']['steps_to_goal']} ({ctl['energy_pumping']['seconds']:g} s)",
        ),
        (
            "saturated LQR: q1 offsets it recovers from [rad]",
            f"{ctl['lqr']['q1_basin_rad'][0]:.4f} .. {ctl['lqr']['q1_basin_rad'][1]:.4f}",
        ),
        (
            "bound for any |tau| <= 1 controller, pure q1 offset [rad]",
            f"{ctl['bound_any_controller_q1_rad']:.4f}",
        ),
        (
            "minimum-time swing-up, frame_skip 4 [decisions]",
            str(mt["min_time_decisions_frame_skip_4"]),
        ),
        ("minimum-time swing-up, frame_skip 1 [steps]", str(mt["min_time_steps_frame_skip_1"])),
        (
            "the same with continuous torques (the optimiser, from that sequence) [steps]",
            str(mt["continuous_torque"]["steps"]) if mt.get("continuous_torque") else "-",
        ),
        (
            "swing-up to upright AT REST, |u| <= 1 / with a 0.8 N m reserve [steps]",
            " / ".join(str(t["steps"]) for t in balance["trajectories"].values()),
        ),
        (
            "balanced for 60 s in MuJoCo: min time / reserve / reserve with {-1, 0, +1}",
            " / ".join(
                "yes" if loop["balanced"] else "no" for loop in balance["closed_loop"].values()
            ),
        ),
        (
            "minimum time, explicit Euler / semi-implicit / RK4 [decisions at 0.2 s]",
            " / ".join(str(mt["decisions_frame_skip_4_by_integrator"][m]) for m in METHODS),
        ),
    ]


def markdown(report: dict[str, Any]) -> str:
    """``validation.md``: the summary table and the figures."""
    lines = [
        "# acrobot-mj validation",
        "",
        f"{'Quick' if report['quick'] else 'Full'} run, "
        f"{report['wall_seconds']:.0f} s. All numbers are in `validation.json`.",
        "",
        "| check | result |",
        "|---|---|",
    ]
    lines += [f"| {what} | {value} |" for what, value in summary_rows(report)]
    lines += [
        "",
        "The report's equation (2) as printed (`d12` where `d22` belongs) misses "
        "MuJoCo's accelerations by the relative error above; the corrected form agrees to "
        "rounding.",
        "",
    ]
    titles = {
        "energy_drift.png": "Energy error of the integrators with zero torque",
        "phase_portrait.png": "Zero-torque flow (the report's Fig. 2, in its spirit)",
        "swing_up_phase.png": "The minimum-time swing-up in phase space",
    }
    for figure in report["figures"]:
        lines += [f"## {titles[figure]}", "", f"![{titles[figure]}]({figure})", ""]
    balance = report["balance"]
    lines += [
        "## Swing-up and balance: robustness",
        "",
        f"Closed loops in MuJoCo ({balance['min_time_note']}). {balance['bounds_mean']}.",
        "",
        table(balance["robustness"]),
    ]
    return "\n".join(lines)
