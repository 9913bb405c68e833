"""The docs' tables of AI Olympics scores, written from our recorded runs
(:mod:`~acrobot_mj.olympics.results`) beside the leaderboards' figures
(:mod:`~acrobot_mj.olympics.leaderboard`), with the leaderboards' sources. Each function
returns Markdown that scripts/settings_tables.py puts into a page."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from acrobot_mj.olympics.leaderboard import BOARDS, GLOBAL, PERFORMANCE, REPOSITORY, ROBUSTNESS
from acrobot_mj.olympics.protocol import CATEGORY_KEYS
from acrobot_mj.olympics.results import (
    PARTS,
    figure,
    global_seeds,
    global_text,
    names,
    part,
    percent,
    recorded,
    seeds_text,
    spread,
)

#: The robustness categories' names in the tables.
SHORT = dict(
    zip(
        CATEGORY_KEYS,
        ("model", "velocity noise", "torque noise", "response", "delay", "pulses"),
        strict=True,
    )
)


@dataclass(frozen=True)
class Row:
    """A table's row: its ``label`` and the summaries it shows, each part (performance,
    robustness, global) from the first of ``records`` that holds it."""

    label: str
    records: tuple[str, ...]

    def cells(self) -> dict[str, str]:
        """Each part's cell and each category's by key (``""`` where no record holds it), and
        the label, which names the parts measured on a second machine."""
        cells = dict.fromkeys((*PARTS, *CATEGORY_KEYS), "")
        elsewhere = []
        for which in PARTS:
            found = part(self.records, which)
            if found is None:
                continue
            run, summary = found
            digits = summary.get("digits")
            if summary.get("machine"):
                elsewhere.append(which)
            if which == "global":
                cells[which] = global_text(summary)
                continue
            score = run.get("overall") if which == "robustness" else run["score"]
            cells[which] = "" if score is None else figure(score, digits)
            for category in run.get("categories", ()):
                cells[category["key"]] = percent(category["score"], digits)
        where = ""
        if elsewhere:  # the whole row, or the parts named
            parts = "" if elsewhere == [p for p in PARTS if cells[p]] else ", ".join(elsewhere)
            where = f" ({parts}: a second machine)" if parts else " (a second machine)"
        return cells | {"label": self.label + where}


#: The entries on ``ai_olympics``: the global score on held-out seeds, the rest of seed 0.
FUNNEL = Row("`funnel`", ("funnel-held-out", "funnel", "funnel-robustness"))
MPC = Row("`funnel`, `mpc=true`", ("funnel-mpc-second-machine",))
TREE = Row("`tree`", ("tree-30-seeds", "tree-performance", "tree-robustness"))
REPLAN = Row(
    "`replan`, not real-time",
    ("replan-held-out", "replan-performance", "replan-robustness-second-machine"),
)
LEARNT = Row("`funnel` on a learnt model", ("funnel-learnt", "funnel-learnt-robustness"))
BLACK_BOX = Row("the black box's controller", ("black-box-held-out", "black-box"))
#: The controllers on the report's acrobot, the protocol scaled.
SCALED = (
    Row("`backward`", ("report-backward",)),
    Row("`backward`, held out", ("report-backward-held-out",)),
    Row("`funnel`", ("report-funnel",)),
    Row("`funnel`, `mpc=true`", ("report-funnel-mpc",)),
    Row("`runs/feedback`", ("report-feedback",)),
    Row("`runs/bb`", ("report-black-box",)),
)


def _line(cells: Sequence[str]) -> str:
    return "| " + " | ".join(cells) + " |"


def _table(head: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    lines = [_line(head), "|" + "---|" * len(head), *(_line(r) for r in rows)]
    return "\n".join(lines) + "\n"


def sources(*parts: str) -> str:
    """One line: where the leaderboards of ``parts`` publish their figures."""
    files = ", ".join(f"`{BOARDS[p].path}` ({p})" for p in parts)
    return f"Leaderboard{'s' if len(parts) > 1 else ''}: `{REPOSITORY}`, {files}.\n"


def best_cells() -> dict[str, str]:
    """Each column's best figure on its leaderboard."""
    cells = {
        "label": "leaderboard's best",
        "performance": figure(PERFORMANCE.best()[1]),
        "robustness": figure(ROBUSTNESS.best()[1]),
        "global": figure(GLOBAL.best()[1]),
    }
    return cells | {k: percent(ROBUSTNESS.best_percent(k) / 100) for k in CATEGORY_KEYS}


