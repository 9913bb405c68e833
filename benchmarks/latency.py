"""The latency rows of ``acrobot-mj bench``: each AI Olympics entry's time per call of its
controller in one global-test episode, the measuring thread on one core.

An entry wins in real time when every call takes at most one step of the protocol (0.002 s on
``ai_olympics``). :func:`episode_latency` wraps the entry's controller in
:class:`~acrobot_mj.control.controller.Timed` inside the protocol's testing controller
(:func:`~acrobot_mj.olympics.episodes.global_run`, the one episode loop), so the reset's PID is not
timed; :func:`entry_latency` reports an entry that is not real-time by design as such, without
timing it.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator, Sequence
from dataclasses import replace
from typing import Any

from acrobot_mj.control.controller import Timed
from acrobot_mj.olympics import sources
from acrobot_mj.olympics.entries import ENTRIES
from acrobot_mj.olympics.episodes import Scored, global_run
from acrobot_mj.olympics.protocol import GlobalPolicy
from acrobot_mj.olympics.scaling import protocol_for
from acrobot_mj.olympics.sources import Source
from acrobot_mj.settings import declared, parse

#: The entries the bench times when none are named.
DEFAULT_ENTRIES = ("tree", "funnel")
#: The seconds of a short episode run first, so that building and compiling is not timed.
WARM_UP = 1.0


@contextlib.contextmanager
def pinned(core: int | None = None) -> Iterator[int | None]:
    """The calling thread on ``core`` (None: the lowest it may use) while inside, its cores
    restored after; where the system cannot pin (not Linux), nothing pinned (None)."""
    if not hasattr(os, "sched_setaffinity"):
        yield None
        return
    allowed = os.sched_getaffinity(0)
    chosen = min(allowed) if core is None else core
    os.sched_setaffinity(0, {chosen})
    try:
        yield chosen
    finally:
        os.sched_setaffinity(0, allowed)


def episode_latency(
    scored: Scored,
    model: str,
    policy: GlobalPolicy,
    seed: int = 0,
    *,
    core: int | None = None,
    warm_up: float = WARM_UP,
) -> dict[str, Any]:
    """The time per call of ``scored``'s controller in ``policy``'s global episode of ``seed``
    on ``model``, pinned to ``core`` (:func:`pinned`), after an untimed episode of ``warm_up``
    [s] (0: none): :meth:`~acrobot_mj.control.controller.Timed.summary`, the episode's steps,
    the step [ms] and the core."""
    targets, reset_times = policy.draw(seed)
    with pinned(core) as used:
        if warm_up > 0:
            short = replace(policy, t_final=min(warm_up, policy.t_final))
            global_run(sources.build(scored, model), model, targets, reset_times, short)
        timed = Timed(sources.build(scored, model))
        recording = global_run(timed, model, targets, reset_times, policy)
    return {
        **timed.summary(policy.dt),
        "steps": len(recording.U),
        "step_ms": policy.dt * 1e3,
        "core": used,
    }


def entry_source(spec: str) -> Source:
    """An entry with its options, ``NAME[:OPTION=VALUE]...`` (``tree:candidates=32``), each
    option parsed as the entry declares it; refused in one line where it has no such one."""
    name, *pairs = spec.split(":")
    if name not in ENTRIES:
        raise ValueError(f"entries must be some of {','.join(ENTRIES)}, got {spec!r}")
    entry, options = ENTRIES[name], {}
    for pair in pairs:
        key, _, text = pair.partition("=")
        if key not in declared(entry.options) or not text:
            raise ValueError(f"{spec!r}: the {name} entry has no option {key!r} (OPTION=VALUE)")
        options[key] = parse(entry.options, key, text)
    return Source(name, options)


def entry_latency(name: str, seed: int = 0, seconds: float | None = None) -> dict[str, Any]:
    """:func:`episode_latency` of the entry ``name`` (:func:`entry_source`: with its options)
    on its acrobot (``ai_olympics`` unless it is set for another) in that acrobot's global test
    (``seconds`` long; None: the protocol's length); an entry that is not real-time by design
    is not timed."""
    source = entry_source(name)
    entry = ENTRIES[source.name]
    model = entry.only or "ai_olympics"
    if not entry.realtime:
        return {"model": model, "realtime": False}
    policy = protocol_for(model).global_policy
    if seconds is not None:
        policy = replace(policy, t_final=seconds)
    return {"model": model, "realtime": True, **episode_latency(source, model, policy, seed)}


def checked(entries: Sequence[str]) -> tuple[str, ...]:
    """``entries`` as a tuple, refused in one line unless each is an entry's name, with its
    options (:func:`entry_source`)."""
    if not entries:
        raise ValueError(f"entries must be some of {','.join(ENTRIES)}, got none")
    for spec in entries:
        entry_source(spec)
    return tuple(entries)


def latency_rows(entries: Sequence[str] = DEFAULT_ENTRIES, quick: bool = False) -> dict[str, Any]:
    """:func:`entry_latency` of each of ``entries`` (quick: 10 s episodes), seed 0."""
    return {name: entry_latency(name, seconds=10.0 if quick else None) for name in entries}


def latency_lines(rows: dict[str, Any]) -> list[str]:
    """The latency rows as text, one line an entry."""
    lines = [
        f"time per call of each entry's controller in one global-test episode (after an "
        f"untimed {WARM_UP:g} s one), the thread on one core",
        f"{'entry':<10} {'steps':>7} {'calls':>7} {'median ms':>10} {'p99 ms':>8} "
        f"{'max ms':>8} {'> step':>8}",
    ]
    for name, row in rows.items():
        if not row["realtime"]:
            lines.append(f"{name:<10} not real-time by design (the simulation waits for it)")
            continue
        lines.append(
            f"{name:<10} {row['steps']:7d} {row['calls']:7d} {row['median_ms']:10.3f} "
            f"{row['p99_ms']:8.3f} {row['max_ms']:8.2f} {row['over_step']:8.2%}"
        )
    timed = [row for row in rows.values() if row["realtime"]]
    if timed:
        steps = ", ".join(sorted({f"{row['step_ms']:g} ms" for row in timed}))
        cores = ", ".join(sorted({str(row["core"]) for row in timed}))
        lines.append(f"(> step: the fraction of calls longer than a step, {steps}; core {cores})")
    return lines
