"""Sarsa(lambda) has one source, compiled by numba (:mod:`acrobot_mj.compiled`) and run as the
plain Python it is written in where numba cannot load: the compiled learner against that same
source run uncompiled, the same numbers bit for bit, from its kernels up to short runs of the
book and tuned presets (the full runs against the golden records: ``test_golden.py``); and the
compiled learner's own machinery: the checkpoint state rebuilt mid-episode, resume, divergence."""

from __future__ import annotations

import inspect
import os
import signal
import sys

import gymnasium as gym
import numpy as np
import pytest

from acrobot_mj import compiled as compilation
from acrobot_mj.agents import DivergenceError, sarsa, sarsa_lambda
from acrobot_mj.agents.base import Learning
from acrobot_mj.agents.features import StateGrid, tile_active
from acrobot_mj.compiled import compiled
from acrobot_mj.envs import identified
from acrobot_mj.envs.identified import IdentifiedEnv
from acrobot_mj.envs.rollout import run_episode
from acrobot_mj.envs.spaces import observation_space
from acrobot_mj.physics.integrators import Stepping, step_one
from acrobot_mj.physics.params import AcrobotParams
from acrobot_mj.train.checkpoint import load_checkpoint
from acrobot_mj.train.learners import make_env
from acrobot_mj.train.presets import PRESETS
from acrobot_mj.train.run import Run, RunOptions
from acrobot_mj.train.trainer import learner_for, train

BOOK = PRESETS["book"]
SPACE = observation_space()
RECORD_KEYS = ("episode_lengths", "episode_returns", "greedy_from_rest", "steps")


def uncompiled(function, *args, **kwargs):
    """What :func:`acrobot_mj.compiled.compiled` gives where numba cannot load: the function."""
    return function


def make_agent(config, seed):
    return config.make_agent(seed, SPACE)


def learn_episode(env, agent, seed):
    return run_episode(env, Learning(agent), seed)


def test_the_pairwise_sum_is_numpys_own() -> None:
    rng = np.random.default_rng(0)
    fast = compiled(sarsa_lambda.pairwise_sum)
    assert fast is not sarsa_lambda.pairwise_sum  # numba's, here
    for n in [*range(1, 20), 47, 48, 49, 100, 128]:
        for trial in range(200):
            # Magnitudes spread over ten decades: any other order of the additions rounds
            # differently, so equality means numpy's order.
            values = rng.standard_normal(n) * 10.0 ** rng.uniform(-5, 5, n)
            assert fast(values, n) == values.sum(), n
            rows = rng.standard_normal((3, n)) * 10.0 ** rng.uniform(-5, 5, (3, n))
            sums = rows.sum(axis=1)  # what numpy's Q(s, .) would be
            assert [fast(r.copy(), n) for r in rows] == sums.tolist()
            if trial % 10 == 0:  # the Python source too (slower)
                assert sarsa_lambda.pairwise_sum(values, n) == values.sum(), n


def test_the_compiled_tile_coding_is_the_python_one() -> None:
    coder = BOOK.encoding.build(SPACE)
    rng = np.random.default_rng(1)
    out = np.zeros(coder.num_active, dtype=np.int64)
    for _ in range(2000):  # angles beyond +-pi and velocities beyond the limits included
        obs = rng.uniform([-7, -7, -20, -40], [7, 7, 20, 40])
        tile_active(obs, *coder.tables, out)  # the source, as Python
        np.testing.assert_array_equal(out, coder.active(obs))  # compiled


def run_both(config, seed, tmp_path, monkeypatch):
    """``config`` trained with the compiled learner, then with its kernels run as Python: each
    run's record and trained agent, Python's first."""
    runs = {}
    for name in ("compiled", "python"):
        if name == "python":
            monkeypatch.setattr(sarsa_lambda, "compiled", uncompiled)
        learner = learner_for(config, seed)
        runs[name] = (learner.learn(Run(tmp_path / name)), learner.agent)
    assert runs["python"][1]._decide is sarsa_lambda.decide  # the plain Python function
    assert runs["compiled"][1]._decide is not sarsa_lambda.decide
    return runs["python"], runs["compiled"]


