"""A sweep's summary: the final greedy performance per grid point (median and spread over
seeds, scored by the task), over the trials that finished; failed and unfinished seeds named.
Each finished trial is evaluated on the held-out protocol (its ``eval.json``,
:mod:`acrobot_mj.train.heldout`), and each point counts the distinct greedy behaviours its seeds
produced. ``DIR/summary.json``, ``DIR/summary.md`` (a table) and ``DIR/summary.png``."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from acrobot_mj.envs.tasks import get_task
from acrobot_mj.files import write_json, write_text
from acrobot_mj.report.plots import Series, line_plot
from acrobot_mj.train.evaluate import distinct_outcomes
from acrobot_mj.train.heldout import DEFAULT
from acrobot_mj.train.records import recent_score
from acrobot_mj.train.rundir import SUMMARY_FILE
from acrobot_mj.train.stats import spread
from acrobot_mj.train.sweep_spec import SweepSpec
from acrobot_mj.train.sweep_trials import trial_dir, trial_evaluation, trial_state


def summarize_sweep(spec: SweepSpec, out: str | Path) -> dict[str, Any]:
    """Final greedy performance per grid point (median and spread over seeds), from rest and
    on the held-out starts of the default protocol."""
    out = Path(out)
    quantity = get_task(spec.base().task).score.quantity
    points: dict[str, dict[str, Any]] = {}
    for trial in spec.trials():
        entry = points.setdefault(
            trial.point_name,
            {"point": trial.point, "runs": 0, "failed": [], "unfinished": [], "greedy": []}
            | {"successes": [], "recent": [], "evaluations": []},
        )
        record, _ = trial_state(out, trial)
        if record is not None:  # finished: it says so, with every episode
            entry["runs"] += 1
            greedy = record["greedy_from_rest"]
            entry["greedy"].append(greedy[quantity])
            entry["successes"].append(bool(greedy["success"]))
            entry["recent"].append(recent_score(record))
            evaluation = trial_evaluation(out, trial)
            if evaluation is not None:
                entry["evaluations"].append(evaluation)
        elif (trial_dir(out, trial) / "error.json").exists():
            entry["failed"].append(trial.seed)
        else:
            entry["unfinished"].append(trial.seed)
    rows = [_point_row(key, entry, quantity) for key, entry in points.items()]
    summary = {
        "protocol": DEFAULT.to_dict(),
        "preset": spec.preset,
        "seeds": spec.seeds,
        "grid": spec.grid,
        "overrides": spec.overrides,
        "trials": len(spec.trials()),
        "points": rows,
    }
    summary["unfinished"] = sum(len(r["unfinished_seeds"]) for r in rows)
    write_json(out / SUMMARY_FILE, summary)
    write_text(out / "summary.md", summary_table(summary))
    _plot_summary(out / "summary.png", spec, [r for r in rows if r["runs"]])
    return summary


def _point_row(key: str, entry: dict[str, Any], quantity: str) -> dict[str, Any]:
    """One grid point's line of the summary."""
    greedy, recent = spread(entry["greedy"]), spread(entry["recent"])
    successes, evaluations = entry["successes"], entry["evaluations"]
    held = spread([e["summary"][quantity]["median"] for e in evaluations])
    return {
        "name": key,
        "point": entry["point"],
        "runs": entry["runs"],
        "failed_seeds": entry["failed"],
        "unfinished_seeds": entry["unfinished"],
        "greedy_median": greedy["median"],
        "greedy_q25": greedy["q25"],
        "greedy_q75": greedy["q75"],
        "greedy_success_fraction": sum(successes) / len(successes) if successes else None,
        "last20_median": recent["median"],
        "held_out_median": held["median"],
        "held_out_q25": held["q25"],
        "held_out_q75": held["q75"],
        "held_out_runs": len(evaluations),
        "distinct_outcomes": distinct_outcomes(evaluations),
    }


def _plot_summary(path: Path, spec: SweepSpec, finished: list[dict[str, Any]]) -> None:
    """The greedy score per grid point with its 25-75 % band over seeds."""
    if not finished:
        return
    score = get_task(spec.base().task).score
    line_plot(
        path,
        [
            Series(
                f"greedy {score.unit} from rest: median, 25-75 % band over seeds",
                list(range(len(finished))),
                [r["greedy_median"] for r in finished],
                [r["greedy_q25"] for r in finished],
                [r["greedy_q75"] for r in finished],
            )
        ],
        f"Sweep of the {spec.preset} preset over {list(spec.grid)}",
        "grid point (rows of summary.md, in order)",
        f"{score.unit} from rest",
    )


def summary_table(summary: dict[str, Any]) -> str:
    """The summary as a Markdown table ("-" where no trial of a grid point finished)."""
    lines = [
        "| grid point | runs | failed | unfinished | held-out median per seed: median (IQR) | "
        "distinct behaviours | greedy from rest: median (IQR) | greedy success | "
        "last 20 episodes, median |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in summary["points"]:
        if r["runs"]:
            held = (
                "-"
                if r["held_out_median"] is None
                else f"{r['held_out_median']:g} ({r['held_out_q25']:g}-{r['held_out_q75']:g})"
            )
            distinct = r["distinct_outcomes"]["held_out"]
            greedy = f"{r['greedy_median']:g} ({r['greedy_q25']:g}-{r['greedy_q75']:g})"
            success, recent = f"{r['greedy_success_fraction']:.0%}", f"{r['last20_median']:g}"
        else:
            held = distinct = greedy = success = recent = "-"
        lines.append(
            f"| {r['name']} | {r['runs']} | {len(r['failed_seeds'])} | "
            f"{len(r['unfinished_seeds'])} | {held} | {distinct} | {greedy} | {success} | "
            f"{recent} |"
        )
    return "\n".join(lines) + "\n"
