"""``report.html`` for a run folder: self-contained (pictures inline as PNG data URIs, no
network, no JavaScript), with the pictures also saved beside it. Built from the run's files
only (results.json, episodes.csv, the traces and track pictures), so ``tinyrace report
RUN_DIR`` rebuilds it. The charts are matplotlib's, imported here only when a report is
written."""

from __future__ import annotations

import base64
import html
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from tinyrace.config.image_file import DEFAULT_MAX_IMAGE_PIXELS, read_image_bgr
from tinyrace.experiment.files import write_file, write_text
from tinyrace.experiment.results import (
    EPISODES_FILE,
    RESULTS_FILE,
    EpisodeResult,
    summary_rows,
    table_rows,
)
from tinyrace.experiment.run_folder import check_outputs, read_episodes, read_header, read_trace

if TYPE_CHECKING:
    from matplotlib.figure import Figure

REPORT_FILE = "report.html"
CRASHES = ("out_of_bounds", "obstacle")
CTE_LEFT_OUT = (
    "The cross-track error panel is left out: this track has no reference line to measure "
    "it against (an image track needs reward_design.cross_track_error.use_cte and its "
    "trajectory_color; a ros_map track a waypoint or raceline CSV)."
)


@dataclass
class Picture:
    """One chart of the report: its file name, caption and figure."""

    name: str
    caption: str
    figure: Figure
    wide: bool = False
    section: str = "Per episode"


def rebuild_report(run_dir: Path) -> Path:
    """Rebuild ``report.html`` and its pictures from a run folder's files (checked: a
    ConfigError names the file, the field and what was expected)."""
    header = read_header(run_dir)
    return write_report(run_dir, header, read_episodes(run_dir))


class RowFiles(Protocol):
    """What a row of episodes.csv names in the run folder (one car's episode or a car's)."""

    @property
    def trace(self) -> str | None: ...

    @property
    def video(self) -> str | None: ...


def report_inputs(header: dict[str, Any], rows: Sequence[RowFiles]) -> dict[str, str]:
    """The run files a report reads, each with the file that names it."""
    names = {RESULTS_FILE: RESULTS_FILE, EPISODES_FILE: EPISODES_FILE}
    names |= {name: EPISODES_FILE for r in rows for name in (r.trace, r.video) if name}
    tracks = (header.get("tracks") or {}).values()
    return names | {entry["image"]: RESULTS_FILE for entry in tracks}


def write_report(run_dir: Path, header: dict[str, Any], results: Sequence[EpisodeResult]) -> Path:
    """Draw the charts, save them as PNG and write report.html; returns its path.

    Refused (a ConfigError) when one of the files to write is one the report reads."""
    from tinyrace.experiment import plots

    outputs = [REPORT_FILE, "report_returns.png", "report_lap_times.png"]
    outputs += ["report_time_series.png"]
    outputs += [f"report_track_{key}.png" for key in header.get("tracks") or {}]
    check_outputs(run_dir, outputs, report_inputs(header, results))
    unit = length_unit(header)
    traces = {r.episode: _trace(run_dir, r) for r in results}
    pictures = _track_pictures(run_dir, header, results, traces)
    labels = [str(r.episode) for r in results]
    returns = plots.bars([r.episode_return for r in results], labels, "return", "no return")
    pictures.append(Picture("report_returns.png", "Return (sum of rewards) per episode.", returns))
    lap_times = [r.lap_time for r in results]
    laps = plots.bars(lap_times, labels, "lap time [s]", plots.NO_LAP)
    pictures.append(Picture("report_lap_times.png", _lap_caption(lap_times), laps))
    notes = []
    series, panels = _series(results, traces, unit)
    if series:
        caption = "Speed, steering and cross-track error over each episode."
        if not any(p.startswith("cross-track") for p in panels):
            caption, notes = "Speed and steering over each episode.", [CTE_LEFT_OUT]
        figure = plots.time_series(series, panels)
        pictures.append(Picture("report_time_series.png", caption, figure, True, "Over time"))
    blobs = save_pictures(run_dir, pictures)
    path = run_dir / REPORT_FILE
    write_text(path, _html(header, results, blobs, notes, unit))
    return path


def save_pictures(run_dir: Path, pictures: Sequence[Picture]) -> list[tuple[Picture, bytes]]:
    """Each picture saved as PNG beside the report; with its bytes (inlined in the page)."""
    from tinyrace.experiment.plots import png

    blobs = []
    for picture in pictures:
        data = png(picture.figure)
        write_file(run_dir / picture.name, data)
        blobs.append((picture, data))
    return blobs


