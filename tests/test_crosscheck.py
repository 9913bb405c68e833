"""The analytic Lagrangian model against MuJoCo compiled from models/scene.xml.

Tolerances: the two compute the same formulas in a different order, so they differ by rounding
only. Entries are O(1..100) (torques up to ~60 N m at the speed limits), so double rounding gives
~1e-14 relative; 1e-10 leaves four orders of margin while any modelling error
(a wrong sign, a missing term, the report's erratum) shows at 1e-3 or more.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from acrobot_mj.physics import dynamics, integrators
from acrobot_mj.physics.params import AcrobotParams
from tests.conftest import random_states

REL = 1e-10


def _set(model, data, x, tau):
    data.qpos[:] = x[:2]
    data.qvel[:] = x[2:]
    data.ctrl[:] = tau
    mujoco.mj_forward(model, data)


def _rel_err(a, b) -> float:
    return float(np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-300))


def test_mass_matrix_bias_and_accelerations(model, data) -> None:
    states, torques = random_states(seed=1)
    assert len(states) >= 100
    full_m = np.zeros((2, 2))
    worst = np.zeros(3)
    for x, tau in zip(states, torques, strict=True):
        _set(model, data, x, tau)
        mujoco.mj_fullM(model, data, full_m)
        q, dq = x[:2], x[2:]
        worst = np.maximum(
            worst,
            [
                _rel_err(dynamics.mass_matrix(q), full_m),
                _rel_err(dynamics.bias_forces(q, dq), data.qfrc_bias),
                _rel_err(dynamics.forward_dynamics(q, dq, tau), data.qacc),
            ],
        )
    assert np.all(worst <= REL), worst


def test_batched_equals_one_at_a_time() -> None:
    # The batch path must compute exactly what the single-state path does (same operations).
    states, torques = random_states(seed=2, n=50)
    q, dq = states[:, :2], states[:, 2:]
    batched = dynamics.forward_dynamics(q, dq, torques)
    single = np.array(
        [dynamics.forward_dynamics(a, b, t) for a, b, t in zip(q, dq, torques, strict=True)]
    )
    np.testing.assert_array_equal(batched, single)
    assert dynamics.mass_matrix(q).shape == (50, 2, 2)
    assert dynamics.total_energy(q, dq).shape == (50,)
    assert dynamics.tip_position(q).shape == (50, 2)
    a, b = dynamics.linearize(q, dq, torques)
    assert a.shape == (50, 4, 4) and b.shape == (50, 4, 1)
    np.testing.assert_allclose(a[7], dynamics.linearize(q[7], dq[7], torques[7])[0], rtol=1e-14)


# One step of size 0.05 s: MuJoCo and the analytic model do the same arithmetic up to rounding,
# so the states agree to ~1e-14 absolute (angles O(1), velocities O(10)); a 1e-12 bound
# leaves a 100x margin while a wrong integration order (explicit instead of semi-implicit Euler)
# is off by dt^2 * qacc ~ 1e-1.
@pytest.mark.parametrize(
    ("integrator", "method"),
    [
        (mujoco.mjtIntegrator.mjINT_EULER, "semi_implicit_euler"),
        (mujoco.mjtIntegrator.mjINT_RK4, "rk4"),
    ],
)
def test_one_step(model, data, integrator, method) -> None:
    model.opt.integrator = integrator
    states, torques = random_states(seed=3)
    worst = 0.0
    for x, tau in zip(states, torques, strict=True):
        _set(model, data, x, tau)
        mujoco.mj_step(model, data)
        expected = integrators.step_states(x, tau, method=method, limits=False)
        worst = max(worst, float(np.max(np.abs(np.concatenate([data.qpos, data.qvel]) - expected))))
    assert worst <= 1e-12


def test_explicit_euler_is_not_mujocos_euler(model, data) -> None:
    # The report's forward Euler differs from MuJoCo's semi-implicit one by dt^2 * qacc per step.
    x, tau = np.array([-1.0, 0.5, 1.0, -2.0]), 0.3
    _set(model, data, x, tau)
    mujoco.mj_step(model, data)
    mujoco_next = np.concatenate([data.qpos, data.qvel])
    explicit = integrators.step_states(x, tau, method="explicit_euler", limits=False)
    assert np.max(np.abs(explicit - mujoco_next)) > 1e-3


def _mujoco_trajectory(model, data, x0, torques) -> np.ndarray:
    """MuJoCo from x0 under torques, clipping velocities after every step as the env does."""
    p = AcrobotParams()
    data.qpos[:], data.qvel[:] = x0[:2], x0[2:]
    states = [np.concatenate([data.qpos, data.qvel])]
    for tau in torques:
        data.ctrl[0] = tau
        mujoco.mj_step(model, data)
        data.qvel[:] = np.clip(data.qvel, [-p.max_vel1, -p.max_vel2], [p.max_vel1, p.max_vel2])
        states.append(np.concatenate([data.qpos, data.qvel]))
    return np.array(states)


INTEGRATOR_PAIRS = [
    (mujoco.mjtIntegrator.mjINT_EULER, "semi_implicit_euler"),
    (mujoco.mjtIntegrator.mjINT_RK4, "rk4"),
]


# 1000 steps (50 s) from rest with random actions in {-1, 0, +1} N m. These are the task's own
# trajectories; they stay at moderate energy (|dq1| < 1.6 rad/s), where the measured gap after
# 1000 steps is ~3e-14, so a 1e-8 bound holds with a wide margin.
@pytest.mark.parametrize(("integrator", "method"), INTEGRATOR_PAIRS)
@pytest.mark.parametrize("seed", range(3))
def test_1000_step_trajectories(model, data, integrator, method, seed) -> None:
    model.opt.integrator = integrator
    rng = np.random.default_rng(seed)
    torques = rng.choice([-1.0, 0.0, 1.0], 1000)
    x0 = np.array([-np.pi / 2, 0.0, 0.0, 0.0])
    analytic = integrators.simulate(x0, torques, method)
    np.testing.assert_allclose(
        _mujoco_trajectory(model, data, x0, torques), analytic, rtol=0, atol=1e-8
    )
    # The trajectory must actually move for the comparison to mean anything.
    assert np.ptp(analytic[:, 0]) > 0.3


# High energy: random states anywhere in the domain (speeds up to the limits), so velocity
# clipping acts. The motion is chaotic there: rounding differences (1e-16) grow until, after
# ~200 steps, they pass 1e-8 (measured: first at step 196 to 261 for these seeds). That is the
# flow's divergence, not a model error, so the horizon is 100 steps, where the largest measured
# gap is 6e-11: 1e-8 leaves a 170x margin.
@pytest.mark.parametrize(("integrator", "method"), INTEGRATOR_PAIRS)
def test_high_energy_trajectories_with_clipping(model, data, integrator, method) -> None:
    p = AcrobotParams()
    model.opt.integrator = integrator
    clipped = 0
    for seed in range(5):
        rng = np.random.default_rng(seed)
        x0 = np.concatenate(
            [rng.uniform(-np.pi, np.pi, 2), rng.uniform(-1, 1, 2) * [p.max_vel1, p.max_vel2]]
        )
        torques = rng.choice([-1.0, 0.0, 1.0], 100)
        analytic = integrators.simulate(x0, torques, method)
        clipped += np.any(np.abs(analytic[1:, 2:]) == [p.max_vel1, p.max_vel2])
        np.testing.assert_allclose(
            _mujoco_trajectory(model, data, x0, torques), analytic, rtol=0, atol=1e-8
        )
    assert clipped >= 2  # measured: 3 of 5 runs (Euler), 2 of 5 (RK4) end a step clipped
