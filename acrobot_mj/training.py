"""Train and evaluate loops over any Gymnasium env with the acrobot's spaces, with run records,
checkpoints and resume.

A run directory holds ``run.json`` (config, seed, versions, per-episode lengths, returns and
successes), ``checkpoint.npz`` (agent state and progress, see :mod:`acrobot_mj.checkpoint`),
``learning_curve.png`` and, after :func:`evaluate`, ``eval.json``.
"""

from __future__ import annotations

import json
import platform
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import gymnasium as gym
import mujoco
import numpy as np

import acrobot_mj
from acrobot_mj.agents import RandomStream, Sarsa, SarsaLambda
from acrobot_mj.checkpoint import CheckpointError, load_checkpoint, save_checkpoint
from acrobot_mj.config import TrainConfig
from acrobot_mj.plots import learning_curve
from acrobot_mj.shaping import EnergyShaping

RUN_FILE, EVAL_FILE, CHECKPOINT_FILE, CURVE_FILE = (
    "run.json",
    "eval.json",
    "checkpoint.npz",
    "learning_curve.png",
)
#: Best-known minimum decisions to the goal from rest (validation issue), for reference lines.
MIN_DECISIONS = {1: 252, 4: 63}

Agent = Sarsa | SarsaLambda


def versions() -> dict[str, str]:
    """Versions of Python and the packages a result depends on."""
    return {
        "python": platform.python_version(),
        "acrobot_mj": acrobot_mj.__version__,
        "mujoco": mujoco.__version__,
        "gymnasium": gym.__version__,
        "numpy": np.__version__,
    }


def make_env(config: TrainConfig, **overrides: Any) -> gym.Env:
    """The training env of ``config`` (through ``gymnasium.make``, so with its TimeLimit, and
    with its reward shaping if any)."""
    kwargs = {**config.env_kwargs(), **overrides}
    return shape_rewards(gym.make(acrobot_mj.ENV_ID, **kwargs), config)


def training_env(config: TrainConfig, env: gym.Env | None = None) -> gym.Env:
    """``config``'s env, or the given ``env`` checked and with ``config``'s reward shaping."""
    if env is None:
        return make_env(config)
    check_spaces(env)
    return shape_rewards(env, config)


def shape_rewards(env: gym.Env, config: TrainConfig) -> gym.Env:
    """``env`` with ``config``'s energy shaping (unchanged without it). Records report the
    unshaped returns (``info["unshaped_reward"]``)."""
    if config.energy_shaping == 0.0:
        return env
    return EnergyShaping(env, config.energy_shaping, config.gamma)


def episode_seed(seed: int, episode: int) -> int:
    """The env's reset seed for ``episode`` of run ``seed``: fixed per episode, so a resumed
    run resets exactly as an uninterrupted one."""
    return int(np.random.SeedSequence([seed, episode]).generate_state(1)[0])


def check_spaces(env: gym.Env) -> None:
    """Refuse envs whose spaces the agents cannot use, naming what is wrong."""
    if not (isinstance(env.action_space, gym.spaces.Discrete) and env.action_space.n == 3):
        raise ValueError(f"the agents need a Discrete(3) action space, got {env.action_space}")
    shape = getattr(env.observation_space, "shape", None)
    if not isinstance(env.observation_space, gym.spaces.Box) or shape != (4,):
        raise ValueError(
            "the agents need observations (q1, q2, dq1, dq2) in a Box of shape "
            f"(4,), got {env.observation_space}"
        )


def learn_episode(
    env: gym.Env, agent: Agent, seed: int | None = None, options: dict[str, Any] | None = None
) -> tuple[int, float, bool]:
    """One learning episode; returns (decisions, return, reached the goal)."""
    obs, _ = env.reset(seed=seed, options=options)
    action = agent.begin_episode(obs)
    length, total = 0, 0.0
    step, learn = env.step, agent.learn
    while True:
        obs, reward, terminated, truncated, info = step(action)
        length += 1
        total += info.get("unshaped_reward", reward)
        action = learn(reward, obs, terminated, truncated)
        if terminated or truncated:
            return length, float(total), bool(info.get("is_success", terminated))


