"""``acrobot-mj validate``: the hand-derived dynamics checked against MuJoCo, and the physics
references the learners are compared with.

:func:`validate` writes ``validation.json``, PNG figures and ``validation.md`` (a short report
that embeds them) and returns the JSON document. Every number comes from the functions here,
:mod:`acrobot_mj.control` and :mod:`acrobot_mj.dynamics`.
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import gymnasium as gym
import mujoco
import numpy as np

import acrobot_mj
from acrobot_mj import control, dynamics, errata, integrators
from acrobot_mj.assets import load_model
from acrobot_mj.params import AcrobotParams
from acrobot_mj.plots import Series, line_plot

P = AcrobotParams()
SCHEMA_VERSION = 1
METHODS = ("explicit_euler", "semi_implicit_euler", "rk4")
EQUILIBRIUM_NAMES = ("hanging", "upright", "down_folded", "up_folded")


def _states(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    q = rng.uniform(-np.pi, np.pi, (n, 2))
    dq = rng.uniform(-1, 1, (n, 2)) * [P.max_vel1, P.max_vel2]
    return np.concatenate([q, dq], 1), rng.uniform(-1, 1, n)


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def cross_check(n_states: int = 200, n_trajectories: int = 3, seed: int = 0) -> dict[str, Any]:
    """Largest relative errors of the analytic model against MuJoCo at random states, and
    absolute errors of one step and of 1000-step random-action trajectories from rest."""
    model = load_model()
    data = mujoco.MjData(model)
    states, torques = _states(n_states, seed)
    full_m = np.zeros((2, 2))
    worst = {
        "mass_matrix": 0.0,
        "bias_forces": 0.0,
        "accelerations": 0.0,
        "accelerations_eq2_as_printed": 0.0,
    }
    for x, tau in zip(states, torques, strict=True):
        data.qpos[:], data.qvel[:], data.ctrl[:] = x[:2], x[2:], tau
        mujoco.mj_forward(model, data)
        mujoco.mj_fullM(model, data, full_m)
        q, dq = x[:2], x[2:]
        for key, value, reference in [
            ("mass_matrix", dynamics.mass_matrix(q), full_m),
            ("bias_forces", dynamics.bias_forces(q, dq), data.qfrc_bias),
            ("accelerations", dynamics.forward_dynamics(q, dq, tau), data.qacc),
            (
                "accelerations_eq2_as_printed",
                errata.forward_dynamics_as_printed(q, dq, tau),
                data.qacc,
            ),
        ]:
            worst[key] = max(worst[key], _rel(value, reference))
    result: dict[str, Any] = {
        "n_states": n_states,
        "relative": worst,
        "one_step": {},
        "trajectory_1000": {},
    }
    for name, integrator, method in [
        ("euler", mujoco.mjtIntegrator.mjINT_EULER, "semi_implicit_euler"),
        ("rk4", mujoco.mjtIntegrator.mjINT_RK4, "rk4"),
    ]:
        model.opt.integrator = integrator
        one = 0.0
        for x, tau in zip(states, torques, strict=True):
            data.qpos[:], data.qvel[:], data.ctrl[:] = x[:2], x[2:], tau
            mujoco.mj_step(model, data)
            step = integrators.STEPS[method](x, tau)
            one = max(one, float(np.max(np.abs(np.concatenate([data.qpos, data.qvel]) - step))))
        traj = 0.0
        for k in range(n_trajectories):
            taus = np.random.default_rng(seed + k).choice([-1.0, 0.0, 1.0], 1000)
            analytic = integrators.simulate(control.HANGING, taus, method)
            data.qpos[:], data.qvel[:] = control.HANGING[:2], 0.0
            for t, tau in enumerate(taus):
                data.ctrl[0] = tau
                mujoco.mj_step(model, data)
                data.qvel[:] = np.clip(
                    data.qvel, [-P.max_vel1, -P.max_vel2], [P.max_vel1, P.max_vel2]
                )
                gap = np.abs(np.concatenate([data.qpos, data.qvel]) - analytic[t + 1])
                traj = max(traj, float(gap.max()))
        result["one_step"][name] = one
        result["trajectory_1000"][name] = traj
    return result


def integrator_study(
    seconds: float = 100.0, reference_substeps: int = 50, out: Path | None = None
) -> dict[str, Any]:
    """Zero torque from several starts: energy drift [J] of each integrator at 0.05 s, and of a
    tight reference (RK4 at 0.05 s / ``reference_substeps``), with no velocity clipping."""
    starts = np.array(
        [
            [-np.pi / 2 + 0.5, 0.0, 0.0, 0.0],  # a 0.5 rad swing
            [-np.pi / 2, 0.0, 1.0, -1.0],  # kicked from hanging
            [0.0, 0.0, 0.0, 0.0],
        ]
    )  # released horizontal: chaotic
    steps = round(seconds / P.dt)
    e0 = dynamics.total_energy(starts[:, :2], starts[:, 2:])
    drift, curves = {}, {}
    for method in METHODS:
        xs = integrators.simulate(starts, np.zeros(steps), method, clip=False)
        error = np.abs(dynamics.total_energy(xs[..., :2], xs[..., 2:]) - e0)
        drift[method] = {"max_abs_J": error.max(axis=0).tolist(), "final_abs_J": error[-1].tolist()}
        curves[method] = error[:, 0]
    x, error = starts.copy(), np.zeros(len(starts))
    h = P.dt / reference_substeps
    ref_curve = [0.0]
    for _ in range(steps):
        for _ in range(reference_substeps):
            x = integrators.rk4_step(x, 0.0, h)
        gap = np.abs(dynamics.total_energy(x[:, :2], x[:, 2:]) - e0)
        error = np.maximum(error, gap)
        ref_curve.append(float(gap[0]))
    drift[f"rk4_reference_dt_{h:g}"] = {"max_abs_J": error.tolist()}
    result = {
        "seconds": seconds,
        "dt": P.dt,
        "starts": starts.tolist(),
        "initial_energy_J": e0.tolist(),
        "energy_drift": drift,
    }
    if out is not None:
        t = np.arange(steps + 1) * P.dt
        series = [
            Series(name.replace("_", " "), t, np.maximum(curves[name], 1e-16)) for name in METHODS
        ]
        series.append(Series(f"RK4 at {h:g} s (reference)", t, np.maximum(ref_curve, 1e-16)))
        line_plot(
            out / "energy_drift.png",
            series,
            "Energy error with zero torque, 0.5 rad swing from hanging (dt = 0.05 s)",
            "time [s]",
            "|E - E0| [J] (log scale)",
            log_y=True,
        )
        result["figure"] = "energy_drift.png"
    return result


def linearisation() -> dict[str, Any]:
    """Equilibria, eigenvalues from the analytic Jacobian (continuous, and as discrete maps
    through the env's step) and from MuJoCo's mjd_transitionFD, and controllability."""
    model = load_model()
    data = mujoco.MjData(model)
    rows = {}
    for name, q in zip(EQUILIBRIUM_NAMES, dynamics.equilibria(), strict=True):
        x0 = np.concatenate([q, [0.0, 0.0]])
        a_c, _ = dynamics.linearize(q, [0.0, 0.0], 0.0)
        a_d, _ = control.discrete_model(x0)
        data.qpos[:], data.qvel[:], data.ctrl[:] = q, 0.0, 0.0
        mujoco.mj_forward(model, data)
        a_fd = np.zeros((4, 4))
        mujoco.mjd_transitionFD(model, data, 1e-6, True, a_fd, None, None, None)
        ev_an = np.sort_complex(np.linalg.eigvals(a_d))
        ev_fd = np.sort_complex(np.linalg.eigvals(a_fd))
        continuous = np.sort_complex(np.linalg.eigvals(a_c))
        rows[name] = {
            "q": q.tolist(),
            "acceleration_at_rest": dynamics.forward_dynamics(q, [0.0, 0.0]).tolist(),
            "eigenvalues_continuous": [[v.real, v.imag] for v in continuous],
            "eigenvalues_discrete_analytic": [[v.real, v.imag] for v in ev_an],
            "eigenvalues_discrete_mujoco_fd": [[v.real, v.imag] for v in ev_fd],
            "max_eigenvalue_gap": float(np.max(np.abs(ev_an - ev_fd))),
            "unstable_modes": int(np.sum(continuous.real > 1e-9)),
        }
    a, b = control.discrete_model()
    return {
        "equilibria": rows,
        "comparison": "discrete maps: MuJoCo's one-step Jacobian "
        "(central differences, eps 1e-6) vs the analytic continuous Jacobian mapped exactly "
        "through one semi-implicit Euler step",
        "controllability_rank_upright": control.controllability_rank(a, b),
    }


def controllers(quick: bool = False) -> dict[str, Any]:
    """Energy pumping from rest in the MuJoCo env; saturated LQR at upright, its basin, and the
    bound for any controller with |tau| <= 1 N m."""
    env = gym.make(acrobot_mj.ENV_ID, continuous=True)
    env.reset(seed=0)
    state, steps, reached = env.unwrapped.state, 0, False
    energies = [float(dynamics.total_energy(state[:2], state[2:]))]
    while not reached and steps < 1000:
        tau = float(control.energy_pumping_torque(state))
        _, _, terminated, truncated, info = env.step(np.array([tau], dtype=np.float32))
        steps += 1
        state = env.unwrapped.state
        energies.append(float(dynamics.total_energy(state[:2], state[2:])))
        reached = bool(info["is_success"])
        if terminated or truncated:
            break
    env_drops = int(np.sum(np.diff(energies) < 0))
    fine = {dt: np.diff(control.pumping_energies(dt)).min() for dt in (1e-2, 1e-3)}
    lqr = control.LQR()
    low, high = control.q1_basin(lqr, upper=0.2, resolution=1e-3 if quick else 1e-4)
    rng = np.random.default_rng(0)
    n = 200 if quick else 2000
    scale = np.array([0.02, 0.02, 0.05, 0.05])
    starts = control.UPRIGHT + rng.uniform(-1, 1, (n, 4)) * scale
    bound = control.unstable_mode_bound()
    return {
        "energy_pumping": {
            "law": "tau = clip(50 (E* - E) dq2, -1, 1) N m, E* = 19.6 J (upright)",
            "reference": "the energy approach of Spong, 'The swing up control problem for the "
            "acrobot', IEEE Control Systems 1995; the same law shape as Fantoni, Lozano and "
            "Spong's for the Pendubot (IEEE TAC 2000)",
            "reached_goal": reached,
            "steps_to_goal": steps,
            "seconds": steps * P.dt,
            "energy_start_J": energies[0],
            "energy_end_J": energies[-1],
            "env_steps_losing_energy": env_drops,
            "monotone_check": "RK4 with the torque held over dt: the largest energy drop of a "
            "step in the pumping phase shrinks as dt^2 (dq2 changing sign within a step), so "
            "the energy rises monotonically in continuous time",
            "largest_drop_J_rk4_dt_0.01": float(-min(fine[1e-2], 0.0)),
            "largest_drop_J_rk4_dt_0.001": float(-min(fine[1e-3], 0.0)),
        },
        "lqr": {
            "gain": lqr.gain[0].tolist(),
            "q": list(lqr.q),
            "r": lqr.r,
            "q1_basin_rad": [low, high],
            "sampled_box": scale.tolist(),
            "sampled": n,
            "sampled_fraction_balanced": float(np.mean(control.balances(lqr, starts))),
        },
        "bound_any_controller_q1_rad": min(bound.values()),
        "bound_per_unstable_mode": bound,
    }


def minimum_time(quick: bool = False) -> dict[str, Any]:
    """Beam searches for the fewest decisions to the goal from rest, replayed in the env."""
    width = 3000 if quick else 20_000
    results = {}
    best4 = control.min_time_search(frame_skip=4, width=width)
    results["frame_skip_4"] = best4
    # At frame_skip 1 a sequence may hold a torque for k steps: search with holds of 1, 3, 4.
    holds = {1: control.min_time_search(frame_skip=1, width=2000 if quick else 5000)}
    holds[4] = best4
    if not quick:
        holds[3] = control.min_time_search(frame_skip=3, width=width)
    per_hold = {k: r.decisions * k for k, r in holds.items() if r.decisions is not None}
    k_best = min(per_hold, key=per_hold.get)
    fs1_actions = [a for a in holds[k_best].actions for _ in range(k_best)]
    replay = {"frame_skip_1": _replay(fs1_actions, 1), "frame_skip_4": _replay(best4.actions, 4)}
    by_integrator = {}
    for method in METHODS:
        result = (
            best4
            if method == "semi_implicit_euler"
            else control.min_time_search(frame_skip=4, width=width, method=method)
        )
        by_integrator[method] = result.decisions
    return {
        "min_time_decisions_frame_skip_4": best4.decisions,
        "min_time_steps_frame_skip_1": len(fs1_actions),
        "actions_frame_skip_4": best4.actions,
        "actions_frame_skip_1": fs1_actions,
        "frame_skip_1_steps_by_hold": per_hold,
        "beam_width": width,
        "replayed_in_env": replay,
        "decisions_frame_skip_4_by_integrator": by_integrator,
    }


def _replay(actions: list[int], frame_skip: int) -> dict[str, Any]:
    """Play ``actions`` in the MuJoCo env from rest: when does it terminate?"""
    env = gym.make(acrobot_mj.ENV_ID, frame_skip=frame_skip)
    env.reset(seed=0)
    for k, action in enumerate(actions, start=1):
        _, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            return {
                "steps": k,
                "reached_goal": bool(info["is_success"]),
                "at_last_action": k == len(actions),
                "tip_height": info["tip_height"],
            }
    return {"steps": len(actions), "reached_goal": False, "at_last_action": True}


def phase_figures(actions_fs4: list[int], out: Path) -> list[str]:
    """The zero-torque flow in (q1, dq1) (in the spirit of the report's Fig. 2) and the
    minimum-time swing-up in phase space."""
    series = []
    for offset in (0.3, 0.8, 1.4, 2.2, 3.0):
        x0 = np.array([-np.pi / 2 + offset, 0.0, 0.0, 0.0])
        xs = integrators.simulate(x0, np.zeros(200), "rk4", dt=0.02, clip=False)
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
    x, xs = control.HANGING.copy(), [control.HANGING.copy()]
    for action in actions_fs4:
        for _ in range(4):
            x = control.step(x, np.array([-1.0, 0.0, 1.0])[action])
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


def validate(out: str | Path = "runs/validation", quick: bool = False) -> dict[str, Any]:
    """Run every check and write ``validation.json``, the figures and ``validation.md``."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    report: dict[str, Any] = {
        "schema_version": SCHEMA_VERSION,
        "quick": quick,
        "versions": {"acrobot_mj": acrobot_mj.__version__, "mujoco": mujoco.__version__},
    }
    report["cross_check"] = cross_check(
        n_states=50 if quick else 200, n_trajectories=1 if quick else 3
    )
    report["integrators"] = integrator_study(
        seconds=20.0 if quick else 100.0, reference_substeps=10 if quick else 50, out=out
    )
    report["linearisation"] = linearisation()
    report["controllers"] = controllers(quick)
    report["minimum_time"] = minimum_time(quick)
    report["min_time_steps_frame_skip_1"] = report["minimum_time"]["min_time_steps_frame_skip_1"]
    report["min_time_decisions_frame_skip_4"] = report["minimum_time"][
        "min_time_decisions_frame_skip_4"
    ]
    report["figures"] = [
        "energy_drift.png",
        *phase_figures(report["minimum_time"]["actions_frame_skip_4"], out),
    ]
    basin = report["controllers"]["lqr"]["q1_basin_rad"][1]
    bound = report["controllers"]["bound_any_controller_q1_rad"]
    report["moonshot_balance"] = {
        "done": False,
        "why": f"not attempted in this version: the saturated LQR recovers from pure q1 offsets "
        f"up to {basin:.4f} rad and no |tau| <= 1 controller from more than {bound:.4f} rad, "
        "far less than the error with which a swing-up arrives near upright",
    }
    report["wall_seconds"] = time.perf_counter() - started
    (out / "validation.json").write_text(json.dumps(report, indent=1))
    (out / "validation.md").write_text(markdown(report))
    return report


def summary_rows(report: dict[str, Any]) -> list[tuple[str, str]]:
    """The headline numbers, as (what, value) rows."""
    cc, lin, ctl = report["cross_check"], report["linearisation"], report["controllers"]
    mt, drift = report["minimum_time"], report["integrators"]["energy_drift"]
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
    return "\n".join(lines)
