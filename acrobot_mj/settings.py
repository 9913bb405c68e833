"""Settings declared once: a config is a frozen dataclass whose fields are declared with
:func:`setting` (default, help, unit, range or choices). From that declaration come the config's
check (:func:`check`: types from the annotations, ranges, choices; one line naming the
setting), its record (:func:`to_dict`, :func:`from_dict`, :func:`replace`), its command-line
options (:func:`add_arguments`, :func:`parse`) and the docs' tables (:func:`table`)."""

from __future__ import annotations

import argparse
import dataclasses
import functools
import math
import types
import typing
from collections.abc import Callable, Iterable, Mapping
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from acrobot_mj.checks import shown_number

if TYPE_CHECKING:
    from typing_extensions import Self


class SettingError(ValueError, TypeError):
    """A setting refused: of the wrong type or out of its range (either kind of error)."""


def setting(default: Any, help: str, unit: str = "", **rules: Any) -> Any:
    """A config field: its ``default``, ``help`` and ``unit``, and ``rules``: ``low``, ``high``
    (bounds, closed unless ``low_open`` or ``high_open``), ``choices``, ``sep`` (a tuple's
    separator on the command line, ``":"`` for ``START:STOP:STEP`` horizons), ``flag`` (the
    command-line name where it is not the field's), ``metavar``, ``cli=False`` for one the
    command line does not take, and ``follows``: another setting, a change of which puts this
    one back to its default unless it is changed too (a model's integrator)."""
    known = {"low", "high", "low_open", "high_open", "choices", "sep", "flag", "metavar", "cli"}
    known.add("follows")
    if unknown := sorted(set(rules) - known):
        raise TypeError(f"unknown setting rules {unknown}; known: {sorted(known)}")
    return dataclasses.field(default=default, metadata={"help": help, "unit": unit, **rules})


def declared(cls: type) -> dict[str, Any]:
    """The settings of config class ``cls`` by name (fields declared with :func:`setting`)."""
    return {n: f for n, f in _fields(cls).items() if "help" in f.metadata}


def _field(cls: type, name: str) -> dataclasses.Field:
    """Field ``name`` of ``cls``, declared with :func:`setting` or not (a plain field has no
    help, unit or range)."""
    return _fields(cls)[name]


@functools.cache
def _fields(cls: type) -> dict[str, dataclasses.Field]:
    return {f.name: f for f in dataclasses.fields(cls)}


@functools.cache
def _hints(cls: type) -> dict[str, Any]:
    return typing.get_type_hints(cls)


def _parts(kind: Any) -> tuple[Any, bool]:
    """The type of a setting without None, and whether it may be None."""
    args = typing.get_args(kind)
    if typing.get_origin(kind) in (typing.Union, types.UnionType) and type(None) in args:
        rest = [a for a in args if a is not type(None)]
        return rest[0], True
    return kind, False


def _is_config(kind: Any) -> bool:
    return isinstance(kind, type) and dataclasses.is_dataclass(kind)


def _bounds(meta: Mapping[str, Any], kind: Any) -> str:
    """``>= 1``, ``in [0, 1]`` or ``in (0, 86400]``: the bounds of a setting, in words (an open
    end in a round bracket)."""
    low, high = meta.get("low"), meta.get("high")
    low_open, high_open = meta.get("low_open", False), meta.get("high_open", False)
    if low is None and high is None:
        return ""
    if kind is int and high is None:
        return f"{'>' if low_open else '>='} {low}"
    if kind is int and low is None:
        return f"{'<' if high_open else '<='} {high}"
    if kind is int:  # whole numbers as written: 10000000, not 1e+07
        ends = f"{low}, {high}"
    else:
        ends = f"{-math.inf if low is None else low:g}, {math.inf if high is None else high:g}"
    return f"in {'(' if low_open else '['}{ends}{')' if high_open else ']'}"


def _requirement(meta: Mapping[str, Any], kind: Any) -> str:
    """What a value must be, in words: an int with a unit and no upper bound counts (``a whole
    number of steps >= 0``); one with both bounds names its unit after them."""
    bounds, unit = _bounds(meta, kind), meta.get("unit", "")
    if kind is int:
        if unit and meta.get("high") is None:
            return f"a whole number of {unit} {bounds}".strip()
        return f"{bounds} ({unit})" if unit and bounds else bounds
    return bounds


