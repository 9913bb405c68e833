"""A learner whose policy is a controller (:class:`ControllerLearner`): the state feedback of
``balance --feedback`` and the black box, which ``evaluate``, ``render`` and ``olympics`` take
as a :class:`~acrobot_mj.control.controller.Controller`."""

from __future__ import annotations

from abc import abstractmethod
from typing import Any

from acrobot_mj.control.controller import Controller
from acrobot_mj.train.learners import Learner


class ControllerLearner(Learner):
    """A learner whose policy is a :class:`~acrobot_mj.control.controller.Controller` with no
    clock (``balance --feedback``, the black box): it decides every step of its plan
    (``trajectory.dt``), from any start."""

    trajectory: Any

    @abstractmethod
    def controller(self) -> Controller:
        """The controller, reset before each episode by whoever runs it."""
