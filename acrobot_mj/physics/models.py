"""Any acrobot: :class:`AcrobotModel` is one robot (its rigid bodies as
:class:`~acrobot_mj.physics.params.AcrobotParams`, the actuated joint, joint losses, motor inertia
and integrator); :data:`MODELS` holds the shipped sets by name, :func:`resolve` reads a name, a
JSON or TOML file, or a model. The MJCF is generated from a model by
:mod:`acrobot_mj.envs.mjcf`."""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Mapping
from dataclasses import asdict, dataclass, fields, replace
from pathlib import Path
from typing import Any, TypeAlias

from acrobot_mj.checks import check_float, shown_number
from acrobot_mj.physics.integrators import ENV_INTEGRATORS
from acrobot_mj.physics.params import REPORT, AcrobotParams
from acrobot_mj.settings import SettingError, setting

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

#: The joints an acrobot's one motor may drive: ``"elbow"`` (an acrobot), ``"shoulder"`` (a
#: pendubot).
JOINTS = ("shoulder", "elbow")
Pair = tuple[float, float]


@dataclass(frozen=True)
class AcrobotModel:
    """One acrobot: ``params`` (masses, lengths, centres of mass, inertias about the centres of
    mass, gravity, torque and speed limits, time step), the ``actuated`` joint, per-joint
    (shoulder, elbow) viscous ``damping`` [N m s/rad], Coulomb ``friction`` [N m] and
    ``motor_inertia`` [kg m^2] (MuJoCo's armature), and the ``integrator`` its MJCF names (an
    env's name)."""

    params: AcrobotParams = REPORT
    actuated: str = "elbow"
    damping: Pair = (0.0, 0.0)
    friction: Pair = (0.0, 0.0)
    motor_inertia: Pair = (0.0, 0.0)
    integrator: str = "euler"

    def __post_init__(self) -> None:
        if not isinstance(self.params, AcrobotParams):
            raise TypeError(f"AcrobotModel.params must be AcrobotParams, got {self.params!r}")
        if self.actuated not in JOINTS:
            raise ValueError(f"actuated must be one of {JOINTS}, got {self.actuated!r}")
        if self.integrator not in ENV_INTEGRATORS:
            names = list(ENV_INTEGRATORS)
            raise ValueError(f"integrator must be one of {names}, got {self.integrator!r}")
        for name in ("damping", "friction", "motor_inertia"):
            pair = getattr(self, name)
            if not isinstance(pair, tuple) or len(pair) != 2 or not all(map(_loss, pair)):
                shown = ", ".join(map(shown_number, pair)) if isinstance(pair, tuple) else pair
                raise ValueError(f"{name} must be two numbers in [0, 1e6], got ({shown})")

    def to_dict(self) -> dict[str, Any]:
        """The model as flat keys, as :func:`model_from_dict` reads them (an infinite velocity
        limit, which JSON cannot hold, as None)."""
        flat = {**asdict(self.params), **asdict(self)}
        del flat["params"]
        return {k: None if v == math.inf else v for k, v in flat.items()}

    @property
    def analytic(self) -> AcrobotParams:
        """The parameters the analytic model takes (:mod:`acrobot_mj.physics.dynamics`): refused
        in one line for a model it cannot represent (a driven shoulder, damping, friction or
        motor inertia)."""
        losses = {n: getattr(self, n) for n in ("damping", "friction", "motor_inertia")}
        extra = [f"{n} {v}" for n, v in losses.items() if any(v)]
        if self.actuated != "elbow":
            extra.insert(0, f"the {self.actuated} actuated")
        if extra:
            raise ValueError(
                "the analytic model is a rigid acrobot driven at the elbow; this model has "
                + ", ".join(extra)
            )
        return self.params


def _loss(value: Any) -> bool:
    """Whether ``value`` is a joint loss or motor inertia this project takes: a real number in
    [0, 1e6] (past that no acrobot moves)."""
    try:
        check_float("a loss", value, 0.0, 1e6)
    except (TypeError, ValueError):
        return False
    return True


def joint_inertias(model: AcrobotModel) -> tuple[float, float]:
    """The links' inertias about their joint axes [kg m^2], as the protocol's plant takes them:
    ours (about the centres of mass) plus ``m lc^2``."""
    p = model.params
    return p.I1 + p.m1 * p.lc1**2, p.I2 + p.m2 * p.lc2**2


