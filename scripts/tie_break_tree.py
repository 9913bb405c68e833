"""Enumerate every run the book preset can make: its tie-break tree.

With epsilon 0 and zero weights the book learner's only random choices are the ties of its
argmax (all actions equal while the weights are still zero). Replacing its stream by a scripted
one that takes a given branch at each tie, and walking the tree depth first, lists every
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

from acrobot_mj.agents.random_stream import RandomStream
from acrobot_mj.agents.registry import make_agent
from acrobot_mj.train.episodes import episode_seed, learn_episode, make_env, noise_options
from acrobot_mj.train.evaluate import evaluate_agent
from acrobot_mj.train.presets import PRESETS


class ScriptedTies(RandomStream):
    """Breaks the k-th tie by ``script[k]`` (then by the first action), recording each tie."""

    def __init__(self, script: list[int]) -> None:
        super().__init__(0)
        self.script, self.ties = script, []

    def random(self) -> float:
        raise RuntimeError("the scripted stream serves ties only (epsilon must be 0)")

    def argmax(self, values: list[float]) -> int:
        best = max(values)
        tied = [i for i, v in enumerate(values) if v == best]
        if len(tied) == 1:
            return tied[0]
        k = len(self.ties)
        choice = self.script[k] if k < len(self.script) else 0
        self.ties.append(len(tied))
        return tied[choice]


def run_leaf(config, script: list[int]) -> tuple[list[int], list[int], object]:
    """Train with ties broken by ``script``: the ties met, the episode lengths, the agent."""
    agent = make_agent(config, seed=0)
    agent.stream = ScriptedTies(script)
    env = make_env(config)
    lengths = []
    for episode in range(config.episodes):
        noise = noise_options(config.start_noise_at(episode))
        lengths.append(learn_episode(env, agent, episode_seed(0, episode), noise).length)
    return agent.stream.ties, lengths, agent


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
        evaluation = evaluate_agent(config, agent, 0)
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
