"""Hand-computed SARSA and Sarsa(lambda) updates on a tiny chain, and determinism."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import acrobot_mj
from acrobot_mj.agents import RandomStream, Sarsa, SarsaLambda
from acrobot_mj.agents.base import Learning
from acrobot_mj.agents.features import StateGrid
from acrobot_mj.envs.rollout import run_episode
from acrobot_mj.envs.spaces import observation_space
from acrobot_mj.train.presets import PRESETS


def learn_episode(env, agent, seed=None):
    """One learning episode of ``agent`` on ``env``."""
    return run_episode(env, Learning(agent), seed)


# All values below are dyadic (alpha = 0.5, lambda = 0.5, integer rewards), so the floating-
# point results are exact and the comparisons use ==.


class Chain:
    """One-hot features of a chain of 3 states: observation (i, ...) -> feature i."""

    num_features = 3
    num_active = 1

    def index(self, obs) -> int:
        return int(obs[0])

    def active(self, obs) -> np.ndarray:
        return np.array([int(obs[0])])


def _with_values(agent, values: np.ndarray):
    """Load action values (Q table or weights) through the public state_dict round trip."""
    state = agent.state_dict()
    state["q" if isinstance(agent, Sarsa) else "w"] = values
    agent.load_state_dict(state)
    return agent


def test_sarsa_updates_by_hand() -> None:
    # Q[s] rows; action 2 is greedy in states 0 and 1, so no tie-breaking happens.
    q = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 3.0], [0.0, 0.0, 0.0]])
    agent = _with_values(Sarsa(Chain(), alpha=0.5, gamma=1.0, epsilon=0.0, seed=0), q)
    assert agent.begin_episode([0]) == 2
    # Step 1: r = -1, s' = 1, a' = 2: Q(0,2) += 0.5 (-1 + 3 - 1) = 1.5.
    assert agent.learn(-1.0, [1], terminated=False, truncated=False) == 2
    assert agent.q[0, 2] == 1.5 and agent.q[1, 2] == 3.0
    # Step 2: the goal, r = +100, no bootstrap: Q(1,2) += 0.5 (100 - 3) = 51.5.
    assert agent.learn(100.0, [2], terminated=True, truncated=False) is None
    expected = q.copy()
    expected[0, 2], expected[1, 2] = 1.5, 51.5
    np.testing.assert_array_equal(agent.q, expected)


def test_sarsa_truncation_bootstraps() -> None:
    q = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 3.0], [0.0, 0.0, 0.0]])
    agent = _with_values(Sarsa(Chain(), alpha=0.5, epsilon=0.0, seed=0), q)
    agent.begin_episode([0])
    # Truncated (time limit), not terminal: the target still includes Q(1, 2) = 3.
    assert agent.learn(-1.0, [1], terminated=False, truncated=True) is None
    assert agent.q[0, 2] == 1.5


def test_sarsa_lambda_updates_and_traces_by_hand() -> None:
    w = np.zeros((3, 3))
    w[2, 0], w[2, 1] = 1.0, 3.0  # w[action, feature]
    agent = _with_values(
        SarsaLambda(Chain(), alpha=0.5, gamma=1.0, lam=0.5, epsilon=0.0, trace_cutoff=0.0, seed=0),
        w,
    )
    assert agent.begin_episode([0]) == 2
    # Step 1: delta = -1 - w[2,0] + w[2,1] = 1; z[2,0] = 1; w[2,0] += 0.5 * 1 * 1 = 1.5;
    # then the trace decays: z[2,0] = gamma * lambda = 0.5.
    assert agent.learn(-1.0, [1], terminated=False, truncated=False) == 2
    assert agent.w[2, 0] == 1.5 and agent.w[2, 1] == 3.0
    z = np.zeros((3, 3))
    z[2, 0] = 0.5
    np.testing.assert_array_equal(agent.traces, z)
    # Step 2: the goal. delta = 100 - w[2,1] = 97; z[2,1] = 1; w += 0.5 * 97 * z:
    # w[2,0] = 1.5 + 24.25 = 25.75, w[2,1] = 3 + 48.5 = 51.5.
    assert agent.learn(100.0, [2], terminated=True, truncated=False) is None
    assert agent.w[2, 0] == 25.75 and agent.w[2, 1] == 51.5
    assert np.count_nonzero(agent.w) == 2


@pytest.mark.parametrize(
    ("traces", "trace", "weight"), [("replacing", 1.0, -0.25), ("accumulating", 1.5, -0.625)]
)
def test_replacing_and_accumulating_traces_by_hand(traces, trace, weight) -> None:
    w = np.zeros((3, 3))
    w[2, 0] = 1.0
    agent = _with_values(
        SarsaLambda(
            Chain(), alpha=0.5, lam=0.5, epsilon=0.0, traces=traces, trace_cutoff=0.0, seed=0
        ),
        w,
    )
    agent.begin_episode([0])
    # Step 1 stays in state 0: delta = -1 - 1 + 1 = -1; w[2,0] = 1 - 0.5 = 0.5; z[2,0] -> 0.5.
    assert agent.learn(-1.0, [0], terminated=False, truncated=False) == 2
    assert agent.w[2, 0] == 0.5 and agent.traces[2, 0] == 0.5
    # Step 2 revisits (0, 2): replacing sets z = 1, accumulating adds 1 (1.5).
    # delta = -1 - 0.5 = -1.5; w[2,0] = 0.5 + 0.5 * -1.5 * z.
    agent.learn(-1.0, [1], terminated=True, truncated=False)
    assert agent.w[2, 0] == 0.5 + 0.5 * -1.5 * trace == weight


def test_trace_cutoff_drops_small_traces() -> None:
    agent = SarsaLambda(Chain(), alpha=0.5, lam=0.5, epsilon=0.0, trace_cutoff=0.3, seed=0)
    agent.begin_episode([0])
    agent.learn(-1.0, [1], False, False)  # z[., 0] = 0.5 >= 0.3: kept
    assert np.count_nonzero(agent.traces) == 1
    agent.learn(-1.0, [2], False, False)  # z[., 0] = 0.25 < 0.3: dropped; z[., 1] = 0.5
    assert np.count_nonzero(agent.traces) == 1 and agent.traces.max() == 0.5


@pytest.mark.parametrize("epsilon", [0.001, 0.0])
def test_sarsa_lambda_with_grid_and_lambda_0_is_tabular_sarsa(epsilon) -> None:
    # One active feature and lambda = 0: the same algorithm, and with the same seed the same
    # random draws, so the learned values agree exactly (alpha = 0.5 keeps them dyadic).
    env = gym.make(acrobot_mj.ENV_ID)
    tabular = Sarsa(StateGrid(), alpha=0.5, epsilon=epsilon, seed=3)
    linear = SarsaLambda(StateGrid(), alpha=0.5, lam=0.0, epsilon=epsilon, seed=3)
    for episode in range(3):
        a = learn_episode(env, tabular, seed=episode)
        b = learn_episode(env, linear, seed=episode)
        assert a == b
    np.testing.assert_array_equal(tabular.q, linear.w.T)


@pytest.mark.parametrize(
    "make",
    [
        lambda seed: Sarsa(StateGrid(), seed=seed),
        lambda seed: SarsaLambda(PRESETS["book"].encoding.build(observation_space()), seed=seed),
    ],
)
def test_same_seed_same_learned_values(make) -> None:
    env = gym.make(acrobot_mj.ENV_ID, frame_skip=4)
    values = []
    for seed in (5, 5, 6):
        agent = make(seed)
        for episode in range(3):
            learn_episode(env, agent, seed=episode)
        values.append(agent.state_dict()["q" if isinstance(agent, Sarsa) else "w"])
    np.testing.assert_array_equal(values[0], values[1])
    assert not np.array_equal(values[0], values[2])


def test_random_stream_is_seeded_and_restorable() -> None:
    a, b = RandomStream(1), RandomStream(1)
    draws = [a.random() for _ in range(1500)]  # crosses a block boundary
    assert draws == [b.random() for _ in range(1500)]
    state = a.state_dict()
    after = [a.random() for _ in range(10)]
    c = RandomStream(99)
    c.load_state_dict(state)
    assert [c.random() for _ in range(10)] == after
    assert all(0 <= a.below(3) < 3 for _ in range(100))
    # Ties broken uniformly: all three tied actions come up.
    assert {a.argmax([0.0, 0.0, 0.0]) for _ in range(100)} == {0, 1, 2}
    assert a.argmax([0.0, 2.0, 1.0]) == 1


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [({"alpha": 0.0}, "alpha"), ({"gamma": 1.5}, "gamma"), ({"epsilon": -0.1}, "epsilon")],
)
def test_agents_refuse_bad_hyperparameters(kwargs, match) -> None:
    with pytest.raises(ValueError, match=match):
        Sarsa(StateGrid(), **kwargs)
    with pytest.raises(ValueError, match=match):
        SarsaLambda(StateGrid(), **kwargs)


def test_sarsa_lambda_refuses_bad_trace_options() -> None:
    with pytest.raises(ValueError, match="traces"):
        SarsaLambda(StateGrid(), traces="dutch")
    with pytest.raises(ValueError, match="trace_cutoff"):
        SarsaLambda(StateGrid(), trace_cutoff=1.0)


@pytest.mark.parametrize(
    "make", [lambda: Sarsa(Chain(), seed=0), lambda: SarsaLambda(Chain(), seed=0)]
)
def test_learn_outside_an_episode_is_refused(make) -> None:
    agent = make()
    with pytest.raises(RuntimeError, match="begin_episode"):
        agent.learn(-1.0, [0], False, False)
    agent.begin_episode([0])
    agent.learn(-1.0, [1], terminated=True, truncated=False)
    with pytest.raises(RuntimeError, match="begin_episode"):  # the episode is over
        agent.learn(-1.0, [1], False, False)