def _gymnasium() -> AcrobotModel:
    # Farama-Foundation/Gymnasium, gymnasium/envs/classic_control/acrobot.py: LINK_LENGTH_1/2 =
    # 1, LINK_MASS_1/2 = 1, LINK_COM_POS_1/2 = 0.5, LINK_MOI = 1 (about the centre of mass: its
    # _dsdt adds I1 + I2 to m1 lc1^2 + m2 (...)), g = 9.8, MAX_VEL_1/2 = 4 pi, 9 pi, torques
    # -1, 0, +1, dt = 0.2 by one RK4 step; the report's bodies, so only dt and RK4 differ.
    return AcrobotModel(replace(REPORT, dt=0.2), integrator="rk4")


def capsule_inertia(mass: float, radius: float, length: float) -> float:
    """A solid capsule's moment of inertia [kg m^2] about an axis through its centre across it:
    ``mass`` [kg] spread by volume over the cylinder of ``length`` [m] and two hemispheres of
    ``radius`` [m] (MuJoCo's inertia of a capsule geom)."""
    cylinder, spheres = math.pi * radius**2 * length, 4.0 / 3.0 * math.pi * radius**3
    m_cylinder = mass * cylinder / (cylinder + spheres)
    m_spheres = mass - m_cylinder
    return m_cylinder * (3 * radius**2 + length**2) / 12 + m_spheres * (
        2 * radius**2 / 5 + length**2 / 4 + 3 * length * radius / 8
    )


def _dm_control() -> AcrobotModel:
    # google-deepmind/dm_control, dm_control/suite/acrobot.xml: two capsules fromto 0 .. 1 m of
    # mass 1 kg (geom default), radii 0.05 m (upper_arm) and 0.049 m (lower_arm), the
    # decoration cylinder mass 0; joint damping 0.05; motor gear 2, ctrlrange [-1, 1] (so 2 N m
    # at the elbow); timestep 0.01 s, RK4; MuJoCo's gravity 9.81. No velocity limits.
    params = AcrobotParams(
        I1=capsule_inertia(1.0, 0.05, 1.0),
        I2=capsule_inertia(1.0, 0.049, 1.0),
        g=9.81,
        max_torque=2.0,
        max_vel1=math.inf,
        max_vel2=math.inf,
        dt=0.01,
    )
    return AcrobotModel(params, damping=(0.05, 0.05), integrator="rk4")


def _ai_olympics(actuated: str) -> AcrobotModel:
    # dfki-ric-underactuated-lab/double_pendulum, data/system_identification/
    # identified_parameters/design_C.1/model_1.0/model_parameters.yml (m, l, r, I, g). Its plant
    # (src/python/double_pendulum/model/plant.py, "UnderactuatedLecture" formulas: M22 = I2)
    # takes I about the joint axes, so I about the centre of mass is I - m r^2. The AI Olympics
    # leaderboards: torque limit 6 N m, damping, Coulomb friction and motor inertia 0, RK4 at
    # dt = 0.002 s. No velocity limits.
    m1, m2, r1, r2 = 0.5234602302310271, 0.6255677234174437, 0.2, 0.25569305436052964
    params = AcrobotParams(
        l1=0.2,
        l2=0.3,
        lc1=r1,
        lc2=r2,
        m1=m1,
        m2=m2,
        I1=0.031887199591513114 - m1 * r1**2,
        I2=0.05086984812807257 - m2 * r2**2,
        g=9.81,
        max_torque=6.0,
        max_vel1=math.inf,
        max_vel2=math.inf,
        dt=0.002,
    )
    return AcrobotModel(params, actuated=actuated, integrator="rk4")


#: What names an acrobot: a name in :data:`MODELS`, a JSON or TOML file, a model or its
#: parameters; ``None`` is the report's (:func:`resolve`).
ModelSpec: TypeAlias = str | Path | Mapping[str, Any] | AcrobotModel | AcrobotParams | None

#: The shipped parameter sets by name; ``"report"`` is the default everywhere.
MODELS: dict[str, AcrobotModel] = {
    "report": AcrobotModel(),
    "gymnasium": _gymnasium(),
    "dm_control": _dm_control(),
    "ai_olympics": _ai_olympics("elbow"),
    "ai_olympics_pendubot": _ai_olympics("shoulder"),
}


