"""The AI Olympics record, ``olympics.json`` (written atomically, sealed with its digest), its
reader, and its figures beside it (:mod:`acrobot_mj.report.olympics_figures`).

Per-step torques are stored compactly: each episode's elbow torques [N m] as base64 of
little-endian float32 (:data:`TORQUE_ENCODING`)."""

from __future__ import annotations

import base64
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from acrobot_mj.files import is_sealed, read_json, sealed, versions, write_json
from acrobot_mj.olympics import scores
from acrobot_mj.olympics.bound import Bound
from acrobot_mj.olympics.protocol import CATEGORY_KEYS, PERFORMANCE, Category, to_protocol
from acrobot_mj.olympics.scaling import ORIGINAL, Rules
from acrobot_mj.olympics.scores import Recording
from acrobot_mj.report.olympics_figures import category_figure, height_figure
from acrobot_mj.report.plots import save_figure

#: The record's file name.
RECORD_FILE = "olympics.json"
KIND, FORMAT = "acrobot-mj olympics", 1
#: How an episode's torques are stored.
TORQUE_ENCODING = "base64 of little-endian float32 elbow torques [N m], one per step"
_DTYPE = np.dtype("<f4")


@dataclass(frozen=True)
class EpisodeRecord:
    """What the record keeps of one episode: its ``start`` (4,) in our convention [rad, rad/s],
    the elbow ``torques`` (N,) applied [N m], its ``success`` and the ``disturbance`` it met
    (the level's parameter or the drawn pulses, as JSON)."""

    start: tuple[float, ...]
    torques: np.ndarray
    success: bool
    disturbance: Mapping[str, Any] = field(default_factory=dict)

    @classmethod
    def of(
        cls, trajectory: Recording, success: bool, disturbance: Mapping[str, Any] | None = None
    ) -> EpisodeRecord:
        """The record of ``trajectory``."""
        start = tuple(float(v) for v in trajectory.X[0])
        return cls(start, trajectory.U, bool(success), dict(disturbance or {}))

    def to_dict(self) -> dict[str, Any]:
        """The episode as JSON."""
        return {
            "start": list(self.start),
            "disturbance": dict(self.disturbance),
            "success": self.success,
            "steps": len(self.torques),
            "torques": encode_torques(self.torques),
        }


def encode_torques(torques: np.ndarray) -> str:
    """Torques (N,) [N m] as :data:`TORQUE_ENCODING` says."""
    return base64.b64encode(np.asarray(torques, dtype=_DTYPE).tobytes()).decode("ascii")


def decode_torques(text: str, steps: int) -> np.ndarray:
    """The torques (``steps``,) [N m] of :func:`encode_torques`; ValueError where ``text`` is not
    ``steps`` of them."""
    try:
        raw = base64.b64decode(text.encode("ascii"), validate=True)
    except (ValueError, UnicodeEncodeError):
        raise ValueError("torques are not base64") from None
    if len(raw) != steps * _DTYPE.itemsize:
        raise ValueError(f"torques hold {len(raw) // _DTYPE.itemsize} steps, not {steps}")
    return np.frombuffer(raw, dtype=_DTYPE).astype(float)


#: A category's episodes: per sweep, per level, per episode.
Episodes = Sequence[Sequence[Sequence[EpisodeRecord]]]