def tie_stream(run_seed: int, episode: int = 0) -> RandomStream:
    """The stream that breaks ties of greedy episode ``episode`` of run ``run_seed``: the same
    for the greedy run from rest in ``train``, in ``evaluate`` (its episode 0) and in
    ``render``, so all three report the same swing-up."""
    return RandomStream(np.random.SeedSequence([run_seed, episode]))


def greedy_episode(
    env: gym.Env,
    agent: Agent,
    stream: RandomStream,
    seed: int | None = None,
    options: dict[str, Any] | None = None,
) -> tuple[int, float, bool]:
    """One episode of the greedy policy (no learning); ties broken by ``stream``."""
    obs, _ = env.reset(seed=seed, options=options)
    length, total = 0, 0.0
    while True:
        obs, reward, terminated, truncated, info = env.step(agent.greedy_action(obs, stream))
        length += 1
        total += info.get("unshaped_reward", reward)
        if terminated or truncated:
            return length, float(total), bool(info.get("is_success", terminated))


@dataclass
class History:
    """Per-episode results so far."""

    episode_lengths: list[int] = field(default_factory=list)
    episode_returns: list[float] = field(default_factory=list)
    episode_successes: list[bool] = field(default_factory=list)

    def add(self, length: int, total: float, success: bool) -> None:
        self.episode_lengths.append(length)
        self.episode_returns.append(total)
        self.episode_successes.append(success)

    def __len__(self) -> int:
        return len(self.episode_lengths)

    def to_dict(self) -> dict[str, list]:
        return {
            "episode_lengths": self.episode_lengths,
            "episode_returns": self.episode_returns,
            "episode_successes": self.episode_successes,
        }


class Progress:
    """A one-line progress bar on stderr, redrawn at most every 0.5 s (and only if enabled)."""

    def __init__(self, total: int, label: str, enabled: bool) -> None:
        self.total, self.label, self.enabled = total, label, enabled
        self.start = self.last = time.perf_counter()

    def update(self, done: int, history: History) -> None:
        now = time.perf_counter()
        if not self.enabled or (now - self.last < 0.5 and done < self.total):
            return
        self.last = now
        bar = "#" * int(30 * done / self.total)
        end = "\n" if done >= self.total else ""
        sys.stderr.write(
            f"\r{self.label} [{bar:<30}] {done}/{self.total} episodes, last 20: median "
            f"{recent_median(history.episode_lengths):.0f} decisions, "
            f"{sum(history.episode_successes)} successes, "
            f"{now - self.start:.0f} s{end}"
        )
        sys.stderr.flush()


def _meta(config: TrainConfig, seed: int, history: History, steps: int) -> dict[str, Any]:
    return {
        "config": config.to_dict(),
        "seed": seed,
        "episodes_done": len(history),
        "steps": steps,
        "history": {k: list(v) for k, v in history.to_dict().items()},
        "agent": config.algorithm,
    }


def train(
    config: TrainConfig,
    seed: int,
    out_dir: str | Path | None = None,
    env: gym.Env | None = None,
    resume: bool = False,
    progress: bool = False,
    on_episode: Callable[[int, History], None] | None = None,
    overwrite: bool = False,
) -> dict[str, Any]:
    """Train ``config``'s agent with ``seed`` for ``config.episodes`` episodes.

    With ``out_dir`` it writes the run record, checkpoints (every ``checkpoint_every`` episodes,
    at the end and on Ctrl-C) and the learning curve there; with ``resume`` it continues from
    the checkpoint in ``out_dir`` and ends exactly as an uninterrupted run would. ``env`` may be
    any env with ``Discrete(3)`` actions and ``(q1, q2, dq1, dq2)`` observations (default: the
    config's acrobot env). Returns the run record. With ``config.population > 1`` it trains
    that many learners and keeps one (:mod:`acrobot_mj.population`).
    """
    out = Path(out_dir) if out_dir is not None else None
    if out is not None and not resume and not overwrite:
        check_fresh(out)
    if config.population > 1:
        from acrobot_mj.population import train_population

        return train_population(config, seed, out, env, resume, progress, on_episode)
    return train_agent(config, seed, out, env, resume, progress, on_episode)[0]


