"""The report's errata as tests: equation (2) as printed fails the cross-check, the fix passes."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from acrobot_mj.physics import dynamics, errata
from tests.conftest import random_states


def _mujoco_accelerations(model, data, states, torques) -> np.ndarray:
    out = []
    for x, tau in zip(states, torques, strict=True):
        data.qpos[:], data.qvel[:], data.ctrl[:] = x[:2], x[2:], tau
        mujoco.mj_forward(model, data)
        out.append(data.qacc.copy())
    return np.array(out)


def test_equation_2_as_printed_fails_and_corrected_passes(model, data) -> None:
    states, torques = random_states(seed=4)
    q, dq = states[:, :2], states[:, 2:]
    reference = _mujoco_accelerations(model, data, states, torques)
    scale = np.max(np.abs(reference))
    corrected = np.max(np.abs(dynamics.forward_dynamics(q, dq, torques) - reference)) / scale
    printed = np.max(np.abs(errata.forward_dynamics_as_printed(q, dq, torques) - reference)) / scale
    # Corrected: rounding only (see test_crosscheck). Printed: d12 in place of d22 changes the
    # elbow row by m2 l1 lc2 cos(q2) = 0.5 cos(q2) kg m^2, an O(1) relative error in ddq.
    assert corrected <= 1e-10
    assert printed > 0.1


def test_printed_mass_matrix_is_wrong_only_in_d22(model, data) -> None:
    q = np.array([0.3, 1.1])
    data.qpos[:] = q
    mujoco.mj_forward(model, data)
    full_m = np.zeros((2, 2))
    mujoco.mj_fullM(model, data, full_m)
    diff = errata.mass_matrix_as_printed(q) - full_m
    # d12 - d22 = m2 l1 lc2 cos(q2): 1e-12 covers rounding in the O(1) entries.
    np.testing.assert_allclose(diff, [[0, 0], [0, 0.5 * np.cos(1.1)]], atol=1e-12)


def test_d12_definition(model, data, params) -> None:
    # The report uses d12 without defining it; d12 = m2 (lc2^2 + l1 lc2 cos q2) + I2 is MuJoCo's
    # off-diagonal inertia. 1e-12: O(1) entries, rounding only (see test_crosscheck).
    full_m = np.zeros((2, 2))
    for q2 in np.linspace(-np.pi, np.pi, 7):
        data.qpos[:] = [0.4, q2]
        mujoco.mj_forward(model, data)
        mujoco.mj_fullM(model, data, full_m)
        d12 = params.m2 * (params.lc2**2 + params.l1 * params.lc2 * np.cos(q2)) + params.I2
        assert full_m[0, 1] == pytest.approx(d12, abs=1e-12)
        assert full_m[1, 0] == pytest.approx(d12, abs=1e-12)


def test_four_equilibria_not_two(model, data) -> None:
    # The report names two fixed points; with zero torque there are four.
    eq = dynamics.equilibria()
    assert eq.shape == (4, 2)
    for q in eq:
        data.qpos[:], data.qvel[:], data.ctrl[:] = q, 0, 0
        mujoco.mj_forward(model, data)
        # cos(pi/2) = 6e-17 in doubles, times g and masses ~ 1e-15 N m of residual gravity.
        np.testing.assert_allclose(data.qacc, 0, atol=1e-12)
        np.testing.assert_allclose(dynamics.forward_dynamics(q, [0, 0]), 0, atol=1e-12)
