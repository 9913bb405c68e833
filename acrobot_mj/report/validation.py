"""``acrobot-mj validate``: the dynamics checked against MuJoCo (:mod:`.crosscheck`) and the
physics references (:mod:`.references`), as ``validation.json``, figures and ``validation.md``."""

from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from acrobot_mj.bars import Steps
from acrobot_mj.control.trajopt import shipped
from acrobot_mj.envs.control_loop import closed_loop
from acrobot_mj.files import write_json, write_text
from acrobot_mj.physics import dynamics, integrators
from acrobot_mj.physics.params import REPORT
from acrobot_mj.report.balance_run import CASES, robustness, robustness_table
from acrobot_mj.report.crosscheck import COMPARED, cross_check, integrator_study, linearisation
from acrobot_mj.report.plots import Labels, Series, line_plot
from acrobot_mj.report.references import controllers, minimum_time
from acrobot_mj.version import __version__

SCHEMA_VERSION = 1
FIGURE_TITLES = {
    "energy_drift.png": "Energy error of the integrators with zero torque",
    "phase_portrait.png": "Zero-torque flow (the report's Fig. 2, in its spirit)",
    "swing_up_phase.png": "The minimum-time swing-up in phase space",
}


def phase_figures(actions_fs4: list[int], out: Path) -> list[str]:
    """The zero-torque flow in (q1, dq1), and the minimum-time swing-up in phase space."""
    series = []
    for offset in (0.3, 0.8, 1.4, 2.2, 3.0):
        x0 = np.array([-np.pi / 2 + offset, 0.0, 0.0, 0.0])
        xs = integrators.simulate(x0, np.zeros(200), "rk4", replace(REPORT, dt=0.02), False)
        series.append(Series(f"released at q1 = -pi/2 + {offset}", xs[:, 0], xs[:, 2]))
    # The flow (dq1, ddq1) on the slice q2 = 0, dq2 = 0, as arrows of equal length on screen
    # (normalised by the axes' spans, about 4.7 rad and 9 rad/s).
    q1, dq1 = np.meshgrid(np.linspace(-np.pi, np.pi / 2, 15), np.linspace(-4.5, 4.5, 11))
    q = np.stack([q1.ravel(), np.zeros(q1.size)], 1)
    dq = np.stack([dq1.ravel(), np.zeros(q1.size)], 1)
    ddq1 = dynamics.forward_dynamics(q, dq, 0.0)[:, 0]
    u, v = dq1.ravel() / 4.7, ddq1 / 9.0
    norm = np.hypot(u, v) + 1e-12
    field = np.stack([q1.ravel(), dq1.ravel(), 0.05 * 4.7 * u / norm, 0.05 * 9.0 * v / norm], 1)
    title = "Zero-torque flow: arrows (dq1, ddq1) at q2 = dq2 = 0; lines released from rest, q2 = 0"
    labels = ("q1 [rad] (unwrapped)", "dq1 [rad/s]")
    line_plot(out / "phase_portrait.png", series, Labels(f"{title} (10 s)", *labels), arrows=field)
    path = [dynamics.HANGING.copy()]
    for u in np.repeat(np.array([-1.0, 0.0, 1.0])[actions_fs4], 4):
        path.append(integrators.step_states(path[-1], u))
    xs = np.array(path)
    series = [
        Series("shoulder (q1, dq1)", xs[:, 0], xs[:, 2]),
        Series("elbow (q2, dq2)", xs[:, 1], xs[:, 3]),
    ]
    title = f"Minimum-time swing-up ({len(actions_fs4)} decisions of 0.2 s) in phase space"
    words = Labels(title, "angle [rad]", "angular velocity [rad/s]")
    line_plot(out / "swing_up_phase.png", series, words)
    return ["phase_portrait.png", "swing_up_phase.png"]


