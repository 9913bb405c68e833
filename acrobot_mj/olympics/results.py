"""Our entries' AI Olympics scores as recorded: one small file per run in ``recorded/``, each the
scores of a run's ``olympics.json`` (:mod:`~acrobot_mj.olympics.report`) without its episodes
(:func:`summary`), with the command that reproduces it. The docs' tables are written from
these files (:mod:`~acrobot_mj.olympics.tables`).

Beside the record's keys a summary may hold: ``command``; ``note``; ``machine`` (the scores
came from another machine than the rest, where rounding sends episodes elsewhere); ``digits``
(the figures were kept rounded to that many decimals, not as the run computed them); and in
``global``, ``range`` ``[low, high]`` where the seeds' own scores were not kept."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from acrobot_mj.files import read_json, write_json
from acrobot_mj.olympics.report import FORMAT, KIND

#: The folder of the recorded summaries, ``NAME.json`` each.
FOLDER = Path(__file__).with_name("recorded")
#: The record's keys a summary keeps as they are.
KEPT = ("kind", "format", "versions", "model", "seeds", "protocol")
#: The parts of the protocol a record may hold.
PARTS = ("performance", "robustness", "global")
#: The decimals a score is printed to, unless its record was kept to fewer.
DIGITS = 3


def summary(record: Mapping[str, Any], command: str, note: str = "") -> dict[str, Any]:
    """``record`` (an ``olympics.json`` as read, or a summary) reduced to its scores: the
    record's keys :data:`KEPT`, each part without its episodes, each robustness category's
    ``key``, ``title`` and ``score``; with the ``command`` that made it and a ``note``."""
    if record.get("kind") != KIND or record.get("format") != FORMAT:
        raise ValueError(f"not an olympics record of format {FORMAT} (kind {KIND!r})")
    kept = {k: record[k] for k in KEPT if k in record}
    if "performance" in record:
        kept["performance"] = {k: v for k, v in record["performance"].items() if k != "episode"}
    if "robustness" in record:
        robustness = record["robustness"]
        categories = [
            {k: c[k] for k in ("key", "title", "score")} for c in robustness["categories"]
        ]
        kept["robustness"] = {"categories": categories}
        if "overall" in robustness:
            kept["robustness"]["overall"] = robustness["overall"]
    if "global" in record:
        kept["global"] = {k: v for k, v in record["global"].items() if k != "episode"}
    return {**kept, "command": command, **({"note": note} if note else {})}


def record_summary(run: str | Path, name: str, command: str, note: str = "") -> Path:
    """Write the :func:`summary` of the run ``run`` (its folder or its ``olympics.json``) as
    :data:`FOLDER`/``name``.json; returns its path."""
    from acrobot_mj.olympics.report import RECORD_FILE, read_olympics

    run = Path(run)
    record = read_olympics(run / RECORD_FILE if run.is_dir() else run)
    return write_json(FOLDER / f"{name}.json", summary(record, command, note))


def names() -> list[str]:
    """The recorded summaries' names."""
    return sorted(p.stem for p in FOLDER.glob("*.json"))


def recorded(name: str) -> dict[str, Any]:
    """The summary ``name`` (:data:`FOLDER`/``name``.json); ValueError, naming it, where it
    is no summary of an olympics record or names no command."""
    path = FOLDER / f"{name}.json"
    found = read_json(path)
    if not isinstance(found, dict) or found.get("kind") != KIND or not found.get("command"):
        raise ValueError(f"{path} is no olympics summary (its kind and command)")
    return found


def part(records: Sequence[str], which: str) -> tuple[dict[str, Any], dict[str, Any]] | None:
    """The part ``which`` of the first of the summaries named ``records`` that holds it, with
    that summary; None where none does."""
    for name in records:
        found = recorded(name)
        if which in found:
            return found[which], found
    return None


def figure(value: float, digits: int | None = None) -> str:
    """A score as the docs print it: :data:`DIGITS` decimals, or the ``digits`` it was kept to."""
    return f"{value:.{DIGITS if digits is None else digits}f}"


def percent(value: float, digits: int | None = None) -> str:
    """A category's score (a fraction) in per cent, one decimal fewer than :func:`figure`
    (``100 %`` whole)."""
    shown = f"{100 * value:.{max(0, (DIGITS if digits is None else digits) - 2)}f}"
    return f"{shown.rstrip('0').rstrip('.') if '.' in shown else shown} %"


def seeds_text(seeds: Sequence[int]) -> str:
    """``seed 0``, ``seeds 3-10`` (a run of seeds) or ``seeds 1, 5``."""
    if len(seeds) == 1:
        return f"seed {seeds[0]}"
    if list(seeds) == list(range(seeds[0], seeds[0] + len(seeds))):
        return f"seeds {seeds[0]}-{seeds[-1]}"
    return "seeds " + ", ".join(str(s) for s in seeds)


def global_seeds(summary: Mapping[str, Any]) -> list[dict[str, Any]]:
    """The global part's seeds, each ``{"seed", "score"}`` (no score where it was not kept); a
    record of one seed written before records listed their seeds: that seed."""
    run = summary["global"]
    if "seeds" in run:
        return list(run["seeds"])
    return [{"seed": summary["seeds"]["seed"], "score": run["score"]}]


def spread(summary: Mapping[str, Any]) -> tuple[float, float] | None:
    """The lowest and highest of the global part's seeds' scores (its ``range`` where they
    were not kept); None for one seed."""
    seeds = global_seeds(summary)
    scores = [s["score"] for s in seeds if "score" in s]
    if len(seeds) < 2:
        return None
    if len(scores) == len(seeds):
        return min(scores), max(scores)
    low, high = summary["global"]["range"]
    return low, high


def global_text(summary: Mapping[str, Any]) -> str:
    """The global part in one cell: its score, and over several seeds their lowest and highest
    and which seeds."""
    run, digits = summary["global"], summary.get("digits")
    seeds = [s["seed"] for s in global_seeds(summary)]
    score = figure(run["score"], digits)
    if len(seeds) == 1:
        return f"{score} ({seeds_text(seeds)})"
    low, high = spread(summary) or (run["score"], run["score"])
    return f"{score} ({figure(low, digits)}-{figure(high, digits)}, {seeds_text(seeds)})"
