"""The identified model's decision compiled with numba: numba compiles
:func:`acrobot_mj.control.identification.lumped_step` itself, so the Python and compiled steps
are one definition and give the same numbers bit for bit (``tests/test_compiled.py``).
:class:`~acrobot_mj.envs.model_env.ModelEnv` uses it with ``compiled=True`` (the ``fast``
extra; numba is imported only then)."""

from __future__ import annotations

from acrobot_mj.control.identification import lumped_step

try:
    from numba import njit
except ImportError as error:  # pragma: no cover  (the fast extra is missing)
    raise ImportError(
        "the compiled model step needs numba: pip install acrobot-mj[fast]"
    ) from error

#: :func:`lumped_step`, compiled.
lumped_step_jit = njit(cache=True)(lumped_step)
