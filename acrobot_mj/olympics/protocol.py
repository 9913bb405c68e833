"""The AI Olympics protocol's constants, levels and draws, as dfki-ric-underactuated-lab/
double_pendulum defines them: leaderboard/acrobot/simulation_v2/{sim_parameters,
calculate_leaderboard_score}.py (performance), leaderboard/acrobot/robustness_v2/
benchmark_controller.py with src/python/double_pendulum/analysis/{benchmark_scores,utils}.py
and simulation/perturbations.py (robustness), leaderboard/acrobot/simulation_v3/ with
src/python/double_pendulum/controller/global_policy_testing_controller.py (global policy).

Their convention: ``theta1`` from hanging, ``theta2`` relative; hanging is ``(0, 0)``, upright
``(pi, 0)``. Ours: ``q1`` from the horizontal, so ``q1 = theta1 - pi/2``, ``q2 = theta2``
(:func:`to_protocol`, :func:`from_protocol`: the one conversion). Their plant takes inertias
about the joint axes; ours are about the centres of mass
(:func:`~acrobot_mj.physics.models.joint_inertias`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from acrobot_mj.physics.models import AcrobotModel, joint_inertias

#: The robustness categories' keys (the protocol's), in the leaderboard's order.
CATEGORY_KEYS = (
    "model",
    "measurement_noise",
    "u_noise",
    "u_responsiveness",
    "delay",
    "perturbation",
)
#: The time step of every protocol episode [s].
DT = 0.002
#: The tip is up above this fraction of the arm's reach ``l1 + l2``.
HEIGHT = 0.9


def episode_times(t_final: float, dt: float = DT) -> np.ndarray:
    """The times (N+1,) [s] of an episode as the protocol's loop makes them: ``t = 0; while t <
    t_final: t += dt``, each time the sum of the steps before it (not ``i * dt``)."""
    if not (isinstance(t_final, (int, float)) and 0 < t_final < math.inf):
        raise ValueError(f"t_final must be a finite number of seconds > 0, got {t_final!r}")
    if not (isinstance(dt, (int, float)) and 0 < dt <= t_final):
        raise ValueError(f"dt must be a number of seconds in (0, t_final], got {dt!r}")
    times, t = [0.0], 0.0
    while t < t_final:
        t += dt
        times.append(t)
    return np.array(times)


def step_count(t_final: float, dt: float = DT) -> int:
    """The number of steps N of an episode of ``t_final`` [s] (:func:`episode_times`)."""
    return len(episode_times(t_final, dt)) - 1


def to_protocol(states: np.ndarray) -> np.ndarray:
    """States (..., 4) in our convention ``(q1, q2, dq1, dq2)`` [rad, rad/s] as the protocol's
    ``(theta1, theta2, dtheta1, dtheta2)``: ``theta1 = q1 + pi/2``; a new array."""
    theirs = np.array(states, dtype=float)
    theirs[..., 0] += math.pi / 2
    return theirs


def from_protocol(states: np.ndarray) -> np.ndarray:
    """The protocol's states (..., 4) in our convention: ``q1 = theta1 - pi/2``; a new array."""
    ours = np.array(states, dtype=float)
    ours[..., 0] -= math.pi / 2
    return ours


def wrap_top(state: np.ndarray) -> np.ndarray:
    """A protocol state (4,) wrapped as its success test wraps it (``wrap_angles_top``):
    ``theta1`` into ``[0, 2 pi)``, ``theta2`` into ``[-pi, pi)``, velocities as they are."""
    wrapped = np.array(state, dtype=float)
    wrapped[0] = wrapped[0] % (2 * np.pi)
    wrapped[1] = (wrapped[1] + np.pi) % (2 * np.pi) - np.pi
    return wrapped


@dataclass(frozen=True)
class Criterion:
    """One performance criterion: its ``name`` (the protocol's key), ``unit``, normalisation
    ``norm`` and ``weight`` in the v2 score."""

    name: str
    unit: str
    norm: float
    weight: float = 1.0


#: The v2 score's criteria, in the order its sum takes them.
CRITERIA = (
    Criterion("swingup_time", "s", 20.0),
    Criterion("energy", "J", 60.0),
    Criterion("tau_cost", "N^2 m^2 s", 20.0),
    Criterion("tau_smoothness", "N m", 0.1),
    Criterion("velocity_cost", "rad^2/s", 400.0),
)


@dataclass(frozen=True)
class Performance:
    """The swing-up leaderboard (simulation_v2): one episode of ``t_final`` [s] from hanging at
    rest, torque limit ``torque_limit`` [N m] at the elbow, scored by ``criteria``."""

    t_final: float = 10.0
    dt: float = DT
    height: float = HEIGHT
    torque_limit: float = 6.0
    criteria: tuple[Criterion, ...] = CRITERIA

    @property
    def steps(self) -> int:
        """The episode's step count N (:func:`step_count`)."""
        return step_count(self.t_final, self.dt)


