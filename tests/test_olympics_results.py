"""Our recorded AI Olympics scores (acrobot_mj/olympics/recorded/) and the leaderboards'
figures (acrobot_mj.olympics.leaderboard): each record is its run's olympics.json without the
episodes, its command makes that run, its figures hold together, and the README states them."""

from __future__ import annotations

import itertools
import json
import re
import shlex
from pathlib import Path

import numpy as np
import pytest

from acrobot_mj.cli import build_parser
from acrobot_mj.olympics import results
from acrobot_mj.olympics.leaderboard import BOARDS, GLOBAL, PERFORMANCE, ROBUSTNESS
from acrobot_mj.olympics.protocol import CATEGORY_KEYS, ICRA2025_DRAWS
from acrobot_mj.olympics.report import read_olympics, write_olympics
from acrobot_mj.olympics.results import global_seeds, names, recorded, summary
from tests.test_olympics_scores import small_results

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()
#: The keys a summary may hold beyond the record's kept ones and its parts.
EXTRA = {"command", "note", "digits", "machine"}


def test_a_summary_is_the_record_without_its_episodes(tmp_path, monkeypatch) -> None:
    record = read_olympics(write_olympics(tmp_path / "run", small_results()))
    kept = summary(record, "acrobot-mj olympics funnel --out run", "a note")
    assert kept["command"] == "acrobot-mj olympics funnel --out run" and kept["note"] == "a note"
    assert "episode" not in json.dumps(kept) and "sweeps" not in json.dumps(kept)
    assert kept["performance"] == {k: v for k, v in record["performance"].items() if k != "episode"}
    assert kept["robustness"]["overall"] == record["robustness"]["overall"]
    categories = record["robustness"]["categories"]
    assert [c["score"] for c in kept["robustness"]["categories"]] == [
        c["score"] for c in categories
    ]
    assert kept["global"]["seeds"] == record["global"]["seeds"]
    assert summary(kept, kept["command"], kept["note"]) == kept  # a summary reduces to itself
    with pytest.raises(ValueError, match="not an olympics record"):
        summary({"kind": "run"}, "x")
    monkeypatch.setattr(results, "FOLDER", tmp_path / "recorded")
    path = results.record_summary(tmp_path / "run", "small", "acrobot-mj olympics funnel --out run")
    assert path == tmp_path / "recorded" / "small.json"
    assert results.recorded("small") == summary(record, "acrobot-mj olympics funnel --out run")


@pytest.mark.parametrize("name", names())
def test_a_recorded_run_is_what_its_command_makes(name, tmp_path, monkeypatch) -> None:
    found = recorded(name)
    parts = [p for p in results.PARTS if p in found]
    assert parts and set(found) <= {*results.KEPT, *parts, *EXTRA}, sorted(found)
    words = shlex.split(found["command"])
    seeds = [s["seed"] for s in global_seeds(found)] if "global" in found else []
    monkeypatch.chdir(tmp_path)  # a black-box run given as --model: its folder must exist
    for flag, value in itertools.pairwise(words):
        if flag == "--model" and "/" in value:
            (tmp_path / value).mkdir(parents=True)
    args = build_parser().parse_args(words[1:])
    assert args.command == "olympics" and args.controller == found["model"]["entry"]
    learnt = "/" in args.model  # a black-box run's learnt model of the acrobot scored
    assert learnt or args.model == found["model"]["name"]
    assert found["protocol"] == (
        "ai_olympics" if learnt or args.model == "ai_olympics" else "scaled"
    )
    assert list(args.scores) == parts
    assert args.seed == found["seeds"]["seed"]
    if seeds:
        assert seeds == list(range(args.seed, args.seed + args.seeds))


@pytest.mark.parametrize("name", names())
def test_recorded_figures_hold_together(name) -> None:
    """A mean is its seeds' mean, a range holds it, the overall robustness is its categories'
    mean: exactly as computed, or to the digits a rounded record keeps."""
    found = recorded(name)
    tolerance = 10.0 ** -found["digits"] if "digits" in found else 1e-9
    scores = [found[p]["score"] for p in ("performance", "global") if p in found]
    if "global" in found:
        run, seeds = found["global"], global_seeds(found)
        kept = [s["score"] for s in seeds if "score" in s]
        if len(kept) == len(seeds):
            assert run["score"] == pytest.approx(np.mean(kept), abs=tolerance)
        else:
            low, high = run["range"]
            assert low <= run["score"] <= high and not kept
        if run.get("interval"):
            low, high = run["interval"]
            assert low < run["score"] < high
    if "robustness" in found:
        robustness = found["robustness"]
        categories = {c["key"]: c["score"] for c in robustness["categories"]}
        assert set(categories) <= set(CATEGORY_KEYS)
        if len(categories) == len(CATEGORY_KEYS):
            assert robustness["overall"] == pytest.approx(
                np.mean([*categories.values()]), abs=tolerance
            )
        scores += [robustness["overall"], *categories.values()]
    assert all(0.0 <= s <= 1.0 for s in scores)


