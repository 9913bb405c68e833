"""Other libraries' controllers, adapted at the boundary once to this package's
:class:`~acrobot_mj.control.controller.Controller`: an object in ``double_pendulum``'s
convention (:class:`TheirConvention`) and a Stable-Baselines3 policy file
(:func:`sb3_policy`)."""

from __future__ import annotations

import json
import zipfile
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import gymnasium as gym
import numpy as np

from acrobot_mj.control.controller import Controller, Held
from acrobot_mj.envs.acrobot import AcrobotEnv, observation
from acrobot_mj.envs.spaces import action_torque, cos_sin
from acrobot_mj.olympics.protocol import to_protocol
from acrobot_mj.physics.params import AcrobotParams


@runtime_checkable
class DoublePendulumController(Protocol):
    """What ``double_pendulum``'s simulator asks of a controller (its ``AbstractController``):
    ``get_control_output(x, t)``, ``x`` its state ``(theta1, theta2, dtheta1, dtheta2)``
    [rad, rad/s] with ``theta1`` from hanging, the torques ``[u1, u2]`` [N m] out."""

    def get_control_output(self, x: Any, t: Any = None) -> Any: ...


@runtime_checkable
class Initialised(Protocol):
    """An object with ``init()``."""

    def init(self) -> Any: ...


@runtime_checkable
class Resettable(Protocol):
    """An object with ``reset()``."""

    def reset(self) -> Any: ...


class TheirConvention(Controller):
    """``theirs`` (a :class:`DoublePendulumController`) as a controller: it sees what is
    observed in its convention (:func:`~acrobot_mj.olympics.protocol.to_protocol`) and gives
    ``[u1, u2]``, of which the acrobot's elbow takes ``u2`` (its shoulder has no motor, as the
    protocol's plant with a zero shoulder limit). Before each episode ``init()`` is called where
    it exists, as the protocol's own benchmark calls it, else ``reset()`` where that exists;
    an ``AbstractController``'s ``reset()`` also restores its filter and compensation to their
    defaults, so it is not called where ``init()`` is."""

    def __init__(self, theirs: DoublePendulumController) -> None:
        self.theirs = theirs

    def reset(self, seed: int | None = None) -> None:
        if isinstance(self.theirs, Initialised):
            self.theirs.init()
        elif isinstance(self.theirs, Resettable):
            self.theirs.reset()

    def act(self, x: np.ndarray, t: float) -> float:
        u = np.asarray(self.theirs.get_control_output(to_protocol(x), t), dtype=float)
        if u.shape != (2,):
            raise ValueError(
                f"get_control_output must give the torques [u1, u2], got shape {u.shape}"
            )
        return float(u[1])


def policy_algorithm(path: Path) -> Any:
    """The Stable-Baselines3 (or sb3-contrib) algorithm class that saved the policy file
    ``path``, read from its ``data`` (the policy class's module, ``<package>.<algo>.policies``)."""
    try:
        with zipfile.ZipFile(path) as archive:
            data = json.loads(archive.read("data"))
        module = data["policy_class"]["__module__"]
    except (OSError, KeyError, TypeError, ValueError, zipfile.BadZipFile) as error:
        raise ValueError(f"{path} is not a Stable-Baselines3 policy file: {error}") from None
    package, _, rest = module.partition(".")
    algorithm = rest.partition(".")[0].upper()
    try:
        found = getattr(__import__(package), algorithm)
    except (ImportError, AttributeError):
        raise ValueError(
            f"{path} was saved by {package}'s {algorithm}, which cannot be imported here "
            "(pip install stable-baselines3, or the package that saved it)"
        ) from None
    return found


class PolicyController(Controller):
    """A Stable-Baselines3 ``policy`` acting through ``env`` (an acrobot env of this package):
    the env's observation of the state (its angles wrapped; float32 ``cos``/``sin`` for a
    ``"cos_sin"`` env), the deterministic action, and the env's torque of that action."""

    def __init__(self, policy: Any, env: AcrobotEnv) -> None:
        self.policy = policy
        self.cos_sin = env.observation == "cos_sin"
        self.continuous, self.torques = env.continuous, env.torque_limit

    def act(self, x: np.ndarray, t: float) -> float:
        obs = observation(*(float(v) for v in x))
        if obs is None:
            raise ValueError(f"the policy cannot observe the state {np.asarray(x).tolist()}")
        action, _ = self.policy.predict(cos_sin(obs) if self.cos_sin else obs, deterministic=True)
        return action_torque(action, self.continuous, self.torques)


def sb3_policy(
    path: str | Path, env_id: str, env_kwargs: dict[str, Any], params: AcrobotParams
) -> Held:
    """The policy saved at ``path``, trained on ``gymnasium.make(env_id, **env_kwargs)``, as a
    controller of the acrobot ``params`` (the env's own): it decides every ``frame_skip``
    physics steps and holds its torque in between; one line where the file or the env does
    not fit."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"no policy file at {path}")
    algorithm = policy_algorithm(path)
    try:
        with gym.make(env_id, **env_kwargs) as made:
            env = made.unwrapped
    except gym.error.Error as error:
        raise ValueError(f"--env {env_id}: {error}") from None
    if not isinstance(env, AcrobotEnv):
        raise ValueError(f"--env {env_id} is not an acrobot env of this package")
    if env.params != params:
        raise ValueError(
            f"--env {env_id} with {env_kwargs} is another acrobot than the one scored: give "
            "its model in --env-kwargs '{\"model\": ...}'"
        )
    policy = algorithm.load(path, device="cpu")
    return Held(PolicyController(policy, env), params.max_torque, env.frame_skip)
