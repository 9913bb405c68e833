"""Enumerate every run the book preset can make: its tie-break tree.

With epsilon 0 and zero weights the book learner's only random choices are the ties of its
argmax (all actions equal while the weights are still zero). Writing each tie's draw of its
stream so that it takes a given branch, and walking the tree depth first, lists every
possible training run with its probability (the product of 1/ties over its branch points), its
greedy swing-up from rest and its held-out evaluation (the default protocol). A seed is a draw
from this distribution, so a sample of seeds shows at most as many distinct outcomes as leaves.

    python scripts/tie_break_tree.py [--preset book] [--out tree.json]   # about a minute
"""

from __future__ import annotations

import argparse
import json
from fractions import Fraction

import numpy as np

from acrobot_mj.envs.rollout import run_episode
from acrobot_mj.train.evaluate import evaluate_learner
from acrobot_mj.train.learners import DEFAULT, AgentLearner, episode_seed, make_env
from acrobot_mj.train.presets import PRESETS


class ScriptedTies:
    """The agent learning (an actor of the episode loop), the k-th tie of its argmax broken by
    ``script[k]`` (then by the first action), each tie's size recorded in ``ties``. Before each
    decision it finds the tie in the agent's action values (those the decision compares) and
    writes the stream's next draw so that the decision picks the scripted action; it checks
    that the decision read exactly that draw (with epsilon 0 nothing else is drawn)."""

    def __init__(self, agent, script: list[int]) -> None:
        self.agent, self.script, self.ties = agent, script, []

    def _script(self, obs) -> tuple[int, int]:
        """Set up the decision at ``obs``: the stream's position, and the draws it must read."""
        q = self.agent.q_values(obs)
        tied = np.flatnonzero(q == q.max())
        stream = self.agent.stream
        stream.reserve(2)  # the decision's own reserve(2) then keeps this block
        if len(tied) == 1:
            return stream.position, 0
        k = len(self.ties)
        choice = self.script[k] if k < len(self.script) else 0
        self.ties.append(len(tied))
        stream.block[stream.position] = (choice + 0.5) / len(tied)  # picks tied[choice]
        return stream.position, 1

    def _check(self, at: tuple[int, int]) -> None:
        if self.agent.stream.position - at[0] != at[1]:
            raise RuntimeError("the scripted stream serves ties only (epsilon must be 0)")

    def begin(self, obs) -> int:
        at = self._script(obs)
        action = self.agent.begin_episode(obs)
        self._check(at)
        return action

    def observe(self, reward, obs, terminated, truncated):
        at = (self.agent.stream.position, 0) if terminated else self._script(obs)
        action = self.agent.learn(reward, obs, terminated, truncated)
        self._check(at)
        return action


def run_leaf(config, script: list[int]) -> tuple[list[int], list[int], object]:
    """Train with ties broken by ``script``: the ties met, the episode lengths, the agent."""
    env = make_env(config)
    agent = config.make_agent(0, env.observation_space)
    actor = ScriptedTies(agent, script)
    lengths = []
    for episode in range(config.episodes):
        noise = config.start_noise_at(episode)
        options = {"start_noise": noise} if noise > 0 else None
        lengths.append(run_episode(env, actor, episode_seed(0, episode), options).length)
    return actor.ties, lengths, agent


def walk(config) -> list[dict]:
    """Every leaf of the tie-break tree, depth first."""
    leaves, todo = [], [[]]
    while todo:
        script = todo.pop()
        ties, lengths, agent = run_leaf(config, script)
        for k in range(len(script), len(ties)):  # branches this run did not script: open them
            for branch in range(1, ties[k]):
                todo.append(script + [0] * (k - len(script)) + [branch])
        full = script + [0] * (len(ties) - len(script))
        probability = Fraction(1)
        for n in ties:
            probability /= n
        learner = AgentLearner(config, 0)
        learner.agent = agent
        evaluation = evaluate_learner(learner, DEFAULT)
        leaves.append(
            {
                "branches": full,
                "ties": ties,
                "probability": str(probability),
                "training_decisions": sum(lengths),
                "from_rest": evaluation["rest"]["length"],
                "held_out_median": evaluation["summary"]["length"]["median"],
            }
        )
        print(leaves[-1], flush=True)
    return leaves


def weighted_median(values: list[float], weights: list[Fraction]) -> float:
    order = np.argsort(values, kind="stable")
    total, acc = sum(weights), Fraction(0)
    for i in order:
        acc += weights[i]
        if acc >= total / 2:
            return values[i]
    raise AssertionError("weights sum to zero")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--preset", default="book")
    parser.add_argument("--out")
    args = parser.parse_args()
    config = PRESETS[args.preset]
    if config.epsilon != 0.0 or config.start_noise != 0.0 or config.population != 1:
        raise SystemExit("the tree exists for epsilon 0, no start noise and one learner only")
    leaves = walk(config)
    weights = [Fraction(leaf["probability"]) for leaf in leaves]
    summary = {
        "leaves": len(leaves),
        "probability_total": str(sum(weights)),
        "exact_median_from_rest": weighted_median([x["from_rest"] for x in leaves], weights),
        "exact_median_held_out": weighted_median([x["held_out_median"] for x in leaves], weights),
    }
    print(json.dumps(summary))
    if args.out:
        with open(args.out, "w") as f:
            json.dump({"summary": summary, "leaves": leaves}, f, indent=1)


if __name__ == "__main__":
    main()
