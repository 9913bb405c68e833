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
    width, height = size
    left, right, top, bottom = 80, 20, 40, 60
    image = Image.new("RGB", size, "white")
    draw = ImageDraw.Draw(image, "RGBA")
    font, small = ImageFont.load_default(size=15), ImageFont.load_default(size=12)

    def fy(v: np.ndarray) -> np.ndarray:
        v = np.asarray(v, dtype=float)
        return np.log10(np.maximum(v, 1e-12)) if log_y else v

    xs = np.concatenate(
        [np.asarray(s.x, float) for s in series]
        + ([np.asarray(arrows, float)[:, 0]] if arrows is not None else [])
    )
    parts = [fy(v) for s in series for v in (s.y, s.low, s.high) if v is not None]
    if hlines:
        parts.append(fy([v for v, _ in hlines]))
    if arrows is not None:
        parts.append(fy(np.asarray(arrows, float)[:, 1]))
    ys = np.concatenate(parts)
    x0, x1 = float(xs.min()), float(xs.max())
    y0, y1 = float(np.nanmin(ys)), float(np.nanmax(ys))
    if x1 == x0:
        x1 = x0 + 1
    pad = (y1 - y0) * 0.05 or 1.0
    y0, y1 = y0 - pad, y1 + pad

    def px(x: np.ndarray) -> np.ndarray:
        return left + (np.asarray(x, float) - x0) / (x1 - x0) * (width - left - right)

    def py(y: np.ndarray) -> np.ndarray:
        return height - bottom - (fy(y) - y0) / (y1 - y0) * (height - top - bottom)

    # Axes, ticks and grid.
    draw.rectangle([left, top, width - right, height - bottom], outline="black")
    for t in _ticks(x0, x1, False):
        x = float(px([t])[0])
        draw.line([x, top, x, height - bottom], fill=(230, 230, 230))
        draw.text((x, height - bottom + 4), _label(t), fill="black", font=small, anchor="ma")
    for t in _ticks(y0, y1, log_y):
        y = float(py([t])[0])
        draw.line([left, y, width - right, y], fill=(230, 230, 230))
        draw.text((left - 6, y), _label(t), fill="black", font=small, anchor="rm")
    draw.text((width / 2, 10), title, fill="black", font=font, anchor="ma")
    draw.text((width / 2, height - 22), xlabel, fill="black", font=font, anchor="ma")
    label = Image.new("RGBA", (height, 24), (255, 255, 255, 0))
    ImageDraw.Draw(label).text((height / 2, 2), ylabel, fill="black", font=font, anchor="ma")
    image.paste(label.rotate(90, expand=True), (4, 0), label.rotate(90, expand=True))

    if arrows is not None:
        for x, y, dx, dy in np.asarray(arrows, dtype=float):
            (tail_x, head_x), (tail_y, head_y) = px([x, x + dx]), py([y, y + dy])
            draw.line([tail_x, tail_y, head_x, head_y], fill=(170, 170, 170), width=1)
            draw.ellipse(
                [head_x - 1.5, head_y - 1.5, head_x + 1.5, head_y + 1.5], fill=(150, 150, 150)
            )
    for value, text in hlines:
        y = float(py([value])[0])
        draw.line([left, y, width - right, y], fill=(90, 90, 90), width=1)
        draw.text((width - right - 4, y - 2), text, fill=(90, 90, 90), font=small, anchor="rd")
    for k, s in enumerate(series):
        colour = COLOURS[k % len(COLOURS)]
        x = px(s.x)
        if s.low is not None and s.high is not None:
            polygon = list(zip(x, py(s.high), strict=True))
            polygon += list(zip(x[::-1], py(s.low)[::-1], strict=True))
            draw.polygon([(float(a), float(b)) for a, b in polygon], fill=(*colour, 50))
        points = [(float(a), float(b)) for a, b in zip(x, py(s.y), strict=True)]
        if len(points) > 1:
            draw.line(points, fill=colour, width=2)
        draw.text((left + 10, top + 8 + 18 * k), s.label, fill=colour, font=small)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    image.save(path)
    return path


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