def train_agent(
    config: TrainConfig,
    seed: int,
    out: Path | None,
    env: gym.Env | None = None,
    resume: bool = False,
    progress: bool = False,
    on_episode: Callable[[int, History], None] | None = None,
) -> tuple[dict[str, Any], Agent]:
    """:func:`train` for one learner (no freshness check); returns the record and the agent."""
    env_name = "acrobot_mj (make_env)" if env is None else str(env)
    env = training_env(config, env)
    agent = config.make_agent(seed=seed)
    history, steps = History(), 0
    if resume:
        if out is None:
            raise ValueError("resume needs the run directory (out_dir)")
        history, steps = _restore(out / CHECKPOINT_FILE, config, seed, agent)

    # The state after the last completed episode: what a checkpoint holds, so a run stopped in
    # the middle of an episode resumes exactly (that episode is run again from its start).
    snapshot = (agent.state_dict(), _meta(config, seed, history, steps))

    def checkpoint() -> None:
        if out is not None:
            save_checkpoint(out / CHECKPOINT_FILE, *snapshot)

    bar = Progress(config.episodes, f"{config.algorithm} seed {seed}", progress)
    started = time.perf_counter()
    interrupted = False
    try:
        for episode in range(len(history), config.episodes):
            noise = config.start_noise_at(episode)
            options = {"start_noise": noise} if noise > 0 else None
            length, total, success = learn_episode(env, agent, episode_seed(seed, episode), options)
            history.add(length, total, success)
            steps += length
            if out is not None:
                snapshot = (agent.state_dict(), _meta(config, seed, history, steps))
            bar.update(len(history), history)
            if (episode + 1) % config.checkpoint_every == 0:
                checkpoint()
            if on_episode is not None:
                on_episode(episode, history)
    except KeyboardInterrupt:
        interrupted = True
    elapsed = time.perf_counter() - started
    checkpoint()

    record: dict[str, Any] = {
        "config": config.to_dict(),
        "seed": seed,
        "versions": versions(),
        "episodes_done": len(history),
        "steps": steps,
        "interrupted": interrupted,
        "env": env_name,
        "wall_seconds": elapsed,
        **history.to_dict(),
    }
    if not interrupted:
        # The greedy policy from rest, on the training env (ties broken by a fixed stream).
        length, total, success = greedy_episode(
            env, agent, tie_stream(seed), seed=seed, options={"start_noise": 0.0}
        )
        record["greedy_from_rest"] = {"length": length, "return": total, "success": success}
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        (out / RUN_FILE).write_text(json.dumps(record, indent=1))
        if history.episode_lengths:
            learning_curve(
                out / CURVE_FILE,
                [history.episode_lengths],
                f"{config.algorithm} ({config.features}), seed {seed}",
                _reference(config),
            )
    if interrupted:
        raise KeyboardInterrupt(f"interrupted after {len(history)} episodes; checkpoint saved")
    return record, agent


def _reference(config: TrainConfig) -> list[tuple[float, str]]:
    best = MIN_DECISIONS.get(config.frame_skip)
    return [(best, f"best known minimum ({best})")] if best else []