def assert_same_runs(ref, ref_agent, fast, fast_agent, keys=RECORD_KEYS) -> None:
    for key in keys:
        assert fast[key] == ref[key], key
    # Bit for bit, not to rounding: the same source, the same operations in the same order.
    assert np.array_equal(fast_agent.w, ref_agent.w)
    state, ref_state = fast_agent.state_dict(), ref_agent.state_dict()
    assert state.keys() == ref_state.keys()
    for key in state:
        assert np.array_equal(state[key], ref_state[key]), key


@pytest.mark.parametrize(
    "config",
    [
        # The book's learner: ties at zero weights (a draw breaks them), goals (the terminal
        # update), greedy decisions without a draw.
        BOOK.replace(episodes=2),
        # Accumulating traces with no cutoff and exploration: every trace lives to the
        # episode's end (the trace arrays grow past their first room), and draws every
        # decision; truncated episodes.
        BOOK.replace(
            traces="accumulating", trace_cutoff=0.0, epsilon=0.1, episodes=3, max_episode_steps=300
        ),
        # Accumulating traces with epsilon 0.
        BOOK.replace(traces="accumulating", episodes=3, max_episode_steps=200),
    ],
    ids=["book", "accumulating-no-cutoff-exploring", "accumulating"],
)
def test_a_run_is_the_same_compiled_and_uncompiled(config, tmp_path, monkeypatch) -> None:
    (ref, ref_agent), (fast, fast_agent) = run_both(config, 1, tmp_path, monkeypatch)
    assert_same_runs(ref, ref_agent, fast, fast_agent)
    if config.trace_cutoff == 0.0:  # the trace arrays grew past their first room, both ways
        assert ref_agent._pairs.size == fast_agent._pairs.size > 64 * 48
    if config.max_episode_steps == 1000:
        assert all(fast["episode_successes"])  # the goal's terminal updates ran


def test_the_learners_call_their_kernels_without_dispatch_after_the_first() -> None:
    # Both learners pin their kernel's machine code after the first decision (the golden runs
    # and the comparisons above hold the numbers); a plain function stays itself.
    env = make_env(BOOK)
    tiles = BOOK.make_agent(0, env.observation_space)
    grid = PRESETS["report"].make_agent(0, env.observation_space)
    for agent in (tiles, grid):
        run_episode(env, Learning(agent), 0, max_steps=5)
    for pinned, kernel in (
        (tiles._decide_tiles, sarsa_lambda.decide_tiles),
        (grid._learn, sarsa.sarsa_learn),
    ):
        assert not inspect.ismethod(pinned) and pinned is not compiled(kernel)
    assert compilation.without_dispatch(sarsa.sarsa_step, ()) is sarsa.sarsa_step
    kernel = compiled(sarsa.sarsa_step)
    args = (
        np.arange(6.0).reshape(2, 3),
        0,
        1,
        -1.0,
        1,
        False,
        (0.5, 1.0, 0.1),
        np.full(4, 0.05),
        0,
    )
    python = sarsa.sarsa_step(*[x.copy() if isinstance(x, np.ndarray) else x for x in args])
    assert kernel(*args) == python == compilation.without_dispatch(kernel, args)(*args)


@pytest.mark.slow
def test_a_model_based_population_is_the_same_compiled_and_uncompiled(
    tmp_path, monkeypatch
) -> None:
    small = PRESETS["tuned"].replace(identify_decisions=300, population=2, max_decisions=2000)
    (ref, ref_agent), (fast, fast_agent) = run_both(small, 5, tmp_path, monkeypatch)
    keys = ("episode_lengths", "greedy_from_rest", "population", "model")
    assert_same_runs(ref, ref_agent, fast, fast_agent, keys)


