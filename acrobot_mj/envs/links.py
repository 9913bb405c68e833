"""An acrobot's links in its MuJoCo model, read and written by name: each link's mass [kg], the
distance [m] from its joint to its centre of mass along the link, and its inertia [kg m^2]
about its centre of mass, about the hinge axis (the body's second principal axis; the other two
follow it in proportion). The one writer of these: a perturbed model
(:class:`~acrobot_mj.envs.disturbances.Disturbances`), a balance run's scaled links and the
protocol's model errors (:class:`~acrobot_mj.envs.model_error.ModelError`)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import gymnasium as gym
import mujoco

#: The links' bodies in the MJCF.
LINKS = ("link1", "link2")
#: The names a record gives the links' masses [kg] and inertias [kg m^2].
LINK_PARAMETERS = ("m1", "m2", "I1", "I2")


def read_link(model: mujoco.MjModel, k: int) -> tuple[float, float, float]:
    """Link ``k``'s (1 or 2) mass [kg], centre of mass from its joint [m] and inertia about its
    centre of mass [kg m^2]."""
    body = model.body(LINKS[k - 1])
    return float(body.mass[0]), float(body.ipos[0]), float(body.inertia[1])


def write_link(model: mujoco.MjModel, k: int, mass: float, centre: float, inertia: float) -> None:
    """Give link ``k`` (1 or 2) ``mass`` [kg], its centre of mass ``centre`` [m] from its joint
    and ``inertia`` [kg m^2] about it; the other principal inertias scale with the hinge
    axis's (all three set where it was 0)."""
    body = model.body(LINKS[k - 1])
    before = float(body.inertia[1])
    if before != 0.0:
        model.body_inertia[body.id] *= inertia / before
    else:
        model.body_inertia[body.id] = inertia
    model.body_inertia[body.id, 1] = inertia
    model.body_mass[body.id] = mass
    model.body_ipos[body.id, 0] = centre


def acrobot_under(env: gym.Env, wrapper: str) -> Any:
    """``env.unwrapped``, refused in one line unless it is a MuJoCo acrobot (an
    :class:`~acrobot_mj.envs.acrobot.AcrobotEnv`, its ``model``, ``data`` and ``state``),
    which the disturbance ``wrapper`` changes (Gymnasium's own ``Acrobot-v1`` has none)."""
    acrobot = env.unwrapped
    model = getattr(acrobot, "model", None)
    if not isinstance(model, mujoco.MjModel) or not hasattr(acrobot, "state"):
        raise TypeError(
            f"{wrapper} wraps an acrobot-mj env (a MuJoCo acrobot), got "
            f"{type(acrobot).__module__}.{type(acrobot).__name__}"
        )
    return acrobot


def _model(env: gym.Env) -> mujoco.MjModel:
    return env.unwrapped.model  # type: ignore[attr-defined]


def model_parameters(env: gym.Env) -> dict[str, float]:
    """The masses [kg] and inertias about the centres of mass [kg m^2] of ``env``'s links, by
    :data:`LINK_PARAMETERS`."""
    values = {}
    for k in (1, 2):
        values[f"m{k}"], _, values[f"I{k}"] = read_link(_model(env), k)
    return values


def set_model_parameters(env: gym.Env, values: Mapping[str, float]) -> None:
    """Give ``env``'s links the masses and inertias ``values`` (:data:`LINK_PARAMETERS`)."""
    for k in (1, 2):
        _, centre, _ = read_link(_model(env), k)
        write_link(_model(env), k, values[f"m{k}"], centre, values[f"I{k}"])


def scale_links(env: gym.Env, mass_scale: float, inertia_scale: float) -> None:
    """Scale the mass and the inertias of each of ``env``'s links."""
    values = model_parameters(env)
    set_model_parameters(
        env,
        {
            name: value * (mass_scale if name.startswith("m") else inertia_scale)
            for name, value in values.items()
        },
    )
