"""acrobot-mj bench --quick runs and reports every measurement (speed itself is never asserted:
the machines are shared and noisy)."""

from __future__ import annotations

import json

import pytest

from acrobot_mj.cli import main


@pytest.mark.slow  # minutes: every row of the bench, at its smallest
def test_bench_quick_runs_and_writes_json(tmp_path, capsys, monkeypatch) -> None:
    out = tmp_path / "bench.json"
    # A peer python that is not there (through the variable): one line, the bench goes on.
    monkeypatch.setenv("ACROBOT_MJ_PEER_PYTHON", str(tmp_path / "no-such-python"))
    assert main(["bench", "--quick", "--json", str(out)]) == 0
    text = capsys.readouterr().out
    result = json.loads(out.read_text())
    for key in (
        "env_vs_gymnasium",
        "sarsa_vs_gymnasium_sarsa",
        "vector_env_vs_batch_ceiling",
        "lockstep_sarsa_vs_gymnasium_sarsa",
        *(f"vector_env_vs_sync_vector_env_N{n}" for n in (1, 4, 16, 64)),
        "book_vs_gymnasium_env_step",
        "tuned_vs_gymnasium_env_step",
        "tuned_seeds_vs_gymnasium_env_step",
        "vector_env_vs_batch_N1024",  # target 0.9 at N >= 256 (quick: N = 1024 only)
        "vector_env_vs_batch_io_floor_N1024",
    ):
        assert result["ratios"][key] > 0 and key in text
    assert len(result["rates_steps_per_second"]) == 11
    # The robustness score's 722 episodes of 5,000 steps, from the episode row, on 2 workers.
    rate = result["rates_steps_per_second"]["olympics robustness episode (steps)"]
    assert result["robustness_minutes_2_workers"] == pytest.approx(722 * 5000 / rate / 2 / 60)
    assert "olympics robustness (722 episodes) projected on 2 workers" in text
    assert "book learner (decisions)" in text and "tuned learner (decisions)" in text
    assert result["targets"]["book_vs_gymnasium_env_step"] == 1.5
    seeds = result["tuned_seeds"]  # 2 seeds of the CLI's whole run, between two baselines
    assert (seeds["seeds"], seeds["jobs"]) == (2, 2)
    assert seeds["ratio"] == seeds["decisions_per_second"] / seeds["gymnasium_env_step_per_second"]
    assert result["targets"]["tuned_seeds_vs_gymnasium_env_step"] == 3.0
    assert "tuned over 2 seeds, --jobs 2:" in text
    compiled = result["compiled_learner"]  # a fresh process compiles, then loads the cache
    assert compiled["cold"] > compiled["cached"] > 0 and "numba's cache" in text
    assert set(result["scaling_steps_per_second"]) == {"1", "64", "1024"}
    big = result["scaling_steps_per_second"]["1024"]
    assert result["ratios"]["vector_env_vs_batch_N1024"] == big["vector_env"] / big["batch_ceiling"]
    assert result["targets"]["vector_env_vs_batch_N1024"] == 0.9 and "batch + I/O" in text
    versus_sync = result["vector_env_vs_sync_steps_per_second"]
    assert set(versus_sync) == {"1", "4", "16", "64"}
    for row in versus_sync.values():  # the ratio is of the two rates measured side by side
        assert row["ratio"] == row["vector_env"] / row["sync_vector_env"]
    assert 1 < result["lockstep_peak_memory_mb_1024_learners"] < 1000
    sims = result["sim_seconds_per_second"]  # the env rows, at their own steps' lengths
    assert sims["gymnasium Acrobot-v1 env.step"] > 0 and "simulated s per wall s" in text
    peers = result["peers"]  # gymnax never runs in this Python (its Gymnasium is older)
    assert "gymnax" not in peers["peers"]
    gymnax = [line for line in text.splitlines() if line.startswith("skipped gymnax")]
    assert len(gymnax) == 1 and "no-such-python cannot run" in gymnax[0]
    assert {"envpool", "gymnax"} <= {*peers["peers"], *(w.split(":")[0] for w in peers["skipped"])}

    analytic = result["analytic_backend"]
    assert set(analytic["sizes"]) == {"1", "64", "1024", "4096"} and "analytic backend" in text
    for row in analytic["sizes"].values():
        for name in ("analytic_env", "mujoco_env", "kernel_scan", "kernel_scan_threads"):
            assert row[name] > 0
            assert row[f"{name}_sim_s_per_s"] == row[name] * analytic["decision_s"]
    assert analytic["decision_s"] == 0.2  # frame_skip 4 of 0.05 s
    assert analytic["profile_N1024"]["step_us"] > 0 and analytic["profile_N1024"]["physics_us"] > 0
    latency = result["latency"]  # the default entries, quick: 10 s global-test episodes
    assert list(latency) == ["tree", "funnel"] and "time per call of each entry's" in text
    for row in latency.values():
        assert row["realtime"] and row["steps"] == 5000 and 0 < row["calls"] < 5000
        assert 0 < row["median_ms"] <= row["p99_ms"] <= row["max_ms"]


def test_bench_parser_takes_a_peer_python() -> None:
    from acrobot_mj.cli import build_parser

    args = build_parser().parse_args(["bench", "--quick", "--peer-python", "/opt/peer/python"])
    assert args.peer_python == "/opt/peer/python"