def _label(name: str, meta: Mapping[str, Any]) -> str:
    return f"config {meta.get('flag', name)}"


def _kind_words(meta: Mapping[str, Any], kind: Any) -> str:
    if kind is int:
        phrase = _requirement(meta, kind)
        return phrase if phrase.startswith("a whole") else f"an integer {phrase}".strip()
    if kind is float:
        return f"a real number {_bounds(meta, kind)}".strip()
    if kind is bool:
        return "True or False"
    if _is_config(kind):
        return f"a {kind.__name__} (or a dict of its settings)"
    return f"a {getattr(kind, '__name__', kind)}"


def _scalar(name: str, meta: Mapping[str, Any], kind: Any, value: Any) -> Any:
    """``value`` as ``kind`` (numpy scalars converted), or one line naming the setting."""
    label = _label(name, meta)
    is_bool = isinstance(value, (bool, np.bool_))
    if kind is bool:
        ok = is_bool
    elif kind is int:
        ok = isinstance(value, (int, np.integer)) and not is_bool
    elif kind is float:
        ok = isinstance(value, (int, float, np.integer, np.floating)) and not is_bool
    elif _is_config(kind):
        if isinstance(value, dict):
            return from_dict(kind, value, name)
        ok = isinstance(value, kind)
    else:
        ok = isinstance(value, kind)
    if not ok:
        got = f"{value!r} ({type(value).__name__})"
        raise SettingError(f"{label} must be {_kind_words(meta, kind)}, got {got}")
    if kind is float:
        try:
            finite = math.isfinite(value)
        except OverflowError:  # an integer past float's range
            raise SettingError(f"{label} must be finite, got {shown_number(value)}") from None
        if not finite:
            raise SettingError(f"{label} must be finite, got {value}")
    choices = meta.get("choices")
    if choices is not None:
        return _choice(label, choices, value)
    return kind(value) if kind in (bool, int, float) else value


def _choice(label: str, choices: Iterable[Any], value: Any) -> Any:
    """The choice ``value`` names; a numpy float names one equal at its own precision."""
    for choice in choices:
        if type(value)(choice) == value if isinstance(value, np.floating) else choice == value:
            return choice
    raise SettingError(f"{label} must be one of {list(choices)}, got {value!r}")


def _in_range(name: str, meta: Mapping[str, Any], kind: Any, value: Any) -> None:
    low, high = meta.get("low"), meta.get("high")
    got = shown_number(value) if isinstance(value, int) else f"{value:g}"
    label = _label(name, meta)
    if (low is not None and value < low) or (high is not None and value > high):
        raise SettingError(f"{label} must be {_requirement(meta, kind)}, got {got}")
    if meta.get("low_open") and value == low:
        raise SettingError(f"{label} must be > {low:g}, got {got}")
    if meta.get("high_open") and value == high:
        raise SettingError(f"{label} must be < {high:g}, got {got}")


def _sequence(name: str, meta: Mapping[str, Any], kind: Any, value: Any) -> tuple:
    """A tuple setting (lists and arrays taken) with each entry checked."""
    args = typing.get_args(kind)
    item = args[0]
    fixed = None if len(args) == 2 and args[1] is Ellipsis else len(args)
    label = _label(name, meta)
    if isinstance(value, (str, bytes)) or not isinstance(value, (tuple, list, np.ndarray)):
        raise SettingError(f"{label} must be {_sequence_words(meta, fixed, item)}, got {value!r}")
    inner = {k: v for k, v in meta.items() if k != "unit"}
    try:
        values = tuple(_scalar(name, inner, item, v) for v in value)
        for v in values:
            _in_range(name, inner, item, v)
    except SettingError:
        raise SettingError(
            f"{label} must be {_sequence_words(meta, fixed, item)}, got {value!r}"
        ) from None
    wrong = not values or (fixed is not None and len(values) != fixed)
    if wrong or (meta.get("sep") == ":" and values[1] <= values[0]):
        raise SettingError(f"{label} must be {_sequence_words(meta, fixed, item)}, got {values!r}")
    return values


