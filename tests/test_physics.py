"""Physical sanity of the analytic model and MuJoCo: energy, equilibria, linearisation."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from acrobot_mj.physics import dynamics, integrators
from acrobot_mj.physics.params import REPORT, AcrobotParams
from tests.conftest import random_states

STARTS = np.array(
    [
        [0.0, 0.0, 0.0, 0.0],  # both links horizontal, released
        [-np.pi / 2 + 1.0, 0.5, 0.0, 0.0],  # a large swing
        [-np.pi / 2, 0.0, 2.0, -3.0],  # kicked from hanging
        [1.3, 2.0, 0.5, 1.0],  # near the top, folded
    ]
)


def _max_energy_drift(dt: float, seconds: float = 10.0) -> float:
    x = STARTS.copy()
    e0 = dynamics.total_energy(x[:, :2], x[:, 2:])
    drift = 0.0
    p = dataclasses.replace(REPORT, dt=dt)
    for _ in range(round(seconds / dt)):
        x = integrators.step_states(x, 0.0, p, method="rk4", limits=False)
        drift = max(drift, float(np.max(np.abs(dynamics.total_energy(x[:, :2], x[:, 2:]) - e0))))
    return drift


def test_rk4_conserves_energy_and_drift_shrinks_with_dt() -> None:
    coarse, fine = _max_energy_drift(0.01), _max_energy_drift(0.005)
    # RK4's error is O(dt^4). Measured over 10 s from these starts (|E| up to 15.5 J):
    # 4.1e-6 J at dt = 0.01 s and 2.7e-7 J at 0.005 s. The bound 1e-5 J (4e-7 of the energy)
    # keeps a 2.5x margin; first-order schemes at dt = 0.01 s drift by 0.7 J (semi-implicit
    # Euler) and 5.8 J (explicit Euler) from the same starts.
    assert coarse < 1e-5
    # Halving dt divides a fourth-order error by 16; demand at least 10 (the asymptotic regime
    # is not exact at dt = 0.01 s).
    assert coarse / fine > 10


def test_explicit_euler_pumps_energy_and_semi_implicit_does_not() -> None:
    # docs/explain/design.md, integrators: the report's forward Euler gains energy at dt = 0.05 s,
    # MuJoCo's semi-implicit Euler (symplectic) keeps it bounded.
    x0 = np.array([-np.pi / 2 + 0.5, 0.0, 0.0, 0.0])
    e0 = dynamics.total_energy(x0[:2], x0[2:])
    energies = {}
    for method in ("explicit_euler", "semi_implicit_euler"):
        xs = integrators.simulate(x0, np.zeros(400), method, limits=False)
        energies[method] = dynamics.total_energy(xs[:, :2], xs[:, 2:]) - e0
    # Measured: explicit Euler gains 52 J in 20 s (more than the 19.6 J that separates hanging
    # from upright); semi-implicit Euler oscillates within 0.16 J of the start. The bounds sit
    # far from both (1 J, 0.5 J): any sign or ordering slip in either scheme crosses them.
    assert energies["explicit_euler"][-1] > 1.0
    assert np.max(np.abs(energies["semi_implicit_euler"])) < 0.5


def test_equilibria_have_zero_acceleration() -> None:
    for q in dynamics.equilibria():
        # Residual gravity from cos(pi/2) = 6e-17 in doubles: ~1e-15 rad/s^2.
        np.testing.assert_allclose(dynamics.forward_dynamics(q, [0.0, 0.0]), 0.0, atol=1e-12)


def test_design_eigenvalues() -> None:
    # docs/explain/design.md, errata: hanging is a centre with +-2.82i, +-1.88i; upright has +-2.82,
    # +-1.88.
    hanging = np.linalg.eigvals(dynamics.linearize([-np.pi / 2, 0.0])[0])
    upright = np.linalg.eigvals(dynamics.linearize([np.pi / 2, 0.0])[0])
    # Real parts at hanging are rounding (1e-15); the documented values are given to 2 decimals.
    np.testing.assert_allclose(hanging.real, 0, atol=1e-12)
    np.testing.assert_allclose(np.sort(np.abs(hanging.imag)), [1.88, 1.88, 2.82, 2.82], atol=6e-3)
    np.testing.assert_allclose(np.sort(upright.real), [-2.82, -1.88, 1.88, 2.82], atol=6e-3)


def test_linearize_matches_finite_differences() -> None:
    # Central differences of forward_dynamics with step 1e-6: truncation ~1e-12 * |f'''|,
    # rounding ~1e-16 / 1e-6 * |f| ~ 1e-9 for |f| ~ 100; 1e-6 covers both with margin.
    states, torques = random_states(seed=5, n=20)
    eps = 1e-6
    for x, tau in zip(states, torques, strict=True):
        a, b = dynamics.linearize(x[:2], x[2:], tau)
        fd = np.zeros((4, 4))
        for j in range(4):
            dx = np.zeros(4)
            dx[j] = eps
            fd[:, j] = (
                integrators.state_derivative(x + dx, tau)
                - integrators.state_derivative(x - dx, tau)
            ) / (2 * eps)
        np.testing.assert_allclose(a, fd, rtol=0, atol=1e-6)
        fd_b = (
            integrators.state_derivative(x, tau + eps) - integrators.state_derivative(x, tau - eps)
        ) / (2 * eps)
        np.testing.assert_allclose(b[:, 0], fd_b, rtol=0, atol=1e-6)


def _semi_implicit_euler_jacobian(a_c: np.ndarray, b_c: np.ndarray, h: float):
    """Exact Jacobian of one semi-implicit Euler step from the continuous one:
    v' = v + h a(q, v), q' = q + h v'."""
    aq, av, bu = a_c[2:, :2], a_c[2:, 2:], b_c[2:]
    eye = np.eye(2)
    a_d = np.block([[eye + h * h * aq, h * (eye + h * av)], [h * aq, eye + h * av]])
    return a_d, np.vstack([h * h * bu, h * bu])