def check_fresh(out: Path) -> None:
    """Refuse to write a new run over an existing one."""
    if out.exists() and not out.is_dir():
        raise FileExistsError(f"{out} is a file, not a run directory")
    names = (RUN_FILE, CHECKPOINT_FILE, "summary.json", "learner_0")  # learner_0: a population
    taken = [name for name in names if (out / name).exists()]
    if taken:
        raise FileExistsError(
            f"{out} already holds a run ({', '.join(taken)}): resume it, "
            "choose another directory, or overwrite it on purpose"
        )


def _read_run(path: Path) -> tuple[dict[str, Any], dict[str, np.ndarray], TrainConfig]:
    """A training checkpoint's meta (schema checked), arrays and config."""
    meta, arrays = load_checkpoint(path)
    kinds = {"config": dict, "seed": int, "episodes_done": int, "steps": int, "history": dict}
    wrong = [key for key, kind in kinds.items() if not isinstance(meta.get(key), kind)]
    history = meta.get("history", {})
    if not wrong and (
        sorted(history) != sorted(History().to_dict())
        or len({len(v) for v in history.values()}) != 1
        or len(history["episode_lengths"]) != meta["episodes_done"]
    ):
        wrong.append("history")
    if wrong:
        raise CheckpointError(f"{path} is not a training checkpoint: bad or missing {wrong}")
    try:
        config = TrainConfig.from_dict(meta["config"])
    except (TypeError, ValueError) as error:
        raise CheckpointError(f"{path} holds an invalid config: {error}") from error
    return meta, arrays, config


def _load_into(agent: Agent, arrays: dict[str, np.ndarray], path: Path) -> None:
    try:
        agent.load_state_dict(arrays)
    except (KeyError, ValueError, TypeError, IndexError) as error:
        raise CheckpointError(f"{path} does not fit its agent: {error!r}") from error


def check_same_run(
    path: Path,
    meta: dict[str, Any],
    saved: TrainConfig,
    config: TrainConfig,
    seed: int,
    may_differ: tuple[str, ...] = (),
) -> None:
    """Refuse a checkpoint written with another config (but ``may_differ``) or seed."""
    differs = {k for k, v in saved.to_dict().items() if v != getattr(config, k)} - set(may_differ)
    if differs:
        raise CheckpointError(f"{path} was written with a different config ({sorted(differs)})")
    if meta["seed"] != seed:
        raise CheckpointError(f"{path} was written for seed {meta['seed']}, not {seed}")


def _check_resume(
    path: Path, meta: dict[str, Any], saved: TrainConfig, config: TrainConfig, seed: int
) -> None:
    check_same_run(path, meta, saved, config, seed, may_differ=("episodes",))
    if config.episodes < meta["episodes_done"]:
        raise CheckpointError(
            f"{path} already holds {meta['episodes_done']} episodes; resume "
            f"needs episodes >= that, got {config.episodes}"
        )
    if config.noise_until > 0 and config.episodes != saved.episodes:
        raise CheckpointError(
            f"{path}: the start-noise schedule depends on episodes "
            f"({saved.episodes}), so resume cannot change it"
        )


def _restore(path: Path, config: TrainConfig, seed: int, agent: Agent) -> tuple[History, int]:
    meta, arrays, saved = _read_run(path)
    _check_resume(path, meta, saved, config, seed)
    _load_into(agent, arrays, path)
    return History(**meta["history"]), meta["steps"]


def load_agent(run_dir: str | Path) -> tuple[TrainConfig, int, Agent]:
    """The config, seed and trained agent of a run directory."""
    path = Path(run_dir) / CHECKPOINT_FILE
    if not path.exists() and (Path(run_dir) / "summary.json").exists():
        raise FileNotFoundError(
            f"{run_dir} holds several seeds (summary.json): give one of its seed_S directories"
        )
    meta, arrays, config = _read_run(path)
    agent = config.make_agent(seed=meta["seed"])
    _load_into(agent, arrays, path)
    return config, meta["seed"], agent


