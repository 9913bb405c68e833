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


def _variant(tmp_path: Path, base: str = "ai_olympics", **changes: float) -> str:
    """A model file: the shipped ``base`` with ``changes``."""
    data = {**MODELS[base].to_dict(), **changes}
    path = tmp_path / f"{base}_variant.json"
    path.write_text(json.dumps(data))
    return str(path)


def test_a_model_file_takes_its_kin_s_settings_and_the_entries_set_for_one_acrobot_refuse_it(
    tmp_path: Path,
) -> None:
    from acrobot_mj.control.planned import kindred
    from acrobot_mj.olympics.swing_ups import check_plannable

    heavy = _variant(tmp_path, m2=0.6)
    assert kindred("ai_olympics") == "ai_olympics" and kindred(heavy) == "ai_olympics"
    # The pendubot shares the step and integrator but drives the shoulder: not kin.
    assert kindred(_variant(tmp_path, "ai_olympics_pendubot", m2=0.6)) == "ai_olympics_pendubot"
    assert check_plannable(heavy) == "ai_olympics"
    entries.ENTRIES["funnel"].check(heavy)
    for name in ("tree", "replan"):  # their plan sets and waits are ai_olympics' own
        with pytest.raises(ValueError, match=f"the {name} entry is for ai_olympics, not '"):
            entries.ENTRIES[name].check(heavy)
    report_like = _variant(tmp_path, "report", m2=1.1)
    assert kindred(report_like) == "report"
    with pytest.raises(ValueError, match="planned on first use only for an acrobot stepped as"):
        entries.ENTRIES["funnel"].check(report_like)


def test_a_swing_up_planned_on_first_use_is_kept_and_planned_again_only_when_unusable(
    tmp_path: Path, monkeypatch
) -> None:
    from acrobot_mj.olympics import swing_ups

    heavy = _variant(tmp_path, m2=0.6)
    acrobot = plants.resolve(heavy)
    made: list[int] = []

    def plan(model):  # a stand-in for minutes of IPOPT: the shipped torques on this acrobot
        made.append(1)
        torques = planned_swing_up("ai_olympics").torques
        p = model.analytic
        states = integrators.simulate(plants.HANGING.copy(), torques, "rk4", p)
        states[-1] = (np.pi / 2, 0.0, 0.0, 0.0)  # the check wants upright at its end
        return Trajectory(states, torques, p.dt, "rk4", p.max_torque, p)

    monkeypatch.setattr(swing_ups, "performance_swing_up", plan)
    monkeypatch.setattr(Trajectory, "residual", lambda self: 0.0)
    monkeypatch.setenv("ACROBOT_MJ_CACHE", str(tmp_path / "cache"))
    first = swing_ups.swing_up_for(heavy)
    assert made == [1] and first.params == acrobot.analytic
    again = swing_ups.swing_up_for(heavy)
    assert made == [1] and np.array_equal(again.torques, first.torques)  # read, not planned
    kept = next((tmp_path / "cache" / "swing_ups").glob("*.json"))
    kept.write_text("{not json")
    swing_ups.swing_up_for(heavy)
    assert made == [1, 1]  # a corrupt plan is planned again, and kept again
    assert swing_ups.swing_up_for(heavy).params == acrobot.analytic and made == [1, 1]
    plant = plants.equations(heavy)
    assert (plant.name, plant.model) == ("ai_olympics", heavy)
    assert plant.levels == plants.levels("ai_olympics")
    assert plants.equations("ai_olympics").model == ""  # a shipped acrobot is its own


@pytest.mark.slow
def test_funnel_scores_an_acrobot_read_from_a_file_on_a_swing_up_planned_for_it(
    tmp_path: Path, monkeypatch
) -> None:
    """``ai_olympics`` with its second link 10 % heavier: the swing-up planned on its
    parameters (about 2 minutes of one core), checked on them, and followed in the performance
    episode. Measured (the CLI, the same file): it swings up and scores 0.67506 (0.688 on
    ai_olympics)."""
    from acrobot_mj.olympics import sources
    from acrobot_mj.olympics.swing_ups import FIRST_USE, swing_up_for

    monkeypatch.setenv("ACROBOT_MJ_CACHE", str(tmp_path / "cache"))
    heavy = _variant(tmp_path, m2=MODELS["ai_olympics"].params.m2 * 1.1)
    plan = swing_up_for(heavy)
    assert plan.params == plants.resolve(heavy).analytic and plan.residual() < FIRST_USE
    recording = episode(sources.build("funnel", heavy), heavy, 10.0, Conditions(), 0)
    run = performance(recording, P.l1, P.l2)
    assert run["success"] and abs(run["score"] - 0.67506) < 5e-3  # IPOPT's rounding across BLAS
