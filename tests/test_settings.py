"""Settings declared once (acrobot_mj.settings): one typed check of every config, its record,
its command-line options and the docs' tables, all from the fields' declarations."""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import numpy as np
import pytest

from acrobot_mj import settings
from acrobot_mj.agents.features import GridConfig, TilesConfig
from acrobot_mj.agents.sarsa import SarsaConfig
from acrobot_mj.agents.sarsa_lambda import SarsaLambdaConfig
from acrobot_mj.control.tracker import FunnelSettings, TrackerSettings
from acrobot_mj.settings import SettingError, declared, parse, table
from acrobot_mj.train.balance_preset import PlanConfig
from acrobot_mj.train.black_box import BlackBoxConfig
from acrobot_mj.train.config import TrainConfig
from acrobot_mj.train.feedback_run import FeedbackConfig
from acrobot_mj.train.learners import HeldOut

ROOT = Path(__file__).resolve().parents[1]
CONFIGS = (
    TrainConfig,
    SarsaConfig,
    SarsaLambdaConfig,
    GridConfig,
    TilesConfig,
    PlanConfig,
    FeedbackConfig,
    FunnelSettings,
    BlackBoxConfig,
    HeldOut,
)
_spec = importlib.util.spec_from_file_location(
    "settings_tables", ROOT / "scripts" / "settings_tables.py"
)
tables = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(tables)


@pytest.mark.parametrize(
    ("make", "words"),
    [
        (lambda: FeedbackConfig(funnel=3), "config funnel must be a FunnelSettings"),
        (lambda: FeedbackConfig(reserve=True), "config reserve must be a real number"),
        (lambda: FeedbackConfig(discrete=1), "config discrete must be True or False"),
        (lambda: BlackBoxConfig(horizons=(True, 800, 40)), "config horizons must be"),
        (lambda: BlackBoxConfig(seconds=True), "config seconds must be a real number"),
        (lambda: PlanConfig(reserve=True), "config reserve must be a real number"),
        (lambda: PlanConfig(targets=(1, 6)), r"config targets must be .* in \[0, 5\]"),
        (
            lambda: TrainConfig(episodes=True),
            r"config episodes must be an integer in \[1, 10000000\]",
        ),
        (lambda: TrainConfig(start_noise=float("nan")), "config start_noise must be finite"),
        (lambda: HeldOut(episodes=np.float64(3.0)), "config episodes must be an integer"),
        (lambda: FeedbackConfig(funnel={"levels": 3}), r"unknown funnel settings \['levels'\]"),
    ],
)
def test_a_wrong_type_is_refused_in_one_line_naming_the_setting(make, words) -> None:
    with pytest.raises(SettingError, match=words) as error:
        make()
    assert isinstance(error.value, ValueError) and isinstance(error.value, TypeError)
    assert "\n" not in str(error.value)


def test_numpy_scalars_lists_and_dicts_are_taken_as_their_settings() -> None:
    feedback = FeedbackConfig(reserve=np.float32(0.8), seconds=np.int64(90))
    assert feedback.reserve == 0.8 and type(feedback.reserve) is float
    assert feedback.seconds == 90.0 and type(feedback.seconds) is float
    assert FeedbackConfig(funnel={"horizon": 10}).funnel == FunnelSettings(horizon=10)
    box = BlackBoxConfig(horizons=[np.int64(400), 800, 40])
    assert box.horizons == (400, 800, 40) and all(type(v) is int for v in box.horizons)
    config = TrainConfig(episodes=np.int64(3), start_noise=np.float32(0.5))
    assert type(config.episodes) is int and config.start_noise == 0.5
    assert HeldOut(seed=np.uint32(7)).seed == 7


@pytest.mark.parametrize("config", [*CONFIGS, FeedbackConfig(funnel=FunnelSettings(horizon=0))])
def test_a_record_of_settings_reads_back(config) -> None:
    config = config() if isinstance(config, type) else config
    kind = type(config)
    data = config.to_dict() if hasattr(config, "to_dict") else settings.to_dict(config)
    read = kind.from_dict if hasattr(kind, "from_dict") else None
    again = read(data) if read else settings.from_dict(kind, data, "held-out")
    assert again == config


def test_unknown_keys_are_refused_naming_the_known_ones() -> None:
    with pytest.raises(ValueError, match=r"unknown black-box settings \['decision'\]; known"):
        BlackBoxConfig.from_dict({"decision": 100})
    with pytest.raises(ValueError, match=r"unknown balance-preset settings \['reserv'\]"):
        PlanConfig().replace(reserv=0.5)
    with pytest.raises(ValueError, match="state-feedback settings must be a JSON object"):
        FeedbackConfig.from_dict([1])


def test_text_is_parsed_as_the_declared_type() -> None:
    assert parse(TrainConfig, "frame_skip", "4") == 4
    assert parse(SarsaConfig, "alpha", "0.2/48") == 0.2 / 48
    assert parse(TilesConfig, "subset_tilings", "false") is False
    assert parse(PlanConfig, "horizons", "456:457:1") == (456, 457, 1)
    assert parse(PlanConfig, "targets", "1,4") == (1, 4)
    with pytest.raises(ValueError, match="config frame_skip needs an int, got 'x'"):
        parse(TrainConfig, "frame_skip", "x")
    with pytest.raises(ValueError, match="--targets needs int values, got '1,y'"):
        parse(PlanConfig, "targets", "1,y")
    # "none" is None where the setting may be None (a tracker's jump), else refused.
    assert parse(TrackerSettings, "jump", "none") is None
    assert parse(TrackerSettings, "jump", "None") is None
    with pytest.raises(ValueError, match="config stride needs an int, got 'none'"):
        parse(TrackerSettings, "stride", "none")


def _help_texts() -> list[tuple[str, str]]:
    return [(c.__name__, f.metadata["help"]) for c in CONFIGS for f in declared(c).values()]


def test_every_setting_has_help_and_each_help_is_written_once() -> None:
    sources = "".join(p.read_text() for p in (ROOT / "acrobot_mj").rglob("*.py"))
    for owner, text in _help_texts():
        assert text, owner
        # Shared settings (alpha, gamma, epsilon) come from one declaration in agents/sarsa.py.
        assert sources.count(f'"{text}"') <= 1, (owner, text)


def test_the_train_help_lists_every_settings_help(capsys) -> None:
    from acrobot_mj.cli import main

    with pytest.raises(SystemExit):
        main(["train", "--help"])
    out = re.sub(r"\s+", " ", capsys.readouterr().out)
    for config in (TrainConfig, SarsaLambdaConfig, GridConfig, TilesConfig):
        for name, f in declared(config).items():
            assert f"--{name.replace('_', '-')}" in out
            assert f.metadata["help"] in out, name


def test_a_table_has_a_row_per_setting() -> None:
    rows = table(PlanConfig).splitlines()
    assert len(rows) == 2 + len(declared(PlanConfig))
    assert rows[4].startswith("| `reserve` | `0.8` | N m | in (0, 1] |")


def test_the_docs_tables_are_the_declarations() -> None:
    pages = [p for p in tables.PAGES if tables.BLOCK.search(p.read_text())]
    assert pages, "no generated tables in docs/"
    for page in pages:
        text = page.read_text()
        assert tables.rendered(text) == text, f"{page}: python scripts/settings_tables.py"
