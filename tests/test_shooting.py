"""Energy removal planned on the model's own steps (acrobot_mj.control.shooting): it takes a
whole-arm spin down to upright's energy where ``-clip(dq2)`` leaves it spinning, it acts only
above upright's energy, the same seed gives the same torques, a funnel's fresh copy owns its
law, and bad states and settings are refused in one line."""

from __future__ import annotations

import numpy as np
import pytest

from acrobot_mj.control.feedback import FunnelController
from acrobot_mj.control.shooting import EnergyShooting, ShootingSettings
from acrobot_mj.olympics.controllers import shipped_swing_up
from acrobot_mj.physics import integrators
from acrobot_mj.physics.dynamics import HANGING, UPRIGHT
from acrobot_mj.physics.params import REPORT

METHOD = "semi_implicit_euler"
#: The arm nearly straight, the shoulder at -8.5 rad/s: 129 J over upright's energy (the start
#: of scripts/spin_energy.py).
SPIN = np.array([0.0, 0.3, -8.5, 1.0])


def spin_down(law: EnergyShooting | None, seconds: float = 30.0) -> float:
    """The energy [J] over upright's after ``seconds`` from :data:`SPIN` on the model's steps,
    under ``law`` and, where it gives None (or there is none), ``-clip(dq2)``."""
    x, shooting = SPIN.copy(), EnergyShooting(REPORT, METHOD)
    for _ in range(integrators.steps_in(seconds, REPORT.dt)):
        u = None if law is None else law(x)
        x = integrators.step_states(x, float(np.clip(-x[3], -1, 1)) if u is None else u, REPORT)
    return float(shooting.energy(x))


def test_shooting_takes_a_whole_arm_spin_down_where_damping_cannot() -> None:
    """Measured over 30 s: under ``-clip(dq2)`` the arm spins on at the shoulder's velocity
    limit, 248 J over upright's (so above 200 J); the planner brings it to -13 J. It stops
    acting at ``above`` (5 J), and below that the damping only lowers the energy, so at most
    5 J is a bound, not a fit."""
    assert spin_down(None) > 200.0
    assert spin_down(EnergyShooting(REPORT, METHOD)) <= ShootingSettings().above


def test_it_acts_only_above_upright_energy_and_is_seeded() -> None:
    law = EnergyShooting(REPORT, METHOD)
    assert law(HANGING) is None and law(UPRIGHT) is None
    first = [law(SPIN + 0.01 * k) for k in range(5)]
    assert all(u in (-1.0, 0.0, 1.0) for u in first)
    law.reset()
    assert [law(SPIN + 0.01 * k) for k in range(5)] == first
    other = EnergyShooting(REPORT, METHOD, ShootingSettings(seed=1))
    assert [other(SPIN + 0.01 * k) for k in range(5)] != first


def test_a_fresh_funnel_owns_its_law_and_resets_it() -> None:
    trajectory = shipped_swing_up("report")
    law = EnergyShooting(trajectory.params, trajectory.method)
    funnel = FunnelController(trajectory, elsewhere=law)
    copy = funnel.fresh()
    assert copy.elsewhere is not law and isinstance(copy.elsewhere, EnergyShooting)
    law(SPIN)
    assert law.plan.any() and not copy.elsewhere.plan.any()
    funnel.reset()
    assert not law.plan.any()
    # Below upright's energy the law gives None and the funnel's own removal acts.
    x = np.array([-np.pi / 2, 0.5, 0.0, 2.0])
    assert funnel.removal(x) == -1.0


@pytest.mark.parametrize(
    ("state", "match"),
    [(np.array([0.0, 0.0, np.nan, 0.0]), "finite"), (np.zeros(3), "4 finite numbers")],
)
def test_a_bad_state_is_refused(state: np.ndarray, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        EnergyShooting(REPORT, METHOD)(state)


@pytest.mark.parametrize(
    ("changes", "match"),
    [
        ({"candidates": 0}, "candidates"),
        ({"segment": 3.0}, "segment"),
        ({"above": -1.0}, "above"),
        ({"horizon": float("nan")}, "horizon"),
    ],
)
def test_bad_settings_are_refused(changes: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        ShootingSettings(**changes)
