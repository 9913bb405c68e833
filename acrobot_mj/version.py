"""The package's version (one place: ``pyproject.toml`` reads the same number), and the versions
of what results depend on."""

from __future__ import annotations

__version__ = "0.3.0"


def versions() -> dict[str, str]:
    """Versions of Python and the packages a result depends on (for every record)."""
    import platform

    import gymnasium
    import mujoco
    import numpy

    return {
        "python": platform.python_version(),
        "acrobot_mj": __version__,
        "mujoco": mujoco.__version__,
        "gymnasium": gymnasium.__version__,
        "numpy": numpy.__version__,
    }