def _scores(rows: Sequence[Row], best: bool = True) -> str:
    columns = ("label", "performance", "robustness", *CATEGORY_KEYS, "global")
    found = [row.cells() for row in rows] + ([best_cells()] if best else [])
    head = ("entry", "performance", "robustness", *SHORT.values(), "global")
    text = _table(head, [[cells[c] for c in columns] for cells in found])
    return text + (f"\n{sources(*PARTS)}" if best else "")


def scores_table() -> str:
    """Our entries on ``ai_olympics`` (the categories in per cent) against each column's best
    on the leaderboards."""
    return _scores([FUNNEL, MPC, TREE, REPLAN])


def learnt_table() -> str:
    """``funnel`` built on the black box's learnt model, on the equations, and the
    leaderboards' best."""
    return _scores([LEARNT, Row("`funnel` on the equations", FUNNEL.records[1:])])


def black_box_table() -> str:
    """The black box's own controller on ``ai_olympics``, ``funnel`` built on its learnt
    model, and the leaderboards' best."""
    return _scores([BLACK_BOX, LEARNT])


def scaled_table() -> str:
    """The controllers on the report's acrobot under the scaled protocol (no leaderboard
    runs it)."""
    return _scores(SCALED, best=False)


def results_table() -> str:
    """The entries' three scores on both acrobots, and the leaderboards' best."""
    rows = [("`ai_olympics`", r) for r in (FUNNEL, LEARNT, TREE, REPLAN)]
    backward = Row("`backward`", ("report-backward-held-out", "report-backward"))
    rows += [("`report`, scaled", r) for r in (backward, SCALED[2])]
    found = [(model, row.cells()) for model, row in rows]
    found.append(("their plant", best_cells()))
    head = ("model", "controller", *PARTS)
    text = _table(head, [(m, *(c[k] for k in ("label", *PARTS))) for m, c in found])
    return text + "\n" + sources(*PARTS)


def _seed_cell(names_: Sequence[str]) -> str:
    """Each seed's global score and their mean, or their range where they were not kept."""
    found = part(names_, "global")
    if found is None:
        return ""
    run, summary = found
    digits, seeds = summary.get("digits"), global_seeds(summary)
    scores = [s["score"] for s in seeds if "score" in s]
    if len(seeds) == 1:
        return global_text(summary)
    if len(scores) < len(seeds):
        low, high = spread(summary) or (0.0, 0.0)
        shown = f"{figure(low, digits)} to {figure(high, digits)}"
    else:
        shown = ", ".join(figure(s, digits) for s in scores)
    return f"{shown}; mean {figure(run['score'], digits)}"


def seeds_table() -> str:
    """The global score of ``tree``, ``funnel`` and ``replan`` seed by seed: on the seeds the
    levels were chosen on, on held-out ones, and held out on a second machine."""
    rows = (
        (" (the levels were chosen here)", ("tree-global", "funnel", "replan-global")),
        (" (held out)", ("tree-held-out", "funnel-held-out", "replan-held-out")),
        (
            ", a second machine (AMD EPYC; `tree`'s first version)",
            ("tree-first-held-out-second-machine", "funnel-held-out-second-machine", ""),
        ),
    )
    lines = []
    for suffix, columns in rows:
        seeds = [s["seed"] for s in global_seeds(recorded(columns[0]))]
        cells = [_seed_cell([n]) if n else "" for n in columns]
        lines.append([seeds_text(seeds).removeprefix("seeds ") + suffix, *cells])
    head = ("seeds", "`tree`", "`funnel`", "`replan` (not real-time)")
    name, score = GLOBAL.best()
    best = f"The leaderboard's best global score: {name}'s {figure(score)}"
    return _table(head, lines) + f"\n{best}. {sources('global')}"


def leaderboard_table() -> str:
    """Every entry of the three leaderboards and its scores, best performance first."""
    entries = sorted(PERFORMANCE.scores, key=lambda e: -PERFORMANCE.scores[e])
    entries += sorted(set(GLOBAL.scores) - set(entries), key=lambda e: -GLOBAL.scores[e])
    boards = [BOARDS[p] for p in PARTS]
    rows = [[e, *(figure(b.scores[e]) if e in b.scores else "" for b in boards)] for e in entries]
    return _table(("entry", *PARTS), rows) + "\n" + sources(*PARTS)


def many_seeds() -> str:
    """``tree``'s mean over many seeds, its interval, and the entries of the global
    leaderboard above and below it."""
    return _seeds_line("tree-30-seeds", "`tree`")


def first_seeds() -> str:
    """The same for ``tree``'s first version (entered by state alone, the grown plans)."""
    return _seeds_line("tree-first-30-seeds", "its first version")


