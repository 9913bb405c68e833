"""Trajectory optimisation with CasADi and IPOPT (the control extra): the symbolic step is the
env's step, solutions meet their bounds, and bad requests are refused."""

from __future__ import annotations

import numpy as np
import pytest

from acrobot_mj.control.trajopt import TOLERANCE, miss, shipped, waiting
from acrobot_mj.physics import integrators

casadi = pytest.importorskip("casadi", reason="trajectory optimisation needs the control extra")


@pytest.mark.parametrize("method", ["semi_implicit_euler", "rk4"])
def test_the_symbolic_step_is_the_numpy_step(method) -> None:
    from acrobot_mj.control.trajopt import symbolic_step

    x, u = casadi.SX.sym("x", 4), casadi.SX.sym("u")
    step = casadi.Function("step", [x, u], [symbolic_step(x, u, 0.05, method)])
    rng = np.random.default_rng(0)
    for _ in range(20):
        state, torque = rng.uniform(-3, 3, 4), rng.uniform(-1, 1)
        # The same formulas in another order of evaluation: rounding only.
        np.testing.assert_allclose(
            np.array(step(state, torque)).ravel(),
            integrators.step_states(state, torque, method=method, limits=False),
            rtol=0,
            atol=1e-12,
        )


def test_the_shipped_reserve_trajectory_loads() -> None:
    # What the optimisation below starts from (it was loaded on import of this module before).
    reserve = shipped("reserve")
    assert reserve.u_max == 0.8 and reserve.steps == 476 and reserve.residual() < TOLERANCE


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda o: o.min_time(u_max=-1), r"u_max must be in \(0, 1\]"),
        (
            lambda o: o.min_time(warm=o.WarmStarts("random")),
            r"starts must be one of \('rest', 'pumping'\)",
        ),
    ],
)
def test_bad_optimisation_requests_are_refused(call, message) -> None:
    from acrobot_mj.control import trajopt

    with pytest.raises(ValueError, match=message):
        call(trajopt)


def test_the_warm_start_from_rest_is_the_same_every_time() -> None:
    from acrobot_mj.control.trajopt import Optimiser

    (states, torques), (again, _) = Optimiser().tiny_torques(200), Optimiser(0.8).tiny_torques(200)
    # Drawn from the horizon alone, whatever the bound; 0.01 N m: a few tenths of a degree.
    assert np.array_equal(states, again) and np.abs(torques).max() < 0.05
    assert 1e-4 < np.abs(states[:, :2] - states[0, :2]).max() < 0.02


@pytest.mark.slow
def test_the_search_from_rest_beats_the_shipped_reserve_swing_up() -> None:
    from acrobot_mj.control.trajopt import min_time, shipped

    # Measured: 449 steps (22.45 s) in about 40 s on 2 cores; the pumping search's 476 took
    # about 250 s. Checked: it stays within its bounds and reaches upright at rest.
    found = min_time(0.8).check()
    assert found.steps == 449 < shipped("reserve").steps


@pytest.mark.slow
def test_continuous_torque_reaches_the_height_goal_sooner() -> None:
    # Seeded with the {-1, 0, +1} 63-decision minimum (252 steps, the beam search), the
    # optimiser finds 248 steps, and the MuJoCo env terminates on the last of them (float32
    # torques included).
    from acrobot_mj.control.search import Beam, min_time_search
    from acrobot_mj.report.references import continuous_torque_height

    search = min_time_search(frame_skip=4, beam=Beam(20_000))
    result = continuous_torque_height([a for a in search.actions for _ in range(4)])
    assert result["steps"] <= 250 and result["residual"] < TOLERANCE  # as above: rounding only
    assert result["reached_goal"] and result["replayed_steps"] == result["steps"]


class Stop(Exception):
    """What this test's SIGTERM handler raises (a CLI's raises its own kind)."""


def test_a_signal_during_a_solve_stops_it_and_is_raised() -> None:
    # IPOPT stops on the exception a signal handler raises but reports a failed solve, which the
    # multi-start search passed over (a SIGTERM was followed by 12 more minutes): the handler's
    # own exception must come out, about when the signal came.
    import os
    import signal
    import threading
    import time

    from acrobot_mj.control.trajopt import Optimiser, solve_or_none

    def stop(signum, frame):
        raise Stop("terminated")

    previous = signal.signal(signal.SIGTERM, stop)
    try:
        optimiser = Optimiser(u_max=0.5)
        opti, xs, us, _ = optimiser.problem(600)  # about a minute of IPOPT on these machines
        opti.subject_to(xs[:, 600] == np.array([np.pi / 2, 0, 0, 0]))
        opti.minimize(casadi.sumsqr(us))
        warm = optimiser.pumping(600)
        opti.set_initial(xs, warm[0].T)
        opti.set_initial(us, warm[1][None])
        timer = threading.Timer(1.0, os.kill, (os.getpid(), signal.SIGTERM))
        started = time.monotonic()
        with pytest.raises(Stop, match="terminated"):
            timer.start()
            solve_or_none(opti)
        assert time.monotonic() - started < 10  # a guard against running on, not a timing
        assert signal.getsignal(signal.SIGTERM) is stop  # the caller's handler is back
    finally:
        signal.signal(signal.SIGTERM, previous)


def test_a_path_led_by_a_wait_at_rest_is_as_feasible_as_the_path() -> None:
    # The shipped swing-up starts hanging at rest, an equilibrium: waiting there with zero torque
    # and then following the plan is a path of the model too (the black box's continuation).
    path = shipped("reserve")
    states, torques = waiting(path.states, path.torques, path.steps + 40)
    assert len(torques) == path.steps + 40 and not torques[:40].any()
    np.testing.assert_array_equal(states[40:], path.states)
    replay = integrators.simulate(states[0], torques, path.method, path.params)
    plain = integrators.simulate(path.states[0], path.torques, path.method, path.params)
    # The wait adds rounding only: the two replays end 5e-10 apart (measured), 1e-8 allows
    # for another machine's; a wait that moved the arm would leave it radians off.
    assert np.abs(replay[-1] - plain[-1]).max() < 1e-8
    assert miss(states, path.states[-1] + np.array([0.0, 0.3, -0.2, 0.0])) == pytest.approx(0.3)
