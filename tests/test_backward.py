"""Swing-ups integrated backwards from upright (acrobot_mj.control.backward): the backward step
inverts the model's own step, every plan ends at upright within its torque bound, the library
is the same for the same seed, and bad settings, another step rule and another model are
refused in one line."""

from __future__ import annotations

import numpy as np
import pytest

from acrobot_mj.control.backward import BackwardSettings, back, backward_library
from acrobot_mj.olympics import entries
from acrobot_mj.physics import integrators
from acrobot_mj.physics.dynamics import UPRIGHT
from acrobot_mj.physics.params import REPORT

SMALL = BackwardSettings(count=5)


@pytest.mark.parametrize("u", [-0.8, 0.0, 0.55])
def test_the_backward_step_inverts_the_semi_implicit_euler_step(u: float) -> None:
    """One step forward from ``back(x)`` returns to ``x``: the fixed point is iterated to
    1e-15 rad/s, so the round trip is exact to rounding (1e-12, a few hundred ulps at 10)."""
    rng = np.random.default_rng(7)
    for _ in range(20):
        x = np.append(rng.uniform(-np.pi, np.pi, 2), rng.uniform(-3.0, 3.0, 2))
        again = integrators.step_states(back(x, u, REPORT), u, REPORT, method="semi_implicit_euler")
        np.testing.assert_allclose(again, x, rtol=0, atol=1e-12)


def test_every_plan_ends_upright_within_its_bound_and_is_seeded() -> None:
    plans = backward_library(REPORT, "semi_implicit_euler", SMALL)
    assert len(plans) == SMALL.count
    for plan in plans:
        # tolerance: the forward rollout of the backward states, 0.05 (BackwardSettings).
        assert np.abs(plan.states[-1] - UPRIGHT).max() <= SMALL.tolerance
        assert np.abs(plan.torques).max() <= SMALL.reserve * (SMALL.pump + SMALL.jitter) + 1e-12
        assert SMALL.shortest <= plan.steps <= SMALL.longest
    again = backward_library(REPORT, "semi_implicit_euler", SMALL)
    assert all(np.array_equal(a.torques, b.torques) for a, b in zip(plans, again, strict=True))
    other = backward_library(REPORT, "semi_implicit_euler", BackwardSettings(count=5, seed=1))
    assert not np.array_equal(plans[0].torques, other[0].torques)


def test_refusals() -> None:
    with pytest.raises(ValueError, match="integrated backwards by semi_implicit_euler"):
        backward_library(REPORT, "rk4", SMALL)
    with pytest.raises(ValueError, match="count"):
        BackwardSettings(count=0)
    with pytest.raises(ValueError, match="pump"):
        BackwardSettings(pump=1.5)
    with pytest.raises(ValueError, match="backward entry is for report, not 'ai_olympics'"):
        entries.build("backward", "ai_olympics")
