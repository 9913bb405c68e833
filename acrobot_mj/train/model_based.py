"""Model-based training: the five lumped parameters identified from ``identify_decisions``
random-torque env decisions (the learner is told the equations' structure, not the masses), then
the config's learners trained in :class:`~acrobot_mj.envs.identified.IdentifiedEnv`."""

from __future__ import annotations

from typing import Any, cast

import gymnasium as gym
import numpy as np

from acrobot_mj.agents import Agent
from acrobot_mj.agents.base import Greedy, RandomStream
from acrobot_mj.envs.identified import IdentifiedEnv
from acrobot_mj.envs.rollout import acrobot_of, run_episode
from acrobot_mj.envs.spaces import MAX_VEL1, MAX_VEL2
from acrobot_mj.envs.tasks import get_task
from acrobot_mj.identify.lumped import Transition, identify
from acrobot_mj.physics.integrators import Stepping
from acrobot_mj.train.config import TrainConfig
from acrobot_mj.train.learners import AgentLearner, greedy_from_rest, make_env, train_learners
from acrobot_mj.train.records import greedy_result, write_run
from acrobot_mj.train.run import Run

#: Seed-tree branches of the data's draws and of the judging episodes' starts.
IDENTIFY_BRANCH, JUDGE_BRANCH = 0xDA7A, 0x7D6E
#: Decisions per data episode at most (short: the data should cover many starts).
DATA_EPISODE = 100
#: Greedy episodes in the model that judge a population's learners.
JUDGE_EPISODES = 30


class ModelJudge:
    """Scores learner ``k``: the median of the task's score of its greedy policy in the model
    over :data:`JUDGE_EPISODES` episodes from the config's training starts (never held-out)."""

    rule = f"median greedy score in the identified model over {JUDGE_EPISODES} training starts"

    def __init__(self, model: gym.Env, config: TrainConfig, seed: int) -> None:
        self.model, self.config, self.seed = model, config, seed
        self.score = get_task(config.task).score

    def __call__(self, agent: Agent, k: int) -> float:
        tree = np.random.SeedSequence([self.seed, JUDGE_BRANCH, k])
        options = {"start_noise": self.config.start_noise}
        quantity = "episode_return" if self.score.quantity == "return" else "length"
        values = []
        for j, child in enumerate(tree.spawn(JUDGE_EPISODES)):
            ties = RandomStream(np.random.SeedSequence([self.seed, JUDGE_BRANCH, k, j]))
            start = int(child.generate_state(1)[0])
            episode = run_episode(self.model, Greedy(agent, ties), start, options)
            values.append(getattr(episode, quantity))
        return float(np.median(values))


def collect(env: gym.Env, decisions: int, seed: int, noise: float) -> list[Transition]:
    """``decisions`` transitions of uniformly random actions in ``env`` (unwrapped states, and
    the torque [N m] MuJoCo applied)."""
    acrobot, space = acrobot_of(env), env.action_space
    tree = np.random.SeedSequence([seed, IDENTIFY_BRANCH])
    rng = np.random.default_rng(tree)
    data: list[Transition] = []
    for child in tree.spawn(decisions):  # at least one decision per episode: enough
        if len(data) == decisions:
            break
        env.reset(seed=int(child.generate_state(1)[0]), options={"start_noise": noise})
        for _ in range(DATA_EPISODE):
            x = acrobot.state.tolist()
            if isinstance(space, gym.spaces.Discrete):
                action: int | np.ndarray = int(rng.integers(space.n))
            else:  # a Box: float32, as the env takes it
                box = cast(gym.spaces.Box, space)
                action = rng.uniform(box.low, box.high).astype(box.dtype)
            _, _, terminated, truncated, _ = env.step(action)
            torque = float(acrobot.data.actuator("elbow_motor").ctrl[0])
            data.append((x, torque, acrobot.state.tolist()))
            if terminated or truncated or len(data) == decisions:
                break
    return data


#: The largest RMS prediction error [rad, rad/s] of a model that fits: MuJoCo's step and the
#: lumped model agree to rounding (about 1e-16), so anything near 1e-6 is another system.
FIT_TOLERANCE = 1e-6


def check_identified(rms: float) -> None:
    """Refuse a model whose predictions miss the data: the structure does not fit the env."""
    if not rms <= FIT_TOLERANCE:
        raise ValueError(
            f"the identified model does not fit its data (RMS error {rms:.3g} > "
            f"{FIT_TOLERANCE:g}): the acrobot's structure does not describe "
            "this env"
        )


def stepping(env: gym.Env) -> Stepping:
    """What the learner is told about ``env``'s step (no inertial parameter)."""
    acrobot = acrobot_of(env)
    return Stepping(acrobot.model.opt.timestep, acrobot.frame_skip, (MAX_VEL1, MAX_VEL2))


def identified_model(
    env: gym.Env, decisions: int, seed: int, noise: float
) -> tuple[int, np.ndarray, float, Stepping]:
    """The lumped parameters fitted to ``decisions`` random-action transitions in ``env``: the
    transitions' count, the parameters, the fit's RMS error and what the learner was told."""
    data = collect(env, decisions, seed, noise)
    told = stepping(env)
    theta, rms = identify(data, told)
    check_identified(rms)
    return len(data), theta, rms, told


class ModelBasedLearner(AgentLearner):
    """An :class:`~acrobot_mj.train.learners.AgentLearner` that trains in a model identified
    from a few env decisions."""

    def train(self, run: Run) -> tuple[dict[str, Any], Agent]:
        config, seed = self.config, self.seed
        if self.given_env is not None:
            raise ValueError("model-based training identifies the package's own env; give no env")
        real = make_env(config)
        decisions, theta, rms, told = identified_model(
            real, config.identify_decisions, seed, config.start_noise
        )
        model = IdentifiedEnv(theta, acrobot_of(real).task, told, config.max_episode_steps)
        # The model as it is: each learner's training env adds the config's shaping (once).
        record, agent = train_learners(config, seed, run, model, ModelJudge(model, config, seed))
        greedy = greedy_from_rest(real, agent, seed)
        fit = {"data_decisions": decisions, "theta": theta.tolist(), "rms": rms}
        record.update(
            env="the identified model (IdentifiedEnv)",
            greedy_from_rest=greedy_result(greedy),
            decisions_total=decisions + greedy.length,
            model=fit,
        )
        if run.out is not None:
            write_run(run.out, record, f"seed {seed}, learnt in an identified model")
        return record, agent