def test_the_leaderboards_name_their_entries_alike() -> None:
    """Performance and robustness rank the same entries, each robustness entry has every
    category, and the global board's entries are the ones whose draws are replayed."""
    assert set(PERFORMANCE.scores) == set(ROBUSTNESS.scores) == set(ROBUSTNESS.percents)
    assert all(set(p) == set(CATEGORY_KEYS) for p in ROBUSTNESS.percents.values())
    assert set(GLOBAL.scores) == set(ICRA2025_DRAWS)
    for board in BOARDS.values():
        assert all(0.0 <= s <= 1.0 for s in board.scores.values())
        name, score = board.best()
        assert score == max(board.scores.values()) and board.scores[name] == score
        assert board.source().endswith(f"`{board.path}`") and board.path.endswith(".csv")


def _figure(name: str, part: str = "global", digits: int = 3) -> str:
    found = recorded(name)[part]
    return f"{found['overall'] if part == 'robustness' else found['score']:.{digits}f}"


def test_the_readme_states_the_recorded_scores() -> None:
    """The README's results table is not generated: each AI Olympics figure it states is the
    recorded one, rounded as it prints it, and each leaderboard figure the board's best."""
    best = {p: f"{b.best()[1]:.3f}" for p, b in BOARDS.items()}
    tree = recorded("tree-30-seeds")["global"]
    bound = recorded("tree-first-30-seeds")["global"]["bound"]  # the same seeds: the same bound
    low, high = tree["interval"]
    side = "above" if tree["score"] > float(best["global"]) else "below"
    first = recorded("tree-first-30-seeds")["global"]["seeds"]
    assert [s["seed"] for s in tree["seeds"]] == [s["seed"] for s in first]
    scaled = [recorded(f"report-{c}") for c in ("backward", "funnel", "feedback", "black-box")]
    perf = [r["performance"]["score"] for r in scaled]
    robust = [r["robustness"]["overall"] for r in scaled]
    held_out = recorded("report-backward-held-out")["global"]
    held = [seed["score"] for seed in held_out["seeds"]]
    stated = [
        f"performance {_figure('funnel', 'performance')}, robustness "
        f"{_figure('funnel-robustness', 'robustness')}, global "
        f"{_figure('funnel-held-out', digits=2)} on held-out seeds (leaderboard's best: "
        f"{best['performance']}, {best['robustness']}, {best['global']})",
        f"performance {_figure('funnel-learnt', 'performance')}, robustness "
        f"{_figure('funnel-learnt-robustness', 'robustness')} (leaderboard's best: "
        f"{best['performance']}, {best['robustness']})",
        f"performance {min(perf):.2f}-{max(perf):.2f}, robustness {min(robust):.2f}-"
        f"{max(robust):.2f}; global {held_out['score']:.2f} on held-out seeds 3 to 10 "
        f"({min(held):.3f} to {max(held):.3f}; 0.6 aimed for)",
        f"global {tree['score']:.3f} on {len(tree['seeds'])} held-out seeds ([95 % interval "
        f"{low:.3f} to {high:.3f}](docs/guide/olympics-global.md); {side} the leaderboard's "
        f"best, {best['global']}; [{tree['score'] / bound['score']:.3f} of the bound]"
        "(docs/guide/olympics-global.md#the-bound)), robustness "
        f"{_figure('tree-robustness', 'robustness')}",
        f"global {_figure('replan-held-out', digits=2)} on held-out seeds 3 to 10 (the "
        f"leaderboard's best: {best['global']})",
    ]
    missing = [line for line in stated if line not in README]
    assert missing == [], "README.md does not state the recorded figures:\n" + "\n".join(missing)
    quoted = re.findall(r"leaderboard's best[:,] ((?:\d\.\d+(?:, )?)+)", README)
    assert len(quoted) == 4 and set(", ".join(quoted).split(", ")) <= set(best.values())
