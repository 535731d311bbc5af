"""The report's charts, drawn by matplotlib: trajectories over the track picture, a bar per
episode, time series. Each function returns a ``Figure`` made without pyplot (no window, no
global backend switch: ``png`` renders it with Agg). Imported only when a report is written."""

from __future__ import annotations

import io
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from matplotlib import patheffects
from matplotlib.axes import Axes
from matplotlib.collections import LineCollection
from matplotlib.colors import Normalize
from matplotlib.figure import Figure
from matplotlib.ticker import FuncFormatter, MaxNLocator

NO_LAP = "no lap finished"
SPEED_MAP = "turbo"
BAR = "#4a6fb0"
LAP_LINE = "#ff00ff"  # magenta: seen on grass, road, kerbs and dark image tracks alike


@dataclass
class Path2D:
    """One episode's trajectory in track units, with what happened along it."""

    label: str
    points: np.ndarray  # (N, 2) [track units]
    speed: np.ndarray  # (N,) [track units/s]
    hits: np.ndarray  # (N,) bool: an obstacle was touched at this step
    crashed: bool  # the episode ended for a crash (End.crash: out of bounds, an obstacle, ...)


@dataclass
class Series:
    """One episode's time series: time [s] and the values of each panel."""

    label: str
    t: np.ndarray
    values: dict[str, np.ndarray]  # panel title -> (N,) values


def png(figure: Figure) -> bytes:
    """The figure as PNG bytes (no timestamp: a rebuilt report is the same file)."""
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=100, metadata={"Software": None}, bbox_inches="tight")
    return buffer.getvalue()


def trajectories(
    background: np.ndarray,
    extent: tuple[float, float, float, float],
    paths: Sequence[Path2D],
    lap_line: np.ndarray | None,
    unit: str,
    size: float = 10.0,
) -> Figure:
    """The track picture (RGB, spanning ``extent`` = left, right, bottom, top [track units])
    with each path coloured by speed; start, lap line, crashes and obstacle hits marked and
    named in the legend only where drawn. ``size`` [in]: the figure's width."""
    figure, ax = track_axes(background, extent, lap_line, "lap line (start/finish)", size)
    finite = [p.speed[np.isfinite(p.speed)] for p in paths]
    top = max([float(s.max()) for s in finite if len(s)] + [1e-9])
    lines = _draw_paths(ax, paths, Normalize(0.0, top))
    _start_labels(ax, paths, 0.02 * abs(extent[1] - extent[0]))
    if lines is not None:  # a colour scale as tall as the picture
        figure.colorbar(lines, cax=ax.inset_axes((1.02, 0.0, 0.03, 1.0)), label=f"speed [{unit}/s]")
    track_axes_done(ax, extent, unit)
    _legend(figure, ax)
    return figure


def track_axes(
    background: np.ndarray,
    extent: tuple[float, float, float, float],
    lap_line: np.ndarray | None,
    lap_label: str,
    size: float,
) -> tuple[Figure, Axes]:
    """A figure ``size`` [in] wide of the track picture (RGB) spanning ``extent``, with the
    lap line (labelled ``lap_label``) drawn first: under whatever is drawn next. One car's
    trajectories and a race's paths alike."""
    height, width = background.shape[:2]
    figure = Figure(figsize=(size, size * height / width), layout="constrained")
    ax = figure.add_subplot()
    ax.imshow(background, extent=extent, interpolation="antialiased")
    if lap_line is not None:  # on top of the paths, outlined: seen on any ground
        outline = [patheffects.withStroke(linewidth=7, foreground="black")]
        ax.plot(*np.asarray(lap_line).T, color=LAP_LINE, lw=4, label=lap_label, zorder=5,
                path_effects=outline, solid_capstyle="butt")  # fmt: skip
    return figure, ax


def track_axes_done(ax: Axes, extent: tuple[float, float, float, float], unit: str) -> None:
    """The track picture's axes titled in ``unit`` and limited to the picture (paths that
    leave it are cut at its edge)."""
    ax.set_xlabel(f"x [{unit}]")
    ax.set_ylabel(f"y [{unit}]")
    ax.set_xlim(extent[0], extent[1])
    ax.set_ylim(extent[2], extent[3])