@pytest.mark.parametrize("name", ["hanging", "upright"])
def test_linearisation_eigenvalues_match_mujoco(model, data, name) -> None:
    """Compared as discrete maps: MuJoCo's mjd_transitionFD differentiates one Euler step
    (semi-implicit) by central differences; the analytic continuous Jacobian is mapped through
    the same step exactly (_semi_implicit_euler_jacobian), so no log or approximation is needed."""
    mujoco.mj_resetDataKeyframe(model, data, model.key(name).id)
    mujoco.mj_forward(model, data)
    a_fd, b_fd = np.zeros((4, 4)), np.zeros((4, 1))
    mujoco.mjd_transitionFD(model, data, 1e-6, True, a_fd, b_fd, None, None)
    a_c, b_c = dynamics.linearize(data.qpos.copy(), data.qvel.copy(), 0.0)
    a_d, b_d = _semi_implicit_euler_jacobian(a_c, b_c, model.opt.timestep)
    # Central differences at eps 1e-6 on entries O(1): measured gap 1e-10; 1e-6 is the bound
    # validate reports eigenvalues to.
    np.testing.assert_allclose(a_fd, a_d, atol=1e-6)
    np.testing.assert_allclose(b_fd, b_d, atol=1e-6)
    ev_fd = np.sort_complex(np.linalg.eigvals(a_fd))
    ev_an = np.sort_complex(np.linalg.eigvals(a_d))
    np.testing.assert_allclose(ev_fd, ev_an, atol=1e-6)
    # |lambda| of the neutral modes differs from 1 by rounding only (1e-15); the unstable ones
    # are 1.10 and 1.15, so 1e-9 separates the two kinds with room on both sides.
    unstable = np.abs(ev_an) > 1 + 1e-9
    # Hanging: a centre (all |lambda| = 1 to O(h^2) for semi-implicit Euler); upright: two
    # unstable modes.
    assert unstable.sum() == (0 if name == "hanging" else 2)


def test_tip_and_energy_golden_values(params) -> None:
    # Tolerances: cos(+-pi/2) = 6e-17 in doubles, so positions are exact to ~1e-16 and
    # energies (times g and masses ~ 20) to ~1e-14.
    # Hand-computed: hanging, tip at (0, -2) m; V = g ((m1 lc1 + m2 l1)(-1) + m2 lc2 (-1))
    # = -9.8 * 2 = -19.6 J. Upright: tip at (0, 2), V = +19.6 J. Horizontal: V = 0.
    np.testing.assert_allclose(dynamics.tip_position([-np.pi / 2, 0.0]), [0, -2], atol=1e-15)
    np.testing.assert_allclose(dynamics.tip_position([np.pi / 2, 0.0]), [0, 2], atol=1e-15)
    assert dynamics.total_energy([-np.pi / 2, 0.0], [0, 0]) == pytest.approx(-19.6, abs=1e-12)
    assert dynamics.total_energy([np.pi / 2, 0.0], [0, 0]) == pytest.approx(19.6, abs=1e-12)
    assert dynamics.total_energy([0.0, 0.0], [0, 0]) == 0.0


def test_energy_matches_mujoco(model, data) -> None:
    # MuJoCo's energy (enableflags energy) with potential measured from the world origin: the
    # pivot, as here. Relative 1e-10: same rounding argument as the cross-check.
    model.opt.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY
    states, _torques = random_states(seed=6, n=100)
    for x in states:
        data.qpos[:], data.qvel[:] = x[:2], x[2:]
        mujoco.mj_forward(model, data)
        expected = dynamics.total_energy(x[:2], x[2:])
        assert data.energy.sum() == pytest.approx(expected, rel=1e-10, abs=1e-10)


@pytest.mark.parametrize(
    "p",
    [
        REPORT,
        # Not the report's numbers: every inertial term of its own size.
        AcrobotParams(l1=1.3, lc1=0.7, lc2=0.35, m1=0.8, m2=1.7, I1=0.4, I2=0.9, g=9.81),
    ],
)
def test_the_scalar_energy_is_total_energy_bit_for_bit(p) -> None:
    # Equality, not closeness: the energy shaping's potential is energies() on Python floats,
    # and the shaped presets' runs (and golden values) were made with total_energy's numbers
    # (the same source over numpy arrays), so math's sines and numpy's must give the same
    # doubles and the terms be summed in the same order. 20,000 states beyond the velocity
    # limits and past +-pi.
    rng = np.random.default_rng(7)
    states = rng.uniform([-4, -4, -15, -30], [4, 4, 15, 30], (20_000, 4))
    for q1, q2, dq1, dq2 in states.tolist():
        expected = float(dynamics.total_energy(np.array([q1, q2]), np.array([dq1, dq2]), p))
        kinetic, potential = dynamics.energies(q1, q2, dq1, dq2, p.lumped)
        assert kinetic + potential == expected, (q1, q2, dq1, dq2)