def evaluate(run_dir: str | Path, episodes: int | None = None, seed: int = 0) -> dict[str, Any]:
    """Greedy episodes of a trained run on its own env settings: episode 0 from rest (the same
    episode as the run's ``greedy_from_rest``), the others with ``config.eval_noise`` start
    noise drawn with ``seed``. Writes and returns ``eval.json``."""
    run_dir = Path(run_dir)
    config, run_seed, agent = load_agent(run_dir)
    episodes = config.eval_episodes if episodes is None else episodes
    if episodes < 1:
        raise ValueError(f"episodes must be >= 1, got {episodes}")
    env = make_env(config)
    history = History()
    for k in range(episodes):
        noise = 0.0 if k == 0 else config.eval_noise
        history.add(
            *greedy_episode(
                env,
                agent,
                tie_stream(run_seed, k),
                seed=episode_seed(seed, k),
                options={"start_noise": noise},
            )
        )
    record = {
        "run": str(run_dir),
        "run_seed": run_seed,
        "eval_seed": seed,
        "config": config.to_dict(),
        "versions": versions(),
        "start_noise": [0.0 if k == 0 else config.eval_noise for k in range(episodes)],
        **history.to_dict(),
    }
    (run_dir / EVAL_FILE).write_text(json.dumps(record, indent=1))
    return record


def _train_one(args: tuple[TrainConfig, int, str, bool, bool]) -> dict[str, Any]:
    config, seed, out_dir, resume, progress = args
    return train(config, seed, out_dir, resume=resume, progress=progress, overwrite=True)


def recent_median(lengths: list[int]) -> float:
    """Median length of the last 20 episodes of ``lengths``."""
    return float(np.median(lengths[-20:]))


def last20_length(record: dict[str, Any]) -> float:
    """Median length of the last 20 training episodes of the learner a run keeps (in a
    population run: the kept learner's, not the last learner's)."""
    pop = record.get("population")
    if pop is not None:
        return float(pop["scores"][pop["kept"]])
    return recent_median(record["episode_lengths"])


def summarize(records: list[dict[str, Any]]) -> dict[str, Any]:
    """Mean and spread across seeds of what a run record reports."""

    def stats(values: list[float]) -> dict[str, float]:
        v = np.asarray(values, dtype=float)
        q25, q50, q75 = np.percentile(v, [25, 50, 75])
        return {
            "mean": float(v.mean()),
            "std": float(v.std()),
            "median": float(q50),
            "q25": float(q25),
            "q75": float(q75),
            "min": float(v.min()),
            "max": float(v.max()),
        }

    greedy = [r["greedy_from_rest"] for r in records if "greedy_from_rest" in r]
    return {
        "seeds": [r["seed"] for r in records],
        "successes": stats([sum(r["episode_successes"]) for r in records]),
        "runs_with_a_success": sum(any(r["episode_successes"]) for r in records),
        "last20_median_length": stats([last20_length(r) for r in records]),
        "greedy_from_rest_length": stats([g["length"] for g in greedy]),
        "greedy_from_rest_successes": sum(g["success"] for g in greedy),
    }