def test_the_package_runs_uncompiled_where_numba_cannot_load(monkeypatch, capsys) -> None:
    config = BOOK.replace(episodes=2, max_episode_steps=300)
    fast = train(config, 3)
    monkeypatch.setitem(sys.modules, "numba", None)  # `import numba` fails
    monkeypatch.setattr(compilation, "_NUMBA", None)
    monkeypatch.setattr(compilation, "_COMPILED", {})
    assert compiled(sarsa_lambda.decide) is sarsa_lambda.decide
    assert "numba cannot load" in capsys.readouterr().err  # said once, on stderr
    slow = train(config, 3)
    for key in RECORD_KEYS:
        assert slow[key] == fast[key], key


def test_the_kernel_setting_is_retired() -> None:
    # There is one Sarsa(lambda), always compiled: asking for a kernel is refused in one line
    # as an unknown setting; the compiled learner takes the grid as well as tiles.
    for kernel in ("numba", "numpy"):
        with pytest.raises(ValueError, match=r"unknown config keys \['kernel'\]") as no:
            BOOK.replace(kernel=kernel)
        assert len(str(no.value).splitlines()) == 1
    agent = make_agent(BOOK.replace(features="grid"), seed=0)
    assert isinstance(agent.features, StateGrid) and agent._decide is not sarsa_lambda.decide


def test_both_paths_of_a_decision_are_taken(monkeypatch) -> None:
    # A greedy decision draws from the stream only to break a tie (all weights start at 0); in a
    # book run both kinds occur (the runs above check that their numbers are the source's).
    agent = make_agent(BOOK, seed=0)
    stream, learn, drew = agent.stream, agent.learn, []

    def counted(*args):
        block, position = stream.block, stream.position
        action = learn(*args)
        # A new block starts with the old one's unread draws: then every draw is its position.
        drew.append(stream.position - (position if stream.block is block else 0))
        return action

    monkeypatch.setattr(agent, "learn", counted)
    env = make_env(BOOK)
    for episode in range(20):
        learn_episode(env, agent, seed=episode)
    assert set(drew) == {0, 1}  # some decisions drew (ties), some did not, none drew twice


def test_the_compiled_model_step_is_the_python_one(monkeypatch) -> None:
    theta = AcrobotParams().lumped
    task = make_env(BOOK).unwrapped.task
    book_step = Stepping(substeps=4)
    fast_env = IdentifiedEnv(theta, task, book_step, 1000)
    monkeypatch.setattr(identified, "compiled", uncompiled)
    python_env = IdentifiedEnv(theta, task, book_step, 1000)
    assert python_env._step is step_one and fast_env._step is not step_one
    envs = [python_env, fast_env]
    rng = np.random.default_rng(2)
    fast = {"state": np.array([0.3, -0.2, 12.56, 28.27])}  # just below both velocity limits
    for env in envs:
        env.reset(options=fast)
    clipped = 0
    for t in range(3000):  # through goals and resets
        action = int(rng.integers(3))
        results = [env.step(action) for env in envs]
        # Bit for bit: the same floats through the same operations (libm's cos and sin).
        assert envs[0].state.tolist() == envs[1].state.tolist(), t
        assert results[0][1:4] == results[1][1:4]
        v1, v2 = np.abs(envs[0].state[2:])
        clipped += v1 == book_step.max_vel[0] or v2 == book_step.max_vel[1]
        if results[0][2] or results[0][3] or t % 200 == 0:
            for env in envs:
                env.reset(options=fast)
    assert clipped > 0  # the clipping was exercised


