"""The ``black_box`` preset: a learner told nothing of the acrobot's equations. It explores the
env with random actions, fits a generic model of one decision
(:class:`~acrobot_mj.identify.library.LibraryModel`) and of the reward, takes as its goal the
learnt model's state at rest of highest learnt reward, plans a swing-up to it on the learnt model
(CasADi/IPOPT from a near-zero warm start) and follows it with the state feedback
:class:`~acrobot_mj.control.tracker.PlanTracker`, every gain from the learnt model."""

from __future__ import annotations

import dataclasses
import functools
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

import gymnasium as gym
import numpy as np

from acrobot_mj.checks import check_memory
from acrobot_mj.control.controller import Controller
from acrobot_mj.control.lqr import LQR
from acrobot_mj.control.tracker import PlanTracker
from acrobot_mj.control.trajopt import Arrays, Optimiser, Trajectory, miss, waiting
from acrobot_mj.envs.acrobot import MAX_FRAME_SKIP
from acrobot_mj.envs.control_loop import BalanceActor, assess_from_rest
from acrobot_mj.envs.rollout import Actor
from acrobot_mj.envs.tasks import Balance
from acrobot_mj.files import read_json, write_json
from acrobot_mj.identify.fit import THRESHOLD
from acrobot_mj.identify.library import LibraryModel, best_angles, library_size
from acrobot_mj.identify.terms import HARMONICS
from acrobot_mj.physics.integrators import steps_in
from acrobot_mj.physics.models import (
    AcrobotModel,
    carried_acrobot,
    carry_model,
    table_setting,
)
from acrobot_mj.physics.params import REPORT, AcrobotParams
from acrobot_mj.settings import Settings, setting
from acrobot_mj.train.controller_run import ControllerLearner
from acrobot_mj.train.learners import HeldOut
from acrobot_mj.train.records import MODEL_FILE
from acrobot_mj.train.run import Run

MODEL_FORMAT = "acrobot_mj.black_box_model"
#: What the learner is told, in the run record and the docs.
TOLD = (
    "the env's spaces: a Box action (a number in [-1, 1]) and four observations, the first two "
    "angles wrapped at +-pi; the bounds they declare and the seconds of a decision (env.dt)",
    "the seconds of one physics step, to choose how many make a decision (the frame skip)",
    "the reward of each decision",
    "it may reset the env to a state it names (angles uniform on the circle, at rest)",
)
#: Seed-tree branch of the exploration's draws.
EXPLORATION_BRANCH = 0xB1AC
#: Float64 arrays of the fit's design matrix's size that the fit holds at once (measured).
FIT_COPIES = 3
#: The same for the ODE's fit: four columns' sensitivities, a stage's terms and the solve's.
ODE_FIT_COPIES = 9
#: The ODE is fitted on at most this many transitions (the first): 4,500 fit four shipped
#: acrobots to about 4e-5 rad/s, and each costs about 10 ms of Gauss-Newton (measured).
ODE_TRANSITIONS = 5_000


