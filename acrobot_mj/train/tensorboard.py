"""TensorBoard scalars per training episode (``acrobot-mj train --tensorboard DIR``), through
tensorboardX (the ``tensorboard`` extra) or, failing that, ``torch.utils.tensorboard``;
imported only when asked for.

Each learner writes its own TensorBoard run: ``DIR`` for a run of one learner, ``DIR/seed_S``,
``DIR/learner_K`` (and ``DIR/seed_S/learner_K``) for the learners of bigger runs, so
TensorBoard draws them side by side. The scalars are ``episode/length``, ``episode/return`` and
``episode/success`` (1 or 0), at the episode's index as the step.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

EXTRA = "pip install acrobot-mj[tensorboard]"


def summary_writer() -> Any:
    """The ``SummaryWriter`` class of tensorboardX, or of torch; a one-line error without."""
    try:
        from tensorboardX import SummaryWriter
    except ImportError:
        try:
            from torch.utils.tensorboard import SummaryWriter
        except ImportError:
            raise ImportError(
                f"--tensorboard needs tensorboardX (or torch with tensorboard): {EXTRA}"
            ) from None
    return SummaryWriter


class Board:
    """One ``SummaryWriter`` per learner under ``root``, opened at the learner's first
    episode."""

    def __init__(self, root: str | Path) -> None:
        self.root = Path(root)
        self._writer_class = summary_writer()  # fails here, before any training
        self._writers: dict[str, Any] = {}

    def add(self, name: str, index: int, length: int, total: float, success: bool) -> None:
        """Learner ``name``'s episode ``index``."""
        writer = self._writers.get(name)
        if writer is None:
            writer = self._writers[name] = self._writer_class(str(self.root / name))
        writer.add_scalar("episode/length", length, index)
        writer.add_scalar("episode/return", total, index)
        writer.add_scalar("episode/success", float(success), index)

    def close(self) -> None:
        for writer in self._writers.values():
            writer.close()
        self._writers.clear()
