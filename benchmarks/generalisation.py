"""The learner variants of the README's generalisation study that are not package options.

Every recipe here trains on the `book` env within 48,000 learning decisions (the last episode
cut at the budget, as ``--max-decisions`` does) and is evaluated by the package's own held-out
protocol (:func:`acrobot_mj.train.evaluate.evaluate_learner`, 100 starts, seed 0). The variants
(prototypes, kept out of the package because none helped):

- ``init_*``: initial action values other than 0 (weights = value / active features);
- ``rep*``: after every episode, backward one-step replay of stored real transitions (the
  episode just finished, plus random earlier ones): Q-learning or Sarsa targets;
- ``kb*``: keep the weights at the end of the best window of W training episodes (median
  length, training starts only) instead of the last ones;
- ``fork*``: one learner for D decisions, then B copies (own streams and starts) share the rest,
  the copy with the shortest last 20 training episodes kept;
- ``rs*``: restart a learner that has shown no 20-episode window of median <= T after D
  decisions.

    python benchmarks/generalisation.py NAME [--seeds 0-9]     # one recipe, about 5 s a seed
    python benchmarks/generalisation.py --list
"""

from __future__ import annotations

import argparse
import copy
import json

import numpy as np

from acrobot_mj.agents.base import Learning, RandomStream
from acrobot_mj.agents.sarsa_lambda import SarsaLambda
from acrobot_mj.envs.rollout import run_episode
from acrobot_mj.train.evaluate import evaluate_learner
from acrobot_mj.train.learners import DEFAULT, AgentLearner, episode_seed, learner_seed, make_env
from acrobot_mj.train.presets import PRESETS

BUDGET = 48_000
#: The study's base: the book with finer tiles and constant start noise 0.05; episodes never bind.
BASE = PRESETS["book"].replace(
    episodes=100_000, angle_tiles=12, velocity_tiles=14, start_noise=0.05
)


class Variant(SarsaLambda):
    """Sarsa(lambda) with an initial value and backward replay of stored episodes."""

    def __init__(self, *args, init_value=0.0, replay=0, target="q", replay_seed=0, **kw):
        super().__init__(*args, **kw)
        if init_value:
            self._w[:] = init_value / self.features.num_active
        self.replay, self.target = replay, target
        self._rng = np.random.default_rng(replay_seed)
        self._episodes, self._current = [], None

    def begin_episode(self, obs):
        self._current = [] if self.replay else None
        return super().begin_episode(obs)

    def learn(self, reward, obs, terminated, truncated):
        before = (self._active.copy(), self._a)  # the learner reuses its buffers
        action = super().learn(reward, obs, terminated, truncated)
        if self.replay:
            after = self._active.copy() if action is not None else self.features.active(obs)
            self._current.append((*before, reward, after, terminated))
        return action

    def end_episode(self):
        if not self.replay or not self._current:
            return
        self._episodes.append(self._current)
        order = [len(self._episodes) - 1]
        if self.replay > 1 and len(self._episodes) > 1:
            order += list(self._rng.integers(0, len(self._episodes), self.replay - 1))
        for i in order:
            self._sweep(self._episodes[i])

    def _sweep(self, episode):
        w, n = self._w, self.num_features  # w[a, i] at a * n + i
        offsets = np.arange(self.n_actions)[:, None] * n
        for t in range(len(episode) - 1, -1, -1):
            active, a, reward, after, terminal = episode[t]
            pairs = a * n + active
            if terminal:
                target = reward
            elif self.target == "sarsa" and t + 1 < len(episode):
                target = reward + w[episode[t + 1][1] * n + after].sum()
            else:
                target = reward + w[offsets + after].sum(axis=1).max()
            w[pairs] += self.alpha * (target - w[pairs].sum())


def variant(**options):
    def build(c, seed, space):
        return Variant(
            c.encoding.build(space),
            3,
            alpha=c.alpha,
            gamma=c.gamma,
            lam=c.lam,
            epsilon=c.epsilon,
            traces=c.traces,
            trace_cutoff=c.trace_cutoff,
            seed=seed,
            replay_seed=seed,
            **options,
        )

    return build


