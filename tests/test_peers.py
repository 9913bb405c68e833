"""The peers' side of ``acrobot-mj bench`` (benchmarks/peers.py, benchmarks/peer_compare.py)
without the peers: the subprocess's failures become one line each, ``peers.py`` says what is
missing, and nothing depends on a peer env being installed (none is in CI). Speed is never
asserted."""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
from pathlib import Path
from types import ModuleType

import pytest

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"


def load(name: str) -> ModuleType:
    spec = importlib.util.spec_from_file_location(f"test_bench_{name}", BENCHMARKS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def compare() -> ModuleType:
    return load("peer_compare")


ROW = {"steps_per_second": 10.0, "sim_seconds_per_second": 2.0}
GOOD = {"dt": 0.2, "peers": {"gymnax": {"version": "1", "rows": {"1": ROW}}}, "skipped": {}}


def python_printing(code: str) -> list[str]:
    return [sys.executable, "-c", code]


def test_run_peer_parses_the_last_json_line(compare) -> None:
    code = f"print('jax says hello'); print({json.dumps(json.dumps(GOOD))})"
    assert compare.run_peer(python_printing(code), 30) == GOOD


@pytest.mark.parametrize(
    ("code", "said"),
    [
        (
            "import sys; sys.stderr.write('first\\nModuleNotFoundError: jax\\n'); sys.exit(3)",
            "exited with 3: ModuleNotFoundError: jax",
        ),
        ("print('not json')", "printed no peer result (last line: not json)"),
        (
            'print(\'{"peers": {"gymnax": {"rows": {"1": {}}}}, "skipped": {}}\')',
            "printed no peer result",
        ),
        ("", "printed no peer result (last line: nothing)"),
    ],
)
def test_run_peer_failures_are_one_line(compare, code: str, said: str) -> None:
    with pytest.raises(compare.PeerError) as error:
        compare.run_peer(python_printing(code), 30)
    assert said in str(error.value) and "\n" not in str(error.value)


def test_run_peer_times_out_and_missing_python(compare) -> None:
    with pytest.raises(compare.PeerError, match=r"timed out after 0\.5 s"):
        compare.run_peer(python_printing("import time; time.sleep(30)"), 0.5)
    with pytest.raises(compare.PeerError, match="cannot run: No such file"):
        compare.run_peer(["/nonexistent/bin/python", "peers.py"], 30)


def fake_vector_env(n: int, steps: int):
    return lambda k: 1000.0 * n  # no env: the peers' handling only


def test_compare_skips_peers_that_cannot_run(compare, monkeypatch) -> None:
    peers = load("peers")
    monkeypatch.setattr(peers, "missing", lambda peer: f"{peer}: not installed in this test")
    monkeypatch.setattr(compare, "load_peers", lambda: peers)
    section = compare.compare(None, True, 1, fake_vector_env, 0.05)
    assert section["peers"] == {} and section["ours"] == {}
    assert [line.split(":")[0] for line in section["skipped"]] == ["envpool", "gymnax"]
    assert all("no peer python was given" in line for line in section["skipped"])
    section = compare.compare("/nonexistent/bin/python", True, 1, fake_vector_env, 0.05)
    for line in section["skipped"]:
        assert "cannot run" in line and "\n" not in line
    lines = compare.report_lines(section)
    assert sum(line.startswith("skipped ") for line in lines) == 2


def test_compare_ratios_from_a_peer_result(compare, monkeypatch) -> None:
    peers = load("peers")
    monkeypatch.setattr(peers, "missing", lambda peer: f"{peer}: not installed in this test")
    monkeypatch.setattr(compare, "load_peers", lambda: peers)
    monkeypatch.setattr(compare, "run_peer", lambda command, timeout: GOOD)
    section = compare.compare("python-with-gymnax", True, 1, fake_vector_env, 0.05)
    row = section["peers"]["gymnax"]["rows"]["1"]
    assert row["ours_over_theirs_steps"] == 1000.0 / 10.0
    assert row["ours_over_theirs_sim_seconds"] == 50.0 / 2.0
    assert section["peers"]["gymnax"]["where"] == "peer python python-with-gymnax"
    assert any("gymnax Acrobot-v1" in line for line in compare.report_lines(section))


def test_peer_script_says_what_is_missing() -> None:
    if importlib.util.find_spec("gymnax") is not None:
        pytest.skip("gymnax is installed here")
    out = subprocess.run(
        [sys.executable, str(BENCHMARKS / "peers.py"), "--json", "--only", "gymnax"],
        capture_output=True,
        text=True,
        timeout=120,
        check=True,
    )
    result = json.loads(out.stdout.splitlines()[-1])
    assert result["peers"] == {}
    why = result["skipped"]["gymnax"]
    assert "not installed" in why and "docs/guide/benchmarks.md" in why
