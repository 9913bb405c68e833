"""Long random-torque runs: no MuJoCo warning, no non-finite state (Menagerie's warning test)."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from acrobot_mj.envs.acrobot import AcrobotEnv

STEPS = 100_000


@pytest.mark.parametrize(("integrator", "continuous"), [("euler", False), ("rk4", True)])
def test_no_warning_and_finite_over_1e5_random_torque_steps(integrator, continuous) -> None:
    """Random torques alone stay at low energy (|dq1| < 8 rad/s), so every 1000 steps the
    acrobot also jumps to a random state of the whole domain (angles on the circle, speeds up to
    the limits); the env steps on through the goal without resets."""
    env = AcrobotEnv(integrator=integrator, continuous=continuous)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    actions = (
        rng.uniform(-1, 1, (STEPS, 1)).astype(np.float32)
        if continuous
        else rng.integers(0, 3, STEPS)
    )
    limits = np.array([4 * math.pi, 9 * math.pi])
    peak = np.zeros(4)
    for k, action in enumerate(actions):
        if k % 1000 == 0:
            env.set_state(rng.uniform(-math.pi, math.pi, 2), rng.uniform(-1, 1, 2) * limits)
        obs, *_ = env.step(action)
        peak = np.maximum(peak, np.abs(obs))
    assert np.all(np.isfinite(env.state))
    warnings = {
        mujoco.mjtWarning(i).name: env.data.warning[i].number
        for i in range(mujoco.mjtWarning.mjNWARNING)
    }
    assert not any(warnings.values()), warnings
    # The run reached both velocity limits and the whole circle: it covered the task's domain.
    np.testing.assert_array_equal(peak[2:], limits)
    assert peak[0] > 3.1 and peak[1] > 3.1
