"""Figures with matplotlib: PNG by default, SVG or PDF chosen by the output file's suffix.

:func:`line_figure` builds a :class:`matplotlib.figure.Figure` of series and shaded bands on
linear or log axes, with reference lines, an optional arrow field and a legend;
:func:`line_plot` saves one. :func:`learning_curve` is the figure ``acrobot-mj train`` writes
and :func:`compare_curves` the one ``acrobot-mj curves`` writes (their labels come from the
caller, which asks the task).

matplotlib is imported inside the functions (``import acrobot_mj`` stays light), and only its
object-oriented API is used (a ``Figure`` on an Agg canvas): a user's own pyplot state and
backend are left as they are.
"""

from __future__ import annotations

import textwrap
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from acrobot_mj.files import write_atomic

if TYPE_CHECKING:
    from matplotlib.figure import Figure

#: Output formats by file suffix (matplotlib's format names).
FORMATS = {".png": "png", ".svg": "svg", ".pdf": "pdf"}
#: Line colours, in order (matplotlib's tab10, named so that a user's style does not change them).
COLOURS = ("tab:blue", "tab:red", "tab:green", "tab:orange", "tab:purple", "tab:brown")
#: Metadata left out so that the same data gives the same file.
_NO_DATE = {"svg": {"Date": None}, "pdf": {"CreationDate": None}, "png": {}}


@dataclass
class Series:
    """One line (and optional band ``low..high`` around it) of a plot."""

    label: str
    x: Sequence[float]
    y: Sequence[float]
    low: Sequence[float] | None = None
    high: Sequence[float] | None = None


def figure_format(path: str | Path) -> str:
    """The format a figure at ``path`` is written in, from its suffix; ValueError for others."""
    suffix = Path(path).suffix.lower()
    if suffix not in FORMATS:
        raise ValueError(
            f"cannot write a figure to {str(path)!r}: the file name must end in "
            f"{', '.join(FORMATS)} (got {suffix or 'no suffix'!r})"
        )
    return FORMATS[suffix]


def new_figure(size: tuple[int, int] = (800, 500)) -> Figure:
    """An empty figure of ``size`` pixels (at 100 dpi) on its own Agg canvas."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    figure = Figure(figsize=(size[0] / 100, size[1] / 100), dpi=100, layout="constrained")
    FigureCanvasAgg(figure)
    return figure


def save_figure(figure: Figure, path: str | Path) -> Path:
    """Write ``figure`` to ``path`` atomically, in the format its suffix names (the same
    figure gives the same bytes: no dates, and fixed SVG ids)."""
    import matplotlib

    fmt = figure_format(path)

    def write(f: Any) -> None:
        with matplotlib.rc_context({"svg.hashsalt": "acrobot-mj"}):  # restored afterwards
            figure.savefig(f, format=fmt, dpi=100, metadata=_NO_DATE[fmt])

    return write_atomic(path, write)


def _draw_series(ax: Any, series: Sequence[Series]) -> None:
    for k, s in enumerate(series):
        colour = COLOURS[k % len(COLOURS)]
        if s.low is not None and s.high is not None:
            ax.fill_between(s.x, s.low, s.high, color=colour, alpha=0.2, linewidth=0)
        marker = "o" if len(s.x) <= 25 else None  # a few points: show each one
        ax.plot(s.x, s.y, color=colour, linewidth=1.6, marker=marker, markersize=4, label=s.label)


def line_figure(
    series: Sequence[Series],
    title: str,
    xlabel: str,
    ylabel: str,
    *,
    log_y: bool = False,
    size: tuple[int, int] = (800, 500),
    hlines: Sequence[tuple[float, str]] = (),
    arrows: np.ndarray | None = None,
) -> Figure:
    """``series`` (lines with optional bands), labelled horizontal reference lines (dashed,
    in the legend) and a field of ``arrows`` (rows ``x, y, dx, dy`` in data units, grey)."""
    figure = new_figure(size)
    ax = figure.add_subplot()
    if arrows is not None:
        x, y, dx, dy = np.asarray(arrows, dtype=float).T
        ax.quiver(x, y, dx, dy, angles="xy", scale_units="xy", scale=1, color="0.65",
                  width=0.0025, zorder=1)  # fmt: skip
    for value, text in hlines:
        ax.axhline(value, color="0.35", linestyle="--", linewidth=1, label=text)
    _draw_series(ax, series)
    if log_y:
        ax.set_yscale("log")
    ax.set_title(textwrap.fill(title, 96), fontsize=11)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.grid(True, color="0.9", linewidth=0.8)
    ax.set_axisbelow(True)
    if series or hlines:
        ax.legend(loc="best", fontsize=9, framealpha=0.85)
    return figure


def line_plot(path: str | Path, series: Sequence[Series], *args: Any, **kwargs: Any) -> Path:
    """Save :func:`line_figure` of ``series`` (same arguments) to ``path`` (.png, .svg or .pdf;
    the suffix is checked before anything is drawn)."""
    figure_format(path)
    return save_figure(line_figure(series, *args, **kwargs), path)


def curves_figure(
    groups: dict[str, Sequence[Sequence[float]]],
    title: str,
    reference: Sequence[tuple[float, str]] = (),
    ylabel: str = "decisions per episode",
    log_y: bool = True,
) -> Figure:
    """A per-episode score against episode for each group of runs: one run as a line, several
    as the median with the 25-75 % band across runs (label ``""``: a group with no name). Runs
    of different lengths (a decision budget ends each after its own number of episodes) count
    at each episode where they have one."""
    series = []
    for label, runs in groups.items():
        values = padded(runs)
        episodes = np.arange(1, values.shape[1] + 1)
        prefix = f"{label}: " if label else ""
        if len(values) == 1:
            series.append(Series(f"{prefix}one run", episodes, values[0]))
            continue
        low, median, high = np.nanpercentile(values, [25, 50, 75], axis=0)
        text = f"{prefix}median of {len(values)} seeds, 25-75 % band"
        if np.isnan(values).any():
            text += " (of the runs still going)"
        series.append(Series(text, episodes, median, low, high))
    return line_figure(
        series,
        title,
        "episode",
        f"{ylabel} (log scale)" if log_y else ylabel,
        log_y=log_y,
        hlines=reference,
    )


def padded(runs: Sequence[Sequence[float]]) -> np.ndarray:
    """Runs as rows of one array, the shorter ones padded with NaN."""
    values = np.full((len(runs), max(len(r) for r in runs)), np.nan)
    for row, run in zip(values, runs, strict=True):
        row[: len(run)] = run
    return values


def learning_curve(
    path: str | Path,
    runs: Sequence[Sequence[float]],
    title: str,
    reference: Sequence[tuple[float, str]] = (),
    ylabel: str = "decisions per episode",
    log_y: bool = True,
) -> Path:
    """Save the curve of ``runs`` (one run: a line; several: median and 25-75 % band)."""
    return compare_curves(path, {"": runs}, title, reference, ylabel, log_y)


def compare_curves(
    path: str | Path,
    groups: dict[str, Sequence[Sequence[float]]],
    title: str,
    reference: Sequence[tuple[float, str]] = (),
    ylabel: str = "decisions per episode",
    log_y: bool = True,
) -> Path:
    """Save :func:`curves_figure` of ``groups`` to ``path`` (.png, .svg or .pdf)."""
    figure_format(path)
    return save_figure(curves_figure(groups, title, reference, ylabel, log_y), path)