def _sequence_words(meta: Mapping[str, Any], fixed: int | None, item: type = int) -> str:
    unit = meta.get("unit", "")
    if meta.get("sep") == ":":
        return f"(start, stop, step) {unit} > 0 with stop > start".replace("  ", " ")
    bounds = _bounds(meta, item)
    what = "integers" if item is int else "numbers"
    return f"{'a tuple of' if fixed is None else fixed} {what} {bounds}".strip()


def checked(cls: type, name: str, value: Any) -> Any:
    """``value`` of setting ``name`` of ``cls``, checked and converted (lists to tuples, numpy
    scalars to Python's, a dict to a nested config)."""
    meta = _field(cls, name).metadata
    kind, optional = _parts(_hints(cls)[name])
    if value is None and optional:
        return None
    if typing.get_origin(kind) is tuple:
        return _sequence(name, meta, kind, value)
    value = _scalar(name, meta, kind, value)
    if kind in (int, float):
        _in_range(name, meta, kind, value)
    return value


def check(config: Any) -> None:
    """Check every setting of the (frozen) dataclass ``config``, converting each in place."""
    for name in declared(type(config)):
        value = checked(type(config), name, getattr(config, name))
        object.__setattr__(config, name, value)


def to_dict(config: Any) -> dict[str, Any]:
    """Every setting of ``config`` by name, as JSON holds it (tuples as lists)."""

    def plain(value: Any) -> Any:
        if dataclasses.is_dataclass(value) and not isinstance(value, type):
            return to_dict(value)
        return list(value) if isinstance(value, tuple) else value

    return {f.name: plain(getattr(config, f.name)) for f in dataclasses.fields(config)}


def _refuse_unknown(cls: type, data: Any, what: str) -> None:
    if not isinstance(data, dict):
        raise SettingError(f"{what} settings must be a JSON object, got {data!r:.40}")
    names = sorted(f.name for f in dataclasses.fields(cls))
    if unknown := sorted(set(data) - set(names)):
        raise SettingError(f"unknown {what} settings {unknown}; known: {names}")


def from_dict(cls: type, data: Any, what: str) -> Any:
    """The config ``cls`` of a record's settings ``data``; keys it does not know are refused,
    naming them and the known ones (``what``: the settings' name in the error)."""
    _refuse_unknown(cls, data, what)
    return cls(**data)


def replace(config: Any, changes: dict[str, Any], what: str) -> Any:
    """A copy of ``config`` with ``changes``, checked as :func:`from_dict` checks a record."""
    _refuse_unknown(type(config), changes, what)
    return dataclasses.replace(config, **followers(type(config), changes), **changes)


def followers(cls: type, changes: Mapping[str, Any]) -> dict[str, Any]:
    """The defaults of the settings of ``cls`` that follow one of ``changes`` and are not in
    them (``setting(follows=...)``)."""
    return {
        name: f.default
        for name, f in declared(cls).items()
        if f.metadata.get("follows") in changes and name not in changes
    }


class Settings:
    """A config whose fields are declared with :func:`setting`: checked as it is made, with
    :meth:`replace`, :meth:`to_dict` and :meth:`from_dict` from the declaration (``what``: the
    settings' name in errors). Subclasses are frozen dataclasses."""

    what: ClassVar[str] = "config"

    def __post_init__(self) -> None:
        check(self)

    def replace(self, **changes: Any) -> Self:
        return replace(self, changes, self.what)

    def to_dict(self) -> dict[str, Any]:
        return to_dict(self)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Self:
        return from_dict(cls, data, cls.what)


def flag(cls: type, name: str) -> str:
    """The command-line flag of setting ``name``: ``--name-with-dashes``."""
    meta = _field(cls, name).metadata
    return "--" + meta.get("flag", name).replace("_", "-")


def cli_names(cls: type) -> tuple[str, ...]:
    """The settings of ``cls`` the command line takes."""
    return tuple(n for n, f in declared(cls).items() if f.metadata.get("cli", True))