def train_seeds(
    config: TrainConfig,
    seeds: list[int],
    out_dir: str | Path,
    jobs: int = 1,
    resume: bool = False,
    progress: bool = False,
    overwrite: bool = False,
) -> dict[str, Any]:
    """Train one run per seed into ``out_dir/seed_S``, then write ``out_dir/summary.json`` and
    the learning curve across seeds. Tabular SARSA (unshaped) trains all seeds in lockstep on one
    vector env (:func:`train_lockstep`, identical records); Sarsa(lambda) runs one seed per
    process in ``jobs`` processes."""
    out = Path(out_dir)
    if not resume and not overwrite:
        for path in (out, *(out / f"seed_{s}" for s in seeds)):
            check_fresh(path)
    tasks = [(config, s, str(out / f"seed_{s}"), resume, progress and jobs == 1) for s in seeds]
    if config.lockstep:
        # Tabular SARSA: all seeds in lockstep on one batched vector env (same records).
        records = train_lockstep(config, seeds, out, progress=progress, resume=resume)
    elif jobs > 1:
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(max_workers=jobs) as pool:
            records = list(pool.map(_train_one, tasks))
    else:
        records = [_train_one(task) for task in tasks]
    summary = {
        "config": config.to_dict(),
        "versions": versions(),
        **summarize(records),
        "runs": [f"seed_{s}" for s in seeds],
    }
    out.mkdir(parents=True, exist_ok=True)
    (out / "summary.json").write_text(json.dumps(summary, indent=1))
    learning_curve(
        out / CURVE_FILE,
        [r["episode_lengths"] for r in records],
        f"{config.algorithm} ({config.features}), {len(seeds)} seeds",
        _reference(config),
    )
    return summary