def _lap_caption(lap_times: Sequence[float | None]) -> str:
    finished = sum(t is not None for t in lap_times)
    if finished == 0:
        return "Lap time per episode: no lap finished in any episode."
    missing = "" if finished == len(lap_times) else " (the others: no lap finished)"
    return f"Time from the reset to the end of the first lap: {finished} episode(s){missing}."


def length_unit(header: dict[str, Any]) -> str:
    """The track's unit as the run recorded it (``track_unit``; older runs: the unit of
    their first track picture): CarRacing's u, image pixels or metres."""
    recorded = header.get("track_unit")
    if isinstance(recorded, str):
        return recorded
    entries = list((header.get("tracks") or {}).values())
    unit = entries[0].get("unit") if entries else None
    return unit if isinstance(unit, str) and unit else "track units"


def _trace(run_dir: Path, result: EpisodeResult) -> dict[str, np.ndarray] | None:
    path = run_dir / result.trace if result.trace else None
    return read_trace(path) if path is not None and path.is_file() else None


def _series(
    results: Sequence[EpisodeResult], traces: dict[int, dict[str, np.ndarray] | None], unit: str
) -> tuple[list[Any], list[str]]:
    """Each traced episode's time series, and the panels that have data in some episode."""
    from tinyrace.experiment.plots import Series

    names = {
        "speed": f"speed [{unit}/s]",
        "steer": "steering\n[-1 left .. +1 right]",
        "cte": f"cross-track error [{unit}]",
    }
    series = []
    for result in results:
        trace = traces[result.episode]
        if trace is not None:
            values = {title: trace[key] for key, title in names.items()}
            series.append(Series(str(result.episode), trace["t"], values))
    panels = [
        title for title in names.values() if any(np.isfinite(s.values[title]).any() for s in series)
    ]
    return series, panels


def _track_pictures(
    run_dir: Path,
    header: dict[str, Any],
    results: Sequence[EpisodeResult],
    traces: dict[int, dict[str, np.ndarray] | None],
) -> list[Picture]:
    """One picture per track with the trajectories of the episodes run on it."""
    from tinyrace.experiment import plots

    pictures = []
    tracks: dict[str, Any] = header.get("tracks") or {}
    for key, entry in tracks.items():
        background = track_background(run_dir, key, entry["image"])
        if background is None:
            continue
        extent = picture_extent(entry["frame"], background.shape)
        paths = []
        for result in (r for r in results if r.track == key):
            trace = traces[result.episode]
            if trace is not None:
                points = trace_points(trace, extent)
                hits, crashed = trace["obstacle_hit"] > 0, result.end in CRASHES
                paths.append(
                    plots.Path2D(f"ep {result.episode}", points, trace["speed"], hits, crashed)
                )
        lap_line = entry.get("lap_line")
        if lap_line is not None and not np.isfinite(np.asarray(lap_line, np.float64)).all():
            lap_line = None
        unit = entry.get("unit", "")
        size = 10.0 if len(tracks) == 1 else 6.5  # [in] wide: two pictures side by side
        figure = plots.trajectories(background[..., ::-1], extent, paths, lap_line, unit, size)
        episodes = ", ".join(p.label.removeprefix("ep ") for p in paths) or "none"
        caption = f"Track {key}: the path of episode(s) {episodes}, coloured by speed."
        if lap_line is None and any(r.laps for r in results if r.track == key):
            caption += " Laps here are counted by progress round the track's drawn trajectory."
        name = f"report_track_{key}.png"
        pictures.append(Picture(name, caption, figure, len(tracks) == 1, "Where the car went"))
    return pictures


def track_background(run_dir: Path, key: str, name: str) -> np.ndarray | None:
    """A track picture of the run folder (None when missing), read within the pixel cap."""
    path = run_dir / name
    if not path.is_file():
        return None
    where = f"tracks.{key}.image"
    return read_image_bgr(path, DEFAULT_MAX_IMAGE_PIXELS, str(run_dir / RESULTS_FILE), where)


def trace_points(
    trace: dict[str, np.ndarray], extent: tuple[float, float, float, float]
) -> np.ndarray:
    """A trace's (x, y) [track units] as (N, 2) points, kept near the picture's extent."""
    return _near(np.stack([trace["x"], trace["y"]], axis=-1), extent)


def _near(points: np.ndarray, extent: tuple[float, float, float, float]) -> np.ndarray:
    """Points clipped to a band around the picture's extent (hand-edited traces or frames
    may send them to 1e300); NaN stays NaN (not drawn)."""
    left, right, bottom, top = extent
    reach = 100.0 * max(abs(right - left), abs(top - bottom), 1e-9)
    low = (min(left, right) - reach, min(bottom, top) - reach)
    high = (max(left, right) + reach, max(bottom, top) + reach)
    with np.errstate(invalid="ignore", over="ignore"):
        return np.asarray(np.clip(points, low, high), np.float64)


