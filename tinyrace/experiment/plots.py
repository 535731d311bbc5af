"""The report's pictures, drawn with OpenCV and numpy: trajectories over a track picture,
bar charts per episode and time series. All images are RGB uint8."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import ArrayLike

_FONT = cv2.FONT_HERSHEY_SIMPLEX
INK = (40, 40, 40)  # RGB: axes and text
GRID = (225, 225, 225)
PAPER = (255, 255, 255)
BAR = (70, 110, 180)
START = (40, 200, 60)
LAP_LINE = (255, 255, 255)
CRASH = (230, 30, 30)
HIT = (255, 150, 0)


@dataclass
class Path2D:
    """One episode's trajectory in picture pixels, with what happened along it."""

    label: str
    points: np.ndarray  # (N, 2) [px]
    speed: np.ndarray  # (N,) [track units/s]
    hits: np.ndarray  # (N,) bool: an obstacle was touched at this step
    crashed: bool  # the episode ended out of bounds or on a done obstacle


def speed_colors(speed: np.ndarray, top: float) -> np.ndarray:
    """(N, 3) RGB of each speed on OpenCV's turbo map, 0 (blue) .. ``top`` (red)."""
    if len(speed) == 0:  # OpenCV maps no pixels to None
        return np.zeros((0, 3), np.uint8)
    level = np.clip(np.nan_to_num(speed) / max(top, 1e-9), 0, 1) * 255
    bgr = cv2.applyColorMap(level.astype(np.uint8).reshape(-1, 1), cv2.COLORMAP_TURBO)
    rgb: np.ndarray = bgr.reshape(-1, 3)[:, ::-1]
    return rgb


def trajectories(
    background: np.ndarray, paths: Sequence[Path2D], lap_line: np.ndarray | None, unit: str
) -> np.ndarray:
    """The track with each path coloured by speed; start, lap line, crashes, hits marked."""
    image: np.ndarray = background.copy()
    scale = max(1, round(max(image.shape[:2]) / 800))  # thicker marks on big pictures
    if lap_line is not None:
        a, b = (tuple(round(float(v)) for v in p) for p in lap_line)
        cv2.line(image, a, b, (0, 0, 0), 5 * scale, cv2.LINE_AA)
        cv2.line(image, a, b, LAP_LINE, 2 * scale, cv2.LINE_AA)
    speeds = [p.speed[np.isfinite(p.speed)] for p in paths]
    top = max([float(s.max()) for s in speeds if len(s)] + [1e-9])
    labels: list[tuple[int, int]] = []  # where labels went: same starts stack their labels
    for path in paths:
        _draw_path(image, path, top, scale, labels)
    _speed_bar(image, top, unit)
    return image


def _draw_path(
    image: np.ndarray, path: Path2D, top: float, scale: int, labels: list[tuple[int, int]]
) -> None:
    ok = np.isfinite(path.points).all(axis=1)
    points, colors = path.points[ok], speed_colors(path.speed[ok], top)
    pixels = np.round(points).astype(np.int32)
    for k in range(1, len(pixels)):
        color = tuple(int(c) for c in colors[k])
        cv2.line(image, tuple(pixels[k - 1]), tuple(pixels[k]), color, 2 * scale, cv2.LINE_AA)
    for hit in np.flatnonzero(path.hits[ok]):
        cv2.circle(image, tuple(pixels[hit]), 4 * scale, HIT, scale, cv2.LINE_AA)
    if len(pixels) == 0:
        return
    cv2.circle(image, tuple(pixels[0]), 6 * scale, START, -1, cv2.LINE_AA)
    cv2.circle(image, tuple(pixels[0]), 6 * scale, (0, 0, 0), 1, cv2.LINE_AA)
    at = (int(pixels[0][0]) + 8 * scale, int(pixels[0][1]) - 6 * scale)
    while any(abs(at[0] - x) < 40 * scale and abs(at[1] - y) < 16 * scale for x, y in labels):
        at = (at[0], at[1] + 18 * scale)
    labels.append(at)
    _text(image, path.label, at, 0.5 * scale)
    if path.crashed:
        x, y, r = int(pixels[-1][0]), int(pixels[-1][1]), 9 * scale
        cv2.line(image, (x - r, y - r), (x + r, y + r), CRASH, 3 * scale, cv2.LINE_AA)
        cv2.line(image, (x - r, y + r), (x + r, y - r), CRASH, 3 * scale, cv2.LINE_AA)