def get_par_list(x0: float, low: float, high: float, n: int) -> np.ndarray:
    """The protocol's relative levels: ``linspace(low, high, n) * x0`` (``n`` made odd), or
    ``linspace(0, high, n) * x0`` where ``x0`` is 0 (analysis/utils.py)."""
    if x0 != 0:
        n = n + 1 if n % 2 == 0 else n
        return np.linspace(low, high, n) * x0
    return np.linspace(0, high, n) * x0


@dataclass(frozen=True)
class Sweep:
    """One varied ``parameter`` [``unit``] and its ``levels``."""

    parameter: str
    unit: str
    levels: tuple[float, ...]


@dataclass(frozen=True)
class Category:
    """A robustness category: its ``key`` (the protocol's), leaderboard ``title``, ``sweeps``,
    ``repetitions`` (episodes per level) and its rule: ``majority`` counts the levels whose
    success fraction exceeds one half, else the score is the fraction of successful episodes."""

    key: str
    title: str
    sweeps: tuple[Sweep, ...]
    repetitions: int
    majority: bool = False

    @property
    def episodes(self) -> int:
        """Episodes the category runs."""
        return self.repetitions * sum(len(s.levels) for s in self.sweeps)


@dataclass(frozen=True)
class Pulses:
    """Gaussian torque pulses: centres ``mu`` [s], widths ``sigma`` [s] and amplitudes
    ``amplitude`` [N m], each (2, n): row 0 the shoulder, row 1 the elbow."""

    mu: np.ndarray
    sigma: np.ndarray
    amplitude: np.ndarray

    def torques(self, t_max: float, dt: float = DT) -> np.ndarray:
        """The pulse torques (2, M) [N m] at ``arange(0, t_max, dt)`` (the step index
        ``int(t / dt)`` picks a column)."""
        t = np.arange(0, t_max, dt)
        rows = []
        for mu, sigma, amplitude in zip(self.mu, self.sigma, self.amplitude, strict=True):
            gauss = [
                a * np.exp(-np.power(t - m, 2.0) / (2 * s**2.0))
                for m, s, a in zip(mu, sigma, amplitude, strict=True)
            ]
            rows.append(np.sum(gauss, axis=0))
        return np.asarray(rows)

    def to_dict(self) -> dict[str, list[list[float]]]:
        """The pulses as JSON."""
        return {k: getattr(self, k).tolist() for k in ("mu", "sigma", "amplitude")}


@dataclass(frozen=True)
class Perturbations:
    """The perturbation category's draws (get_random_gauss_perturbation_array): ``episodes``
    episodes, ``per_joint`` pulses on each joint ``min_gap`` [s] apart at least, widths in
    ``sigma`` [s], amplitudes of magnitude in ``amplitude`` [N m]."""

    episodes: int = 50
    per_joint: int = 3
    min_gap: float = 1.0
    sigma: tuple[float, float] = (0.05, 0.1)
    amplitude: tuple[float, float] = (0.5, 5.0)

    def __post_init__(self) -> None:
        if self.sigma[0] <= 0.0 or self.sigma[0] > self.sigma[1]:
            raise ValueError(f"sigma must be (low, high) with 0 < low <= high, got {self.sigma}")
        if not 0.0 <= self.amplitude[0] <= self.amplitude[1]:
            raise ValueError(f"amplitude must be (low, high), 0 <= low <= high: {self.amplitude}")

    def draw(self, rng: np.random.Generator, t_max: float) -> Pulses:
        """One episode's pulses over ``t_max`` [s], drawn from ``rng`` in the protocol's order."""
        n = 2 * self.per_joint
        if (n + 1) * self.min_gap > t_max:
            raise ValueError(f"{n} pulses {self.min_gap:g} s apart do not fit in {t_max:g} s")
        wiggle = (t_max - (n + 1) * self.min_gap) / n
        mu: list[float] = []
        for i in range(n):
            mu.append((mu[-1] if i else 0.0) + self.min_gap + rng.random() * wiggle)
        rng.shuffle(mu)
        centres = np.reshape(mu, (2, self.per_joint))
        low, high = self.sigma
        sigma = low + rng.random((2, self.per_joint)) * (high - low)
        span = self.amplitude[1] - self.amplitude[0]
        amplitude = rng.uniform(-span, span, size=(2, self.per_joint))
        amplitude += self.amplitude[0] * np.sign(amplitude)
        return Pulses(centres, sigma, amplitude)


def _linspace(low: float, high: float, n: int) -> tuple[float, ...]:
    return tuple(float(v) for v in np.linspace(low, high, n))