def picture_extent(
    frame: Sequence[float], shape: tuple[int, ...]
) -> tuple[float, float, float, float]:
    """(left, right, bottom, top) [track units] of a picture's outer pixel edges."""
    sx, ox, sy, oy = frame
    height, width = shape[:2]
    return (
        (-0.5 - ox) / sx,
        (width - 0.5 - ox) / sx,
        (height - 0.5 - oy) / sy,
        (-0.5 - oy) / sy,
    )


def table_html(head: Sequence[str], rows: Sequence[Sequence[str]], text: Sequence[int]) -> str:
    """An HTML table; the columns but ``text`` hold numbers (right-aligned)."""
    cells = "".join(f"<th scope=col>{html.escape(h)}</th>" for h in head)
    body = "\n".join(
        "<tr>"
        + "".join(
            f"<td{'' if k in text else ' class=num'}>{html.escape(c)}</td>"
            for k, c in enumerate(row)
        )
        + "</tr>"
        for row in rows
    )
    return f"<table>\n<thead><tr>{cells}</tr></thead>\n<tbody>\n{body}\n</tbody>\n</table>"


def _figure(picture: Picture, data: bytes) -> str:
    source = base64.b64encode(data).decode()
    caption = html.escape(picture.caption)
    return (
        f"<figure class={'wide' if picture.wide else 'small'}>"
        f"<img alt='{caption}' src='data:image/png;base64,{source}'>"
        f"<figcaption>{caption}</figcaption></figure>"
    )


STYLE = """
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 1100px; color: #222;
       padding: 0 1em; }
table { border-collapse: collapse; margin: 0.5em 0 1.5em; }
th, td { padding: 0.3em 0.8em; border-bottom: 1px solid #ddd; text-align: left; }
th { background: #f2f2f2; } td.num { text-align: right; font-variant-numeric: tabular-nums; }
img { max-width: 100%; }
figure { margin: 1.5em 0; } figcaption { color: #444; font-size: 0.95em; }
figure.small { display: inline-block; vertical-align: top; width: 48%; margin-right: 1%; }
.warn { color: #b00; font-weight: bold; } .note { color: #555; font-style: italic; }
"""


def _html(
    header: dict[str, Any],
    results: Sequence[EpisodeResult],
    blobs: list[tuple[Picture, bytes]],
    notes: Sequence[str],
    unit: str,
) -> str:
    title = f"tinyrace run {header.get('started', '')}"
    planned = header.get("episodes_planned", len(results))
    head, rows = table_rows(results, unit)
    stats_head, stats = summary_rows(header.get("summary") or {}, unit)
    figures = figures_html(blobs, {"Over time": notes} if notes else {})
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{html.escape(title)}</title>
<style>{STYLE}</style></head><body>
<h1>{html.escape(title)}</h1>
<p>Experiment: {html.escape(str(header.get("experiment", "")))};
{len(results)} of {planned} episode(s) finished; track kind:
{html.escape(str(header.get("track_kind", "?")))}; lengths in {html.escape(unit)}.</p>
{state_html(header)}
<h2>Episodes</h2>
{table_html(head, rows, text=[len(head) - 1])}
<h2>Summary</h2>
{table_html(stats_head, stats, text=[0])}
<h2>Charts</h2>
{figures}
</body></html>
"""


def state_html(header: dict[str, Any]) -> str:
    """The page's warnings: the run was interrupted, or stopped by an error."""
    state = []
    if header.get("interrupted"):
        state.append(f"<p class=warn>Interrupted by {html.escape(str(header.get('signal')))}.</p>")
    if header.get("error"):
        state.append(f"<p class=warn>Stopped by an error: {html.escape(header['error'])}</p>")
    return "".join(state)


def figures_html(blobs: Sequence[tuple[Picture, bytes]], notes: Mapping[str, Sequence[str]]) -> str:
    """The pictures inline under a heading per section (in first-seen order), each
    section's ``notes`` after its pictures."""
    sections: dict[str, list[str]] = {}
    for picture, data in blobs:
        sections.setdefault(picture.section, []).append(_figure(picture, data))
    for section, texts in notes.items():
        sections.setdefault(section, []).extend(
            f"<p class=note>{html.escape(n)}</p>" for n in texts
        )
    return "\n".join(
        f"<h3>{html.escape(name)}</h3>\n" + "\n".join(parts) for name, parts in sections.items()
    )
