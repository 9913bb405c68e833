"""The AI Olympics runner: the state estimator, the global policy's testing controller, the
planned swing-up, an episode of the protocol, the ``olympics`` command, and its episodes on a
local Ray."""

from __future__ import annotations

import importlib.util
import json
import math
import threading
import time
from dataclasses import replace

import numpy as np
import pytest

from acrobot_mj.cli import main
from acrobot_mj.control.controller import Controller
from acrobot_mj.control.estimator import Estimated, Observer
from acrobot_mj.control.planned import planned_swing_up
from acrobot_mj.control.tracker import PlanTracker
from acrobot_mj.olympics import entries, leaderboard
from acrobot_mj.olympics.episodes import Conditions, episode, global_episode
from acrobot_mj.olympics.globaltest import GlobalTester
from acrobot_mj.olympics.plants import equations
from acrobot_mj.olympics.protocol import GLOBAL, PERFORMANCE, from_protocol
from acrobot_mj.olympics.report import RECORD_FILE, olympics_record, write_olympics
from acrobot_mj.olympics.run import OlympicsRun, score
from acrobot_mj.olympics.scaling import protocol_for
from acrobot_mj.olympics.scores import final_success, performance, uptime
from acrobot_mj.olympics.sources import Source
from acrobot_mj.olympics.swing_ups import performance_swing_up
from acrobot_mj.physics import integrators
from acrobot_mj.physics.dynamics import HANGING
from acrobot_mj.physics.models import MODELS
from acrobot_mj.pool import Ray
from tests.conftest import LOOPBACK, listening
from tests.test_protocol_rules import tiny_rules

OLYMPICS = MODELS["ai_olympics"]


def test_observer_is_exact_on_its_own_model() -> None:
    """Noise-free measurements of the observer's own model: the prediction is the next state,
    so the estimate equals it to rounding (1e-9 over 200 steps of a swinging arm)."""
    p, observer = OLYMPICS.params, Observer(OLYMPICS.params)
    x, rng = HANGING + np.array([0.3, -0.5, 1.0, -2.0]), np.random.default_rng(0)
    for _ in range(200):
        estimate = observer(x)
        assert np.abs(estimate - x).max() < 1e-9
        u = float(rng.uniform(-6, 6))
        observer.applied(u)
        x = integrators.step_states(x, u, p, method="rk4")


def test_observer_ignores_velocity_noise() -> None:
    """Velocity noise of sigma 0.5 rad/s (the protocol's largest level), angles exact: the
    estimated velocities' RMS error after 50 steps is under 0.1 rad/s, a fifth of the noise
    (with velocity_gain 0.05 the noise passes as an AR(1) of std 0.05 x 0.5 / sqrt(1 - 0.95^2),
    about 0.08 rad/s)."""
    p, observer = OLYMPICS.params, Observer(OLYMPICS.params)
    x, rng = HANGING + np.array([1.0, 0.0, 0.0, 0.0]), np.random.default_rng(1)
    errors = []
    for k in range(400):
        y = x + np.r_[0.0, 0.0, rng.normal(0.0, 0.5, 2)]
        error = (observer(y) - x)[2:]
        if k > 50:
            errors.extend(error)
        observer.applied(0.0)
        x = integrators.step_states(x, 0.0, p, method="rk4")
    assert np.sqrt(np.mean(np.square(errors))) < 0.1


def test_observer_restarts_after_a_jump_and_refuses_bad_gains() -> None:
    observer = Observer(OLYMPICS.params)
    observer(HANGING)
    jumped = HANGING + np.array([1.0, 1.0, 0.5, 0.5])
    assert np.array_equal(observer(jumped), jumped)  # taken as it is, not a huge velocity
    with pytest.raises(ValueError, match="angle_gain"):
        Observer(OLYMPICS.params, angle_gain=2.0)


class Constant(Controller):
    def act(self, x: np.ndarray, t: float) -> float:
        return 1.5


