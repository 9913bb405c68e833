"""The peers beside our vector env in one ``acrobot-mj bench`` run (the suite's side of
``benchmarks/peers.py``).

Peers importable in the bench's own Python (envpool, from the ``bench`` extra) are timed in
process, in rounds interleaved with our vector env at the same N. The others run in
``peers.py`` under a peer Python (``--peer-python PATH`` or :data:`ENV_VAR`: gymnax needs an
older Gymnasium, so an environment of its own), in a subprocess with a timeout, with our
vector env timed just before and just after it (medians). A peer that cannot run is skipped
with one line saying why; nothing here stops the rest of the bench.

Every row has steps per second and simulated seconds per wall second (theirs 0.2 s a step,
ours ``timestep * frame_skip``), and ours over theirs at the same N (> 1: ours is faster).
"""

from __future__ import annotations

import importlib.util
import json
import subprocess
from collections.abc import Callable
from pathlib import Path
from types import ModuleType
from typing import Any

Rate = Callable[[int], float]  # round -> sub-env steps per second
#: The peer Python when ``--peer-python`` is not given.
ENV_VAR = "ACROBOT_MJ_PEER_PYTHON"
PEER_SCRIPT = Path(__file__).with_name("peers.py")
#: Seconds the peer subprocess may take (JAX's import and three compiles included).
TIMEOUT = {True: 300.0, False: 900.0}  # by quick


class PeerError(RuntimeError):
    """The peer subprocess gave no result; the message is one line that says why."""