def validate(
    out: str | Path = "runs/validation", quick: bool = False, progress: bool = False
) -> dict[str, Any]:
    """Run every check and write ``validation.json``, the figures and ``validation.md``."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    versions = {"acrobot_mj": __version__, "mujoco": mujoco.__version__}
    report: dict[str, Any] = dict(schema_version=SCHEMA_VERSION, quick=quick, versions=versions)
    states, trajectories, seconds, substeps = (50, 1, 20.0, 10) if quick else (200, 3, 100.0, 50)
    with Steps(7, "validate", progress, unit="checks") as steps:
        report["cross_check"] = cross_check(n_states=states, n_trajectories=trajectories)
        steps.done("cross-check")
        report["integrators"] = integrator_study(seconds, reference_substeps=substeps, out=out)
        steps.done("integrators")
        report["linearisation"] = linearisation()
        steps.done("linearisation")
        report["controllers"] = controllers(quick)
        steps.done("controllers")
        minimum = report["minimum_time"] = minimum_time(quick)
        steps.done("minimum time")
        for key in ("min_time_steps_frame_skip_1", "min_time_decisions_frame_skip_4"):
            report[key] = minimum[key]
        figures = phase_figures(minimum["actions_frame_skip_4"], out)
        report["figures"] = ["energy_drift.png", *figures]
        steps.done("figures")
        report["balance"] = balance_section(report, quick)
        steps.done("balance")
    report["wall_seconds"] = time.perf_counter() - started
    write_json(out / "validation.json", report)
    write_text(out / "validation.md", markdown(report))
    return report


def balance_section(report: dict[str, Any], quick: bool) -> dict[str, Any]:
    """The shipped swing-ups to upright at rest, their closed loops and robustness in MuJoCo."""
    trajectories = {"min_time": shipped("min_time"), "reserve": shipped("reserve")}
    loops = {}
    for name, discrete in (("min_time", False), ("reserve", False), ("reserve", True)):
        result = closed_loop(trajectories[name], discrete)
        loops[f"{name}, {'{-1, 0, +1}' if discrete else 'continuous'}"] = {
            k: v for k, v in result.items() if k not in ("torques", "states")
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
        "bounds_mean": f"the {bound:.4f} rad bound and the {basin:.4f} rad LQR basin are pure "
        "q1 offsets of a state at rest from upright, not the states a swing-up "
        "reaches: following a trajectory to upright at rest with TVLQR, the "
        "acrobot arrives with errors of 1e-9 rad (continuous torques) or 1e-2 rad "
        "({-1, 0, +1}), well inside both",
    }


def summary_rows(report: dict[str, Any]) -> list[tuple[str, str]]:
    """The headline numbers, as (what, value) rows: the model's, then the controllers'."""
    return _model_rows(report) + _control_rows(report)


def _joined(values: Any) -> str:
    return " / ".join(map(str, values))


def _model_rows(report: dict[str, Any]) -> list[tuple[str, str]]:
    """The analytic model against MuJoCo: terms, steps, energy drift, linearisation."""
    cc, lin = report["cross_check"], report["linearisation"]
    rel, drift = cc["relative"], report["integrators"]["energy_drift"]
    gap = max(row["max_eigenvalue_gap"] for row in lin["equilibria"].values())
    eq2 = rel["accelerations_eq2_as_printed"]
    return [
        ("mass matrix vs mj_fullM (max rel. error)", f"{rel['mass_matrix']:.1e}"),
        ("bias forces vs qfrc_bias", f"{rel['bias_forces']:.1e}"),
        ("accelerations vs qacc", f"{rel['accelerations']:.1e}"),
        ("accelerations, report's eq. (2) as printed", f"{eq2:.2f}"),
        (
            "one step, Euler / RK4 (max abs. error)",
            _joined(f"{cc['one_step'][m]:.1e}" for m in ("euler", "rk4")),
        ),
        (
            "1000-step trajectories, Euler / RK4",
            _joined(f"{cc['trajectory_1000'][m]:.1e}" for m in ("euler", "rk4")),
        ),
        (
            f"energy drift over {report['integrators']['seconds']:g} s (0.5 rad swing): "
            "explicit / semi-implicit Euler / RK4 [J]",
            _joined(f"{drift[m]['max_abs_J'][0]:.2g}" for m in COMPARED),
        ),
        ("eigenvalues, analytic vs mjd_transitionFD (max gap)", f"{gap:.1e}"),
        ("controllability rank at upright", str(lin["controllability_rank_upright"])),
    ]


def _control_rows(report: dict[str, Any]) -> list[tuple[str, str]]:
    """The controllers, the bound, the minimum-time swing-ups and the balance."""
    ctl, mt = report["controllers"], report["minimum_time"]
    pumping, basin, balance = ctl["energy_pumping"], ctl["lqr"]["q1_basin_rad"], report["balance"]
    continuous, fs4 = mt.get("continuous_torque"), mt["min_time_decisions_frame_skip_4"]
    bound = ctl["bound_any_controller_q1_rad"]
    return [
        (
            "energy pumping from rest: steps to the goal",
            f"{pumping['steps_to_goal']} ({pumping['seconds']:g} s)",
        ),
        ("saturated LQR: q1 offsets it recovers from [rad]", f"{basin[0]:.4f} .. {basin[1]:.4f}"),
        (
            "constrained LQR (MPC): q1 offsets it recovers from [rad]",
            "{:.4f} .. {:.4f}".format(*ctl["constrained_lqr"]["q1_basin_rad"]),
        ),
        (
            "bound for any |tau| <= 1 controller, pure q1 offset: both unstable modes / one [rad]",
            f"{bound:.4f} / {ctl['bound_one_mode_q1_rad']:.3f}",
        ),
        ("minimum-time swing-up, frame_skip 4 [decisions]", str(fs4)),
        ("minimum-time swing-up, frame_skip 1 [steps]", str(mt["min_time_steps_frame_skip_1"])),
        (
            "the same with continuous torques (the optimiser, from that sequence) [steps]",
            str(continuous["steps"]) if continuous else "-",
        ),
        (
            "swing-up to upright AT REST, |u| <= 1 / with a 0.8 N m reserve [steps]",
            _joined(t["steps"] for t in balance["trajectories"].values()),
        ),
        (
            "balanced for 60 s in MuJoCo: min time / reserve / reserve with {-1, 0, +1}",
            _joined("yes" if r["balanced"] else "no" for r in balance["closed_loop"].values()),
        ),
        (
            "minimum time, explicit Euler / semi-implicit / RK4 [decisions at 0.2 s]",
            _joined(mt["decisions_frame_skip_4_by_integrator"][m] for m in COMPARED),
        ),
    ]


def markdown(report: dict[str, Any]) -> str:
    """``validation.md``: the summary table and the figures."""
    balance, kind = report["balance"], "Quick" if report["quick"] else "Full"
    rows = "\n".join(f"| {what} | {value} |" for what, value in summary_rows(report))
    titles = {figure: FIGURE_TITLES[figure] for figure in report["figures"]}
    return (
        f"# acrobot-mj validation\n\n{kind} run, {report['wall_seconds']:.0f} s. "
        f"All numbers are in `validation.json`.\n\n| check | result |\n|---|---|\n{rows}\n\n"
        "The report's equation (2) as printed (`d12` where `d22` belongs) misses MuJoCo's "
        "accelerations by the relative error above; the corrected form agrees to rounding.\n\n"
        + "".join(f"## {title}\n\n![{title}]({figure})\n\n" for figure, title in titles.items())
        + "## Swing-up and balance: robustness\n\n"
        f"Closed loops in MuJoCo ({balance['min_time_note']}). {balance['bounds_mean']}.\n\n"
        + robustness_table(balance["robustness"])
    )