def learn(config, seed, budget, env, build=None, keep_best=0, stop=None, agent=None):
    """One learner until ``budget`` decisions: (agent, decisions, episode lengths)."""
    if agent is None:
        space = env.observation_space
        agent = config.make_agent(seed, space) if build is None else build(config, seed, space)
    used, lengths, best = 0, [], (None, None)
    for episode in range(config.episodes):
        left = budget - used
        if left <= 0:
            break
        limit = left if left < config.max_episode_steps else None
        result = run_episode(
            env,
            Learning(agent),
            episode_seed(seed, episode),
            {"start_noise": config.start_noise},
            max_steps=limit,
        )
        used += result.length
        lengths.append(result.length)
        if hasattr(agent, "end_episode"):
            agent.end_episode()
        if keep_best and len(lengths) >= keep_best and result.length < left:
            m = float(np.median(lengths[-keep_best:]))
            if best[0] is None or m <= best[0]:
                best = (m, agent._w.copy())
        if stop is not None and stop(used, best[0]):
            break
    if keep_best and best[0] is not None:
        agent._w[:] = best[1]
    agent.score = best[0] if keep_best and best[0] is not None else float(np.median(lengths[-20:]))
    return agent, used, lengths


def population(config, seed, build=None, keep_best=0):
    env, kept, total = make_env(config), None, 0
    for k in range(config.population):
        s = seed if config.population == 1 else learner_seed(seed, k)
        share = (BUDGET - total) // (config.population - k)
        agent, used, _ = learn(config, s, share, env, build, keep_best)
        total += used
        kept = agent if kept is None or agent.score < kept.score else kept
    return kept, total


def fork(config, seed, shared, branches):
    env = make_env(config)
    parent, total, _ = learn(config, seed, shared, env)
    kept = None
    for k in range(branches):
        child = copy.deepcopy(parent)
        child.stream = RandomStream(learner_seed(seed, k))
        share = (BUDGET - total) // (branches - k)
        agent, used, _ = learn(config, learner_seed(seed, k), share, env, agent=child)
        total += used
        kept = agent if kept is None or agent.score < kept.score else kept
    return kept, total


def restart(config, seed, check_at, threshold, keep_best=20):
    env, kept, total, k = make_env(config), None, 0, 0
    while BUDGET - total > 0:
        left = BUDGET - total
        last = left < 2 * check_at

        def stop(used, m, last=last):
            return not last and used >= check_at and (m is None or m > threshold)

        agent, used, _ = learn(
            config, learner_seed(seed, k), left, env, keep_best=keep_best, stop=stop
        )
        total += used
        kept = agent if kept is None or agent.score <= kept.score else kept
        k += 1
    return kept, total


RECIPES = {
    "init_p20": lambda c, s: population(c, s, variant(init_value=20.0)),
    "init_p50": lambda c, s: population(c, s, variant(init_value=50.0)),
    "init_m30": lambda c, s: population(c, s, variant(init_value=-30.0)),
    "rep1": lambda c, s: population(c, s, variant(replay=1)),
    "rep4": lambda c, s: population(c, s, variant(replay=4)),
    "rep4_sarsa": lambda c, s: population(c, s, variant(replay=4, target="sarsa")),
    "kb10": lambda c, s: population(c, s, keep_best=10),
    "kb20": lambda c, s: population(c, s, keep_best=20),
    "kb20_sh20": lambda c, s: population(c.replace(energy_shaping=20.0), s, keep_best=20),
    "fork8k_x4": lambda c, s: fork(c, s, 8000, 4),
    "fork16k_x2": lambda c, s: fork(c, s, 16000, 2),
    "rs12k_76": lambda c, s: restart(c, s, 12000, 76.0),
}


def measure(name, seeds):
    medians = []
    for seed in seeds:
        agent, used = RECIPES[name](BASE, seed)
        config = BASE.replace(energy_shaping=20.0) if "sh20" in name else BASE
        learner = AgentLearner(config, seed)
        learner.agent = agent
        record = evaluate_learner(learner, DEFAULT)
        medians.append(record["summary"]["length"]["median"])
        print(name, seed, used, medians[-1], record["rest"]["length"], flush=True)
    print(
        json.dumps(
            {
                "recipe": name,
                "seeds": [seeds[0], seeds[-1]],
                "median": float(np.median(medians)),
                "best": min(medians),
                "worst": max(medians),
                "at_most_76": sum(m <= 76 for m in medians),
            }
        )
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("name", nargs="?", choices=sorted(RECIPES))
    parser.add_argument("--seeds", default="0-9", help="A-B (inclusive)")
    parser.add_argument("--list", action="store_true")
    args = parser.parse_args()
    if args.list or args.name is None:
        print("\n".join(sorted(RECIPES)))
        return
    first, last = (int(x) for x in args.seeds.split("-"))
    measure(args.name, list(range(first, last + 1)))


if __name__ == "__main__":
    main()
