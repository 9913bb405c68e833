"""Learning agents, one algorithm per module: tabular SARSA (the report's) and Sarsa(lambda) (the
book's), over the report's grid or tile coding; the registry
:data:`~acrobot_mj.agents.base.AGENTS` builds them."""

from acrobot_mj.agents.base import (
    AGENTS,
    Agent,
    AgentSpec,
    DivergenceError,
    RandomStream,
    agent_spec,
    register_agent,
)
from acrobot_mj.agents.features import FEATURES
from acrobot_mj.agents.sarsa import Sarsa, SarsaConfig, SarsaGroup
from acrobot_mj.agents.sarsa_lambda import SarsaLambda, SarsaLambdaConfig

__all__ = [
    "AGENTS",
    "FEATURES",
    "Agent",
    "AgentSpec",
    "DivergenceError",
    "RandomStream",
    "Sarsa",
    "SarsaConfig",
    "SarsaGroup",
    "SarsaLambda",
    "SarsaLambdaConfig",
    "agent_spec",
    "register_agent",
]

register_agent(
    AgentSpec(
        "sarsa",
        "one-step tabular SARSA (the report), in lockstep for many seeds",
        SarsaConfig,
        ("grid",),
        build=lambda grid, c, seed, n: Sarsa(grid, n, c.alpha, c.gamma, c.epsilon, seed=seed),
        group=lambda grid, c, seeds: SarsaGroup(grid, c, seeds),
    )
)
register_agent(
    AgentSpec(
        "sarsa_lambda",
        "linear Sarsa(lambda) with eligibility traces (Sutton and Barto)",
        SarsaLambdaConfig,
        ("grid", "tiles"),
        build=lambda features, c, seed, n: SarsaLambda(
            features,
            n,
            alpha=c.alpha,
            gamma=c.gamma,
            lam=c.lam,
            epsilon=c.epsilon,
            traces=c.traces,
            trace_cutoff=c.trace_cutoff,
            seed=seed,
        ),
    )
)