def test_global_tester_resets_by_the_protocols_rule() -> None:
    """Before the first reset time the entry acts (shoulder 0); at it the PID with gravity
    compensation takes over for more than 0.2 s, then hands back; torques within +-6 N m."""
    targets = np.zeros((151, 4))
    targets[0, :2] = (np.pi, 0.0)  # to upright (protocol angles)
    tester = GlobalTester(Constant(), OLYMPICS, targets, np.array([1.0] + [70.0] * 14))
    state = HANGING.copy()
    assert tester.act(state, 0.998) == 1.5 and tester.shoulder == 0.0
    elbow = tester.act(state, 1.0)
    # The first PID call: P only (kp 10 x pi, clipped to 6) plus gravity compensation (0
    # hanging, to rounding: cos(-pi/2) is 6e-17).
    assert tester.shoulder == 6.0 and abs(elbow) < 1e-15
    t = 1.0
    while tester.resetting:
        t += 0.002
        tester.act(state, t)
    assert 1.2 < t <= 1.21  # more than reset_length, by one step
    assert tester.act(state, t + 0.002) == 1.5 and tester.shoulder == 0.0


def test_gravity_compensation_is_the_plants_gravity_torque() -> None:
    """At the protocol's theta = (pi/2, 0) (arm horizontal) the shoulder holds the whole arm:
    (m1 r1 + m2 l1 + m2 r2) g, the elbow m2 r2 g, by hand from the model's numbers."""
    tester = GlobalTester(Constant(), OLYMPICS, np.zeros((151, 4)), np.full(15, 70.0))
    p = OLYMPICS.params
    x = from_protocol(np.array([np.pi / 2, 0.0, 0.0, 0.0]))
    expected = [(p.m1 * p.lc1 + p.m2 * p.l1 + p.m2 * p.lc2) * p.g, p.m2 * p.lc2 * p.g]
    assert np.allclose(tester.gravity(x), expected, rtol=0, atol=1e-12)


def test_planned_swing_up_loads_and_is_exact() -> None:
    trajectory = planned_swing_up("ai_olympics")
    assert trajectory.steps == 1000 and trajectory.dt == 0.002 and trajectory.u_max == 6.0
    assert trajectory.residual() < 1e-9
    with pytest.raises(ValueError, match="no planned swing-up"):
        planned_swing_up("dm_control")
    assert planned_swing_up("report").steps == 476  # the control package's reserve plan


@pytest.mark.slow
def test_planning_reproduces_the_planned_swing_up() -> None:
    """The NLP from the model's parameters alone gives the shipped torques (IPOPT is
    deterministic; 1e-6 N m is far above its tolerance, far below any other optimum)."""
    planned = performance_swing_up(OLYMPICS, decisions=200, hold=5)
    assert np.abs(planned.torques - planned_swing_up("ai_olympics").torques).max() < 1e-6


def test_performance_episode_of_the_funnel() -> None:
    """The funnel entry's performance episode in MuJoCo: its v2 score (0.6882, above the
    leaderboard's best; MuJoCo and the planning model agree to 1e-10, so 1e-4 is loose
    for platforms yet would catch any change of controller or scoring). 0.68817 is confirmed
    by an independent implementation of the leaderboard's formula (leaderboard.py), which gives
    0.65527 to the digit on the leaderboard's own History SAC trajectory."""
    recording = episode(Source("funnel"), "ai_olympics", 10.0, Conditions(), 0)
    run = performance(recording, 0.2, 0.3)
    assert run["success"] and abs(run["score"] - 0.68817) < 1e-4
    assert run["score"] > leaderboard.PERFORMANCE.best()[1]
    assert math.isclose(run["swingup_time"], 1.254, abs_tol=1e-9)


def test_robustness_episode_under_velocity_noise() -> None:
    """The protocol's largest velocity noise (0.5 rad/s on both velocities): upright at the end."""
    conditions = Conditions(sensor={"sigma": (0.0, 0.0, 0.5, 0.5)})
    recording = episode(Source("funnel"), "ai_olympics", 10.0, conditions, 3)
    assert final_success(recording.X[-1])