def _seeds_line(name: str, label: str) -> str:
    """The recorded run ``name``'s mean over many seeds, its interval, the leaderboard's
    entries above and below it, and its fraction of the bound (where the run has none, the
    bound of ``tree-first-30-seeds`` where its seeds are the same: the bound is the
    draw's)."""
    summary = recorded(name)
    low, high = summary["global"]["interval"]
    mean = summary["global"]["score"]
    ranked = sorted(GLOBAL.scores.items(), key=lambda item: -item[1])
    above = [f"{e}'s {figure(s)}" for e, s in ranked if s > mean]
    below = [f"{e}'s {figure(s)}" for e, s in ranked if s <= mean]
    seeds = [s["seed"] for s in global_seeds(summary)]
    bounded = summary
    if "bound" not in summary["global"]:
        bounded = recorded("tree-first-30-seeds")
        if [s["seed"] for s in global_seeds(bounded)] != seeds:
            bounded = summary
    bound = bounded["global"].get("bound")
    within = (
        f" The bound on these draws averages {figure(bound['score'])}: {label} is up "
        f"{figure(mean / bound['score'])} of it."
        if bound
        else ""
    )
    versus = f"below {_and(above)}, above {_and(below)}" if above else f"above {_and(below)}"
    first, top = ranked[0]
    unsure = (  # above the best in the mean, not beyond its interval
        f" Its interval reaches below {first}'s {figure(top)}: the lead is not sure."
        if mean > top >= low
        else ""
    )
    return (
        f"Mean **{figure(mean)}**, 95 % interval {figure(low)} to {figure(high)} "
        f"({seeds_text(seeds)}): {versus} on the ICRA 2025 simulation leaderboard.{unsure}"
        f"{within} {sources('global')}"
    )


def _and(words: Sequence[str]) -> str:
    return words[0] if len(words) == 1 else ", ".join(words[:-1]) + " and " + words[-1]


def icra_table() -> str:
    """Each leaderboard entry's own draw (the ICRA 2025 test replayed): its score there and
    ours, ``tree`` and ``funnel``; then who beats ``tree`` on whose draw."""
    drawn = [e for e in GLOBAL.scores if f"tree-icra2025-{e}" in names()]
    ours = {
        e: [recorded(f"{c}-icra2025-{e}")["global"]["score"] for c in ("tree", "funnel")]
        for e in drawn
    }
    bounds = {e: recorded(f"tree-icra2025-{e}")["global"].get("bound") for e in drawn}
    rows = [
        [
            f"{e}'s",
            figure(bounds[e]["score"]) if bounds[e] else "",
            figure(GLOBAL.scores[e]),
            *(figure(s) for s in ours[e]),
        ]
        for e in drawn
    ]
    text = _table(("draw", "bound", "leaderboard", "`tree`", "`funnel`"), rows)
    ahead = [e for e in drawn if ours[e][0] > GLOBAL.scores[e]]
    behind = [e for e in drawn if e not in ahead]
    said = f"On their own draws `tree` beats {_and(ahead)}" if ahead else "`tree` beats none"
    if behind:
        one = len(behind) == 1
        said += f"; {_and(behind)} beat{'s' if one else ''} `tree` on {'its' if one else 'theirs'}"
    return text + f"\n{said}. {sources('global')}"


def swing_up() -> str:
    """The criteria of ``funnel``'s performance episode."""
    run = recorded("funnel")["performance"]
    return (
        f"`funnel`'s swing-up: up at {run['swingup_time']:.3f} s, {run['energy']:.2f} J, torque "
        f"cost {run['tau_cost']:.2f}, smoothness {run['tau_smoothness']:.4f}, velocity cost "
        f"{run['velocity_cost']:.1f}.\n"
    )


def records_table() -> str:
    """Every recorded run: its file, entry, model, parts, how its figures were kept, and the
    command that reproduces it."""
    rows = []
    for name in names():
        summary = recorded(name)
        kept = [f"rounded to {summary['digits']}" if "digits" in summary else "as computed"]
        kept += ["seeds' range only"] if "range" in summary.get("global", {}) else []
        kept += ["a second machine"] if summary.get("machine") else []
        parts = ", ".join(p for p in PARTS if p in summary)
        model = summary["model"]
        rows.append(
            [
                f"`{name}`",
                f"`{model['entry']}` on `{model['name']}`",
                parts,
                "; ".join(kept),
                f"`{summary['command']}`",
            ]
        )
    return _table(("run", "controller", "parts", "figures", "command"), rows)
