"""acrobot-mj bench --quick runs and reports every measurement (speed itself is never asserted:
the machines are shared and noisy)."""

from __future__ import annotations

import json

from acrobot_mj.cli import main


def test_bench_quick_runs_and_writes_json(tmp_path, capsys) -> None:
    out = tmp_path / "bench.json"
    assert main(["bench", "--quick", "--json", str(out)]) == 0
    text = capsys.readouterr().out
    result = json.loads(out.read_text())
    for key in (
        "env_vs_gymnasium",
        "sarsa_vs_gymnasium_sarsa",
        "vector_env_vs_batch_ceiling",
        "lockstep_sarsa_vs_gymnasium_sarsa",
        *(f"vector_env_vs_sync_vector_env_N{n}" for n in (1, 4, 16, 64)),
        "book_numpy_vs_gymnasium_env_step",
        "book_numba_vs_gymnasium_env_step",  # numba is in the test extra
    ):
        assert result["ratios"][key] > 0 and key in text
    assert len(result["rates_steps_per_second"]) == 10
    compiled = result["compiled_learner"]  # a fresh process compiles, then loads the cache
    assert compiled["cold"] > compiled["cached"] > 0 and "numba's cache" in text
    assert set(result["scaling_steps_per_second"]) == {"1", "64", "1024"}
    versus_sync = result["vector_env_vs_sync_steps_per_second"]
    assert set(versus_sync) == {"1", "4", "16", "64"}
    for row in versus_sync.values():  # the ratio is of the two rates measured side by side
        assert row["ratio"] == row["vector_env"] / row["sync_vector_env"]
    assert 1 < result["lockstep_peak_memory_mb_1024_learners"] < 1000
    analytic = result["analytic_backend"]  # numba is in the test extra
    assert set(analytic["sizes"]) == {"1", "64", "1024", "4096"} and "analytic backend" in text
    for row in analytic["sizes"].values():
        for name in ("analytic_env", "mujoco_env", "kernel_scan", "kernel_scan_threads"):
            assert row[name] > 0
            assert row[f"{name}_sim_s_per_s"] == row[name] * analytic["decision_s"]
    assert analytic["decision_s"] == 0.2  # frame_skip 4 of 0.05 s
    assert analytic["profile_N1024"]["step_us"] > 0 and analytic["profile_N1024"]["physics_us"] > 0