def test_olympics_command_writes_the_record(tmp_path, capsys) -> None:
    out = tmp_path / "o"
    main(["olympics", "funnel", "--scores", "performance", "--out", str(out), "--no-progress"])
    record = json.loads((out / "olympics.json").read_text())
    assert record["performance"]["success"] is True
    assert abs(record["performance"]["score"] - 0.68817) < 1e-4
    assert record["model"] == {"name": "ai_olympics", "entry": "funnel"}  # no options given
    given = tmp_path / "given"
    argv = ["olympics", "funnel", "--option", "mpc=false", "--scores", "performance"]
    main([*argv, "--out", str(given), "--no-progress"])
    options = json.loads((given / "olympics.json").read_text())["model"]["options"]
    assert options == {"mpc": False}  # the record says which variant of the entry ran
    assert (out / "performance.png").is_file()
    assert "performance 0.688" in capsys.readouterr().out
    again = ["olympics", "funnel", "--scores", "global", "--out", str(out), "--no-progress"]
    before = (out / "olympics.json").read_bytes()
    with pytest.raises(SystemExit):
        main(again)
    assert "already holds olympics.json" in capsys.readouterr().err
    assert (out / "olympics.json").read_bytes() == before


def test_olympics_command_refuses_a_file_as_out(tmp_path, capsys) -> None:
    """Refused before any episode runs, the file untouched."""
    out = tmp_path / "o"
    out.write_text("mine")
    with pytest.raises(SystemExit):
        main(["olympics", "funnel", "--out", str(out), "--no-progress"])
    assert "exists and is not a folder" in capsys.readouterr().err
    assert out.read_text() == "mine"
    with pytest.raises(SystemExit):  # below a file: once refused only at the write
        main(["olympics", "funnel", "--out", str(out / "below"), "--no-progress"])
    assert f"{out} exists and is not a folder" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("argv", "match"),
    [
        (["olympics", "nobody", "--out", "x"], "neither an entry"),
        (["olympics", "", "--out", "x"], "must name a path"),  # once the current folder
        (["olympics", "funnel", "--scores", "speed", "--out", "x"], "--scores"),
        (["olympics", "funnel", "--model", "dm_control", "--out", "x"], "no planned swing-up"),
        (["olympics", "funnel", "--global-test", "april", "--out", "x"], "got 'april'"),
        (["olympics", "funnel", "--global-test", "icra2025:me", "--out", "x"], "got 'me'"),
        (
            ["olympics", "funnel", "--global-test", "icra2025:AR-EAPO", "--seeds", "2"]
            + ["--out", "x"],
            "is one draw: give no --seeds",
        ),
        (["olympics", "funnel", "--scores", "performance", "--seeds", "2", "--out", "x"], "global"),
        # Ray's options without Ray, local processes with it, and Ray where it cannot run.
        (
            ["olympics", "funnel", "--num-cpus", "2", "--out", "x"],
            "--num-cpus is for --backend ray",
        ),
        (
            ["olympics", "funnel", "--address", "auto", "--out", "x"],
            "--address is for --backend ray",
        ),
        (["olympics", "funnel", "--backend", "ray", "--jobs", "2", "--out", "x"], "--jobs is for"),
        (
            ["olympics", "funnel", "--backend", "ray", "--address", "auto", "--num-cpus", "2"]
            + ["--out", "x"],
            "--num-cpus sizes a local Ray instance: give no --address",
        ),
        # Nothing listens on port 1: refused at once, before any episode (Ray retries minutes).
        (
            ["olympics", "funnel", "--backend", "ray", "--address", "127.0.0.1:1", "--out", "x"],
            "no Ray cluster answers at 127.0.0.1:1",
        ),
    ],
)
def test_olympics_command_refuses_bad_input(argv, match, capsys) -> None:
    with pytest.raises(SystemExit):
        main(argv)
    err = capsys.readouterr().err.strip()
    assert match in err and "\n" not in err