def parse(cls: type, name: str, text: str) -> Any:
    """``text`` as setting ``name``'s type: floats may be fractions (``0.2/48``), bools ``true``
    or ``false``, tuples ``START:STOP:STEP`` or ``1,4`` (by the setting's ``sep``), ``none``
    None where the setting may be None."""
    meta = _field(cls, name).metadata
    kind, optional = _parts(_hints(cls)[name])
    if optional and text.lower() == "none":
        return None
    if typing.get_origin(kind) is tuple:
        try:
            return tuple(int(v) for v in text.split(meta.get("sep", ",")))
        except ValueError:
            raise SettingError(f"{flag(cls, name)} needs int values, got {text!r}") from None
    try:
        if kind is bool:
            if text.lower() not in ("true", "false", "1", "0"):
                raise ValueError(text)
            return text.lower() in ("true", "1")
        if kind is int:
            return int(text)
        if kind is float:
            numerator, _, denominator = text.partition("/")
            return float(numerator) / float(denominator or 1.0)
    except (ValueError, ZeroDivisionError) as error:
        article = "an" if kind is int else "a"
        raise SettingError(
            f"config {name} needs {article} {kind.__name__}, got {text!r}"
        ) from error
    return text


def _text(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:g}"
    if isinstance(value, tuple):
        return ", ".join(str(v) for v in value)
    return str(value).lower() if isinstance(value, bool) else str(value)


def help_text(cls: type, name: str, *, default: bool = True) -> str:
    """``HELP [UNIT] (default D)`` of setting ``name`` (without the default: ``default=False``)."""
    f = _field(cls, name)
    unit = f" [{f.metadata['unit']}]" if f.metadata.get("unit") else ""
    value = f.default
    shown = "" if not default or value is None or value is False else f" (default {_text(value)})"
    return f"{f.metadata.get('help', '')}{unit}{shown}"


def _parser(cls: type, name: str) -> Callable[[str], Any]:
    def parsed(text: str) -> Any:
        try:
            return parse(cls, name, text)
        except SettingError as error:
            raise argparse.ArgumentTypeError(str(error)) from None

    return parsed


def add_arguments(
    group: Any,
    cls: type,
    names: Iterable[str],
    *,
    typed: bool = True,
    given: bool = False,
    defaults: bool = True,
) -> None:
    """A flag of each setting ``names`` of ``cls`` in argparse ``group``, with its declared help
    (and default, unless not ``defaults``). A bool off by default is a switch. ``typed``: parsed
    as the declared type (else the text, for the caller to parse), defaulting to the declared
    default (``given``: to None, where the caller fills in what was not given); whatever takes
    the value checks its range."""
    for name in names:
        f = _field(cls, name)
        kind, _ = _parts(_hints(cls)[name])
        options: dict[str, Any] = {"dest": name, "help": help_text(cls, name, default=defaults)}
        if kind is bool and f.default is False:
            options["action"] = "store_true"
        elif typed:
            options.update(type=_parser(cls, name), default=None if given else f.default)
            if f.metadata.get("choices") is not None:
                options["choices"] = f.metadata["choices"]
            else:
                options["metavar"] = f.metadata.get("metavar", "VALUE")
        else:
            options["metavar"] = f.metadata.get("metavar", "VALUE")
        group.add_argument(flag(cls, name), **options)


def _range_text(f: dataclasses.Field, kind: Any) -> str:
    meta = f.metadata
    if meta.get("choices") is not None:
        return ", ".join(_text(c) for c in meta["choices"])
    if typing.get_origin(kind) is tuple:
        return _sequence_words(meta, None if typing.get_args(kind)[-1] is Ellipsis else 3)
    return _bounds(meta, kind)


def table(cls: type) -> str:
    """A Markdown table of ``cls``'s settings: flag, default, unit, range and help."""
    rows = ["| setting | default | unit | range | help |", "|---|---|---|---|---|"]
    hints = _hints(cls)
    for name, f in declared(cls).items():
        kind, _ = _parts(hints[name])
        default = f.default
        if dataclasses.is_dataclass(default):
            default = type(default).__name__
        cells = (
            f"`{name}`",
            "-" if default is None else f"`{_text(default)}`",
            f.metadata["unit"].replace("|", "\\|"),
            _range_text(f, kind).replace("|", "\\|"),
            f.metadata["help"].replace("|", "\\|"),
        )
        rows.append("| " + " | ".join(cells) + " |")
    return "\n".join(rows) + "\n"
