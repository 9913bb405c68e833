"""How a run goes, whatever it trains (:class:`RunOptions`, given by the caller), and where one
learner of it writes and what watches it (:class:`Run`, handed to
:meth:`~acrobot_mj.train.learners.Learner.learn`)."""

from __future__ import annotations

from dataclasses import dataclass, fields
from pathlib import Path

from acrobot_mj.train.bookkeeping import OnEpisode
from acrobot_mj.train.episode_log import RunLog
from acrobot_mj.train.monitor import Monitor
from acrobot_mj.train.records import CHECKPOINT_FILE, learner_dir


@dataclass(frozen=True)
class RunOptions:
    """How a run goes, whatever it trains: ``resume`` from its checkpoints (exactly),
    ``overwrite`` another run in its directory, a ``progress`` bar on stderr (or the
    :class:`~acrobot_mj.train.monitor.Monitor` of a bigger run this one is part of), each episode's
    scalars in ``tensorboard``, ``on_episode(index, history)`` after every training episode;
    for several seeds or trials, ``jobs`` processes (None: one; a sweep: one per CPU) and
    ``lockstep``: seeds together on one vector env (True), apart (False), where that pays
    (None)."""

    resume: bool = False
    overwrite: bool = False
    progress: bool | Monitor = False
    tensorboard: str | Path | None = None
    on_episode: OnEpisode | None = None
    jobs: int | None = None
    lockstep: bool | None = None

    def only(self, what: str, *used: str) -> RunOptions:
        """These options, refused where one that ``what`` has no use for is set."""
        unused = [
            f.name
            for f in fields(self)
            if f.name not in used and getattr(self, f.name) != f.default
        ]
        if unused:
            raise ValueError(f"{what} takes no {' or '.join(unused)} option")
        return self


#: Every option at its default: a fresh run, no bar.
PLAIN = RunOptions()


@dataclass
class Run:
    """Where a run writes (None: nowhere), whether it resumes, and what watches it."""

    out: Path | None = None
    resume: bool = False
    monitor: Monitor | None = None
    on_episode: OnEpisode | None = None
    tee: RunLog | None = None
    progress: bool = False  # a bar where the learner keeps no monitor (the balance preset)

    def learner(self, k: int, tee: RunLog | None) -> Run:
        """The run of learner ``k`` of a population, in ``learner_K/``."""
        out = None if self.out is None else learner_dir(self.out, k)
        again = self.resume and out is not None and (out / CHECKPOINT_FILE).exists()
        monitor = None if self.monitor is None else self.monitor.scoped(f"learner_{k}")
        return Run(out, again, monitor, self.on_episode, tee, self.progress)