def test_entries_refuse_a_model_they_are_not_set_for_or_a_bad_option() -> None:
    with pytest.raises(ValueError, match="replan entry is for ai_olympics"):
        entries.ENTRIES["replan"].build(equations("report"))  # its 0.1 rad jump is per 0.002 s step
    with pytest.raises(ValueError, match=r"unknown funnel entry settings \['horizon'\]"):
        entries.ENTRIES["funnel"].build(equations("report"), {"horizon": 3})
    with pytest.raises(ValueError, match="config mpc must be True or False"):
        entries.ENTRIES["funnel"].build(equations("report"), {"mpc": "yes"})


def tracker_of(controller: Controller) -> PlanTracker:
    """The tracker inside an entry's estimator."""
    assert isinstance(controller, Estimated) and isinstance(controller.controller, PlanTracker)
    return controller.controller


def test_the_mpc_option_balances_with_the_constrained_lqr() -> None:
    """``funnel`` with ``mpc`` takes the constrained LQR at upright: 250 steps (0.5 s) on
    ai_olympics, the feedback's 40 elsewhere; its swing-up episode is funnel's to the bit (the
    plan is the same, and its balancer's first torque where it saturates is the clipped LQR's)."""
    from acrobot_mj.control.lqr import MPC

    funnel = entries.ENTRIES["funnel"]
    for model, horizon in (("ai_olympics", entries.MPC_HORIZON), ("report", 40)):
        balancer = tracker_of(funnel.build(equations(model), {"mpc": True})).balancer
        assert isinstance(balancer, MPC) and balancer.horizon == horizon
    assert not isinstance(tracker_of(funnel.build(equations("ai_olympics"))).balancer, MPC)
    mpc, plain = Source("funnel", {"mpc": True}), Source("funnel")
    ours, theirs = (episode(e, "ai_olympics", 10.0, Conditions(), 0) for e in (mpc, plain))
    assert np.array_equal(ours.U, theirs.U)


def test_the_funnel_entry_pumps_energy_only_on_ai_olympics() -> None:
    """Away from its funnel (the arm out level, the elbow turning at 2 rad/s, below upright's
    energy) the ``funnel`` entry pumps energy on ai_olympics (its torque along the elbow's
    velocity) and removes it on the report's acrobot (against it), where pumping kept the arm
    whirling (:data:`~acrobot_mj.olympics.entries.PUMPING_ON`)."""
    x = np.array([0.0, 0.0, 0.0, 2.0])
    for model, sign in (("ai_olympics", 1.0), ("report", -1.0)):
        funnel = tracker_of(entries.ENTRIES["funnel"].build(equations(model)))
        assert sign * funnel.act(x, 0.0) * x[3] > 0.0, model
        assert funnel.mode == "fallback"


def test_the_global_score_of_several_seeds_is_their_mean_with_a_t_interval() -> None:
    """Three seeds of a short global test (4 s, 3 resets), over two processes: each seed's
    uptime is that of its own episode run alone, the score their mean, the interval
    mean +- t(0.975, 2) s / sqrt(3) with t = 4.302652729749 (a printed t table)."""
    short = replace(GLOBAL, t_final=4.0, resets=3)
    rules = replace(protocol_for("ai_olympics"), global_policy=short)
    run = OlympicsRun(Constant(), parts=("global",), seed=3, jobs=2, protocol=rules, global_seeds=3)
    whole = olympics_record(run.run())
    record = whole["global"]
    alone = [
        uptime(global_episode(Constant(), "ai_olympics", s, short)[0], 0.2, 0.3, 4.0)
        for s in (3, 4, 5)
    ]
    assert [s["seed"] for s in record["seeds"]] == [3, 4, 5]
    assert whole["scaling"]["constants"]["global"]["version"] == "current"
    assert [s["uptime"] for s in record["seeds"]] == [a["uptime"] for a in alone]
    values = np.array([a["score"] for a in alone])
    assert len(set(values)) == 3  # three different episodes
    assert record["score"] == pytest.approx(values.mean(), abs=1e-15)
    half = 4.302652729749 * values.std(ddof=1) / math.sqrt(3)
    assert record["interval"] == pytest.approx([values.mean() - half, values.mean() + half])
    assert record["episode"]["disturbance"]["reset_times"] == pytest.approx(
        short.draw(3)[1].tolist()
    )
    with pytest.raises(ValueError, match="global_seeds=2 needs the global score"):
        score(Constant(), scores=("performance",), global_seeds=2)
    with pytest.raises(ValueError, match=r"global_seeds must be in \[1, 10000\], got 0"):
        OlympicsRun(Constant(), global_seeds=0)


