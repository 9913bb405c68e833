"""The registry of algorithms and features: how a config becomes a learner.

Built in: ``sarsa`` (:mod:`.sarsa`, with lockstep training) and ``sarsa_lambda``
(:mod:`.sarsa_lambda`; compiled with ``kernel = "numba"``, :mod:`.sarsa_lambda_jit`, and then
in lockstep too, :mod:`.lockstep_lambda`) over ``grid`` and ``tiles`` features
(:mod:`.features`). A new algorithm is one module in ``agents/`` with an
:class:`~acrobot_mj.agents.protocol.AgentSpec` plus one :func:`register_agent` call; a new
hyperparameter is also a field of the training config.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

from acrobot_mj.agents import sarsa, sarsa_lambda
from acrobot_mj.agents.features import FEATURE_SPECS
from acrobot_mj.agents.protocol import Agent, AgentSpec, Features, FeatureSpec

AGENTS: dict[str, AgentSpec] = {}
FEATURES: dict[str, FeatureSpec] = {}


def register_agent(spec: AgentSpec) -> AgentSpec:
    """Add an algorithm to :data:`AGENTS` (its features must be registered)."""
    _register(AGENTS, spec, "algorithm")
    unknown = sorted(set(spec.features) - set(FEATURES))
    if unknown:
        del AGENTS[spec.name]
        raise ValueError(f"algorithm {spec.name!r} names unknown features {unknown}")
    return spec


def register_features(spec: FeatureSpec) -> FeatureSpec:
    """Add a kind of features to :data:`FEATURES`."""
    return _register(FEATURES, spec, "features")


def _register(table: dict[str, Any], spec: Any, what: str) -> Any:
    known = table.get(spec.name)
    if known is not None and known is not spec:
        raise ValueError(f"{what} {spec.name!r} is already registered")
    table[spec.name] = spec
    return spec


def agent_spec(name: str) -> AgentSpec:
    """The spec of algorithm ``name``; the error lists the known ones."""
    if name not in AGENTS:
        raise ValueError(f"unknown algorithm {name!r}; known: {sorted(AGENTS)}")
    return AGENTS[name]


def feature_spec(name: str) -> FeatureSpec:
    """The spec of features ``name``; the error lists the known ones."""
    if name not in FEATURES:
        raise ValueError(f"unknown features {name!r}; known: {sorted(FEATURES)}")
    return FEATURES[name]


def make_features(config: Any) -> Features:
    """The features of ``config`` (``config.features`` names them)."""
    return feature_spec(config.features).build(config)


def make_agent(config: Any, seed: Any, n_actions: int = 3) -> Agent:
    """The learner of ``config`` (``config.algorithm``), its random stream seeded with ``seed``;
    with ``config.kernel == "numba"`` the compiled form (numba imported only then)."""
    build = agent_spec(config.algorithm).build
    if getattr(config, "kernel", None) == "numba":
        from acrobot_mj.agents.sarsa_lambda_jit import build
    return build(make_features(config), config, seed, n_actions)


def _lockstep_lambda(features: Features, config: Any, seeds: Any) -> Any:
    """K compiled Sarsa(lambda) learners in lockstep (numba imported only now)."""
    from acrobot_mj.agents.lockstep_lambda import LockstepSarsaLambda

    return LockstepSarsaLambda(features, config, seeds)


for _spec in FEATURE_SPECS:
    register_features(_spec)
register_agent(sarsa.SPEC)
# Compiled, Sarsa(lambda) can run in lockstep, when asked: measured (docs/speed.md), a group
# makes 0.5 to 0.75 of one compiled learner's decisions per second on this machine (the batch's
# physics and K weight tables out of cache), so seeds run one per process by default.
register_agent(
    replace(
        sarsa_lambda.SPEC,
        lockstep=_lockstep_lambda,
        lockstep_if=lambda c: c.kernel == "numba",
        lockstep_default=False,
    )
)
