"""Learning agents, one algorithm per module, with the features they learn over.

Every agent follows :class:`~acrobot_mj.agents.protocol.Agent`: ``begin_episode(obs)``, then
``learn(reward, obs, terminated, truncated)`` after every step, ``greedy_action(obs, stream)``,
``state_dict()`` / ``load_state_dict()`` (plain numpy arrays, for checkpoints) and its own
random stream ``agent.stream``. :mod:`.registry` builds them from a training config;
:mod:`.actors` runs them in the episode loop.
"""

from acrobot_mj.agents.protocol import Agent, AgentSpec, FeatureSpec
from acrobot_mj.agents.random_stream import RandomStream
from acrobot_mj.agents.registry import AGENTS, FEATURES, make_agent, make_features
from acrobot_mj.agents.sarsa import Sarsa
from acrobot_mj.agents.sarsa_lambda import SarsaLambda

__all__ = [
    "AGENTS",
    "FEATURES",
    "Agent",
    "AgentSpec",
    "FeatureSpec",
    "RandomStream",
    "Sarsa",
    "SarsaLambda",
    "make_agent",
    "make_features",
]