@dataclass(frozen=True)
class Robustness:
    """The robustness leaderboard (robustness_v2): episodes of ``t_final`` [s] from hanging,
    each a success if its final state is within ``epsilon`` of upright at rest (``|theta1 -
    pi|``, ``|theta2|`` [rad], ``|dtheta1|``, ``|dtheta2|`` [rad/s], all strict) after
    :func:`wrap_top`; ``levels`` per sweep; ``noise_repetitions`` episodes a noise level."""

    t_final: float = 10.0
    dt: float = DT
    torque_limit: float = 6.0
    epsilon: tuple[float, float, float, float] = (0.35, 0.35, 1.0, 1.0)
    levels: int = 21
    noise_repetitions: int = 10
    perturbations: Perturbations = field(default_factory=Perturbations)
    #: The sweeps' highest levels: motor inertia [kg m^2], damping [N m s/rad], Coulomb
    #: friction [N m] (both signs), velocity noise [rad/s], torque noise [N m], delay [s]; and
    #: the torque response's range (a fraction per step, no unit).
    motor_inertia: float = 1e-4
    damping: float = 0.1
    friction: float = 0.2
    velocity_noise: float = 0.5
    torque_noise: float = 1.1
    delay: float = 0.04
    response: tuple[float, float] = (0.1, 2.0)

    def model_sweeps(self, model: AcrobotModel) -> tuple[Sweep, ...]:
        """The model category's ten sweeps around ``model``, in the protocol's order: motor
        inertia ``Ir``; ``m1r1`` (sets ``r1 = value / m1``, the inertia about the joint kept);
        ``I1`` about the joint; damping ``b1``; Coulomb friction ``cf1``; then ``m2r2``, ``m2``
        (``r2`` and ``I2`` kept), ``I2``, ``b2``, ``cf2``. The controller keeps ``model``."""
        p, n = model.params, self.levels
        I1, I2 = joint_inertias(model)

        def relative(x0: float) -> tuple[float, ...]:
            return tuple(float(v) for v in get_par_list(x0, 0.75, 1.25, n))

        return (
            Sweep("Ir", "kg m^2", _linspace(0.0, self.motor_inertia, n)),
            Sweep("m1r1", "kg m", relative(p.m1 * p.lc1)),
            Sweep("I1", "kg m^2", relative(I1)),
            Sweep("b1", "N m s/rad", _linspace(-self.damping, self.damping, n)),
            Sweep("cf1", "N m", _linspace(-self.friction, self.friction, n)),
            Sweep("m2r2", "kg m", relative(p.m2 * p.lc2)),
            Sweep("m2", "kg", relative(p.m2)),
            Sweep("I2", "kg m^2", relative(I2)),
            Sweep("b2", "N m s/rad", _linspace(-self.damping, self.damping, n)),
            Sweep("cf2", "N m", _linspace(-self.friction, self.friction, n)),
        )

    def episodes(self, model: AcrobotModel) -> int:
        """How many episodes the six categories around ``model`` take (722 for the protocol)."""
        return sum(category.episodes for category in self.categories(model))

    def categories(self, model: AcrobotModel) -> tuple[Category, ...]:
        """The six categories around the nominal ``model``, in the leaderboard's order."""
        n, reps = self.levels, self.noise_repetitions
        model_key, noise, u_noise, response, delay, perturbation = CATEGORY_KEYS
        pulses = Sweep("pulses per joint", "", (float(self.perturbations.per_joint),))
        return (
            Category(model_key, "Model", self.model_sweeps(model), 1),
            Category(
                noise,
                "Velocity Noise",
                (Sweep("velocity noise sigma", "rad/s", _linspace(0.0, self.velocity_noise, n)),),
                reps,
                majority=True,
            ),
            Category(
                u_noise,
                "Torque Noise",
                (Sweep("torque noise sigma", "N m", _linspace(0.0, self.torque_noise, n)),),
                reps,
                majority=True,
            ),
            Category(
                response,
                "Torque Step Response",
                (Sweep("torque response k", "", _linspace(*self.response, n)),),
                1,
            ),
            Category(
                delay,
                "Time Delay",
                (Sweep("delay (position and velocity)", "s", _linspace(0.0, self.delay, n)),),
                1,
            ),
            Category(perturbation, "Perturbations", (pulses,), self.perturbations.episodes),
        )


#: The versions of the global test's draws (double_pendulum,
#: src/python/double_pendulum/controller/global_policy_testing_controller.py): ``"current"``
#: (commit ff81de3d, May 2025: 10 resets + 1 targets drawn, then the jitters) and
#: ``"icra2025"`` (commit 9bb3a032, which the ICRA 2025 simulation leaderboard ran in April
#: 2025: one target a reset, then the jitters, from numpy's legacy global generator).
GLOBAL_VERSIONS = ("current", "icra2025")

