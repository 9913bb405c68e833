"""A learner whose policy is a controller (:class:`ControllerLearner`): the state feedback of
``balance --feedback`` and the black box, which ``evaluate``, ``render`` and ``olympics`` take
as a :class:`~acrobot_mj.control.controller.Controller`; and any controller as such a learner
(:class:`ControlledLearner`), for ``evaluate`` and ``render``."""

from __future__ import annotations

from abc import abstractmethod
from pathlib import Path
from typing import Any

import gymnasium as gym

from acrobot_mj.control.controller import Controller
from acrobot_mj.envs.control_loop import BalanceActor
from acrobot_mj.envs.rollout import Actor
from acrobot_mj.envs.tasks import Balance
from acrobot_mj.physics.integrators import steps_in
from acrobot_mj.physics.models import AcrobotModel
from acrobot_mj.train.learners import HeldOut, Learner
from acrobot_mj.train.run import Run


class ControllerLearner(Learner):
    """A learner whose policy is a :class:`~acrobot_mj.control.controller.Controller` with no
    clock (``balance --feedback``, the black box): it decides every step of its plan
    (``trajectory.dt``), from any start."""

    trajectory: Any

    @abstractmethod
    def controller(self) -> Controller:
        """The controller, reset before each episode by whoever runs it."""


class ControlledLearner(ControllerLearner):
    """Any ``controller`` as a learner on the balance task of the acrobot ``model``, with
    continuous torques, the controller told the observation (angles wrapped): what
    ``evaluate`` and ``render`` run for a controller that is not a run, ``name`` in their
    records. Nothing to learn, load or save."""

    describes = "controller"
    protocol = HeldOut(episodes=100, start_noise=0.01, seed=0, starts_from="uniform", seconds=120.0)

    def __init__(self, controller: Controller, model: AcrobotModel, name: str) -> None:
        super().__init__(None, 0)
        self.given, self.model, self.name = controller, model, name
        self.trajectory = None

    def controller(self) -> Controller:
        return self.given

    def learn(self, run: Run) -> dict[str, Any]:
        raise TypeError(f"{self.name} is a controller: there is nothing to learn")

    def env(self, **kwargs: Any) -> gym.Env:
        kwargs.setdefault("max_episode_steps", steps_in(120.0, self.model.params.dt))
        return gym.make(Balance.env_id, continuous=True, model=self.model, **kwargs)

    def actor(self, env: gym.Env, episode: int) -> Actor:
        return BalanceActor(env, self.given, discrete=False, observed=True)

    @classmethod
    def load(cls, run_dir: Path) -> ControlledLearner:
        raise TypeError("a controller is given, not loaded from a run")
