"""Writing records atomically (a temporary file beside the target, renamed over it: never a
half-written record), as strict JSON, with the versions every record carries."""

from __future__ import annotations

import hashlib
import json
import os
import platform
from collections.abc import Callable
from pathlib import Path
from typing import IO, Any

from acrobot_mj.version import __version__


def versions() -> dict[str, str]:
    """Versions of Python and the packages a result depends on."""
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


def check_regular(path: str | Path) -> None:
    """IsADirectoryError (an OSError) where ``path`` exists and is not a regular file: renaming
    a record over it would replace a device, and reading a pipe waits for a writer forever."""
    if Path(path).exists() and not Path(path).is_file():
        raise IsADirectoryError(
            f"{path} exists and is not a regular file (a folder, a device or a pipe): name a file"
        )


def write_atomic(path: str | Path, write: Callable[[IO[bytes]], object]) -> Path:
    """Call ``write(file)`` on a temporary file beside ``path``, then rename it to ``path``
    (refused where ``path`` is not a regular file: the rename would replace a device)."""
    path = Path(path)
    check_regular(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        with open(tmp, "wb") as f:
            write(f)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except OSError as error:
        if error.filename is not None:
            raise
        said = f"cannot write {path}: {error.strerror or error}"
        raise (OSError(said) if error.errno is None else OSError(error.errno, said)) from None
    finally:
        tmp.unlink(missing_ok=True)
    return path


def read_json(path: str | Path) -> Any:
    """The JSON document at ``path``; ValueError where it is not one (nested too deeply
    included: Python's parser would raise RecursionError), or not a regular file (reading a
    pipe would wait for a writer forever)."""
    try:
        check_regular(path)
        return json.loads(Path(path).read_text())
    except RecursionError:
        raise ValueError(f"{path} is nested too deeply to be a record") from None
    except IsADirectoryError as error:
        raise ValueError(str(error)) from None


def write_text(path: str | Path, text: str) -> Path:
    """``text`` (UTF-8) at ``path``, atomically."""
    data = text.encode()
    return write_atomic(path, lambda f: f.write(data))


def write_json(path: str | Path, data: Any) -> Path:
    """``data`` as indented, strict JSON at ``path``, atomically; ValueError on NaN or inf."""
    try:
        text = json.dumps(data, indent=1, allow_nan=False)
    except ValueError as error:
        raise ValueError(f"cannot write {path}: {error} (no NaN or infinity in JSON)") from None
    return write_text(path, text)


def sealed(record: dict[str, Any]) -> dict[str, Any]:
    """``record`` with ``sha256``: the digest of the rest, as canonical JSON (see
    :func:`is_sealed`)."""
    return {**record, "sha256": _record_digest(record)}


def is_sealed(record: Any) -> bool:
    """Whether ``record`` is as :func:`sealed` made it: not edited since, by hand or otherwise."""
    if not isinstance(record, dict) or not isinstance(record.get("sha256"), str):
        return False
    return record["sha256"] == _record_digest({k: v for k, v in record.items() if k != "sha256"})


def _record_digest(record: dict[str, Any]) -> str:
    text = json.dumps(record, sort_keys=True, allow_nan=False, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()