def _legend(figure: Figure, ax: Axes) -> None:
    """A legend of what was drawn, each name once (several episodes crash, hit...)."""
    handles, labels = ax.get_legend_handles_labels()
    unique = dict(zip(labels, handles, strict=True))
    if unique:
        figure.legend(  # under the picture: never over the track
            unique.values(), unique.keys(), loc="outside lower center", ncol=len(unique),
            frameon=False,
        )  # fmt: skip


def _draw_paths(ax: Axes, paths: Sequence[Path2D], norm: Normalize) -> LineCollection | None:
    """Every path in one collection of segments coloured by speed, the starts, obstacle
    hits and crashes each one line of markers: a few artists however many episodes."""
    segments, speeds, starts, hits, crashes = [], [], [], [], []
    for path in paths:
        ok = np.isfinite(path.points).all(axis=1)
        points, speed = path.points[ok], np.nan_to_num(path.speed[ok])
        if len(points) < 2:
            continue
        segments.append(np.stack([points[:-1], points[1:]], axis=1))
        speeds.append(speed[1:])
        starts.append(points[0])
        hits.append(points[path.hits[ok]])
        if path.crashed:
            crashes.append(points[-1])
    if not segments:
        return None
    lines = LineCollection(
        list(np.concatenate(segments)), cmap=SPEED_MAP, norm=norm, linewidths=2.2
    )
    lines.set_array(np.concatenate(speeds))
    ax.add_collection(lines, autolim=False)  # the axes span the picture
    start = np.array(starts)
    ax.plot(*start.T, "o", ms=9, mfc="#28c83c", mec="black", ls="none", label="start", zorder=6)
    hit = np.concatenate(hits)
    if len(hit):
        ax.plot(*hit.T, "o", ms=7, mfc="none", mec="#ff9600", ls="none", label="obstacle hit")
    if crashes:
        ax.plot(*np.array(crashes).T, "X", ms=12, color="#e61e1e", mec="black", ls="none",
                label="crash")  # fmt: skip
    return lines


def _start_labels(ax: Axes, paths: Sequence[Path2D], near: float) -> None:
    """One label per start point: episodes starting within ``near`` [track units] share it
    ("ep 0, 2")."""
    groups: list[tuple[np.ndarray, list[str]]] = []
    for path in paths:
        ok = np.isfinite(path.points).all(axis=1)
        if not ok.any():
            continue
        start = path.points[ok][0]
        same = [g for g in groups if np.hypot(*(g[0] - start)) < near]
        if same:
            same[0][1].append(path.label.removeprefix("ep "))
        else:
            groups.append((start, [path.label]))
    for start, names in groups:
        at = (float(start[0]), float(start[1]))
        ax.annotate(
            _episodes_text(names), at, xytext=(8, 8), textcoords="offset points", color="white",
            fontsize=10, bbox={"boxstyle": "round,pad=0.2", "fc": "black", "alpha": 0.6},
        )  # fmt: skip


def _episodes_text(names: list[str], longest: int = 40) -> str:
    """``["ep 0", "1", "2", "5"]`` as "ep 0-2, 5": runs of numbers joined; a text longer
    than ``longest`` characters (a label over the track) cut to its ends and the count."""
    head, rest = names[0], names[1:]
    prefix = "ep " if head.startswith("ep ") else ""
    items = [head.removeprefix("ep "), *rest]
    if not all(item.isdigit() for item in items):
        text = ", ".join(names)
    else:
        numbers = sorted(int(item) for item in items)
        runs: list[list[int]] = []
        for n in numbers:
            if runs and n == runs[-1][-1] + 1:
                runs[-1].append(n)
            else:
                runs.append([n])
        text = prefix + ", ".join(
            f"{r[0]}-{r[-1]}" if len(r) > 2 else ", ".join(map(str, r)) for r in runs
        )
    if len(text) <= longest:
        return text
    return f"{text[: longest // 2].rsplit(',', 1)[0]}, ... ({len(names)} episodes)"