@dataclass(frozen=True)
class Olympics:
    """What a run of the protocol produced: the ``model`` (as JSON) and its arm ``lengths``
    ``(l1, l2)`` [m], the ``seeds`` of every draw; the ``performance`` episode; the robustness
    ``categories`` run and their ``episodes`` by category key; the ``global_episodes`` of
    ``global_seeds`` (one per seed) and the first one's ``global_draws`` (targets, reset times,
    as JSON), each seed's ``global_bounds`` where asked (:mod:`~acrobot_mj.olympics.bound`);
    the ``protocol`` they ran under (the original or scaled,
    :mod:`~acrobot_mj.olympics.scaling`). A part not run is None or empty."""

    model: Mapping[str, Any]
    lengths: tuple[float, float]
    seeds: Mapping[str, int]
    performance: Recording | None = None
    categories: tuple[Category, ...] = ()
    episodes: Mapping[str, Episodes] = field(default_factory=dict)
    global_episodes: Sequence[Recording] = ()
    global_seeds: Sequence[int] = ()
    global_draws: Mapping[str, Any] = field(default_factory=dict)
    global_bounds: Sequence[Bound] = ()
    protocol: Rules = ORIGINAL

    def __post_init__(self) -> None:
        if len(self.global_seeds) != len(self.global_episodes):
            raise ValueError(
                f"{len(self.global_episodes)} global episodes for {len(self.global_seeds)} seeds"
            )
        if self.global_bounds and len(self.global_bounds) != len(self.global_seeds):
            raise ValueError(
                f"{len(self.global_bounds)} bounds for {len(self.global_seeds)} global seeds"
            )

    @property
    def global_episode(self) -> Recording | None:
        """The first seed's global episode, the one the record keeps whole (None: none)."""
        return self.global_episodes[0] if self.global_episodes else None


def _category(category: Category, episodes: Episodes) -> dict[str, Any]:
    successes = [[[e.success for e in level] for level in sweep] for sweep in episodes]
    fractions = scores.level_fractions(category, successes)
    return {
        "key": category.key,
        "title": category.title,
        "score": scores.category_score(category, successes),
        "repetitions": category.repetitions,
        "majority": category.majority,
        "sweeps": [
            {
                "parameter": sweep.parameter,
                "unit": sweep.unit,
                "levels": list(sweep.levels),
                "fractions": fractions[k],
                "episodes": [[e.to_dict() for e in level] for level in episodes[k]],
            }
            for k, sweep in enumerate(category.sweeps)
        ],
    }


def olympics_record(results: Olympics) -> dict[str, Any]:
    """The record of ``results``: every score, every category with its per-level success
    fractions, every episode (:meth:`EpisodeRecord.to_dict`), the model and seeds, the
    ``protocol``'s name and its ``scaling`` (the scales and every constant)."""
    l1, l2 = results.lengths
    used = results.protocol
    record: dict[str, Any] = {
        "kind": KIND,
        "format": FORMAT,
        "versions": versions(),
        "model": dict(results.model),
        "lengths": [float(l1), float(l2)],
        "seeds": dict(results.seeds),
        "torques": TORQUE_ENCODING,
        "protocol": used.name,
        "scaling": used.to_dict(),
    }
    if results.performance is not None:
        run = scores.performance(results.performance, l1, l2, used.performance)
        episode = EpisodeRecord.of(results.performance, bool(run["success"]))
        record["performance"] = {**run, "episode": episode.to_dict()}
    if results.categories:
        missing = [c.key for c in results.categories if c.key not in results.episodes]
        if missing:
            raise ValueError(f"no episodes for the robustness categories {missing}")
        done = [_category(c, results.episodes[c.key]) for c in results.categories]
        by_key = {c["key"]: c["score"] for c in done}
        robustness: dict[str, Any] = {"categories": done}
        if set(by_key) == set(CATEGORY_KEYS):
            robustness["overall"] = scores.overall_robustness(by_key, results.categories)
        record["robustness"] = robustness
    if results.global_episode is not None:
        g = used.global_policy
        ups: list[dict[str, Any]] = [
            scores.uptime(run, l1, l2, g.t_final, g.height) for run in results.global_episodes
        ]
        episode = EpisodeRecord.of(results.global_episode, True, results.global_draws)
        for up, bound in zip(ups, results.global_bounds, strict=False):
            up |= {"bound": bound.to_dict(), "of_bound": up["uptime"] / bound.uptime}
        record["global"] = {
            **ups[0],
            "episode": episode.to_dict(),
            "seeds": [{"seed": s, **up} for s, up in zip(results.global_seeds, ups, strict=True)],
        }
        if len(ups) > 1:  # the score is the mean over the seeds
            spread = scores.mean_interval([up["score"] for up in ups])
            record["global"] |= {
                "uptime": float(np.mean([up["uptime"] for up in ups])),
                "score": spread["mean"],
                "interval": spread["interval"],
                "level": spread["level"],
            }
            if results.global_bounds:  # the mean uptime over the mean bound
                mean = float(np.mean([b.uptime for b in results.global_bounds]))
                record["global"] |= {
                    "bound": {"uptime": mean, "score": mean / g.t_final},
                    "of_bound": record["global"]["uptime"] / mean,
                }
    return sealed(record)