def random_decision(rng, n_features: int = 200, n_actions: int = 3):
    """Arguments of :func:`sarsa_lambda.decide` for a random learner mid-episode: weights over
    ten decades (ties sometimes, a non-finite one sometimes), live traces (NaN sometimes),
    every cutoff and flag."""
    size, k = n_actions * n_features, int(rng.integers(1, 49))
    w = rng.standard_normal(size) * 10.0 ** rng.uniform(-5, 5, size)
    if rng.random() < 0.3:
        w[: 2 * n_features] = 0.0  # ties between actions 0 and 1
    a = int(rng.integers(n_actions))
    active = np.sort(rng.choice(n_features, k, replace=False)).astype(np.int64)
    if rng.random() < 0.05:
        w[a * n_features + active[0]] = rng.choice([np.inf, np.nan])  # a non-finite TD error
    following = rng.choice(n_features, k, replace=False).astype(np.int64)
    n = int(rng.integers(0, 200))
    room = n + k + 8
    pairs = np.zeros(room, dtype=np.int64)
    pairs[:n] = rng.choice(size, n, replace=False)
    values = np.zeros(room)
    values[:n] = rng.uniform(0, 3, n) * 10.0 ** rng.uniform(-4, 0, n)
    if n and rng.random() < 0.15:
        values[rng.integers(n)] = np.nan
    place = np.full(size, -1, dtype=np.int64)
    place[pairs[:n]] = np.arange(n)
    logging = rng.random() < 0.5
    undo = (np.zeros(room if logging else 0, dtype=np.int64), np.zeros(room if logging else 0))
    ending = int(rng.integers(3))  # 0: goes on, 1: terminated, 2: truncated
    outcome = (float(rng.standard_normal() * 100), ending == 1, ending == 2)
    factor, cutoff = float(rng.uniform(0, 1)), float(rng.choice([0.0, 1e-3, 0.05, 0.5]))
    epsilon = float(rng.choice([0.0, 0.3]))
    settings = (
        float(rng.uniform(0, 1)),
        float(rng.uniform(0, 1)),
        factor,
        cutoff,
        epsilon,
        n_features,
        bool(rng.random() < 0.5),
    )
    stream = (rng.random(8), int(rng.integers(0, 6)))
    scratch = (np.zeros(k), np.zeros(n_actions))
    return (
        w,
        a,
        active,
        following,
        outcome,
        (pairs, values, place, *undo),
        (n, 0),
        settings,
        stream,
        scratch,
    )


@pytest.mark.parametrize("method", ["rk4", "semi_implicit_euler", "explicit_euler"])
def test_one_state_steps_as_the_batch_does(method) -> None:
    """``step_states`` of one state takes the compiled ``step_one``: the numbers of the numpy
    path that steps many, bit for bit, limits on and off, several substeps, NaN kept."""
    from acrobot_mj.physics.integrators import step_states
    from acrobot_mj.physics.models import resolve

    p = resolve("ai_olympics").params
    rng = np.random.default_rng(5)
    states = rng.uniform(-40.0, 40.0, (500, 4))  # past the velocity limits too
    torques = rng.uniform(-6.0, 6.0, 500)
    for limits in (True, False):
        batch = step_states(states, torques, p, 3, method, limits)
        for x, u, expected in zip(states, torques, batch, strict=True):
            assert step_states(x, u, p, 3, method, limits).tolist() == expected.tolist()
    bad = np.array([[0.0, np.nan, 0.0, 0.0]])  # a NaN spreads as it does in the batch
    one = step_states(bad[0], 0.0, p, method=method)
    assert np.isnan(one).any()
    np.testing.assert_array_equal(one, step_states(bad, np.zeros(1), p, method=method)[0])


def test_the_compiled_decision_is_the_python_one() -> None:
    # One Sarsa(lambda) decision (the TD error, the traces marked, the policy's draws, the
    # update and decay with every cutoff branch) compiled and as Python: the same result and
    # the same arrays byte for byte.
    fast = compiled(sarsa_lambda.decide)
    rng = np.random.default_rng(0)
    diverged = 0
    for trial in range(1000):
        args = random_decision(rng)
        copies = []
        for _ in range(2):
            copy = [np.copy(x) if isinstance(x, np.ndarray) else x for x in args]
            for i in (5, 8, 9):  # tuples of arrays
                copy[i] = tuple(np.copy(x) if isinstance(x, np.ndarray) else x for x in args[i])
            copies.append(copy)
        with np.errstate(invalid="ignore", over="ignore"):  # non-finite numbers on purpose
            a = sarsa_lambda.decide(*copies[0])
        b = fast(*copies[1])
        assert np.array_equal(np.array(a, float), np.array(b, float), equal_nan=True), trial
        diverged += a[0] == -2
        for x, y in zip(
            [copies[0][0], *copies[0][5], *copies[0][9]],
            [copies[1][0], *copies[1][5], *copies[1][9]],
            strict=True,
        ):
            assert x.tobytes() == y.tobytes(), trial
    assert 0 < diverged < 1000  # the non-finite TD error's way out was taken too


