"""Shared fixtures: the compiled models, the report's parameters and seeded random states; a
lockstep run interrupted and resumed; the TCP sockets listening (a local Ray's)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

# acrobot_mj before mujoco: it picks the headless GL backend (MUJOCO_GL) that mujoco reads on
# import (see acrobot_mj/envs/gl.py), so frames can be rendered in this process too.
# isort: off
import acrobot_mj  # noqa: F401  before mujoco: it picks the GL backend mujoco reads on import
import mujoco
# isort: on

from acrobot_mj.envs.assets import model_path
from acrobot_mj.physics.params import AcrobotParams
from acrobot_mj.train.run import RunOptions

#: Number of random states for the cross-checks (at least 100, to sample the whole domain).
N_STATES = 200


@pytest.fixture
def params() -> AcrobotParams:
    return AcrobotParams()


@pytest.fixture
def model() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(str(model_path("scene.xml")))


@pytest.fixture
def data(model: mujoco.MjModel) -> mujoco.MjData:
    return mujoco.MjData(model)


def random_states(seed: int, n: int = N_STATES) -> tuple[np.ndarray, np.ndarray]:
    """``n`` states ``(q1, q2, dq1, dq2)`` and torques covering the task's whole domain:
    angles on the full circle, velocities up to the limits, torques in [-1, 1] N m."""
    rng = np.random.default_rng(seed)
    p = AcrobotParams()
    q = rng.uniform(-math.pi, math.pi, (n, 2))
    dq = rng.uniform(-1, 1, (n, 2)) * [p.max_vel1, p.max_vel2]
    tau = rng.uniform(-p.max_torque, p.max_torque, n)
    return np.concatenate([q, dq], 1), tau


def listening() -> set[str]:
    """Local addresses (hex, as /proc/net gives them) of the TCP sockets listening now."""
    found = set()
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        with open(table) as f:
            for line in f.readlines()[1:]:
                local, state = line.split()[1], line.split()[3]
                if state == "0A":  # LISTEN
                    found.add(local)
    return found


#: 127.0.0.1 in /proc/net/tcp, and as an IPv4-mapped or plain loopback in tcp6.
LOOPBACK = ("0100007F:", "0000000000000000FFFF00000100007F:", "00000000000000000000000001000000:")


@pytest.fixture
def figures(monkeypatch) -> dict:
    """The matplotlib figures the package saves during a test, by file name (still saved)."""
    from acrobot_mj.report import plots

    saved, save = {}, plots.save_figure

    def capture(figure, path):
        saved[Path(path).name] = figure
        return save(figure, path)

    monkeypatch.setattr(plots, "save_figure", capture)
    return saved


def lockstep_interrupted_and_resumed(config, seeds, tmp_path, monkeypatch, stop_at: int):
    """``train_lockstep`` whole into ``tmp_path/whole``, and into ``tmp_path/split`` stopped by
    Ctrl-C inside the ``stop_at``-th ``vec.step`` (mid-episode), checked to have stopped part-way
    at each learner's episode boundary, then resumed: the two lists of run records."""
    from acrobot_mj.envs.vector import AcrobotVectorEnv
    from acrobot_mj.train.checkpoint import load_checkpoint
    from acrobot_mj.train.lockstep import train_lockstep
    from acrobot_mj.train.records import CHECKPOINT_FILE

    whole = train_lockstep(config, seeds, tmp_path / "whole")
    calls = {"n": 0}
    step = AcrobotVectorEnv.step

    def interrupting(self, actions):
        calls["n"] += 1
        if calls["n"] == stop_at:
            raise KeyboardInterrupt
        return step(self, actions)

    monkeypatch.setattr(AcrobotVectorEnv, "step", interrupting)
    with pytest.raises(KeyboardInterrupt, match="checkpoint"):
        train_lockstep(config, seeds, tmp_path / "split")
    monkeypatch.setattr(AcrobotVectorEnv, "step", step)
    done = [
        load_checkpoint(tmp_path / "split" / f"seed_{s}" / CHECKPOINT_FILE)[0]["episodes_done"]
        for s in seeds
    ]
    assert 0 < min(done) and max(done) < config.episodes  # stopped part-way
    return whole, train_lockstep(config, seeds, tmp_path / "split", options=RunOptions(resume=True))
