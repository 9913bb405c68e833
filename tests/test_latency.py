"""The latency part of ``acrobot-mj bench`` (benchmarks/latency.py): an entry's controller timed
call by call in a short global-test episode, the reset's PID not timed, the thread pinned to one
core and unpinned after. Times are never compared with a bound: the machines are shared."""

from __future__ import annotations

import importlib.util
import json
import math
import os
from pathlib import Path
from types import ModuleType

import pytest

from acrobot_mj.cli import main
from acrobot_mj.olympics.protocol import GlobalPolicy

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"


@pytest.fixture(scope="module")
def latency() -> ModuleType:
    spec = importlib.util.spec_from_file_location("test_bench_latency", BENCHMARKS / "latency.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def ordered(row: dict) -> None:
    """The row's times finite, positive and in order; the fraction over a step a fraction."""
    times = (row["median_ms"], row["p99_ms"], row["max_ms"])
    assert all(math.isfinite(t) and t > 0 for t in times)
    assert row["median_ms"] <= row["p99_ms"] <= row["max_ms"]
    assert 0.0 <= row["over_step"] <= 1.0


def test_every_call_is_timed_when_no_reset_comes(latency) -> None:
    before = os.sched_getaffinity(0)
    policy = GlobalPolicy(t_final=2.0, resets=0)  # no reset: the entry acts at every step
    row = latency.episode_latency("funnel", "ai_olympics", policy, warm_up=0.1)
    assert row["steps"] == policy.steps == 1000
    assert row["calls"] == 1000  # the warm-up's calls are not counted
    assert row["step_ms"] == 2.0 and row["core"] in before
    ordered(row)
    assert os.sched_getaffinity(0) == before  # unpinned after


def test_the_resets_pid_is_not_timed(latency) -> None:
    # One reset at 1 s, held for more than 0.2 s: about 100 steps the entry does not act in.
    policy = GlobalPolicy(t_final=2.0, resets=1, jitter=0.0)
    row = latency.episode_latency("funnel", "ai_olympics", policy, warm_up=0)
    held = round(policy.reset_length / policy.dt)
    assert row["steps"] == 1000 and held <= row["steps"] - row["calls"] <= held + 2
    ordered(row)


def test_an_entry_that_waits_for_its_plans_is_not_timed(latency) -> None:
    assert latency.entry_latency("replan") == {"model": "ai_olympics", "realtime": False}
    lines = latency.latency_lines({"replan": latency.entry_latency("replan")})
    assert any(line.startswith("replan") and "not real-time" in line for line in lines)


def test_bench_runs_the_latency_part_alone(tmp_path, capsys) -> None:
    out = tmp_path / "bench.json"
    argv = "bench --quick --only latency --entries funnel,replan --json".split()
    assert main([*argv, str(out)]) == 0
    text = capsys.readouterr().out
    result = json.loads(out.read_text())
    assert set(result) == {"machine", "latency"}  # no rates
    funnel = result["latency"]["funnel"]
    assert funnel["realtime"] and funnel["steps"] == 5000  # quick: a 10 s episode
    assert 0 < funnel["calls"] < funnel["steps"]  # the resets' steps not timed
    ordered(funnel)
    assert result["latency"]["replan"] == {"model": "ai_olympics", "realtime": False}
    assert "funnel" in text and "not real-time by design" in text
    assert "steps/s" not in text  # the rates' table is not printed


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--only", "speed"], "parts are some of rates,latency"),
        (["--only", "latency", "--entries", "nope"], "entries must be some of"),
        (["--only", "rates", "--entries", "tree"], "latency part, which was not asked for"),
    ],
)
def test_bench_refuses_unknown_parts_and_entries_at_once(argv, message, capsys) -> None:
    with pytest.raises(SystemExit) as exit:
        main(["bench", *argv])
    assert exit.value.code == 2 and message in capsys.readouterr().err


def test_the_help_names_the_default_entries(latency, capsys) -> None:
    with pytest.raises(SystemExit):
        main(["bench", "--help"])
    help_text = " ".join(capsys.readouterr().out.split())  # argparse wraps the lines
    assert f"(default: {','.join(latency.DEFAULT_ENTRIES)})" in help_text
