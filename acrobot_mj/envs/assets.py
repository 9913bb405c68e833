"""Finding and loading the MJCF model: ``acrobot_mj/models`` in a wheel, ``models/`` in a
checkout."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from acrobot_mj.envs.mjcf import acrobot_xml
from acrobot_mj.physics.models import AcrobotModel, ModelSpec, resolve

_PACKAGE = Path(__file__).resolve().parent.parent  # acrobot_mj/

#: Names the package reads the model by (``docs/explain/design.md``).
REQUIRED_NAMES: dict[mujoco.mjtObj, tuple[str, ...]] = {
    mujoco.mjtObj.mjOBJ_BODY: ("link1", "link2"),
    mujoco.mjtObj.mjOBJ_JOINT: ("shoulder", "elbow"),
    mujoco.mjtObj.mjOBJ_SITE: ("tip",),
    mujoco.mjtObj.mjOBJ_KEY: ("hanging", "upright"),
}


def models_dir() -> Path:
    """The folder holding ``acrobot.xml`` and ``scene.xml``."""
    for candidate in (_PACKAGE / "models", _PACKAGE.parent / "models"):
        if (candidate / "acrobot.xml").is_file():
            return candidate
    raise FileNotFoundError(
        f"acrobot_mj cannot find its MJCF models: neither {_PACKAGE / 'models'} (installed wheel)"
        f" nor {_PACKAGE.parent / 'models'} (source checkout) holds acrobot.xml; reinstall the "
        "package or run from a complete checkout"
    )


def model_path(name: str = "scene.xml") -> Path:
    """Path of a model file shipped with the package (``"scene.xml"`` or ``"acrobot.xml"``)."""
    return models_dir() / name


def load_model(path: str | Path | None = None, model: ModelSpec = None) -> mujoco.MjModel:
    """Compile an MJCF file (default: the packaged ``scene.xml``), or the scene around the MJCF
    generated from ``model`` (:func:`load_acrobot`), and check it is an acrobot. Raises
    ``FileNotFoundError`` for a missing file, ``ValueError`` for a bad one or for both given."""
    if model is not None:
        if path is not None:
            raise ValueError("give model or model_path, not both")
        return load_acrobot(resolve(model))
    path = model_path() if path is None else Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"MJCF model file not found: {path}")
    try:
        model = mujoco.MjModel.from_xml_path(str(path))
    except ValueError as error:
        raise ValueError(f"MuJoCo could not load the MJCF model {path}: {error}") from error
    check_model(model, str(path))
    return model


def load_acrobot(model: AcrobotModel) -> mujoco.MjModel:
    """Compile the packaged ``scene.xml`` around the MJCF generated from ``model`` and check it
    is an acrobot (its motor on either joint)."""
    generated = {"acrobot.xml": acrobot_xml(model).encode()}
    compiled = mujoco.MjModel.from_xml_string(model_path().read_text(), generated)
    check_model(compiled, "the generated model")
    return compiled


def check_model(model: mujoco.MjModel, where: str = "model") -> None:
    """Raise ``ValueError`` if ``model`` is not a two-hinge acrobot with the required names."""
    missing = [
        f"{obj.name.removeprefix('mjOBJ_').lower()} '{name}'"
        for obj, names in REQUIRED_NAMES.items()
        for name in names
        if mujoco.mj_name2id(model, obj, name) < 0
    ]
    if missing:
        raise ValueError(f"{where} is not an acrobot model: it lacks {', '.join(missing)}")
    if (model.nq, model.nv, model.nu) != (2, 2, 1):
        raise ValueError(
            f"{where} is not an acrobot model: expected nq=2, nv=2, nu=1, "
            f"got nq={model.nq}, nv={model.nv}, nu={model.nu}"
        )
    motor, joint = model.actuator(0), actuated_joint(model)
    if motor.name != f"{joint}_motor" or joint not in ("shoulder", "elbow"):
        raise ValueError(
            f"{where} is not an acrobot model: its one actuator must be shoulder_motor or "
            f"elbow_motor on that joint, got {motor.name!r} on {joint!r}"
        )


def actuated_joint(model: mujoco.MjModel) -> str:
    """The joint the model's one motor drives: ``"elbow"`` (an acrobot) or ``"shoulder"``."""
    return model.joint(int(model.actuator_trnid[0, 0])).name


def link_lengths(model: mujoco.MjModel) -> tuple[float, float]:
    """l1, l2 [m] measured on the model: shoulder to elbow, elbow to the ``tip`` site."""
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    shoulder = data.xanchor[model.joint("shoulder").id]
    elbow = data.xanchor[model.joint("elbow").id]
    tip = data.site_xpos[model.site("tip").id]
    return float(np.linalg.norm(elbow - shoulder)), float(np.linalg.norm(tip - elbow))
