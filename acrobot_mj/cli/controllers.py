"""The controller arguments ``olympics``, ``evaluate`` and ``render`` share: a controller that is
not a run (an entry, ``module:attribute``, a Stable-Baselines3 policy file) with its entry's
options and a policy's env (:func:`add_source`, :func:`source_of`), and the learner that runs
it on an acrobot (:func:`controlled`)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from acrobot_mj.cli import tools
from acrobot_mj.olympics import sources
from acrobot_mj.olympics.entries import ENTRIES
from acrobot_mj.olympics.sources import POLICY_ENV, Source
from acrobot_mj.physics.models import resolve
from acrobot_mj.settings import declared, parse
from acrobot_mj.train.controller_run import ControlledLearner

#: What names a controller on the command line.
CONTROLLERS = (
    f"an entry ({', '.join(ENTRIES)}); module:attribute (an acrobot_mj Controller, an object "
    "with double_pendulum's get_control_output(x, t), or a factory of one taking the model); "
    "or a Stable-Baselines3 policy file (.zip)"
)


def option(text: str) -> tuple[str, str]:
    """An argparse type: ``NAME=VALUE``."""
    name, equals, value = text.partition("=")
    if not (equals and name.strip()):
        raise argparse.ArgumentTypeError(f"must be NAME=VALUE, got {text!r}")
    return name.strip(), value.strip()


def json_object(text: str) -> dict[str, Any]:
    """An argparse type: a JSON object."""
    try:
        value = json.loads(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(f"must be a JSON object: {error}") from None
    if not isinstance(value, dict):
        raise argparse.ArgumentTypeError(f"must be a JSON object, got {text!r}")
    return value


def add_source(p: argparse.ArgumentParser, model: str | None, about: str) -> None:
    """``--option``, ``--env``, ``--env-kwargs`` and ``--model`` (default ``model``, helped
    by ``about``)."""
    p.add_argument(
        "--option",
        type=option,
        action="append",
        metavar="NAME=VALUE",
        help="an entry's option (funnel: mpc=true); repeat for more",
    )
    p.add_argument(
        "--env",
        metavar="ID",
        help=f"a .zip policy's training env (default {POLICY_ENV} on --model)",
    )
    p.add_argument(
        "--env-kwargs",
        type=json_object,
        metavar="JSON",
        help="a .zip policy's training env's keyword arguments, a JSON object",
    )
    p.add_argument(
        "--model",
        type=model_or_run,
        default=model,
        metavar="NAME|FILE|RUN",
        help=f"{about}; or a black-box run's folder: an entry built on its learnt model, on "
        "the acrobot it learnt",
    )


def model_or_run(text: str) -> str:
    """An argparse type: an acrobot's name or file (:func:`~acrobot_mj.cli.tools.acrobot_model`)
    or a folder (a black-box run's, checked when the controller is)."""
    return text if Path(text).is_dir() else tools.acrobot_model(text)


def source_of(args: argparse.Namespace, name: str) -> tuple[Source, str]:
    """The controller ``name`` with its entry options (each parsed as the entry's declared
    type), a policy's env and a learnt plant, and the acrobot it runs on (``--model``, or the
    acrobot a black-box run given as ``--model`` learnt)."""
    options: dict[str, Any] = {}
    if args.option:
        entry = ENTRIES.get(name)
        if entry is None:
            raise ValueError(f"--option is for an entry {list(ENTRIES)}, not {name}")
        known = declared(entry.options)
        for key, text in args.option:
            if key not in known:
                raise ValueError(
                    f"the {entry.name} entry has no option {key!r}; it has {sorted(known)}"
                )
            options[key] = parse(entry.options, key, text)
    model, plant = args.model, None
    if model is not None and Path(model).is_dir():
        plant, model = model, sources.trained_model(sources.controller_record(model))
    return Source(name, options, args.env, args.env_kwargs or {}, plant), model


def controlled(args: argparse.Namespace, name: str) -> ControlledLearner:
    """The controller ``name`` on ``--model``, as ``evaluate`` and ``render`` run it."""
    if args.model is None:
        raise ValueError(f"give --model: the acrobot {name} runs on")
    source, model = source_of(args, name)
    return ControlledLearner(sources.build(source, model), resolve(model), name)