def _episodes_of(record: dict[str, Any]) -> list[dict[str, Any]]:
    """Every episode dict in ``record``."""
    found = [record[part]["episode"] for part in ("performance", "global") if part in record]
    for category in record.get("robustness", {}).get("categories", []):
        for sweep in category["sweeps"]:
            found += [e for level in sweep["episodes"] for e in level]
    return found


def read_olympics(path: str | Path) -> dict[str, Any]:
    """The record at ``path`` (a file or the folder holding :data:`RECORD_FILE`), each episode's
    ``torques`` decoded to an array (N,) [N m]; one line naming the file and the problem where it
    is not a whole, unedited olympics record."""
    path = Path(path)
    if path.is_dir():
        path = path / RECORD_FILE
    try:
        record = read_json(path)
    except (OSError, ValueError) as error:
        raise ValueError(f"{path} is not a readable olympics record: {error}") from None
    if not isinstance(record, dict) or record.get("kind") != KIND:
        raise ValueError(f"{path} is not an olympics record (no kind {KIND!r})")
    if record.get("format") != FORMAT:
        raise ValueError(
            f"{path} is an olympics record of format {record.get('format')!r}, "
            f"this version reads format {FORMAT}"
        )
    if not is_sealed(record):
        raise ValueError(f"{path} was edited or cut short since written (its sha256 fails)")
    try:
        for episode in _episodes_of(record):
            episode["torques"] = decode_torques(episode["torques"], episode["steps"])
    except (KeyError, TypeError, ValueError) as error:
        raise ValueError(f"{path} holds a malformed episode: {error}") from None
    return record


def write_olympics(folder: str | Path, results: Olympics) -> Path:
    """Write :func:`olympics_record` of ``results`` to ``folder``/:data:`RECORD_FILE` and its
    figures beside it: ``robustness_<key>.png`` per category, ``performance.png``,
    ``global.png``. Returns the record's path."""
    folder = Path(folder)
    record = olympics_record(results)
    path = write_json(folder / RECORD_FILE, record)
    stale = {*folder.glob("robustness_*.png"), folder / "performance.png", folder / "global.png"}
    for category in record.get("robustness", {}).get("categories", []):
        stale.discard(png := folder / f"robustness_{category['key']}.png")
        save_figure(category_figure(category), png)
    l1, l2 = results.lengths
    for part, recording in (
        ("performance", results.performance),
        ("global", results.global_episode),
    ):
        if recording is not None:
            run = record[part]
            title = (
                f"Performance: score {run['score']:.3f}, swing-up time {run['swingup_time']} s"
                if part == "performance"
                else (
                    f"Global policy, seed {run['seeds'][0]['seed']}: uptime "
                    f"{run['seeds'][0]['uptime']:.2f} s, score {run['seeds'][0]['score']:.3f}"
                )
            )
            heights = scores.tip_heights(to_protocol(recording.X), l1, l2)
            line = PERFORMANCE.height * (l1 + l2)
            figure = height_figure(recording.T, heights, line, recording.U, title)
            stale.discard(folder / f"{part}.png")
            save_figure(figure, folder / f"{part}.png")
    for png in stale:  # a replaced record's: not beside a record without its score
        png.unlink(missing_ok=True)
    return path