@dataclass(frozen=True)
class BlackBoxConfig(Settings):
    """Decisions of random exploration in episodes of ``episode_decisions`` (the last tenth
    held out to measure the model), the library's ``harmonics`` and ``threshold``, the share of
    the action bound the plan may use (``reserve``), the plan's horizons ``(start, stop, step)``
    [decisions] and the seconds of each evaluation episode; the acrobot ``model`` (None: the
    report's) and the ``decision_period`` [s] the frame skip is chosen from (:func:`frame_skip`)."""

    decisions: int = setting(
        20_000,
        "decisions of random exploration (at least 10/9 of the library's terms: 900 with 4 "
        "harmonics)",
        low=100,
        metavar="N",
    )
    episode_decisions: int = setting(
        100, "decisions of each exploration episode", low=1, metavar="N"
    )
    harmonics: int = setting(
        HARMONICS, "Fourier harmonics of each angle in the library", low=1, high=8
    )
    threshold: float = setting(
        THRESHOLD, "library terms below this are dropped (SINDy)", low=0.0, high=1.0, cli=False
    )
    reserve: float = setting(
        0.8,
        "share of the action bound the plan may use",
        low=0.0,
        low_open=True,
        high=1.0,
        cli=False,
    )
    horizons: tuple[int, int, int] = setting(
        (440, 800, 40),
        "horizons the plan tries, in decisions of 0.05 s (the same seconds at another decision)",
        "decisions",
        low=1,
        sep=":",
    )
    seconds: float = setting(
        100.0,
        "simulated seconds of each evaluation episode",
        "s",
        low=0.0,
        low_open=True,
        high=86_400.0,
        cli=False,
    )

    model: str | None = setting(
        None,
        "the acrobot to learn: a shipped model's name or a .json/.toml file (default: the "
        "report's)",
        metavar="NAME|FILE",
    )
    model_table: dict | None = table_setting()
    form: str = setting(
        "best",
        "the model's form: map (x' = x + W' phi), rational (x' = x + W' phi / (1 + w' psi(q))), "
        "ode (dx/dt = W' phi / (1 + w' psi(q)) by RK4 over the decision's physics steps) or "
        "best (the map or the ODE, whichever predicts the held-out tenth better)",
        choices=("best", "map", "rational", "ode"),
    )
    decision_period: float = setting(
        REPORT.dt,
        "shortest decision: the env steps the physics the most whole times within it (once at "
        "least)",
        "s",
        low=0.0,
        low_open=True,
        high=10.0,
    )

    what = "black-box"

    def __post_init__(self) -> None:
        super().__post_init__()
        carry_model(self)

    @property
    def acrobot(self) -> AcrobotModel:
        """The acrobot it learns, a file's as the run read it (``model_table``)."""
        return carried_acrobot(self.model, self.model_table)


def fitted_share(decisions: int) -> int:
    """How many of ``decisions`` transitions the model is fitted on: all but the last tenth."""
    return int(0.9 * decisions)


def fewest_decisions(harmonics: int, form: str = "map") -> int:
    """The fewest decisions whose fitted share holds as many transitions as the ``form``'s
    library has terms."""
    terms = library_size(harmonics, form)
    least = math.ceil(terms / 0.9)
    while fitted_share(least) < terms:
        least += 1
    return least


def check_fit(config: BlackBoxConfig) -> None:
    """Refuse, before any work, a fit that cannot be: fewer decisions than the library's terms
    need, or more than free memory holds."""
    terms = library_size(config.harmonics, config.form)
    least = fewest_decisions(config.harmonics, config.form)
    if config.decisions < least:
        raise ValueError(
            f"config decisions must be >= {least} with {config.harmonics} harmonics and form "
            f"{config.form} (the fit's {terms} terms need as many transitions besides the "
            f"held-out tenth), got {config.decisions}"
        )
    size = FIT_COPIES * 8.0 * terms * config.decisions
    if config.form in ("best", "ode"):
        size = max(size, ODE_FIT_COPIES * 8.0 * terms * min(config.decisions, ODE_TRANSITIONS))
    check_memory(f"the black box's fit of {config.decisions:,} decisions", size)


def frame_skip(physics_seconds: float, decision: float) -> int:
    """The physics steps of one decision: the most whole steps of ``physics_seconds`` within
    ``decision`` seconds, at least one (1 for the report's 0.05 s, 5 for dm_control's 0.01 s, 25
    for RealAIGym's 0.002 s; 1 for Gymnasium's 0.2 s)."""
    return max(1, min(MAX_FRAME_SKIP, math.floor(decision / physics_seconds + 1e-9)))


def black_box_env(config: BlackBoxConfig | None = None, **kwargs: Any) -> gym.Env:
    """The balance task with a Box action on ``config``'s acrobot, each decision
    :func:`frame_skip` physics steps: the only env the learner sees."""
    config = config or BlackBoxConfig()
    if config.model is not None:
        kwargs = {"model": config.model if config.model_table is None else config.acrobot, **kwargs}
    skip = frame_skip(config.acrobot.params.dt, config.decision_period)
    if skip > 1:
        kwargs = {"frame_skip": skip, **kwargs}
    return gym.make(Balance.env_id, continuous=True, **kwargs)