def partial_episode(env, agent, seed: int, decisions: int) -> None:
    """Begin an episode and learn ``decisions`` of it (the episode stays in progress)."""
    obs, _ = env.reset(seed=seed)
    action = agent.begin_episode(obs)
    for _ in range(decisions):
        obs, reward, terminated, truncated, _ = env.step(action)
        action = agent.learn(reward, obs, terminated, truncated)
        assert action is not None, "the episode ended: give fewer decisions"


def test_the_checkpoint_state_mid_episode_is_the_state_after_the_last_episode() -> None:
    # The compiled learner rebuilds a checkpoint's state from the weights the episode in
    # progress changed (the log decide keeps), instead of a copy after every episode. Exact:
    # compared with copies taken when the episode began.
    config = BOOK.replace(epsilon=0.05)  # draws: the stream moves too
    env, agent = make_env(config), make_agent(config, seed=2)
    unwatched = make_agent(config, seed=2)
    learn_episode(make_env(config), unwatched, seed=0)
    assert unwatched._undo[0].size == 0  # no log is kept until a checkpoint's state is asked for
    state = agent.checkpoint_state()
    room = agent._undo[0].size
    # The first episode from zero weights is long: 600 decisions log far more than the
    # log's first room, so it must grow (and keep its entries).
    partial_episode(env, agent, 0, 600)
    assert agent._undo[0].size > room
    rewound = state()
    assert not np.array_equal(agent.w, rewound["w"]) and not rewound["w"].any()
    for episode in range(1, 4):
        learn_episode(env, agent, seed=episode)
    before, state = agent.state_dict(), agent.checkpoint_state()
    assert all(np.array_equal(state()[k], before[k]) for k in before)  # between episodes
    partial_episode(env, agent, 9, 40)
    after = state()
    assert after.keys() == before.keys()
    for key in before:
        assert np.array_equal(after[key], before[key]), key
    assert not np.array_equal(agent.w, before["w"])  # the episode did change weights
    with pytest.raises(RuntimeError, match="between episodes"):
        agent.checkpoint_state()  # mid-episode: there is no state to promise
    partial_episode(env, agent, 10, 5)  # a second episode begun: that state is gone
    with pytest.raises(RuntimeError, match="after the next two had begun"):
        state()
    fresh = make_agent(config, seed=2)
    state = fresh.checkpoint_state()
    fresh.load_state_dict(agent.state_dict())  # a load: the state before it is gone too
    with pytest.raises(RuntimeError, match="after the next two had begun"):
        state()


@pytest.mark.parametrize(
    "changes",
    [{"traces": "accumulating"}, {"trace_cutoff": 0.0}, {"trace_cutoff": 0.3, "epsilon": 0.1}],
)
def test_the_rewind_is_exact_for_other_traces(changes) -> None:
    config = BOOK.replace(**changes)
    env, agent = make_env(config), make_agent(config, seed=3)
    for episode in range(2):
        learn_episode(env, agent, seed=episode)
    before, state = agent.state_dict(), agent.checkpoint_state()
    partial_episode(env, agent, 5, 120)
    after = state()
    assert all(np.array_equal(after[k], before[k]) for k in before)


class StopAtDecision(gym.Wrapper):
    """Ctrl-C in the middle of the ``n``-th decision of the run."""

    def __init__(self, env, n: int) -> None:
        super().__init__(env)
        self.n = n

    def step(self, action):
        self.n -= 1
        if self.n == 0:
            raise KeyboardInterrupt
        return self.env.step(action)


