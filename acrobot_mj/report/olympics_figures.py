"""The AI Olympics record's figures: success fraction per level for each robustness category
(:func:`category_figure`), tip height and torque over time for the performance and global
episodes (:func:`height_figure`)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from acrobot_mj.report.plots import Labels, Series, line_figure

if TYPE_CHECKING:
    from matplotlib.figure import Figure


def _figure(rows: int, columns: int, size: tuple[float, float]) -> Figure:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    figure = Figure(figsize=size, dpi=100, layout="constrained")
    FigureCanvasAgg(figure)  # its own canvas: pyplot is not involved
    figure.subplots(rows, columns, squeeze=False)
    return figure


def category_figure(category: dict[str, Any]) -> Figure:
    """A category's success fraction per level, one panel per sweep, with the pass line at 0.5
    for a majority category (``category``: as the record holds it)."""
    sweeps = category["sweeps"]
    title = f"{category['title']}: score {category['score']:.3f}"
    if len(sweeps) == 1:
        sweep = sweeps[0]
        if len(sweep["levels"]) == 1:  # one level of many episodes: each episode's success
            episodes = sweep["episodes"][0]
            series = [
                Series(
                    "success", range(1, len(episodes) + 1), [float(e["success"]) for e in episodes]
                )
            ]
            return line_figure(series, Labels(title, "episode", "success"))
        unit = f" [{sweep['unit']}]" if sweep["unit"] else ""
        hlines = [(0.5, "pass: more than 0.5")] if category["majority"] else []
        series = [Series("success fraction", sweep["levels"], sweep["fractions"])]
        return line_figure(
            series, Labels(title, sweep["parameter"] + unit, "success fraction"), hlines=hlines
        )
    columns = 5
    figure = _figure(-(-len(sweeps) // columns), columns, (16, 6))
    for ax, sweep in zip(figure.axes, sweeps, strict=False):
        ax.plot(sweep["levels"], sweep["fractions"], marker="o", markersize=3)
        ax.set(title=sweep["parameter"], xlabel=sweep["unit"], ylim=(-0.05, 1.05))
        ax.grid(True, color="0.9")
    figure.suptitle(title)
    return figure


def height_figure(
    times: np.ndarray, heights: np.ndarray, line: float, torques: np.ndarray, title: str
) -> Figure:
    """Tip height [m] (with the ``line`` above which the tip is up) and elbow torque [N m] over
    ``times`` (N+1,) [s]; ``torques`` (N,)."""
    figure = _figure(2, 1, (10, 6))
    top, bottom = figure.axes
    top.plot(times, heights, linewidth=1)
    top.axhline(line, color="0.35", linestyle="--", linewidth=1, label=f"up: {line:.3g} m")
    top.set(title=title, ylabel="tip height [m]")
    top.legend(loc="best", fontsize=9)
    bottom.plot(times[:-1], torques, linewidth=1)
    bottom.set(xlabel="time [s]", ylabel="elbow torque [N m]")
    for ax in figure.axes:
        ax.grid(True, color="0.9")
    return figure