def explore(env: gym.Env, config: BlackBoxConfig, seed: int) -> dict[str, np.ndarray]:
    """``decisions`` random actions, ``U(low, high)``, in episodes from both angles uniform on the
    circle at rest: ``states``, ``actions``, ``next_states`` (observations) and ``rewards``."""
    rng = np.random.default_rng(np.random.SeedSequence([seed, EXPLORATION_BRANCH]))
    box = env.action_space
    if not isinstance(box, gym.spaces.Box) or box.shape != (1,):
        raise ValueError(f"the black-box learner needs a Box action of one number, got {box}")
    rows: dict[str, list] = {"states": [], "actions": [], "next_states": [], "rewards": []}
    while len(rows["actions"]) < config.decisions:
        start = [*rng.uniform(-np.pi, np.pi, 2), 0.0, 0.0]
        obs, _ = env.reset(seed=int(rng.integers(2**31)), options={"state": start})
        for _ in range(min(config.episode_decisions, config.decisions - len(rows["actions"]))):
            action = rng.uniform(box.low, box.high).astype(box.dtype)
            nxt, reward, terminated, truncated, _ = env.step(action)
            for name, value in zip(rows, (obs, action[0], nxt, reward), strict=True):
                rows[name].append(value)
            obs = nxt
            if terminated or truncated:
                break
    return {name: np.asarray(values, dtype=np.float64) for name, values in rows.items()}


def fit_model(
    train: dict[str, np.ndarray], held: dict[str, np.ndarray], config: BlackBoxConfig, env: gym.Env
) -> LibraryModel:
    """The config's form of model fitted to ``train``; with ``best``, the map and the ODE whose
    RK4 substeps are the decision's physics steps (the learner is told their seconds; fitted on
    the first :data:`ODE_TRANSITIONS`), whichever predicts ``held`` with the smaller largest RMS
    error."""
    fields = ("states", "actions", "next_states")
    skip = int(env.unwrapped.frame_skip)  # type: ignore[attr-defined]
    ode = (skip, decision_seconds(env) / skip)
    fits: dict[str, Callable[..., LibraryModel]] = {
        "map": LibraryModel.fit,
        "rational": LibraryModel.fit_rational,
        "ode": functools.partial(LibraryModel.fit, ode=ode),
    }
    rows = {"map": slice(None), "rational": slice(None), "ode": slice(ODE_TRANSITIONS)}
    forms = ["map", "ode"] if config.form == "best" else [config.form]
    fitted = [
        fits[f](
            train["states"][rows[f]],
            train["actions"][rows[f]],
            train["next_states"][rows[f]],
            config.harmonics,
            config.threshold,
        )
        for f in forms
    ]
    return min(fitted, key=lambda m: max(m.errors(*(held[k] for k in fields))["rms"]))


def decision_seconds(env: gym.Env) -> float:
    """The simulated seconds of one decision, as every Gymnasium MuJoCo env states (``dt``)."""
    return float(env.unwrapped.dt)  # type: ignore[attr-defined]


def limits_of(env: gym.Env) -> AcrobotParams:
    """The bounds the env's spaces declare: the action's and the velocities' [rad/s], and the
    decision's seconds; the planner's ``p`` (its masses and lengths are never read)."""
    box, seen = cast(gym.spaces.Box, env.action_space), cast(gym.spaces.Box, env.observation_space)
    return AcrobotParams(
        max_torque=float(box.high[0]),
        max_vel1=float(seen.high[2]),
        max_vel2=float(seen.high[3]),
        dt=decision_seconds(env),
    )


#: The decision [s] the horizons are counted in: the report's.
HORIZON_DECISION = REPORT.dt


