"""The compiled Sarsa(lambda) (``kernel = "numba"``) against the numpy reference: the same
numbers, bit for bit, from its kernels up to full runs of the book and tuned presets."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("numba", reason="the compiled learner needs numba (the fast extra)")

from acrobot_mj.agents import kernels
from acrobot_mj.agents.registry import make_agent
from acrobot_mj.agents.sarsa_lambda_jit import CompiledSarsaLambda
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