def train_lockstep(
    config: TrainConfig,
    seeds: list[int],
    out_dir: str | Path | None = None,
    progress: bool = False,
    greedy: bool = True,
    resume: bool = False,
) -> list[dict[str, Any]]:
    """Train one tabular SARSA learner per seed together, on one :class:`AcrobotVectorEnv`.

    Learner ``k`` sees exactly what ``train(config, seeds[k])`` would show it: its sub-env is
    reset with the same per-episode seed and start noise, and
    :class:`~acrobot_mj.agents.lockstep_sarsa.LockstepSarsa` draws and computes as Sarsa does;
    so the records (and checkpoints) are identical to the single-env trainer's, up to
    ``wall_seconds`` (the training time shared out). Writes ``out_dir/seed_S/`` like
    :func:`train`, with each learner's checkpoint every ``checkpoint_every`` of its episodes, at
    the end and on Ctrl-C; ``resume`` continues from them; ``greedy=False`` skips the final greedy
    run from rest.
    """
    from acrobot_mj.agents.lockstep_sarsa import LockstepSarsa
    from acrobot_mj.vector import AcrobotVectorEnv

    if not config.lockstep:
        raise ValueError(
            "lockstep training is for tabular SARSA (algorithm 'sarsa') without energy "
            f"shaping; train {config.algorithm} (energy_shaping {config.energy_shaping}) with "
            "one process per seed"
        )
    k = len(seeds)
    env_kwargs = config.env_kwargs()
    vec = AcrobotVectorEnv(num_envs=k, autoreset_mode="disabled", **env_kwargs)
    agents = LockstepSarsa(
        config.make_features(), seeds, 3, config.alpha, config.gamma, config.epsilon
    )
    histories = [History() for _ in range(k)]
    episode = np.zeros(k, dtype=np.int64)
    length, total = np.zeros(k, dtype=np.int64), np.zeros(k)
    out = Path(out_dir) if out_dir is not None else None
    if resume:
        if out is None:
            raise ValueError("resume needs the sweep's or run's directory (out_dir)")
        for i, seed in enumerate(seeds):
            path = out / f"seed_{seed}" / CHECKPOINT_FILE
            meta, arrays, saved = _read_run(path)
            _check_resume(path, meta, saved, config, seed)
            agents.load_state(i, arrays)
            histories[i] = History(**meta["history"])
            episode[i] = meta["episodes_done"]
    # Each learner's state after its last completed episode: what its checkpoint holds.
    snapshots: dict[int, tuple] = {}

    def snapshot(i: int) -> None:
        if out is not None:
            steps_i = int(sum(histories[i].episode_lengths))
            snapshots[i] = (agents.state_dict(i), _meta(config, seeds[i], histories[i], steps_i))

    def checkpoint(i: int) -> None:
        if i in snapshots:
            save_checkpoint(out / f"seed_{seeds[i]}" / CHECKPOINT_FILE, *snapshots[i])

    for i in range(k):
        snapshot(i)
    started = time.perf_counter()

    def restart(mask: np.ndarray) -> np.ndarray:
        """Reset the masked sub-envs for their next episode, as train() would."""
        obs = np.zeros((k, 4))
        noises = {config.start_noise_at(int(episode[i])) for i in np.flatnonzero(mask)}
        for noise in noises:  # one reset per distinct noise level (one, without a schedule)
            group = mask & np.array([config.start_noise_at(int(e)) == noise for e in episode])
            seeds_now = [
                episode_seed(seeds[i], int(episode[i])) if group[i] else None for i in range(k)
            ]
            reset_obs, _ = vec.reset(
                seed=seeds_now, options={"reset_mask": group, "start_noise": noise}
            )
            obs[group] = reset_obs[group]
        return obs

    active = episode < config.episodes
    actions = np.ones(k, dtype=np.int64)  # sub-envs of finished learners get no torque
    ids = np.flatnonzero(active)
    actions[ids] = agents.begin_episodes(ids, restart(active)[ids])
    bar = Progress(config.episodes * k, f"lockstep sarsa x{k}", progress)
    try:
        while active.any():
            obs, reward, terminated, truncated, info = vec.step(actions)
            ids = np.flatnonzero(active)
            length[ids] += 1
            total[ids] += reward[ids]
            next_actions = agents.learn(ids, reward[ids], obs[ids], terminated[ids], truncated[ids])
            actions[ids] = np.where(next_actions >= 0, next_actions, 1)
            done = np.zeros(k, dtype=bool)
            done[ids] = terminated[ids] | truncated[ids]
            episode[done] += 1
            for i in np.flatnonzero(done):
                histories[i].add(int(length[i]), float(total[i]), bool(info["is_success"][i]))
                snapshot(i)  # before its next episode draws anything
                if episode[i] % config.checkpoint_every == 0:
                    checkpoint(i)
            length[done], total[done] = 0, 0.0
            active &= episode < config.episodes
            again = done & active
            if again.any():
                actions[again] = agents.begin_episodes(np.flatnonzero(again), restart(again)[again])
            if done.any():
                bar.update(int(episode.sum()), histories[0])
    except KeyboardInterrupt:
        for i in range(k):
            checkpoint(i)
        raise KeyboardInterrupt(
            "interrupted; each learner's checkpoint holds its last completed episode"
        ) from None
    for i in range(k):
        checkpoint(i)
    elapsed = time.perf_counter() - started

    elapsed = time.perf_counter() - started

    records = []
    env = make_env(config)
    for i, seed in enumerate(seeds):
        agent = config.make_agent(seed=seed)
        agent.load_state_dict(agents.state_dict(i))
        record = {
            "config": config.to_dict(),
            "seed": seed,
            "versions": versions(),
            "episodes_done": len(histories[i]),
            "steps": int(sum(histories[i].episode_lengths)),
            "interrupted": False,
            "wall_seconds": elapsed / k,
            "lockstep": k,
            **histories[i].to_dict(),
        }
        if greedy:
            length_g, total_g, success_g = greedy_episode(
                env, agent, tie_stream(seed), seed=seed, options={"start_noise": 0.0}
            )
            record["greedy_from_rest"] = {
                "length": length_g,
                "return": total_g,
                "success": success_g,
            }
        if out_dir is not None:
            run = Path(out_dir) / f"seed_{seed}"
            run.mkdir(parents=True, exist_ok=True)
            save_checkpoint(
                run / CHECKPOINT_FILE,
                agents.state_dict(i),
                _meta(config, seed, histories[i], record["steps"]),
            )
            (run / RUN_FILE).write_text(json.dumps(record, indent=1))
            learning_curve(
                run / CURVE_FILE,
                [histories[i].episode_lengths],
                f"{config.algorithm} ({config.features}), seed {seed}",
                _reference(config),
            )
        records.append(record)
    return records