def plan_horizons(horizons: tuple[int, int, int], dt: float) -> list[int]:
    """The horizons ``range(*horizons)`` counted in decisions of :data:`HORIZON_DECISION`, as
    decisions of ``dt`` seconds (the same seconds, rounded; each once): unchanged at 0.05 s, a
    quarter at Gymnasium's 0.2 s."""
    scale = HORIZON_DECISION / dt
    return list(dict.fromkeys(max(1, round(h * scale)) for h in range(*horizons)))


def swing_up(
    model: LibraryModel,
    start: np.ndarray,
    goal: np.ndarray,
    config: BlackBoxConfig,
    limits: AcrobotParams,
) -> Trajectory:
    """The first swing-up to ``goal`` (or it with ``q2 +- 2 pi``) that IPOPT finds on ``model``
    (an ODE by one RK4 step per decision:
    :meth:`~acrobot_mj.identify.library.LibraryModel.coarse`) from ``start``, over the config's
    horizons. Each is warm-started from the model's rollout of tiny random actions
    (:meth:`~acrobot_mj.control.trajopt.Optimiser.tiny_torques`), then, if that fails, from the
    nearest path found so far led by a wait at the start
    (:func:`~acrobot_mj.control.trajopt.waiting`; a continuation in the horizon)."""
    bound, at = config.reserve * limits.max_torque, tuple(float(v) for v in start)
    optimiser = Optimiser(bound, "learned", limits, model.coarse(), at)
    goals = [goal + np.array([0.0, turn, 0.0, 0.0]) for turn in (0.0, 2 * np.pi, -2 * np.pi)]
    nearest: tuple[float, Arrays, np.ndarray] | None = None  # (miss, path, its target)
    for horizon in plan_horizons(config.horizons, limits.dt):
        tries = [(optimiser.tiny_torques(horizon), goals)]
        if nearest is not None:
            tries.append((waiting(*nearest[1], horizon), [nearest[2]]))
        for warm, targets in tries:
            for target in targets:
                near, found = optimiser.reach(target, warm)
                if found is not None:
                    return optimiser.trajectory(found)
                off = miss(near[0], target)
                if nearest is None or off < nearest[0]:
                    nearest = (off, near, target)
    raise ValueError(f"no swing-up found on the learnt model over horizons {config.horizons}")


def finite_or_none(value: Any) -> Any:
    """``value``, or None for an infinite bound (a velocity limit a model does not have): JSON
    holds no infinity."""
    return None if isinstance(value, float) and math.isinf(value) else value


