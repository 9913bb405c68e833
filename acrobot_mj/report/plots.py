"""PNG figures drawn with Pillow (imageio's own dependency): no plotting library needed.

:func:`line_plot` draws series and shaded bands on linear or log axes with ticks, labels and a
legend; :func:`learning_curve` is the figure ``acrobot-mj train`` writes (its labels come from
the caller, which asks the task).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from acrobot_mj.files import write_atomic

COLOURS = (
    (31, 119, 180),
    (214, 39, 40),
    (44, 160, 44),
    (255, 127, 14),
    (148, 103, 189),
    (140, 86, 75),
)


@dataclass
class Series:
    """One line (and optional band ``low..high`` around it) of a plot."""

    label: str
    x: Sequence[float]
    y: Sequence[float]
    low: Sequence[float] | None = None
    high: Sequence[float] | None = None


def _ticks(low: float, high: float, log: bool) -> list[float]:
    if log:  # low, high in decades: 1-2-5 ticks over a few decades, else every n-th decade
        decades = range(math.floor(low), math.ceil(high) + 1)
        if high - low > 4:
            every = max(1, math.ceil((high - low) / 8))
            return [10.0**k for k in decades if k % every == 0 and low <= k <= high]
        return [
            10.0**k * m
            for k in decades
            for m in (1, 2, 5)
            if low - 1e-9 <= math.log10(10.0**k * m) <= high + 1e-9
        ]
    span = high - low
    step = 10 ** math.floor(math.log10(span / 4)) if span > 0 else 1.0
    for m in (1, 2, 5, 10):
        if span / (step * m) <= 6:
            step *= m
            break
    first = math.ceil(low / step) * step
    return [first + i * step for i in range(int((high - first) / step + 1e-9) + 1)]


def _label(value: float) -> str:
    return f"{value:g}" if abs(value) < 1e5 else f"{value:.0e}"


@dataclass
class _Axes:
    """The plot area and the map from data to pixels (log10 on y if ``log_y``)."""

    x0: float
    x1: float
    y0: float
    y1: float
    log_y: bool
    width: int
    height: int
    left: int = 80
    right: int = 20
    top: int = 40
    bottom: int = 60

    @staticmethod
    def fy(v: Sequence[float] | np.ndarray, log_y: bool) -> np.ndarray:
        v = np.asarray(v, dtype=float)
        return np.log10(np.maximum(v, 1e-12)) if log_y else v

    def px(self, x: Sequence[float] | np.ndarray) -> np.ndarray:
        span = self.width - self.left - self.right
        return self.left + (np.asarray(x, float) - self.x0) / (self.x1 - self.x0) * span

    def py(self, y: Sequence[float] | np.ndarray) -> np.ndarray:
        span = self.height - self.top - self.bottom
        return (
            self.height
            - self.bottom
            - (self.fy(y, self.log_y) - self.y0) / (self.y1 - self.y0) * span
        )


def _axes_for(series, hlines, arrows, log_y: bool, size: tuple[int, int]) -> _Axes:
    """Axes spanning every series, band, reference line and arrow (5 % padding on y)."""
    xs = np.concatenate(
        [np.asarray(s.x, float) for s in series]
        + ([np.asarray(arrows, float)[:, 0]] if arrows is not None else [])
    )
    parts = [_Axes.fy(v, log_y) for s in series for v in (s.y, s.low, s.high) if v is not None]
    if hlines:
        parts.append(_Axes.fy([v for v, _ in hlines], log_y))
    if arrows is not None:
        parts.append(_Axes.fy(np.asarray(arrows, float)[:, 1], log_y))
    ys = np.concatenate(parts)
    x0, x1 = float(xs.min()), float(xs.max())
    y0, y1 = float(np.nanmin(ys)), float(np.nanmax(ys))
    if x1 == x0:
        x1 = x0 + 1
    pad = (y1 - y0) * 0.05 or 1.0
    return _Axes(x0, x1, y0 - pad, y1 + pad, log_y, *size)


def _draw_frame(image, draw, axes: _Axes, title: str, xlabel: str, ylabel: str) -> None:
    """Box, grid, ticks, title and axis labels."""
    font, small = ImageFont.load_default(size=15), ImageFont.load_default(size=12)
    a, width, height = axes, axes.width, axes.height
    draw.rectangle([a.left, a.top, width - a.right, height - a.bottom], outline="black")
    for t in _ticks(a.x0, a.x1, False):
        x = float(a.px([t])[0])
        draw.line([x, a.top, x, height - a.bottom], fill=(230, 230, 230))
        draw.text((x, height - a.bottom + 4), _label(t), fill="black", font=small, anchor="ma")
    for t in _ticks(a.y0, a.y1, a.log_y):
        y = float(a.py([t])[0])
        draw.line([a.left, y, width - a.right, y], fill=(230, 230, 230))
        draw.text((a.left - 6, y), _label(t), fill="black", font=small, anchor="rm")
    draw.text((width / 2, 10), title, fill="black", font=font, anchor="ma")
    draw.text((width / 2, height - 22), xlabel, fill="black", font=font, anchor="ma")
    label = Image.new("RGBA", (height, 24), (255, 255, 255, 0))
    ImageDraw.Draw(label).text((height / 2, 2), ylabel, fill="black", font=font, anchor="ma")
    image.paste(label.rotate(90, expand=True), (4, 0), label.rotate(90, expand=True))


def line_plot(
    path: str | Path,
    series: Sequence[Series],
    title: str,
    xlabel: str,
    ylabel: str,
    log_y: bool = False,
    size: tuple[int, int] = (800, 500),
    hlines: Sequence[tuple[float, str]] = (),
    arrows: np.ndarray | None = None,
) -> Path:
    """Draw ``series`` (lines with optional bands), labelled horizontal reference lines and
    a field of ``arrows`` (rows ``x, y, dx, dy`` in data units, drawn grey with a tick)."""
    image = Image.new("RGB", size, "white")
    draw = ImageDraw.Draw(image, "RGBA")
    small = ImageFont.load_default(size=12)
    axes = _axes_for(series, hlines, arrows, log_y, size)
    _draw_frame(image, draw, axes, title, xlabel, ylabel)
    if arrows is not None:
        for x, y, dx, dy in np.asarray(arrows, dtype=float):
            (tail_x, head_x), (tail_y, head_y) = axes.px([x, x + dx]), axes.py([y, y + dy])
            draw.line([tail_x, tail_y, head_x, head_y], fill=(170, 170, 170), width=1)
            draw.ellipse(
                [head_x - 1.5, head_y - 1.5, head_x + 1.5, head_y + 1.5], fill=(150, 150, 150)
            )
    right = axes.width - axes.right
    for value, text in hlines:
        y = float(axes.py([value])[0])
        draw.line([axes.left, y, right, y], fill=(90, 90, 90), width=1)
        draw.text((right - 4, y - 2), text, fill=(90, 90, 90), font=small, anchor="rd")
    for k, s in enumerate(series):
        colour = COLOURS[k % len(COLOURS)]
        x = axes.px(s.x)
        if s.low is not None and s.high is not None:
            polygon = list(zip(x, axes.py(s.high), strict=True))
            polygon += list(zip(x[::-1], axes.py(s.low)[::-1], strict=True))
            draw.polygon([(float(a), float(b)) for a, b in polygon], fill=(*colour, 50))
        points = [(float(a), float(b)) for a, b in zip(x, axes.py(s.y), strict=True)]
        if len(points) > 1:
            draw.line(points, fill=colour, width=2)
        draw.text((axes.left + 10, axes.top + 8 + 18 * k), s.label, fill=colour, font=small)
    return write_atomic(path, lambda f: image.save(f, format="PNG"))


def learning_curve(
    path: str | Path,
    runs: Sequence[Sequence[float]],
    title: str,
    reference: Sequence[tuple[float, str]] = (),
    ylabel: str = "decisions per episode",
    log_y: bool = True,
) -> Path:
    """A per-episode score against episode: one run as a line, several runs as the median with
    the 25-75 % band across runs."""
    if len(runs) > 1:
        return compare_curves(path, {"": runs}, title, reference, ylabel, log_y)
    values = np.asarray(runs, dtype=float)
    series = [Series("one run", np.arange(1, values.shape[1] + 1), values[0])]
    return _curves(path, series, title, reference, ylabel, log_y)


def _curves(path, series, title, reference, ylabel: str, log_y: bool) -> Path:
    return line_plot(
        path,
        series,
        title,
        "episode",
        f"{ylabel} (log scale)" if log_y else ylabel,
        log_y=log_y,
        hlines=reference,
    )


def compare_curves(
    path: str | Path,
    groups: dict[str, Sequence[Sequence[float]]],
    title: str,
    reference: Sequence[tuple[float, str]] = (),
    ylabel: str = "decisions per episode",
    log_y: bool = True,
) -> Path:
    """Median and 25-75 % band across runs of each group of runs, on one figure."""
    series = []
    for label, runs in groups.items():
        values = np.asarray(runs, dtype=float)
        low, median, high = np.percentile(values, [25, 50, 75], axis=0)
        series.append(
            Series(
                f"{label + ': ' if label else ''}median of {len(values)} seeds, 25-75 % band",
                np.arange(1, values.shape[1] + 1),
                median,
                low,
                high,
            )
        )
    return _curves(path, series, title, reference, ylabel, log_y)
