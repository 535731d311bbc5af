"""A race's charts, drawn by matplotlib as ``plots.py``'s: every car's path over the track
picture (each car in its colour) and each car's position over time. Each function returns a
``Figure`` made without pyplot (``plots.png`` renders it with Agg)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from tinyrace.experiment.plots import track_axes, track_axes_done


@dataclass
class CarLine:
    """One car's line in a race's chart: its name, colour and values."""

    label: str
    color: str  # '#rrggbb'
    x: np.ndarray  # (N,) [track units] or time [s]
    y: np.ndarray  # (N,) [track units] or position
    crashed: bool = False  # its episode ended for a crash (End.crash)


def car_paths(
    background: np.ndarray,
    extent: tuple[float, float, float, float],
    lines: Sequence[CarLine],
    lap_line: np.ndarray | None,
    unit: str,
    size: float = 10.0,
) -> Figure:
    """The track picture (RGB, spanning ``extent`` = left, right, bottom, top [track units])
    with each car's path in its colour, its start and (a crash) its end marked."""
    figure, ax = track_axes(background, extent, lap_line, "lap line", size)
    for line in lines:
        ok = np.isfinite(line.x) & np.isfinite(line.y)
        if not ok.any():
            continue
        x, y = line.x[ok], line.y[ok]
        ax.plot(x, y, color="black", lw=3.2, alpha=0.6)  # an outline: seen on any ground
        ax.plot(x, y, color=line.color, lw=1.8, label=line.label)
        ax.plot(x[0], y[0], "o", ms=8, mfc=line.color, mec="black")
        if line.crashed:
            ax.plot(x[-1], y[-1], "X", ms=11, color=line.color, mec="black")
    track_axes_done(ax, extent, unit)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), title="car (o start, X crash)")
    return figure


def positions(lines: Sequence[CarLine], cars: int) -> Figure:
    """Each car's place over time [s] (1 at the top), a step line per car; a line ends
    where its car left the race."""
    figure = Figure(figsize=(10, 1.6 + 0.35 * cars), layout="constrained")
    ax = figure.add_subplot()
    for k, line in enumerate(lines):
        offset = (k - (len(lines) - 1) / 2) * 0.04  # cars sharing a place stay apart
        ax.step(line.x, line.y + offset, where="post", color=line.color, lw=2, label=line.label)
        if len(line.x):
            ax.plot(line.x[-1], line.y[-1] + offset, "o", ms=5, color=line.color)
    ax.set_ylim(cars + 0.5, 0.5)
    ax.yaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_ylabel("position")
    ax.set_xlabel("time since reset [s]")
    ax.grid(color="#e4e4e4")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), title="car")
    return figure