#: The ICRA 2025 acrobot simulation leaderboard's draws: ``(seed, skip)`` by entry, the seed
#: of ``np.random.RandomState`` and the doubles drawn from it before the entry's draw. One
#: process seeded ``np.random.seed(333)`` (double_pendulum 95048f84,
#: leaderboard/acrobot/simulation_v3/sim_parameters.py, as a comment) and ran the entries in
#: turn; each simulation drew normals every step, so each later entry's draw begins that
#: many doubles into the stream. Found by matching the reset times seen in the leaderboard's
#: stored plots (real_ai_gym_leaderboard, data/acrobot/simulation_icra2025/<entry>/
#: timeseries.png): every reset time seen within 0.18 s, against 6 of 15 for seed 777.
ICRA2025_DRAWS = {
    "mcpilco": (333, 0),
    "prx_analytical": (333, 0),
    "VIMPPI": (333, 381_853),
    "AcadosMpc": (333, 764_226),
    "AR-EAPO": (333, 1_146_567),
}


@dataclass(frozen=True)
class GlobalPolicy:
    """The global policy leaderboard (simulation_v3): one episode of ``t_final`` [s] from
    hanging; ``resets`` times (evenly spaced, each moved by up to ``jitter`` [s]) a PID (gains
    ``kp``, ``ki``, ``kd``, its own step ``pid_dt`` [s], both joints clipped to ``torque_limit``
    [N m]) plus gravity compensation drives the arm to a random target for more than
    ``reset_length`` [s]; the score is the time up over ``t_final``. ``version``: how the
    targets and times are drawn (:data:`GLOBAL_VERSIONS`); ``replay``: with ``"icra2025"``,
    an entry of :data:`ICRA2025_DRAWS` whose draw every episode replays (whatever its seed).
    """

    t_final: float = 60.0
    dt: float = DT
    height: float = HEIGHT
    torque_limit: tuple[float, float] = (6.0, 6.0)
    resets: int = 15
    jitter: float = 1.0
    reset_length: float = 0.2
    kp: float = 10.0
    ki: float = 0.1
    kd: float = 1.0
    pid_dt: float = 0.001
    version: str = "current"
    replay: str = ""

    def __post_init__(self) -> None:
        if self.version not in GLOBAL_VERSIONS:
            raise ValueError(
                f"the global test's version must be one of {list(GLOBAL_VERSIONS)}, "
                f"got {self.version!r}"
            )
        if self.replay and (self.version != "icra2025" or self.replay not in ICRA2025_DRAWS):
            raise ValueError(
                f"replay is a draw of the icra2025 version, one of {list(ICRA2025_DRAWS)}; "
                f"got {self.replay!r} with version {self.version!r}"
            )

    @property
    def steps(self) -> int:
        """The episode's step count N (:func:`step_count`)."""
        return step_count(self.t_final, self.dt)

    def draw(self, seed: int) -> tuple[np.ndarray, np.ndarray]:
        """The episode's targets in the protocol's convention (angles uniform in ``[-pi, pi)``;
        (10 resets + 1, 4), velocities 0, or with ``"icra2025"`` (resets, 4), velocities
        uniform in ``[-4 pi, 4 pi)``, which the PID does not use) and its reset times (resets,)
        [s], drawn in the protocol's order: ``"current"`` from ``np.random.default_rng(seed)``,
        ``"icra2025"`` from ``np.random.RandomState(seed)`` (``np.random.seed``), or the
        ``replay`` entry's seed after its skipped doubles."""
        gap = self.t_final / float(self.resets + 1)
        if self.version == "icra2025":
            seed, skip = ICRA2025_DRAWS[self.replay] if self.replay else (seed, 0)
            legacy = np.random.RandomState(seed)
            legacy.random_sample(skip)
            targets = legacy.uniform(0.0, 2 * np.pi, (self.resets, 4)) - np.pi
            targets[:, 2:] *= 4.0
            nominal = np.arange(gap, self.t_final, gap)[: self.resets]  # 15 of 60 s
            return targets, nominal + 2.0 * self.jitter * (legacy.rand(self.resets) - 0.5)
        rng = np.random.default_rng(seed)
        targets = rng.uniform(0.0, 2 * np.pi, (10 * self.resets + 1, 4)) - np.pi
        targets[:, 2:] *= 0.0
        nominal = np.linspace(gap, self.t_final - gap, self.resets)
        return targets, nominal + 2.0 * self.jitter * (rng.random(self.resets) - 0.5)


PERFORMANCE = Performance()
ROBUSTNESS = Robustness()
GLOBAL = GlobalPolicy()