class BlackBoxLearner(ControllerLearner):
    """Learns a model from the env's observations, actions and rewards only, then plans and
    follows a funnel on it (``learn``); acts through that state feedback, with no clock."""

    kind, kind_name = "black_box", "black-box"
    describes = "black box: learnt model, planned funnel, constrained LQR"
    protocol = HeldOut(episodes=100, start_noise=0.01, seed=0, seconds=100.0)

    def __init__(
        self,
        config: BlackBoxConfig,
        seed: int,
        env: gym.Env | None = None,
        built: tuple[LibraryModel, Trajectory] | None = None,
    ) -> None:
        super().__init__(config, seed)
        self.given_env = env
        self.model: LibraryModel | None = None
        self.trajectory: Trajectory | None = None
        if built is not None:
            self.model, self.trajectory = built
        else:
            check_fit(config)
        self.tracker = None if built is None else self._tracker()

    def _tracker(self) -> PlanTracker:
        """The funnel on the learnt model; elsewhere the LQR of the learnt model's state at rest
        nearest the plan's start (hanging), which brings it back to where the funnel begins."""
        assert self.model is not None and self.trajectory is not None
        t, linear = self.trajectory, self.model.jacobians
        rest = self.model.equilibrium(t.states[0, :2])
        elsewhere = LQR(p=t.params, target=rest, linear=linear)
        return PlanTracker([t], fallback=elsewhere, linear=linear, step=self.model.step)

    def controller(self) -> Controller:
        """The controller, on the observation (angles wrapped)."""
        assert self.tracker is not None
        return self.tracker

    def learn(self, run: Run) -> dict[str, Any]:
        config, clock = self.config, time.perf_counter()
        env = self.given_env if self.given_env is not None else black_box_env(config)
        data = explore(env, config, self.seed)
        cut = fitted_share(len(data["actions"]))
        train, held = ({k: v[s] for k, v in data.items()} for s in (slice(cut), slice(cut, None)))
        fields = ("states", "actions", "next_states")
        self.model = fit_model(train, held, config, env)
        angles, reward_rms = best_angles(train["next_states"], train["rewards"], config.harmonics)
        goal = self.model.equilibrium(angles)
        start = env.reset(seed=self.seed)[0]
        fitted = time.perf_counter()
        self.trajectory = swing_up(self.model, start, goal, config, limits_of(env))
        planned = time.perf_counter()
        self.tracker = self._tracker()
        rest = self.greedy(env)
        simulated = len(data["actions"]) * decision_seconds(env)
        measured = {
            "task": Balance.name,
            "told": list(TOLD),
            "data": {
                "decisions": len(data["actions"]),
                "simulated_seconds": simulated,
                "held_out": len(held["actions"]),
            },
            "model": {
                "form": self.model.form,
                "terms": self.model.terms,
                "held_out_errors": self.model.errors(*(held[k] for k in fields)),
                "reward_rms": reward_rms,
                "goal": goal.tolist(),
            },
            "swing_up": {"decisions": self.trajectory.steps, "seconds": self.trajectory.seconds},
            "greedy_from_rest": rest,
            "fit_seconds": fitted - clock,
            "plan_seconds": planned - fitted,
            "wall_seconds": time.perf_counter() - clock,
        }
        return self.keep(run, measured)

    def save(self, out: Path) -> None:
        write_json(out / MODEL_FILE, self.model_record())

    def greedy(self, env: gym.Env) -> dict[str, Any]:
        """The task's assessment of one episode from rest (the env's own start) in ``env``."""
        dt = decision_seconds(env)
        limited = gym.wrappers.TimeLimit(env, steps_in(self.config.seconds, dt))
        actor = BalanceActor(limited, self.controller(), discrete=False, observed=True)
        return assess_from_rest(limited, actor, self.seed)

    def model_record(self) -> dict[str, Any]:
        assert self.model is not None and self.trajectory is not None
        t = self.trajectory
        return {
            "format": MODEL_FORMAT,
            "library": self.model.to_dict(),
            "limits": {k: finite_or_none(v) for k, v in dataclasses.asdict(t.params).items()},
            "u_max": t.u_max,
            "states": t.states.tolist(),
            "actions": t.torques.tolist(),
        }

    def env(self, **kwargs: Any) -> gym.Env:
        assert self.trajectory is not None
        steps = steps_in(self.config.seconds, self.trajectory.dt)
        return black_box_env(self.config, **{"max_episode_steps": steps, **kwargs})

    def actor(self, env: gym.Env, episode: int) -> Actor:
        return BalanceActor(env, self.controller(), discrete=False, observed=True)

    @classmethod
    def load(cls, run_dir: Path) -> BlackBoxLearner:
        record = cls.read_run(run_dir)
        path = Path(run_dir) / MODEL_FILE
        try:
            data = read_json(path)
            if data.get("format") != MODEL_FORMAT:
                raise ValueError(f"not a black-box model (format {data.get('format')!r})")
            model = LibraryModel.from_dict(data["library"])
            limits = AcrobotParams(
                **{k: math.inf if v is None else v for k, v in data["limits"].items()}
            )
            trajectory = Trajectory(
                np.asarray(data["states"], dtype=float),
                np.asarray(data["actions"], dtype=float),
                limits.dt,
                "learned",
                float(data["u_max"]),
                limits,
            )
        except (OSError, ValueError, KeyError, TypeError, AttributeError) as error:
            raise ValueError(f"{path} is not a usable black-box model: {error}") from None
        config = BlackBoxConfig.from_dict(record["config"])
        return cls(config, int(record["seed"]), built=(model, trajectory))