def _speed_bar(image: np.ndarray, top: float, unit: str) -> None:
    """A colour scale at the top right: 0 .. top speed."""
    w = image.shape[1]
    bar_w, bar_h = min(200, w // 3), 12
    x0, y0 = w - bar_w - 16, 28
    cv2.rectangle(image, (x0 - 8, 6), (w - 8, y0 + bar_h + 8), (30, 30, 30), -1)
    colors = speed_colors(np.linspace(0, top, bar_w), top)
    image[y0 : y0 + bar_h, x0 : x0 + bar_w] = colors[None, :, :]
    label = f"speed 0 .. {top:.0f} {unit}/s"
    cv2.putText(image, label, (x0, y0 - 6), _FONT, 0.45, (255, 255, 255), 1, cv2.LINE_AA)


def _text(image: np.ndarray, text: str, at: tuple[int, int], size: float) -> None:
    at = (int(at[0]), int(at[1]))
    cv2.putText(image, text, at, _FONT, size, (0, 0, 0), 3, cv2.LINE_AA)
    cv2.putText(image, text, at, _FONT, size, (255, 255, 255), 1, cv2.LINE_AA)


# -- charts ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Axes:
    """A plotting area inside a picture and the data range it shows."""

    left: int
    top: int
    width: int
    height: int
    x_range: tuple[float, float]
    y_range: tuple[float, float]
    y_ticks: tuple[float, ...] = ()  # labelled grid lines (none: the frame only)

    def pixel(self, x: ArrayLike, y: ArrayLike) -> np.ndarray:
        (x0, x1), (y0, y1) = self.x_range, self.y_range
        px = self.left + (np.asarray(x, float) - x0) / (x1 - x0) * self.width
        py = self.top + self.height - (np.asarray(y, float) - y0) / (y1 - y0) * self.height
        return np.stack([px, py], axis=-1)


def nice_range(values: np.ndarray, include_zero: bool = False) -> tuple[float, float]:
    """A range that holds every finite value (and 0 if asked), never empty."""
    finite = np.asarray(values, float)
    finite = finite[np.isfinite(finite)]
    low, high = (float(finite.min()), float(finite.max())) if len(finite) else (0.0, 1.0)
    if include_zero:
        low, high = min(low, 0.0), max(high, 0.0)
    if high - low < 1e-9:
        low, high = low - 1.0, high + 1.0
    pad = 0.05 * (high - low)
    return low - (pad if low < 0 or not include_zero else 0), high + pad


_MANTISSAS = (1.0, 2.0, 2.5, 5.0)  # round tick steps, times a power of ten


def nice_ticks(low: float, high: float, most: int = 6) -> tuple[float, ...]:
    """At most ``most`` (>= 3) ticks a round step apart (1, 2, 2.5 or 5 times a power of
    ten), from the step's multiple at or below ``low`` to the one at or above ``high``:
    the smallest such step that needs no more ticks."""
    span = max(high - low, 1e-12 * max(abs(low), abs(high), 1.0))
    exponent = math.floor(math.log10(span / (most - 1)))
    while True:  # ends by the decade after: a step >= span needs at most 3 ticks
        for mantissa in _MANTISSAS:
            step = mantissa * 10.0**exponent
            first, last = math.floor(low / step), math.ceil(high / step)
            if first * step > low:  # k x step rounded past the range's end: one more
                first -= 1
            if last * step < high:
                last += 1
            if last - first < most:
                return tuple(k * step for k in range(first, last + 1))
        exponent += 1


def tick_labels(ticks: Sequence[float]) -> list[str]:
    """The ticks printed with as many decimals as their step needs."""
    if len(ticks) < 2:
        return [f"{t:g}" for t in ticks]
    step = abs(ticks[1] - ticks[0])
    decimals = max(0, -math.floor(math.log10(step) + 1e-9))
    if round(step / 10.0**-decimals, 6) % 1:  # 2.5 x a power of ten: one more decimal
        decimals += 1
    return [f"{t:.{decimals}f}" for t in ticks]


def value_axis(
    values: np.ndarray, include_zero: bool
) -> tuple[tuple[float, float], tuple[float, ...]]:
    """The range and round ticks of a value axis for ``values`` (the range ends on ticks)."""
    ticks = nice_ticks(*nice_range(values, include_zero))
    return (ticks[0], ticks[-1]), ticks


def _frame(image: np.ndarray, axes: Axes, title: str, x_label: str) -> None:
    """Grid, tick labels, title."""
    left, top, w, h = axes.left, axes.top, axes.width, axes.height
    for value, label in zip(axes.y_ticks, tick_labels(axes.y_ticks), strict=True):
        y = round(float(axes.pixel(axes.x_range[0], value)[1]))
        cv2.line(image, (left, y), (left + w, y), GRID, 1)
        cv2.putText(image, label, (4, y + 4), _FONT, 0.4, INK, 1, cv2.LINE_AA)
    cv2.rectangle(image, (left, top), (left + w, top + h), INK, 1)
    cv2.putText(image, title, (left, top - 8), _FONT, 0.5, INK, 1, cv2.LINE_AA)
    if x_label:
        x0, x1 = axes.x_range
        bottom = top + h + 16
        cv2.putText(image, f"{x0:.3g}", (left, bottom), _FONT, 0.4, INK, 1, cv2.LINE_AA)
        end = f"{x1:.3g} {x_label}"
        width = cv2.getTextSize(end, _FONT, 0.4, 1)[0][0]
        cv2.putText(image, end, (left + w - width, bottom), _FONT, 0.4, INK, 1, cv2.LINE_AA)


def bar_chart(
    values: Sequence[float | None],
    labels: Sequence[str],
    title: str,
    size: tuple[int, int] = (560, 260),
) -> np.ndarray:
    """One bar per value (None: no bar, marked '-')."""
    width, height = size
    image = np.full((height, width, 3), PAPER, np.uint8)
    numbers = np.array([np.nan if v is None else v for v in values], float)
    y_range, ticks = value_axis(numbers, include_zero=True)
    axes = Axes(56, 28, width - 72, height - 64, (0, max(len(values), 1)), y_range, ticks)
    _frame(image, axes, title, "")
    zero = axes.pixel(0, 0)[1]
    slot = axes.width / max(len(values), 1)
    for k, (value, label) in enumerate(zip(numbers, labels, strict=True)):
        x0 = int(axes.left + k * slot + slot * 0.15)
        x1 = int(axes.left + (k + 1) * slot - slot * 0.15)
        if np.isfinite(value):
            y = axes.pixel(0, value)[1]
            cv2.rectangle(image, (x0, int(min(y, zero))), (x1, int(max(y, zero))), BAR, -1)
        else:
            cv2.putText(image, "-", (x0, int(zero) - 4), _FONT, 0.5, INK, 1, cv2.LINE_AA)
        cv2.putText(image, label, (x0, axes.top + axes.height + 16), _FONT, 0.4, INK, 1)
    return image


def time_series(
    t: np.ndarray, panels: Sequence[tuple[str, np.ndarray]], title: str, width: int = 560
) -> np.ndarray:
    """Stacked line plots sharing the time axis [s]; a panel without finite values says so."""
    panel_h, gap = 120, 44
    height = 44 + len(panels) * (panel_h + gap)
    image = np.full((height, width, 3), PAPER, np.uint8)
    cv2.putText(image, title, (8, 16), _FONT, 0.55, INK, 1, cv2.LINE_AA)
    finite_t = t[np.isfinite(t)]
    x_range = (float(finite_t.min()), float(finite_t.max())) if len(finite_t) > 1 else (0.0, 1.0)
    for k, (name, values) in enumerate(panels):
        ok = np.isfinite(values) & np.isfinite(t)
        y_range, ticks = value_axis(values, include_zero=True)
        axes = Axes(56, 20 + gap + k * (panel_h + gap) - 10, width - 72, panel_h, x_range,
                    y_range, ticks if ok.any() else ())  # fmt: skip
        _frame(image, axes, name, "s" if k == len(panels) - 1 else "")
        if not ok.any():
            cv2.putText(image, "(not measured on this track)", (axes.left + 10,
                        axes.top + panel_h // 2), _FONT, 0.45, INK, 1)  # fmt: skip
            continue
        points = np.round(axes.pixel(t[ok], values[ok])).astype(np.int32)
        cv2.polylines(image, [points.reshape(-1, 1, 2)], False, BAR, 1, cv2.LINE_AA)
    return image