def test_a_compiled_run_stopped_mid_episode_resumes_to_the_same_run(tmp_path) -> None:
    config = BOOK.replace(episodes=12, checkpoint_every=1000)
    whole = train(config, 6, tmp_path / "whole")
    stopped = StopAtDecision(make_env(config), sum(whole["episode_lengths"][:7]) + 30)
    with pytest.raises(KeyboardInterrupt):
        train(config, 6, tmp_path / "split", env=stopped)
    meta, arrays = load_checkpoint(tmp_path / "split" / "checkpoint.npz")
    assert meta["episodes_done"] == 7  # stopped 30 decisions into the 8th episode
    train(config.replace(episodes=7), 6, tmp_path / "seven")
    seven = load_checkpoint(tmp_path / "seven" / "checkpoint.npz")[1]
    assert all(np.array_equal(arrays[k], seven[k]) for k in seven)  # the rewound state
    resumed = train(config, 6, tmp_path / "split", options=RunOptions(resume=True))
    for key in ("episode_lengths", "episode_returns", "greedy_from_rest", "steps"):
        assert resumed[key] == whole[key], key
    a = load_checkpoint(tmp_path / "whole" / "checkpoint.npz")[1]
    b = load_checkpoint(tmp_path / "split" / "checkpoint.npz")[1]
    assert all(np.array_equal(a[k], b[k]) for k in a)


class SignalAtDecision(gym.Wrapper):
    """A real SIGINT sent during the ``n``-th decision of the run; counts the decisions after."""

    def __init__(self, env, n: int) -> None:
        super().__init__(env)
        self.n, self.after = n, 0

    def step(self, action):
        self.n -= 1
        if self.n == 0:
            os.kill(os.getpid(), signal.SIGINT)
        if self.n < 0:
            self.after += 1
        return self.env.step(action)


def test_a_stop_inside_a_long_episode_cuts_it_at_the_next_step(tmp_path) -> None:
    # The stop is held while an update runs and acted on after the step it arrived in: before,
    # it waited for the episode's end (up to max_episode_steps, 1e6 decisions). The cut episode
    # is not recorded; the run resumes to the uninterrupted one.
    config = BOOK.replace(episodes=3, checkpoint_every=1000)
    whole = train(config, 6, tmp_path / "whole")
    lengths = whole["episode_lengths"]
    assert lengths[1] > 100  # a decision 50 steps into the second episode
    stopped = SignalAtDecision(make_env(config), lengths[0] + 50)
    before = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(KeyboardInterrupt, match="after 1 episodes"):
            train(config, 6, tmp_path / "split", env=stopped)
    finally:
        signal.signal(signal.SIGINT, before)
    assert stopped.after == 0  # no decision taken after the one the signal came in
    meta, _ = load_checkpoint(tmp_path / "split" / "checkpoint.npz")
    assert meta["episodes_done"] == 1
    resumed = train(config, 6, tmp_path / "split", options=RunOptions(resume=True))
    for key in ("episode_lengths", "episode_returns", "greedy_from_rest", "steps"):
        assert resumed[key] == whole[key], key


def test_a_diverging_compiled_learner_checkpoints_its_last_finite_state(
    tmp_path, monkeypatch
) -> None:
    # The divergence is found mid-episode, after weights have overflowed: the checkpoint is
    # rewound to the end of the last finite episode (loading refuses non-finite weights), the
    # state a run of that many episodes ends with (by the uncompiled source).
    config = BOOK.replace(alpha=0.2)
    with pytest.raises(DivergenceError, match="diverged in episode"):
        train(config, 0, tmp_path)
    meta, arrays = load_checkpoint(tmp_path / "checkpoint.npz")
    assert np.isfinite(arrays["w"]).all() and arrays["w"].any()
    done = meta["episodes_done"]
    assert done >= 1
    monkeypatch.setattr(sarsa_lambda, "compiled", uncompiled)
    reference = train(config.replace(episodes=done), 0, tmp_path / "python")
    assert reference["episodes_done"] == done
    ref = load_checkpoint(tmp_path / "python" / "checkpoint.npz")[1]
    assert all(np.array_equal(arrays[k], ref[k]) for k in ref)