def test_a_run_refuses_bad_jobs_and_a_ray_where_nothing_listens() -> None:
    with pytest.raises(ValueError, match="jobs must be >= 1, got 0"):
        OlympicsRun(Constant(), jobs=0)
    with pytest.raises(ValueError, match="num_cpus must be >= 1, got 0"):
        Ray(num_cpus=0)
    with pytest.raises(ConnectionError, match=r"no Ray cluster answers at 127\.0\.0\.1:1"):
        score(Constant(), scores=("performance",), jobs=Ray("127.0.0.1:1"))


@pytest.mark.slow  # about 30 s on 2 busy cores: a local Ray starting, then 55 short episodes
def test_the_episodes_on_a_local_ray_give_the_local_pools_record_to_the_byte(tmp_path) -> None:
    """Every part (the funnel; the protocol's rules with a swing-up of 2 s, robustness episodes
    of 10 steps, global episodes of 4 s of two seeds) on two local processes, then on a local
    Ray of one CPU: olympics.json is the same to the byte (each episode's numbers come from
    its seed alone, and the records go back in their order). Ray listened on 127.0.0.1 only."""
    if importlib.util.find_spec("ray") is None:
        pytest.skip("needs the ray extra")
    swing_up, short = replace(PERFORMANCE, t_final=2.0), replace(GLOBAL, t_final=4.0, resets=3)
    rules = replace(tiny_rules(), performance=swing_up, global_policy=short)
    pooled = OlympicsRun("funnel", jobs=2, protocol=rules, global_seeds=2).run()
    pool = write_olympics(tmp_path / "pool", pooled).read_bytes()
    on_ray = OlympicsRun("funnel", jobs=Ray(num_cpus=1), protocol=rules, global_seeds=2)
    before, seen, finished = listening(), set(), threading.Event()

    def watch() -> None:
        while not finished.is_set():
            seen.update(listening() - before)
            time.sleep(0.05)

    watcher = threading.Thread(target=watch)
    watcher.start()
    try:
        ray = write_olympics(tmp_path / "ray", on_ray.run()).read_bytes()
    finally:
        finished.set()
        watcher.join()
    assert ray == pool
    record = json.loads(ray)
    assert record["performance"]["success"] and len(record["global"]["seeds"]) == 2
    categories = record["robustness"]["categories"]
    episodes = [
        e for c in categories for s in c["sweeps"] for level in s["episodes"] for e in level
    ]
    assert len(episodes) == 50  # 30 + 6 + 6 + 3 + 3 + 2, as tiny_rules makes them
    # Ray's servers (GCS, raylet, workers) listened, on 127.0.0.1 only.
    assert seen and all(address.startswith(LOOPBACK) for address in seen), seen


@pytest.mark.slow  # about 10 s: a local Ray starting, then one performance episode
def test_the_olympics_command_on_a_local_ray(tmp_path, capsys) -> None:
    """``--backend ray --num-cpus 1``: the record of the command run here, to the byte."""
    if importlib.util.find_spec("ray") is None:
        pytest.skip("needs the ray extra")
    command = ["olympics", "funnel", "--scores", "performance", "--no-progress"]
    main([*command, "--out", str(tmp_path / "here")])
    main([*command, "--backend", "ray", "--num-cpus", "1", "--out", str(tmp_path / "ray")])
    here, ray = ((tmp_path / d / RECORD_FILE).read_bytes() for d in ("here", "ray"))
    assert ray == here
    assert capsys.readouterr().out.count("performance 0.688") == 2
