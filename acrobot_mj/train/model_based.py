"""Model-based training: identify the dynamics from a few env decisions, then learn in the model.

A run with ``identify_decisions = N > 0``:

1. takes N decisions in the env with uniformly random torques, from the config's training starts
   (episodes of at most :data:`DATA_EPISODE` decisions; every draw from the run's seed, on its
   own branch of the seed tree), and keeps each transition;
2. identifies the five lumped parameters of the manipulator equations from them
   (:mod:`acrobot_mj.control.identification`: the learner knows the equations' structure and
   the env's step, dt, steps per decision and velocity limits, not the masses, lengths or
   inertias);
3. trains the config's learner, or its population, in :class:`acrobot_mj.envs.identified.IdentifiedEnv`
   over the identified model with the config's task, rewards and shaping (Dyna-style planning:
   the learning episodes are simulated and cost the env nothing); a population keeps the
   learner whose greedy policy does best in the model from :data:`JUDGE_EPISODES` training
   starts (simulated too, from the learner's own seeds: never the held-out ones);
4. runs the kept learner's greedy episode from rest in the env.

``run.json`` adds ``model`` (the data's decisions, the identified parameters, the fit's RMS
error); ``steps`` counts the simulated learning decisions, and ``decisions_total`` the env's:
the data and the greedy run.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from acrobot_mj.agents import Agent
from acrobot_mj.agents.base import Greedy, RandomStream
from acrobot_mj.control.identification import Transition, identify
from acrobot_mj.envs.identified import IdentifiedEnv
from acrobot_mj.envs.rollout import run_episode
from acrobot_mj.envs.spaces import MAX_VEL1, MAX_VEL2
from acrobot_mj.envs.tasks import get_task
from acrobot_mj.physics.integrators import Stepping
from acrobot_mj.train.config import TrainConfig
from acrobot_mj.train.learners import (
    AgentLearner,
    Run,
    greedy_from_rest,
    make_env,
    train_learners,
)
from acrobot_mj.train.records import greedy_result, write_run

#: The seed-tree branch of the data's draws (learning episodes use none).
DATA_BRANCH = 0xDA7A
#: Decisions per data episode at most (short: the data should cover many starts).
DATA_EPISODE = 100
#: Greedy episodes in the model that judge a population's learners.
JUDGE_EPISODES = 30
#: The seed-tree branch of the judging episodes' starts.
JUDGE_BRANCH = 0x7D6E


class ModelJudge:
    """Scores learner ``k`` by its greedy policy in the model: the median of the task's score
    over :data:`JUDGE_EPISODES` episodes from the config's training starts."""

    rule = f"median greedy score in the identified model over {JUDGE_EPISODES} training starts"

    def __init__(self, model: gym.Env, config: TrainConfig, seed: int) -> None:
        self.model, self.config, self.seed = model, config, seed
        self.score = get_task(config.task).score

    def __call__(self, agent: Agent, k: int) -> float:
        tree = np.random.SeedSequence([self.seed, JUDGE_BRANCH, k])
        options = {"start_noise": self.config.start_noise}
        values = []
        for j, child in enumerate(tree.spawn(JUDGE_EPISODES)):
            ties = RandomStream(np.random.SeedSequence([self.seed, JUDGE_BRANCH, k, j]))
            episode = run_episode(
                self.model, Greedy(agent, ties), int(child.generate_state(1)[0]), options
            )
            values.append(
                getattr(episode, "episode_return" if self.score.quantity == "return" else "length")
            )
        return float(np.median(values))


def random_action(env: gym.Env, rng: np.random.Generator) -> Any:
    """A uniformly random action of ``env``: one of ``Discrete(3)``'s torques, or a torque in
    the ``Box``'s range (float32, as the env takes it)."""
    space = env.action_space
    if isinstance(space, gym.spaces.Discrete):
        return int(rng.integers(space.n))
    return rng.uniform(space.low, space.high).astype(space.dtype)


def collect(env: gym.Env, decisions: int, seed: int, noise: float) -> list[Transition]:
    """``decisions`` transitions of uniformly random actions in ``env`` (unwrapped states, and
    the torque [N m] MuJoCo applied)."""
    acrobot = env.unwrapped
    tree = np.random.SeedSequence([seed, DATA_BRANCH])
    rng = np.random.default_rng(tree)
    data: list[Transition] = []
    for child in tree.spawn(decisions):  # at least one decision per episode: enough
        env.reset(seed=int(child.generate_state(1)[0]), options={"start_noise": noise})
        for _ in range(DATA_EPISODE):
            x = acrobot.state.tolist()
            _, _, terminated, truncated, _ = env.step(random_action(env, rng))
            data.append(
                (x, float(acrobot.data.actuator("elbow_motor").ctrl[0]), acrobot.state.tolist())
            )
            if terminated or truncated or len(data) == decisions:
                break
        if len(data) == decisions:
            return data
    return data


#: The largest RMS prediction error [rad, rad/s] of a model that fits: MuJoCo's step and the
#: lumped model agree to rounding (about 1e-16 seen), so anything near 1e-6 is another system.
FIT_TOLERANCE = 1e-6


def check_fit(rms: float) -> None:
    """Refuse a model whose predictions miss the data: the structure does not fit the env."""
    if not rms <= FIT_TOLERANCE:
        raise ValueError(
            f"the identified model does not fit its data (RMS error {rms:.3g} > "
            f"{FIT_TOLERANCE:g}): the acrobot's structure does not describe this env"
        )


def stepping(env: gym.Env) -> Stepping:
    """What the learner is told about ``env``'s step (no inertial parameter)."""
    acrobot = env.unwrapped
    return Stepping(acrobot.model.opt.timestep, acrobot.frame_skip, (MAX_VEL1, MAX_VEL2))


def identified_model(
    env: gym.Env, decisions: int, seed: int, noise: float
) -> tuple[int, np.ndarray, float, Stepping]:
    """Steps 1 and 2 of the module docstring on ``env``: ``decisions`` random-action
    transitions, the lumped parameters fitted to them (a model that misses its data is
    refused). Returns the transitions' count, the parameters, the fit's RMS error and what the
    learner was told of the step."""
    data = collect(env, decisions, seed, noise)
    told = stepping(env)
    theta, rms = identify(data, told)
    check_fit(rms)
    return len(data), theta, rms, told


class ModelBasedLearner(AgentLearner):
    """An :class:`AgentLearner` that trains in a model identified from
    ``config.identify_decisions`` env decisions (see the module docstring); it acts, saves and
    loads as every agent does."""

    def train(self, run: Run) -> tuple[dict[str, Any], Agent]:
        config, seed = self.config, self.seed
        if self.given_env is not None:
            raise ValueError("model-based training identifies the package's own env; give no env")
        real = make_env(config)
        decisions, theta, rms, told = identified_model(
            real, config.identify_decisions, seed, config.start_noise
        )
        model = IdentifiedEnv(theta, real.unwrapped.task, told, config.max_episode_steps)
        # The model as it is: each learner's training env adds the config's shaping (once).
        record, agent = train_learners(config, seed, run, model, ModelJudge(model, config, seed))
        greedy = greedy_from_rest(real, agent, seed)
        record.update(
            env="the identified model (IdentifiedEnv)",
            greedy_from_rest=greedy_result(greedy),
            decisions_total=decisions + greedy.length,
            model={"data_decisions": decisions, "theta": theta.tolist(), "rms": rms},
        )
        if run.out is not None:
            write_run(run.out, record, f"seed {seed}, learnt in an identified model")
        return record, agent
