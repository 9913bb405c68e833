"""CLI smoke tests with tiny budgets, through the real console entry point's main()."""

from __future__ import annotations

import argparse
import json
import subprocess
import sys

import pytest

from acrobot_mj import __version__
from acrobot_mj.cli import build_parser, main


def test_demo_pump_reaches_the_goal_and_writes_json(tmp_path, capsys) -> None:
    out = tmp_path / "demo.json"
    assert main(["demo", "--policy", "pump", "--json", str(out)]) == 0
    assert "reached the goal after 300 actions" in capsys.readouterr().out
    record = json.loads(out.read_text())
    assert record["episode_lengths"] == [300] and record["episode_successes"] == [True]
    assert record["episode_returns"] == [-199.0]  # 299 steps of -1, then +100
    assert record["config"]["policy"] == "pump" and "mujoco" in record["versions"]
    assert len(record["episodes"][0]["states"]) == 301


def test_demo_random_is_seeded(tmp_path) -> None:
    runs = []
    for name in ("a", "b"):
        path = tmp_path / f"{name}.json"
        main(["demo", "--policy", "random", "--steps", "50", "--seed", "3", "--json", str(path)])
        runs.append(json.loads(path.read_text())["episodes"])
    assert runs[0] == runs[1]
    assert runs[0][0]["length"] == 50


def test_params_table(capsys) -> None:
    main(["params"])
    assert "kg m^2" in capsys.readouterr().out


@pytest.mark.parametrize(
    "argv",
    [
        ["demo", "--steps", "0"],
        ["demo", "--policy", "best"],
        ["fly"],
        ["demo", "--frame-skip", "x"],
    ],
)
def test_bad_arguments_exit_with_usage(argv, capsys) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    assert exit_info.value.code == 2
    assert "error" in capsys.readouterr().err


def test_no_command_prints_the_help(capsys) -> None:
    assert main([]) == 0
    out = capsys.readouterr().out
    assert out.startswith("usage: acrobot-mj") and "acrobot-mj COMMAND --help" in out


def _commands() -> dict:
    parser = build_parser()
    return next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices


@pytest.mark.parametrize("name", sorted(_commands()))
def test_every_command_and_option_says_what_it_is_in_plain_text(name) -> None:
    command = _commands()[name]
    assert command.description, f"{name} has no description"
    unexplained = [a.option_strings or a.dest for a in command._actions if not a.help]
    assert unexplained == [], f"{name}: options without help: {unexplained}"
    text = command.format_help()
    markup = [m for m in (":mod:", ":class:", ":func:", "``") if m in text]
    assert markup == [], f"{name}'s help shows markup: {markup}"
    # A default is said once, by the help text or by the formatter.
    assert "(default: None)" not in text and "default: default" not in text


def test_python_dash_m_runs_the_command() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "acrobot_mj", "--version"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 0 and done.stdout.strip() == __version__


def test_no_help_shows_a_default_as_python_writes_it(capsys) -> None:
    """A tuple default as it is typed (olympics --scores once showed ``('performance', ...)``)."""
    from acrobot_mj.cli import build_parser

    commands = build_parser()._subparsers._group_actions[0].choices
    for name, parser in commands.items():
        text = parser.format_help()
        assert "(default: (" not in text and "(default: [" not in text, name
    assert "performance,robustness,global" in " ".join(commands["olympics"].format_help().split())
