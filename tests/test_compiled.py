"""The compiled Sarsa(lambda) (``kernel = "numba"``) against the numpy reference: the same
numbers, bit for bit, from its kernels up to full runs of the book and tuned presets."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("numba", reason="the compiled learner needs numba (the fast extra)")

from acrobot_mj.agents import kernels
from acrobot_mj.agents.protocol import DivergenceError
from acrobot_mj.agents.registry import make_agent
from acrobot_mj.agents.sarsa_lambda_jit import CompiledSarsaLambda
from acrobot_mj.train.checkpoint import load_checkpoint
from acrobot_mj.train.episodes import learn_episode, make_env
from acrobot_mj.train.presets import PRESETS
from acrobot_mj.train.rundir import load_agent
from acrobot_mj.train.trainer import train

BOOK = PRESETS["book"]


def test_the_pairwise_sum_is_numpys_own() -> None:
    rng = np.random.default_rng(0)
    for n in [*range(1, 20), 47, 48, 49, 100, 128]:
        for _ in range(200):
            # Magnitudes spread over ten decades: any other order of the additions rounds
            # differently, so equality means numpy's order.
            values = rng.standard_normal(n) * 10.0 ** rng.uniform(-5, 5, n)
            assert kernels.pairwise_sum(values, n) == values.sum(), n
            rows = rng.standard_normal((3, n)) * 10.0 ** rng.uniform(-5, 5, (3, n))
            sums = rows.sum(axis=1)  # what the numpy learner's Q(s, .) does
            assert [kernels.pairwise_sum(r.copy(), n) for r in rows] == sums.tolist()


def test_the_compiled_tile_coding_is_the_tile_coders() -> None:
    agent = make_agent(BOOK.replace(kernel="numba"), seed=0)
    rng = np.random.default_rng(1)
    out = np.zeros(agent.features.num_active, dtype=np.int64)
    for _ in range(2000):  # angles beyond +-pi and velocities beyond the limits included
        obs = rng.uniform([-7, -7, -20, -40], [7, 7, 20, 40])
        kernels.tile_active(obs, *agent._tiles, out)
        np.testing.assert_array_equal(out, agent.features.active(obs))


def run_both(config, seed, tmp_path):
    runs = {}
    for kernel in ("numpy", "numba"):
        record = train(config.replace(kernel=kernel), seed, tmp_path / kernel)
        runs[kernel] = (record, load_agent(tmp_path / kernel)[2])
    return runs["numpy"], runs["numba"]


def test_a_book_run_is_the_same_through_both(tmp_path) -> None:
    (ref, ref_agent), (fast, fast_agent) = run_both(BOOK, 3, tmp_path)
    assert isinstance(fast_agent, CompiledSarsaLambda)
    for key in ("episode_lengths", "episode_returns", "greedy_from_rest", "steps"):
        assert fast[key] == ref[key], key
    # Bit for bit, not to rounding: the kernels add in numpy's order (see kernels.py).
    assert np.array_equal(fast_agent.w, ref_agent.w)
    state, ref_state = fast_agent.state_dict(), ref_agent.state_dict()
    assert state.keys() == ref_state.keys()
    for key in state:
        assert np.array_equal(state[key], ref_state[key]), key


def test_a_model_based_population_is_the_same_through_both(tmp_path) -> None:
    small = PRESETS["tuned"].replace(identify_decisions=300, population=2, max_decisions=8000)
    (ref, ref_agent), (fast, fast_agent) = run_both(small, 5, tmp_path)
    for key in ("episode_lengths", "greedy_from_rest", "population", "model"):
        assert fast[key] == ref[key], key
    assert np.array_equal(fast_agent.w, ref_agent.w)


def test_accumulating_traces_and_no_cutoff_are_the_same_through_both(tmp_path) -> None:
    # Without a cutoff every trace lives to the episode's end: the trace arrays must grow past
    # their first room (64 x 48 traces) to hold them.
    config = BOOK.replace(traces="accumulating", trace_cutoff=0.0, epsilon=0.1, episodes=20)
    (ref, ref_agent), (fast, fast_agent) = run_both(config, 1, tmp_path)
    assert fast["episode_lengths"] == ref["episode_lengths"]
    agent = make_agent(config.replace(kernel="numba"), seed=1)
    learn_episode(make_env(config), agent, seed=0)  # the first episode: long, weights all 0
    assert agent._pairs.size > 64 * 48  # it grew
    assert np.array_equal(fast_agent.w, ref_agent.w)


def test_the_compiled_kernel_needs_tiles() -> None:
    with pytest.raises(ValueError, match="kernel 'numba' needs features 'tiles'"):
        BOOK.replace(features="grid", kernel="numba")
    with pytest.raises(ValueError, match="kernel must be one of"):
        BOOK.replace(kernel="cuda")


def test_both_paths_of_a_decision_are_taken_and_agree(tmp_path, monkeypatch) -> None:
    # The one-call path (no draw) and the Python-finished path (a tie: all weights start at 0)
    # both occur in a book run (the tests above check that the numbers are numpy's).
    outcomes = []
    fused = kernels.greedy_step

    def counted(*args):
        result = fused(*args)
        outcomes.append(result[0] >= 0)
        return result

    monkeypatch.setattr(kernels, "greedy_step", counted)
    train(BOOK.replace(kernel="numba", episodes=20), 0)
    assert any(outcomes) and not all(outcomes)


def test_the_compiled_model_step_is_the_python_one() -> None:
    from acrobot_mj.control.identification import BOOK_STEP, lumped
    from acrobot_mj.envs.model_env import ModelEnv
    from acrobot_mj.physics.params import AcrobotParams

    theta = lumped(AcrobotParams())
    task = make_env(BOOK).unwrapped.task
    envs = [ModelEnv(theta, task, BOOK_STEP, 1000, compiled) for compiled in (False, True)]
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
        clipped += v1 == BOOK_STEP.max_vel1 or v2 == BOOK_STEP.max_vel2
        if results[0][2] or results[0][3] or t % 200 == 0:
            for env in envs:
                env.reset(options=fast)
    assert clipped > 0  # the clipping was exercised


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
    # progress changed (kernels.mark's log), instead of a copy after every episode. Exact:
    # compared with copies taken when the episode began.
    config = BOOK.replace(kernel="numba", epsilon=0.05)  # draws: the stream moves too
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


def test_the_fused_update_and_decay_is_update_then_decay() -> None:
    # kernels.update_decay must give update's weights and decay's traces byte for byte: random
    # weights over ten decades, NaN traces, every cutoff branch (0 keeps every trace).
    rng = np.random.default_rng(0)
    for trial in range(3000):
        size, n = 500, int(rng.integers(0, 200))
        pairs = rng.choice(size, n, replace=False).astype(np.int64)
        values = rng.uniform(0, 3, n) * 10.0 ** rng.uniform(-4, 0, n)
        if trial % 7 == 0 and n:
            values[rng.integers(n)] = np.nan
        position = np.full(size, -1, np.int64)
        position[pairs] = np.arange(n)
        w = rng.standard_normal(size) * 10.0 ** rng.uniform(-5, 5, size)
        step = float(rng.standard_normal()) * 10.0 ** rng.uniform(-5, 5)
        factor, cutoff = float(rng.uniform(0, 1)), float(rng.choice([0.0, 1e-3, 0.05, 0.5]))
        a = [x.copy() for x in (w, pairs, values, position)]
        b = [x.copy() for x in (w, pairs, values, position)]
        kernels.update(a[0], a[1], a[2], n, step)
        kept = kernels.decay(a[1], a[2], a[3], n, factor, cutoff)
        assert kernels.update_decay(b[0], b[1], b[2], b[3], n, step, factor, cutoff) == kept
        assert a[0].tobytes() == b[0].tobytes() and a[3].tobytes() == b[3].tobytes()
        assert a[1][:kept].tobytes() == b[1][:kept].tobytes()
        assert a[2][:kept].tobytes() == b[2][:kept].tobytes()


@pytest.mark.parametrize(
    "changes",
    [{"traces": "accumulating"}, {"trace_cutoff": 0.0}, {"trace_cutoff": 0.3, "epsilon": 0.1}],
)
def test_the_rewind_is_exact_for_other_traces(changes) -> None:
    config = BOOK.replace(kernel="numba", **changes)
    env, agent = make_env(config), make_agent(config, seed=3)
    for episode in range(2):
        learn_episode(env, agent, seed=episode)
    before, state = agent.state_dict(), agent.checkpoint_state()
    partial_episode(env, agent, 5, 120)
    after = state()
    assert all(np.array_equal(after[k], before[k]) for k in before)


def test_accumulating_traces_with_the_one_call_path_are_the_same_through_both(tmp_path) -> None:
    # epsilon 0: the fused kernel (greedy_step, update_decay) with accumulating traces.
    config = BOOK.replace(traces="accumulating", episodes=15)
    (ref, ref_agent), (fast, fast_agent) = run_both(config, 2, tmp_path)
    assert fast["episode_lengths"] == ref["episode_lengths"]
    assert np.array_equal(fast_agent.w, ref_agent.w)


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
    config = BOOK.replace(kernel="numba", episodes=12, checkpoint_every=1000)
    whole = train(config, 6, tmp_path / "whole")
    stopped = StopAtDecision(make_env(config), sum(whole["episode_lengths"][:7]) + 30)
    with pytest.raises(KeyboardInterrupt):
        train(config, 6, tmp_path / "split", env=stopped)
    meta, arrays = load_checkpoint(tmp_path / "split" / "checkpoint.npz")
    assert meta["episodes_done"] == 7  # stopped 30 decisions into the 8th episode
    train(config.replace(episodes=7), 6, tmp_path / "seven")
    seven = load_checkpoint(tmp_path / "seven" / "checkpoint.npz")[1]
    assert all(np.array_equal(arrays[k], seven[k]) for k in seven)  # the rewound state
    resumed = train(config, 6, tmp_path / "split", resume=True)
    for key in ("episode_lengths", "episode_returns", "greedy_from_rest", "steps"):
        assert resumed[key] == whole[key], key
    a = load_checkpoint(tmp_path / "whole" / "checkpoint.npz")[1]
    b = load_checkpoint(tmp_path / "split" / "checkpoint.npz")[1]
    assert all(np.array_equal(a[k], b[k]) for k in a)


def test_a_diverging_compiled_learner_checkpoints_its_last_finite_state(tmp_path) -> None:
    # The divergence is found mid-episode, after weights have overflowed: the checkpoint is
    # rewound to the end of the last finite episode (loading refuses non-finite weights).
    config = BOOK.replace(kernel="numba", alpha=0.2)
    with pytest.raises(DivergenceError, match="diverged in episode"):
        train(config, 0, tmp_path)
    meta, arrays = load_checkpoint(tmp_path / "checkpoint.npz")
    assert np.isfinite(arrays["w"]).all() and arrays["w"].any()
    done = meta["episodes_done"]
    assert done >= 1
    reference = train(config.replace(episodes=done, kernel="numpy"), 0, tmp_path / "numpy")
    assert reference["episodes_done"] == done
    ref = load_checkpoint(tmp_path / "numpy" / "checkpoint.npz")[1]
    assert all(np.array_equal(arrays[k], ref[k]) for k in ref)