def model_from_dict(data: dict[str, Any], where: str = "model") -> AcrobotModel:
    """A model from flat keys: the fields of
    :class:`~acrobot_mj.physics.params.AcrobotParams` and of :class:`AcrobotModel`
    (``damping``, ``friction``, ``motor_inertia`` as two numbers); a missing key is the
    report's."""
    params = {f.name for f in fields(AcrobotParams)}
    own = {f.name for f in fields(AcrobotModel)} - {"params"}
    unknown = sorted(set(data) - params - own)
    if unknown:
        raise ValueError(f"{where}: unknown keys {unknown}; known: {sorted(params | own)}")
    mine: dict[str, Any] = {k: tuple(v) if isinstance(v, list) else v for k, v in data.items()}
    try:
        # None: no velocity limit (to_dict's inf, which JSON cannot hold)
        limits = {k: math.inf for k in ("max_vel1", "max_vel2") if k in data and data[k] is None}
        p = AcrobotParams(**{k: v for k, v in data.items() if k in params} | limits)
        return AcrobotModel(p, **{k: v for k, v in mine.items() if k in own})
    except (TypeError, ValueError) as error:
        raise ValueError(f"{where}: {error}") from None


def resolve(model: ModelSpec) -> AcrobotModel:
    """A model from a name in :data:`MODELS`, a ``.json`` or ``.toml`` file or the table such a
    file holds (:func:`model_from_dict`), an :class:`~acrobot_mj.physics.params.AcrobotParams`
    (elbow-driven, Euler) or a model; ``None`` is the report's."""
    if model is None:
        return MODELS["report"]
    if isinstance(model, AcrobotModel):
        return model
    if isinstance(model, AcrobotParams):
        return AcrobotModel(model)
    if isinstance(model, str) and model in MODELS:
        return MODELS[model]
    if isinstance(model, Mapping):
        return model_from_dict(dict(model), "the model's parameters")
    if not isinstance(model, (str, Path)):
        raise TypeError(f"model must be a name, a file or AcrobotParams, got {model!r}")
    path = Path(model)
    suffix = path.suffix.lower()
    if suffix not in (".json", ".toml"):
        raise ValueError(
            f"model must be one of {sorted(MODELS)} or a .json or .toml file, got {str(model)!r}"
        )
    try:
        text = path.read_text()
        data = json.loads(text) if suffix == ".json" else tomllib.loads(text)
    except IsADirectoryError:
        raise ValueError(f"the model file {path} is a folder") from None
    except FileNotFoundError:
        raise ValueError(f"the model file {path} is not found") from None
    except (OSError, UnicodeDecodeError, ValueError) as error:
        reason = getattr(error, "strerror", None) or error  # "Too many levels of symbolic links"
        raise ValueError(f"cannot read the model file {path}: {reason}") from None
    if not isinstance(data, dict) or not data:
        raise ValueError(f"{path}: a model file holds one table of parameters, not empty")
    return model_from_dict(data, str(path))


def table_setting() -> Any:
    """The ``model_table`` setting of a run's config: what :func:`carried` keeps of a model
    file (no command-line option: the run reads it from ``model``)."""
    return setting(
        None,
        "a model file's parameters as the run read them (the run keeps its acrobot)",
        cli=False,
        follows="model",
    )


def carried(
    model: str | None, table: Mapping[str, Any] | None = None
) -> tuple[str | None, dict[str, Any] | None]:
    """What a run records of its acrobot ``model`` (a shipped name or a model file; None or
    ``"report"``: the report's): the name (None for the report's) and, for a file, the
    parameters it held when the run began (:meth:`AcrobotModel.to_dict`), or ``table`` where a
    record already holds them, checked. So a run keeps the acrobot it was trained on wherever
    it is moved and whatever becomes of the file."""
    if model == "report":
        model = None
    if model is None or model in MODELS:
        if table is not None:
            raise ValueError(f"the shipped model {model or 'report'!r} carries no parameters")
        return model, None
    if table is not None:
        if not isinstance(table, Mapping):
            raise ValueError(f"the parameters carried for {model} must be a table, got {table!r}")
        return model, model_from_dict(dict(table), f"the parameters carried for {model}").to_dict()
    return model, resolve(model).to_dict()


def carry_model(config: Any) -> None:
    """In a frozen config's ``__post_init__``: its ``model`` and ``model_table`` as
    :func:`carried` makes them, refused as the ``model`` setting in one line."""
    try:  # the default, "report", is None: the packaged MJCF
        model, table = carried(config.model, config.model_table)
    except (TypeError, ValueError) as error:
        raise SettingError(f"config model: {error}") from None
    object.__setattr__(config, "model", model)
    object.__setattr__(config, "model_table", table)


def carried_acrobot(model: str | None, table: Mapping[str, Any] | None) -> AcrobotModel:
    """The acrobot a run records as ``model`` and ``table`` (:func:`carried`): a file's as the
    run read it, not as the file is now."""
    return resolve(model if table is None else table)