def bars(
    values: Sequence[float | None], labels: Sequence[str], y_label: str, missing: str
) -> Figure:
    """One bar per episode; an episode without a value gets the word ``missing`` instead,
    and a chart without any value says so across the plot."""
    figure = Figure(figsize=(6, 3.4), layout="constrained")
    ax = figure.add_subplot()
    x = np.arange(len(values))
    numbers = np.array([np.nan if v is None else v for v in values], float)
    ok = np.isfinite(numbers)
    if len(values) <= LABELLED_BARS:
        ax.bar(x[ok], numbers[ok], color=BAR, width=0.6)
        ax.set_xticks(x, labels)
    else:  # one collection of bars (a Rectangle each takes seconds), a tick now and then
        width = max(72.0 * 5.0 * 0.6 / len(values), 0.3)  # [pt] 0.6 of a bar's share of 5 in
        ax.vlines(x[ok], 0.0, numbers[ok], color=BAR, lw=width)
        ax.xaxis.set_major_locator(MaxNLocator(10, integer=True))
        ax.xaxis.set_major_formatter(
            FuncFormatter(lambda v, _: labels[int(v)] if 0 <= v < len(labels) else "")
        )
    ax.set_xlim(-0.6, max(len(values), 1) - 0.4)
    ax.set_xlabel("episode")
    ax.set_ylabel(y_label)
    if not np.isfinite(numbers).any():
        ax.set_yticks([])
        ax.text(0.5, 0.5, missing, transform=ax.transAxes, ha="center", va="center",
                fontsize=14, color="#b00000")  # fmt: skip
        return figure
    ax.axhline(0.0, color="black", lw=0.8)
    ax.grid(axis="y", color="#dddddd")
    ax.set_axisbelow(True)
    lacking = np.flatnonzero(~np.isfinite(numbers))
    if len(values) > LABELLED_BARS and len(lacking):  # one note, not a word per bar
        ax.text(0.01, 0.97, f"{missing}: {len(lacking)} of {len(values)} episodes",
                transform=ax.transAxes, ha="left", va="top", color="#b00000")  # fmt: skip
        return figure
    for k in lacking:
        ax.text(x[k], 0.0, missing, ha="center", va="bottom", rotation=90, color="#b00000")
    return figure


LABELLED_BARS = 40  # episodes up to which each bar is named (and a missing value said)
BAND_FROM = 5  # episodes from which the time series show a median and a band, not lines


def time_series(series: Sequence[Series], panels: Sequence[str]) -> Figure:
    """Stacked panels sharing the time axis [s]: one line per episode in each, or from
    ``BAND_FROM`` episodes on, each episode a thin grey line under their median and the band
    from the lowest to the highest value (episodes still running at that time)."""
    figure = Figure(figsize=(10, 1.0 + 2.2 * len(panels)), layout="constrained")
    axes = figure.subplots(len(panels), 1, sharex=True, squeeze=False)[:, 0]
    banded = len(series) >= BAND_FROM
    for ax, panel in zip(axes, panels, strict=True):
        if banded:
            _band(ax, series, panel)
        else:
            for entry in series:
                ax.plot(entry.t, entry.values[panel], lw=1.2, label=entry.label)
        ax.set_ylabel(panel)
        ax.grid(color="#e4e4e4")
        ax.yaxis.set_major_locator(MaxNLocator(5))
    axes[-1].set_xlabel("time since reset [s]")
    if banded:
        axes[0].legend(
            loc="upper left", bbox_to_anchor=(1.01, 1.0), title=f"{len(series)} episodes"
        )
    elif len(series) > 1:
        axes[0].legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), title="episode")
    return figure


def _band(ax: Axes, series: Sequence[Series], panel: str) -> None:
    """The episodes' median over time and the band from their lowest to highest value, on
    the longest episode's times (an episode that ended counts no more)."""
    longest = max(series, key=lambda s: len(s.t)).t
    rows = np.full((len(series), len(longest)), np.nan)
    lines = []
    for k, entry in enumerate(series):
        ok = np.isfinite(entry.values[panel]) & np.isfinite(entry.t)
        if ok.sum() >= 2:
            inside = (longest >= entry.t[ok][0]) & (longest <= entry.t[ok][-1])
            rows[k, inside] = np.interp(longest[inside], entry.t[ok], entry.values[panel][ok])
        lines.append(np.stack([entry.t, entry.values[panel]], axis=1)[ok])
    ax.add_collection(  # every episode in one collection
        LineCollection(lines, lw=0.6, color="#9a9a9a", alpha=0.6, label="each episode")
    )
    ax.autoscale_view()
    counted = np.isfinite(rows).any(axis=0)
    if not counted.any():
        return
    t, kept = longest[counted], rows[:, counted]
    low, high = np.nanmin(kept, axis=0), np.nanmax(kept, axis=0)
    ax.fill_between(t, low, high, color=BAR, alpha=0.25, lw=0, label="lowest to highest")
    ax.plot(t, np.nanmedian(kept, axis=0), color=BAR, lw=1.8, label="median")
