"""Learning agents, one algorithm per module.

Every agent follows the same episode protocol, driven by :mod:`acrobot_mj.training`::

    action = agent.begin_episode(obs)
    while True:
        obs, reward, terminated, truncated, info = env.step(action)
        action = agent.learn(reward, obs, terminated, truncated)
        if terminated or truncated:
            break

and has ``greedy_action(obs, stream)``, ``state_dict()`` / ``load_state_dict()`` (plain numpy
arrays, for checkpoints) and its own random stream ``agent.stream``.
"""

from acrobot_mj.agents.random_stream import RandomStream
from acrobot_mj.agents.sarsa import Sarsa
from acrobot_mj.agents.sarsa_lambda import SarsaLambda

__all__ = ["RandomStream", "Sarsa", "SarsaLambda"]
