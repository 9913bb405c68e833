"""What an entry is built on (:mod:`acrobot_mj.olympics.plants`): the equations of a shipped
acrobot, or a model of one decision with its own Jacobians and step, the tracker deciding
every few physics steps and its estimator predicting with that step. A learnt model is stood
in for here by the exact map of one 0.01 s decision (training and planning on a black box
take minutes); a kept plan is found again only for the model it was made on."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from acrobot_mj.control.controller import Held
from acrobot_mj.control.lqr import step_jacobians
from acrobot_mj.control.planned import planned_swing_up
from acrobot_mj.control.trajopt import Trajectory
from acrobot_mj.identify.library import LibraryModel, library_size
from acrobot_mj.olympics import entries, plants
from acrobot_mj.olympics.episodes import Conditions, episode
from acrobot_mj.olympics.scores import performance
from acrobot_mj.physics import integrators
from acrobot_mj.physics.models import MODELS

P = MODELS["ai_olympics"].params
EVERY = 5  # physics steps of 0.002 s a decision of 0.01 s


def decision_step(x: np.ndarray, u: float) -> np.ndarray:
    """Five RK4 steps of the true acrobot: the map a perfect learner of 0.01 s decisions finds."""
    for _ in range(EVERY):
        x = integrators.step_states(x, u, P, method="rk4", limits=False)
    return x


def decision_jacobians(x: np.ndarray, u: float) -> tuple[np.ndarray, np.ndarray]:
    """The chain rule through the five steps."""
    a, b = np.eye(4), np.zeros((4, 1))
    for _ in range(EVERY):
        a_k, b_k = step_jacobians(x, u, "rk4", P)
        a, b = a_k @ a, a_k @ b + b_k
        x = integrators.step_states(x, u, P, method="rk4", limits=False)
    return a, b


def exact_plant() -> plants.Plant:
    """The shipped plan at its decisions (its torques are held 5 steps), on the exact map."""
    shipped = planned_swing_up("ai_olympics")
    limits = replace(P, dt=EVERY * P.dt)
    plan = Trajectory(
        shipped.states[::EVERY], shipped.torques[::EVERY], limits.dt, "learned", 6.0, limits
    )
    chosen = plants.levels("ai_olympics")
    scaled = chosen.replace(
        upright=chosen.upright / 5, track=chosen.track / 5, entry=chosen.entry / 5
    )
    return plants.Plant("ai_olympics", plan, scaled, decision_jacobians, decision_step, EVERY)


def test_the_funnel_on_a_model_of_decisions_swings_up_in_the_protocol() -> None:
    """Its controller decides every 5 steps (held between), on an estimate predicted by the
    model's own step: from the 0.01 s plan it scores as the entry on the equations, 0.688 to
    three digits (the same plan; the criteria sum the same torques). Measured: 0.6882."""
    built = entries.ENTRIES["funnel"].build(exact_plant())
    assert isinstance(built, Held) and built.every == EVERY
    recording = episode(built, "ai_olympics", 10.0, Conditions(), 0)
    run = performance(recording, P.l1, P.l2)
    assert run["success"] and abs(run["score"] - 0.688) < 1e-3
    # Held: the applied torque changes only at a decision (else by the motor's rounding of
    # ``last + k (u - last)``, k = 1, within 1e-12 N m).
    steps = np.diff(recording.U)
    off = np.arange(len(steps)) % EVERY != EVERY - 1
    assert np.abs(steps[off]).max() < 1e-12 < np.abs(steps[~off]).max()


def test_a_learnt_model_gets_no_energy_pumping_and_the_equations_entries_refuse_it() -> None:
    plant = exact_plant()
    assert plant.learnt and entries.fallback(plant) is None  # no equations: no energy
    assert entries.fallback(plants.equations("ai_olympics")) is not None
    with pytest.raises(ValueError, match="the tree entry is built on the equations"):
        entries.ENTRIES["tree"].build(plant)


def _run(folder: Path) -> LibraryModel:
    """A black-box run's files: its model (all weights 0: the state stays) and its record."""
    folder.mkdir()
    model = LibraryModel(1, np.zeros((library_size(1), 4)))
    (folder / "model.json").write_text(json.dumps({"library": model.to_dict()}))
    return model


def test_a_kept_plan_is_found_again_only_for_its_model(tmp_path: Path) -> None:
    run = tmp_path / "bb"
    model = _run(run)
    limits = replace(P, dt=0.01)
    plan = Trajectory(np.zeros((4, 4)), np.array([1.0, -2.0, 0.5]), 0.01, "learned", 6.0, limits)
    plants.keep_plan(run, plan)
    kept = plants.kept_plan(run, model, limits)
    assert kept is not None and kept.torques.tolist() == [1.0, -2.0, 0.5]
    assert np.array_equal(kept.states, np.tile(plants.HANGING, (4, 1)))  # rolled on the model
    (run / "model.json").write_text('{"library": "another model"}')
    assert plants.kept_plan(run, model, limits) is None  # its fingerprint no longer matches
    (run / plants.PLAN_FILE).write_text("not json")
    assert plants.kept_plan(run, model, limits) is None


def test_only_a_black_box_run_is_a_plant(tmp_path: Path, capsys) -> None:
    from acrobot_mj.cli import main

    run = tmp_path / "fb"
    run.mkdir()
    (run / "run.json").write_text(json.dumps({"kind": "state_feedback", "config": {}, "seed": 0}))
    with pytest.raises(SystemExit):
        main(["olympics", "funnel", "--model", str(run), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    assert "is not a black-box run (its kind 'state_feedback')" in err and "\n" not in err
    with pytest.raises(SystemExit):
        main(["olympics", "tree", "--model", str(run), "--out", str(tmp_path / "o")])
    assert "the tree entry is built on the equations" in capsys.readouterr().err
