"""Which config fields apply is declared by the algorithm, the features and the task: switching
one keeps nothing stale, setting a field that has no effect is refused, naming why."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from acrobot_mj.train.config import TrainConfig
from acrobot_mj.train.presets import PRESETS, TUNED_0_2

BOOK, REPORT = PRESETS["book"], PRESETS["report"]
TILES = ("tilings", "subset_tilings", "angle_tiles", "velocity_tiles")
GRID = ("angle_bins", "velocity_bins", "velocity_centre_max")


def test_switching_a_presets_algorithm_drops_what_no_longer_applies() -> None:
    config = BOOK.replace(algorithm="sarsa", features="grid")
    assert (config.lam, config.traces, config.trace_cutoff) == (None, None, None)
    assert all(getattr(config, name) is None for name in TILES)
    assert (config.angle_bins, config.velocity_bins) == (5, 3)  # the grid's defaults
    assert (config.alpha, config.epsilon, config.frame_skip) == (0.2 / 48, 0.0, 4)  # kept
    # And back: the fields that apply again take their defaults (Sarsa(lambda)'s own, the
    # book's: lambda 0.9).
    again = config.replace(algorithm="sarsa_lambda", features="tiles")
    assert (again.lam, again.traces, again.tilings) == (0.9, "replacing", 12)
    assert all(getattr(again, name) is None for name in GRID)


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda: REPORT.replace(lam=0.9), "lam has no effect with algorithm='sarsa'"),
        (
            lambda: TrainConfig().replace(traces="accumulating"),
            "traces has no effect with algorithm=",
        ),
        (lambda: BOOK.replace(angle_bins=7), "angle_bins has no effect with features='tiles'"),
        (
            lambda: BOOK.replace(noise_until=0.5),
            r"noise_until has no effect with start_noise=0.0 \(it applies when start_noise > 0\)",
        ),
    ],
)
def test_settings_without_effect_are_refused_with_the_reason(make, message) -> None:
    with pytest.raises(ValueError, match=message):
        make()


def test_fields_that_depend_on_a_value_follow_it() -> None:
    assert BOOK.noise_until is None
    noisy = BOOK.replace(start_noise=0.1)
    assert noisy.noise_until == 0.0 and noisy.start_noise_at(400) == 0.1  # constant noise
    assert TUNED_0_2.noise_until == 0.5 and PRESETS["tuned"].noise_until == 0.0
    with pytest.raises(ValueError, match=r"noise_until must be in \[0, 1\]"):
        TUNED_0_2.replace(noise_until=1.5)


def test_records_written_before_fields_were_declared_read_back() -> None:
    # run.json of the earlier version writes every field, defaults for those that do not apply
    # (lam 0.0 and the tile fields for tabular SARSA).
    fixture = Path(__file__).parent / "fixtures" / "run_dirs" / "report_fs4" / "run.json"
    old = json.loads(fixture.read_text())["config"]
    assert old["lam"] == 0.0 and old["tilings"] == 12 and "task" not in old
    config = TrainConfig.from_dict(old)
    assert config == REPORT.replace(frame_skip=4, episodes=30)
    assert TrainConfig.from_dict(config.to_dict()) == config
    for name, preset in PRESETS.items():  # the balance preset's is a PlanConfig
        assert type(preset).from_dict(preset.to_dict()) == preset, name


def test_a_record_with_an_unknown_setting_is_refused_in_one_line() -> None:
    # Not dropped in silence: a hand-edited or foreign record names what it holds that no
    # version of the package wrote (the keys 0.1 to 0.3 held are read, as above).
    with pytest.raises(ValueError, match=r"unknown config keys \['bogus'\]") as error:
        TrainConfig.from_dict({**REPORT.to_dict(), "bogus": 1})
    assert "\n" not in str(error.value)


@pytest.mark.parametrize(
    ("setting", "value"),
    [
        ("max_episode_steps", 2**63),  # once ran 10 minutes, its stops held to the end
        ("max_episode_steps", 1_000_001),
        ("episodes", 10**30),
        ("population", 10_001),
    ],
)
def test_sizes_that_cannot_finish_are_refused(setting: str, value: int) -> None:
    from acrobot_mj.settings import SettingError
    from acrobot_mj.train.config import TrainConfig

    with pytest.raises(SettingError, match=f"config {setting} must be in"):
        TrainConfig(**{setting: value})
