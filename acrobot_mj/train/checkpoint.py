"""Checkpoints: numpy ``.npz`` files, no pickle, versioned, checksummed, written atomically.

A checkpoint holds named arrays (the agent's state) and a JSON document (the config, the seed and
the progress so far). :func:`save_checkpoint` writes a temporary file beside the target and renames
it over the target, so an interrupted write never leaves a half-written checkpoint in place.
:func:`load_checkpoint` refuses anything truncated, tampered with, of another format or version,
with a :class:`CheckpointError` that names the file and the problem.
"""

from __future__ import annotations

import hashlib
import json
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from acrobot_mj.files import write_atomic

FORMAT = "acrobot_mj.checkpoint"
VERSION = 1
_RESERVED = ("format", "version", "meta", "sha256")


class CheckpointError(ValueError):
    """A checkpoint file that cannot be used, and why."""


def _digest(arrays: dict[str, np.ndarray]) -> str:
    """SHA-256 over every array's name, dtype, shape and bytes, in name order."""
    sha = hashlib.sha256()
    for name in sorted(arrays):
        array = np.ascontiguousarray(arrays[name])
        sha.update(f"{name}|{array.dtype.str}|{array.shape}|".encode())
        sha.update(array.tobytes())
    return sha.hexdigest()


def save_checkpoint(path: str | Path, arrays: dict[str, np.ndarray], meta: dict[str, Any]) -> Path:
    """Write ``arrays`` and the JSON-serialisable ``meta`` to ``path`` atomically."""
    path = Path(path)
    clash = sorted(set(arrays) & set(_RESERVED))
    if clash:
        raise ValueError(f"array names {clash} are reserved for the checkpoint format")
    payload = {name: np.asarray(value) for name, value in arrays.items()}
    if any(value.dtype == object for value in payload.values()):
        raise ValueError("checkpoints hold plain numeric or string arrays only (no objects)")
    payload.update(
        format=np.array(FORMAT),
        version=np.array(VERSION),
        meta=np.array(json.dumps(meta, sort_keys=True)),
    )
    payload["sha256"] = np.array(_digest(payload))
    return write_atomic(path, lambda f: np.savez(f, **payload))


def load_checkpoint(path: str | Path) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """Read and validate a checkpoint; return ``(meta, arrays)``."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"checkpoint not found: {path}")
    try:
        with np.load(path, allow_pickle=False) as npz:
            data = {name: npz[name] for name in npz.files}
    except (zipfile.BadZipFile, ValueError, OSError, EOFError, KeyError) as error:
        raise CheckpointError(
            f"{path} is not a readable checkpoint (truncated or corrupt?): {error}"
        ) from error
    missing = [name for name in _RESERVED if name not in data]
    if missing:
        raise CheckpointError(f"{path} is not an acrobot_mj checkpoint: it lacks {missing}")
    if str(data["format"]) != FORMAT:
        raise CheckpointError(f"{path} has format {str(data['format'])!r}, expected {FORMAT!r}")
    version = data["version"]
    if version.shape != () or version.dtype.kind not in "iu" or int(version) != VERSION:
        raise CheckpointError(
            f"{path} has format version {version.tolist()!r}; "
            f"this acrobot_mj reads version {VERSION}"
        )
    stored = str(data.pop("sha256"))
    if _digest(data) != stored:
        raise CheckpointError(f"{path} fails its checksum: the file was modified or damaged")
    try:
        meta = json.loads(str(data["meta"]))
    except json.JSONDecodeError as error:
        raise CheckpointError(f"{path} has an unreadable meta document: {error}") from error
    if not isinstance(meta, dict):
        raise CheckpointError(f"{path} has a meta document that is not a JSON object")
    arrays = {name: value for name, value in data.items() if name not in _RESERVED}
    return meta, arrays