def load_peers() -> ModuleType:
    """``benchmarks/peers.py`` as a module (the suite is loaded from its file, not a package)."""
    spec = importlib.util.spec_from_file_location("acrobot_mj_bench_peers", PEER_SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def last_line(text: str, most: int | None = 200) -> str:
    """The last non-blank line of ``text`` (its first ``most`` characters), or "nothing"."""
    lines = [line.strip() for line in text.strip().splitlines() if line.strip()]
    return lines[-1][:most] if lines else "nothing"


def well_formed(result: Any) -> bool:
    """Whether ``result`` has the shape ``peers.py --json`` prints (rows of rates by N)."""
    try:
        return isinstance(result["skipped"], dict) and all(
            float(row["steps_per_second"]) > 0 and float(row["sim_seconds_per_second"]) > 0
            for entry in result["peers"].values()
            for row in entry["rows"].values()
        )
    except (TypeError, KeyError, AttributeError, ValueError):
        return False


def run_peer(command: list[str], timeout: float) -> dict[str, Any]:
    """Run ``command`` (a peer Python on ``peers.py --json ...``) and parse the JSON object on
    its last line of stdout; :class:`PeerError` (one line) if it cannot start, times out
    after ``timeout`` [s], fails, or prints no such object."""
    try:
        out = subprocess.run(command, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        raise PeerError(f"peer python {command[0]} timed out after {timeout:g} s") from None
    except OSError as error:
        raise PeerError(f"peer python {command[0]} cannot run: {error.strerror or error}") from None
    if out.returncode != 0:
        raise PeerError(
            f"peer python {command[0]} exited with {out.returncode}: {last_line(out.stderr)}"
        )
    try:
        result = json.loads(last_line(out.stdout, None))
    except json.JSONDecodeError:
        result = None
    if not well_formed(result):
        raise PeerError(
            f"peer python {command[0]} printed no peer result (last line: {last_line(out.stdout)})"
        )
    return result


def peer_command(
    python: str, peers: list[str], sizes: tuple[int, ...], steps: int, rounds: int
) -> list[str]:
    sizes_arg = ",".join(map(str, sizes))
    return [
        python,
        str(PEER_SCRIPT),
        "--json",
        "--only",
        ",".join(peers),
        "--sizes",
        sizes_arg,
        "--steps",
        str(steps),
        "--rounds",
        str(rounds),
    ]


def not_given(peer: str, why: str) -> str:
    return (
        f"{why}; and no peer python was given (--peer-python PATH or {ENV_VAR}), so {peer} "
        f"is skipped"
    )


def in_process(
    peers_module: ModuleType, local: list[str], ours: dict[int, Rate], steps: int, rounds: int
) -> tuple[dict, dict[int, list[float]], dict[str, str]]:
    """The peers of this Python, interleaved round by round with ``ours`` at each N."""
    sizes = tuple(ours)
    built, skipped = peers_module.build_all(tuple(local), sizes, steps)
    theirs = {(peer, n): [] for peer in built for n in sizes}
    mine: dict[int, list[float]] = {n: [] for n in sizes}
    for k in range(rounds if built else 0):
        for n in sizes:
            mine[n].append(ours[n](k))
            for peer in built:
                theirs[(peer, n)].append(built[peer][0][n](k))
    dt = peers_module.PEER_DT
    entries = {
        peer: {
            **extra,
            "where": "in process",
            "rows": {str(n): peers_module.row(theirs[(peer, n)], dt) for n in sizes},
        }
        for peer, (_, extra) in built.items()
    }
    return entries, mine, skipped


def in_peer(
    python: str, remote: list[str], ours: dict[int, Rate], steps: int, rounds: int, quick: bool
) -> tuple[dict, dict[int, list[float]], dict[str, str]]:
    """The peers of ``python``, run in a subprocess between two rounds of ``ours``."""
    mine = {n: [rate(0)] for n, rate in ours.items()}
    command = peer_command(python, remote, tuple(ours), steps, rounds)
    try:
        result = run_peer(command, TIMEOUT[quick])
    except PeerError as error:
        return (
            {},
            {n: [] for n in ours},
            {p: f"{p}: not installed here, and {error}" for p in remote},
        )
    for n, rate in ours.items():
        mine[n].append(rate(1))
    entries = {peer: {**e, "where": f"peer python {python}"} for peer, e in result["peers"].items()}
    return entries, mine, dict(result["skipped"])


def compare(
    peer_python: str | None,
    quick: bool,
    rounds: int,
    vector_env: Callable[[int, int], Rate],
    our_dt: float,
) -> dict[str, Any]:
    """The peers section of the bench's result: ``vector_env(n, steps)`` is our rate at N,
    ``our_dt`` [s] our simulated time per step; see the module docstring."""
    peers_module = load_peers()
    sizes, steps = peers_module.SIZES, 20_000 if quick else 100_000
    local = [p for p in peers_module.PEERS if peers_module.missing(p) is None]
    remote = [p for p in peers_module.PEERS if p not in local]
    ours = {}
    if local or (remote and peer_python):
        ours = {n: vector_env(n, max(peers_module.MIN_STEPS, steps // n)) for n in sizes}
    entries, mine, skipped = in_process(peers_module, local, ours, steps, rounds)
    if remote and peer_python:
        more, after, why = in_peer(peer_python, remote, ours, steps, rounds, quick)
        entries.update(more)
        skipped.update(why)
        for n in ours:
            mine[n] += after[n]
    elif remote:
        skipped.update({p: not_given(p, peers_module.missing(p)) for p in remote})
    mine = {n: v for n, v in mine.items() if v}
    section: dict[str, Any] = {
        "our_dt": our_dt,
        "peer_dt": peers_module.PEER_DT,
        "ours": {str(n): peers_module.row(v, our_dt) for n, v in mine.items()},
        "peers": entries,
        "skipped": [skipped[p] for p in peers_module.PEERS if p in skipped],
    }
    for entry in entries.values():
        for n, theirs in entry["rows"].items():
            if n in section["ours"]:
                mine_row = section["ours"][n]
                theirs["ours_over_theirs_steps"] = (
                    mine_row["steps_per_second"] / theirs["steps_per_second"]
                )
                theirs["ours_over_theirs_sim_seconds"] = (
                    mine_row["sim_seconds_per_second"] / theirs["sim_seconds_per_second"]
                )
    return section


LABELS = {"envpool": "envpool Acrobot-v1", "gymnax": "gymnax Acrobot-v1, vmap+scan"}


def report_lines(section: dict[str, Any]) -> list[str]:
    """The peers' table: steps and simulated seconds per wall second, ours over theirs."""
    skipped = [f"skipped {why}" for why in section["skipped"]]
    if not section["peers"]:
        return ["peers (envpool, gymnax): none measured", *skipped]
    lines = [
        f"peers beside our vector env (simulated s per wall s: ours {section['our_dt']:g} s a "
        f"step, theirs {section['peer_dt']:g} s; x: ours over theirs at the same N)",
        f"{'row':<34} {'N':>5} {'steps/s':>11} {'sim s/s':>10} {'x steps':>8} {'x sim s':>8}",
    ]
    for n, row in section["ours"].items():
        lines.append(
            f"{'vector env (acrobot_mj, MuJoCo)':<34} {n:>5} "
            f"{row['steps_per_second']:11.0f} {row['sim_seconds_per_second']:10.0f}"
        )
    for peer, entry in section["peers"].items():
        label = f"{LABELS.get(peer, peer)} {entry.get('version', '')}".strip()
        for n, row in entry["rows"].items():
            ratios = "".join(
                f" {row[key]:8.2f}"
                for key in ("ours_over_theirs_steps", "ours_over_theirs_sim_seconds")
                if key in row
            )
            lines.append(
                f"{label:<34} {n:>5} {row['steps_per_second']:11.0f} "
                f"{row['sim_seconds_per_second']:10.0f}{ratios}"
            )
        compiles = entry.get("compile_seconds")
        if compiles:
            said = ", ".join(f"N={n} {s:.1f} s" for n, s in compiles.items())
            lines.append(f"  {peer} compile (jit lower + compile, untimed above): {said}")
    return lines + skipped


def sections(
    rates: dict[str, float],
    quick: bool,
    rounds: int,
    peer_python: str | None,
    vector_env: Callable[[int, int], Rate],
) -> dict[str, Any]:
    """The suite's env rows (``rates`` [steps/s]) in simulated seconds per wall second, and the
    peers beside ``vector_env(n, steps)`` (our vector env's rate) at N = 1, 64 and 1024."""
    import gymnasium as gym

    import acrobot_mj
    from acrobot_mj.train.learners import make_env
    from acrobot_mj.train.presets import PRESETS

    timestep = acrobot_mj.AcrobotEnv().model.opt.timestep  # [s]; the vector env: frame_skip 1
    ours = gym.make(acrobot_mj.ENV_ID).unwrapped.dt  # the default frame_skip's decision [s]
    dts = {
        "gymnasium Acrobot-v1 env.step": gym.make("Acrobot-v1").unwrapped.dt,
        "acrobot_mj env via gymnasium.make": make_env(PRESETS["report"]).unwrapped.dt,
        "raw mj_step loop": timestep,
    }
    dts.update({name: timestep for name in rates if name.startswith(("mujoco.batch", "vector"))})
    return {
        "sim_seconds_per_second": sim_rates(rates, dts),
        "peers": compare(peer_python, quick, rounds, vector_env, ours),
    }


def section_lines(result: dict[str, Any]) -> list[str]:
    """The env rows in simulated seconds per wall second, then :func:`report_lines`."""
    lines = [f"{'env row':<36} {'simulated s per wall s':>23}"]
    for name, value in result["sim_seconds_per_second"].items():
        lines.append(f"{name:<36} {value:23.0f}")
    return [*lines, "", *report_lines(result["peers"])]


def sim_rates(rates: dict[str, float], dts: dict[str, float]) -> dict[str, float]:
    """Simulated seconds per wall second of the rows of ``rates`` [steps/s] that ``dts``
    gives a step's simulated time [s] for."""
    return {name: rate * dts[name] for name, rate in rates.items() if name in dts}
