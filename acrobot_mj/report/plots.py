"""Figures with matplotlib (.png, .svg or .pdf, by suffix), imported on use and only through its
object-oriented API: a user's pyplot state and backend are left as they are."""

from __future__ import annotations

import textwrap
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from acrobot_mj.files import write_atomic

if TYPE_CHECKING:
    from matplotlib.figure import Figure

FORMATS = {".png": "png", ".svg": "svg", ".pdf": "pdf"}
#: Line colours, in order, named so that a user's style does not change them.
COLOURS = ("tab:blue", "tab:red", "tab:green", "tab:orange", "tab:purple", "tab:brown")
#: Metadata left out so that the same data gives the same file.
_NO_DATE = {"svg": {"Date": None}, "pdf": {"CreationDate": None}, "png": {}}


@dataclass
class Series:
    """One line (and optional band ``low..high`` around it) of a plot."""

    label: str
    x: Sequence[float] | np.ndarray
    y: Sequence[float] | np.ndarray
    low: Sequence[float] | np.ndarray | None = None
    high: Sequence[float] | np.ndarray | None = None


def figure_format(path: str | Path) -> str:
    """The format a figure at ``path`` is written in, from its suffix; ValueError for others."""
    suffix = Path(path).suffix.lower()
    if suffix not in FORMATS:
        raise ValueError(
            f"cannot write a figure to {str(path)!r}: the file name must end in "
            f"{', '.join(FORMATS)} (got {suffix or 'no suffix'!r})"
        )
    return FORMATS[suffix]


def save_figure(figure: Figure, path: str | Path) -> Path:
    """Write ``figure`` to ``path`` atomically; the same figure gives the same bytes."""
    import matplotlib

    fmt = figure_format(path)

    def write(f: Any) -> None:
        with matplotlib.rc_context({"svg.hashsalt": "acrobot-mj"}), warnings.catch_warnings():
            # A character the font lacks (an emoji in a title) is drawn as a box, not warned of
            # in two lines of matplotlib's source.
            warnings.filterwarnings("ignore", message="Glyph .* missing from font")
            figure.savefig(f, format=fmt, dpi=100, metadata=_NO_DATE[fmt])  # fixed SVG ids

    return write_atomic(path, write)


@dataclass(frozen=True)
class Labels:
    """A figure's words: its ``title`` and the labels of its ``x`` and ``y`` axes."""

    title: str
    x: str
    y: str


def line_figure(
    series: Sequence[Series],
    labels: Labels,
    *,
    log_y: bool = False,
    size: tuple[int, int] = (800, 500),
    hlines: Sequence[tuple[float, str]] = (),
    arrows: np.ndarray | None = None,
) -> Figure:
    """Lines with optional bands, dashed reference ``hlines`` and ``arrows`` (rows x, y, dx, dy)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    figure = Figure(figsize=(size[0] / 100, size[1] / 100), dpi=100, layout="constrained")
    FigureCanvasAgg(figure)  # its own canvas: pyplot is not involved
    ax = figure.add_subplot()
    if arrows is not None:
        x, y, dx, dy = np.asarray(arrows, dtype=float).T
        ax.quiver(
            x,
            y,
            dx,
            dy,
            angles="xy",
            scale_units="xy",
            scale=1,
            color="0.65",
            width=0.0025,
            zorder=1,
        )
    for value, text in hlines:
        ax.axhline(value, color="0.35", linestyle="--", linewidth=1, label=text)
    for k, s in enumerate(series):
        colour = COLOURS[k % len(COLOURS)]
        if s.low is not None and s.high is not None:
            ax.fill_between(s.x, s.low, s.high, color=colour, alpha=0.2, linewidth=0)
        marker = "o" if len(s.x) <= 25 else None  # a few points: show each one
        ax.plot(s.x, s.y, color=colour, linewidth=1.6, marker=marker, markersize=4, label=s.label)
    if log_y:
        ax.set_yscale("log")
    ax.set_title(textwrap.fill(labels.title, 96), fontsize=11)
    ax.set(xlabel=labels.x, ylabel=labels.y)
    ax.grid(True, color="0.9", linewidth=0.8)
    ax.set_axisbelow(True)
    if series or hlines:
        ax.legend(loc="best", fontsize=9, framealpha=0.85)
    return figure


def line_plot(path: str | Path, series: Sequence[Series], labels: Labels, **kwargs: Any) -> Path:
    """Save :func:`line_figure` (same arguments) to ``path``, its suffix checked first."""
    figure_format(path)
    return save_figure(line_figure(series, labels, **kwargs), path)


def curves_figure(
    groups: Mapping[str, Sequence[Sequence[float]]],
    title: str,
    reference: Sequence[tuple[float, str]] = (),
    ylabel: str = "decisions per episode",
    log_y: bool = True,
) -> Figure:
    """Each group's runs per episode (label ``""``: unnamed): one as a line, more as a median."""
    series = []
    for label, runs in groups.items():
        values = np.full((len(runs), max(len(r) for r in runs)), np.nan)
        for row, run in zip(values, runs, strict=True):
            row[: len(run)] = run
        episodes = np.arange(1, values.shape[1] + 1)
        prefix = f"{label}: " if label else ""
        if len(values) == 1:
            series.append(Series(f"{prefix}one run", episodes, values[0]))
            continue
        low, median, high = np.nanpercentile(values, [25, 50, 75], axis=0)
        going = " (of the runs still going)" if np.isnan(values).any() else ""
        text = f"{prefix}median of {len(values)} seeds, 25-75 % band{going}"
        series.append(Series(text, episodes, median, low, high))
    ylabel = f"{ylabel} (log scale)" if log_y else ylabel
    return line_figure(series, Labels(title, "episode", ylabel), log_y=log_y, hlines=reference)


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
    groups: Mapping[str, Sequence[Sequence[float]]],
    title: str,
    reference: Sequence[tuple[float, str]] = (),
    ylabel: str = "decisions per episode",
    log_y: bool = True,
) -> Path:
    """Save :func:`curves_figure` of ``groups`` to ``path`` (.png, .svg or .pdf)."""
    figure_format(path)
    return save_figure(curves_figure(groups, title, reference, ylabel, log_y), path)
