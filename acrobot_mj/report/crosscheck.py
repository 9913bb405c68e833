"""The hand-derived dynamics checked against MuJoCo: the equations of motion at random states,
one step and long trajectories, the integrators' energy drift, and the linearisation."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from acrobot_mj.control.lqr import controllability_rank, discrete_model
from acrobot_mj.envs.assets import load_model
from acrobot_mj.physics import dynamics, errata, integrators
from acrobot_mj.physics.models import ModelSpec, resolve
from acrobot_mj.physics.params import REPORT as P
from acrobot_mj.report.plots import Labels, Series, line_plot

#: The integrators compared, from the least accurate to the most.
COMPARED = ("explicit_euler", "semi_implicit_euler", "rk4")
EQUILIBRIUM_NAMES = ("hanging", "upright", "down_folded", "up_folded")


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def cross_check(
    n_states: int = 200, n_trajectories: int = 3, seed: int = 0, acrobot: ModelSpec = None
) -> dict[str, Any]:
    """Largest errors against MuJoCo of ``acrobot`` (``resolve``'s; the report's by default):
    relative at random states (speeds within its limits, or the report's), absolute over 1 and
    1000 steps of its ``dt``."""
    p = resolve(acrobot).analytic  # refuses what the analytic model cannot represent
    model, rng = load_model(model=acrobot), np.random.default_rng(seed)
    data, full_m = mujoco.MjData(model), np.zeros((2, 2))
    limits = np.where(np.isinf(p.max_vel), P.max_vel, p.max_vel)
    q = rng.uniform(-np.pi, np.pi, (n_states, 2))
    dq = rng.uniform(-1, 1, (n_states, 2)) * limits
    states, torques = np.concatenate([q, dq], 1), rng.uniform(-1, 1, n_states) * p.max_torque
    keys = ("mass_matrix", "bias_forces", "accelerations", "accelerations_eq2_as_printed")
    worst = dict.fromkeys(keys, 0.0)
    for x, tau in zip(states, torques, strict=True):
        data.qpos[:], data.qvel[:], data.ctrl[:] = x[:2], x[2:], tau
        mujoco.mj_forward(model, data)
        mujoco.mj_fullM(model, data, full_m)
        q, dq = x[:2], x[2:]
        pairs = [
            (dynamics.mass_matrix(q, p), full_m),
            (dynamics.bias_forces(q, dq, p), data.qfrc_bias),
            (dynamics.forward_dynamics(q, dq, tau, p), data.qacc),
            (errata.forward_dynamics_as_printed(q, dq, tau, p), data.qacc),
        ]
        for key, (value, reference) in zip(keys, pairs, strict=True):
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
        one = traj = 0.0
        for x, tau in zip(states, torques, strict=True):
            data.qpos[:], data.qvel[:], data.ctrl[:] = x[:2], x[2:], tau
            mujoco.mj_step(model, data)
            step = integrators.step_states(x, tau, p, method=method, limits=False)
            one = max(one, float(np.max(np.abs(np.concatenate([data.qpos, data.qvel]) - step))))
        for k in range(n_trajectories):
            taus = np.random.default_rng(seed + k).choice([-1.0, 0.0, 1.0], 1000) * p.max_torque
            analytic = integrators.simulate(dynamics.HANGING, taus, method, p)
            data.qpos[:], data.qvel[:] = dynamics.HANGING[:2], 0.0
            for t, tau in enumerate(taus):
                data.ctrl[0] = tau
                mujoco.mj_step(model, data)
                data.qvel[:] = integrators.limit_velocities(*data.qvel, p.max_vel)
                gap = np.abs(np.concatenate([data.qpos, data.qvel]) - analytic[t + 1])
                traj = max(traj, float(gap.max()))
        result["one_step"][name] = one
        result["trajectory_1000"][name] = traj
    return result


def integrator_study(
    seconds: float = 100.0, reference_substeps: int = 50, out: Path | None = None
) -> dict[str, Any]:
    """Energy drift [J] with zero torque of each integrator, and of RK4 at dt / substeps."""
    # A 0.5 rad swing, kicked from hanging, and released horizontal (chaotic).
    starts = np.array([[-np.pi / 2 + 0.5, 0, 0, 0], [-np.pi / 2, 0, 1, -1], [0.0, 0, 0, 0]])
    steps = integrators.steps_in(seconds, P.dt)
    e0 = dynamics.total_energy(starts[:, :2], starts[:, 2:])
    drift, curves = {}, {}
    for method in COMPARED:
        xs = integrators.simulate(starts, np.zeros(steps), method, limits=False)
        error = np.abs(dynamics.total_energy(xs[..., :2], xs[..., 2:]) - e0)
        drift[method] = {"max_abs_J": error.max(axis=0).tolist(), "final_abs_J": error[-1].tolist()}
        curves[method] = error[:, 0]
    h = P.dt / reference_substeps
    fine, x, error, ref_curve = replace(P, dt=h), starts.copy(), np.zeros(len(starts)), [0.0]
    for _ in range(steps):
        for _ in range(reference_substeps):
            x = integrators.step_states(x, 0.0, fine, method="rk4", limits=False)
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
        series = [Series(m.replace("_", " "), t, np.maximum(curves[m], 1e-16)) for m in COMPARED]
        series.append(Series(f"RK4 at {h:g} s (reference)", t, np.maximum(ref_curve, 1e-16)))
        title = "Energy error with zero torque, 0.5 rad swing from hanging (dt = 0.05 s)"
        labels = ("time [s]", "|E - E0| [J] (log scale)")
        line_plot(out / "energy_drift.png", series, Labels(title, *labels), log_y=True)
        result["figure"] = "energy_drift.png"
    return result


def linearisation() -> dict[str, Any]:
    """Eigenvalues at the equilibria, analytic and by mjd_transitionFD, and controllability."""
    model, rows = load_model(), {}
    data = mujoco.MjData(model)
    for name, q in zip(EQUILIBRIUM_NAMES, dynamics.equilibria(), strict=True):
        a_c, _ = dynamics.linearize(q, [0.0, 0.0], 0.0)
        a_d, _ = discrete_model(np.concatenate([q, [0.0, 0.0]]))
        data.qpos[:], data.qvel[:], data.ctrl[:] = q, 0.0, 0.0
        mujoco.mj_forward(model, data)
        a_fd = np.zeros((4, 4))
        mujoco.mjd_transitionFD(model, data, 1e-6, True, a_fd, None, None, None)
        ev_an, ev_fd, continuous = (np.sort_complex(np.linalg.eigvals(a)) for a in (a_d, a_fd, a_c))
        rows[name] = {
            "q": q.tolist(),
            "acceleration_at_rest": dynamics.forward_dynamics(q, [0.0, 0.0]).tolist(),
            "eigenvalues_continuous": [[v.real, v.imag] for v in continuous],
            "eigenvalues_discrete_analytic": [[v.real, v.imag] for v in ev_an],
            "eigenvalues_discrete_mujoco_fd": [[v.real, v.imag] for v in ev_fd],
            "max_eigenvalue_gap": float(np.max(np.abs(ev_an - ev_fd))),
            "unstable_modes": int(np.sum(continuous.real > 1e-9)),
        }
    return {
        "equilibria": rows,
        "comparison": "discrete maps: MuJoCo's one-step Jacobian "
        "(central differences, eps 1e-6) vs the analytic continuous Jacobian mapped exactly "
        "through one semi-implicit Euler step",
        "controllability_rank_upright": controllability_rank(*discrete_model()),
    }
