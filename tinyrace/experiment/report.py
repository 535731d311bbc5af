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
from tinyrace.experiment.files import write_files
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
CTE_LEFT_OUT = (
    "The cross-track error panel is left out: this track has no reference line to measure "
    "it against (an image track needs reward_design.cross_track_error.use_cte and its "
    "trajectory_color; a ros_map track a waypoint or raceline CSV)."
)
MAX_DRAWN = 100  # episodes whose traces one picture draws (evenly spaced over the run)
MAX_TRACK_PICTURES = 12  # tracks drawn (a procedural run has one per seed): the first ones


def crash_ends() -> frozenset[str]:
    """The end reasons drawn as crashes: every registered part's ``End.crash`` (the built-in
    ones: out of bounds, an obstacle, a collision; a part a run registered too)."""
    from tinyrace.episodes.rules import crash_reasons

    return crash_reasons()


@dataclass
class Picture:
    """One chart of the report: its file name, caption and PNG bytes."""

    name: str
    caption: str
    data: bytes
    wide: bool = False
    section: str = "Per episode"


def picture(
    name: str, caption: str, figure: Figure, wide: bool = False, section: str = "Per episode"
) -> Picture:
    """The figure rendered to PNG at once (then let go: a run of many tracks or episodes
    keeps bytes, not figures)."""
    from tinyrace.experiment.plots import png

    data = png(figure)
    figure.clear()
    return Picture(name, caption, data, wide, section)


def drawn(count: int, most: int = MAX_DRAWN) -> list[int]:
    """Which of ``count`` items (indices) a picture draws: all, or ``most`` evenly spaced."""
    if count <= most:
        return list(range(count))
    return sorted({round(k * (count - 1) / (most - 1)) for k in range(most)})


def drawn_note(shown: int, count: int, what: str = "episodes") -> str:
    """A caption's note when a picture draws only some of the run's ``what``."""
    if shown >= count:
        return ""
    return f" Drawn: {shown} of the {count:,} {what}, evenly spaced (the tables list all)."


def rebuild_report(run_dir: Path) -> Path:
    """Rebuild ``report.html`` and its pictures from a run folder's files (checked: a
    ConfigError names the file, the field and what was expected)."""
    header = read_header(run_dir)
    return write_report(run_dir, header, read_episodes(run_dir, list(header.get("tracks") or {})))


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

    Refused (a ConfigError) when one of the files to write is one the report reads. A
    picture draws the traces of at most MAX_DRAWN episodes and the report at most
    MAX_TRACK_PICTURES tracks; the captions say so."""
    from tinyrace.experiment import plots

    tracks = list(header.get("tracks") or {})[:MAX_TRACK_PICTURES]
    outputs = [REPORT_FILE, "report_returns.png", "report_lap_times.png"]
    outputs += ["report_time_series.png"]
    outputs += [f"report_track_{key}.png" for key in tracks]
    check_outputs(run_dir, outputs, report_inputs(header, results))
    unit = length_unit(header)
    pictures = _track_pictures(run_dir, header, results)
    labels = [str(r.episode) for r in results]
    returns = plots.bars([r.episode_return for r in results], labels, "return", "no return")
    caption = "Return (sum of rewards) per episode."
    pictures.append(picture("report_returns.png", caption, returns))
    lap_times = [r.lap_time for r in results]
    laps = plots.bars(lap_times, labels, "lap time [s]", plots.NO_LAP)
    pictures.append(picture("report_lap_times.png", _lap_caption(lap_times), laps))
    notes = []
    chosen = [results[k] for k in drawn(len(results))]
    series, panels = _series(chosen, {r.episode: _trace(run_dir, r) for r in chosen}, unit)
    if series:
        caption = "Speed, steering and cross-track error over each episode."
        if not any(p.startswith("cross-track") for p in panels):
            caption, notes = "Speed and steering over each episode.", [CTE_LEFT_OUT]
        caption += drawn_note(len(chosen), len(results))
        figure = plots.time_series(series, panels)
        pictures.append(picture("report_time_series.png", caption, figure, True, "Over time"))
    page = _html(header, results, pictures, notes, unit)
    return save_report(run_dir, pictures, page)


def save_report(run_dir: Path, pictures: Sequence[Picture], page: str) -> Path:
    """The pictures (PNG) and report.html written together: each whole under a temporary
    name, then all renamed (an interruption leaves the old report and pictures)."""
    files = {run_dir / p.name: p.data for p in pictures}
    path = run_dir / REPORT_FILE
    files[path] = page.encode("utf-8", "backslashreplace")  # report.html last
    write_files(files)
    return path


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
    run_dir: Path, header: dict[str, Any], results: Sequence[EpisodeResult]
) -> list[Picture]:
    """One picture per track (the first MAX_TRACK_PICTURES) with the trajectories of the
    episodes run on it (at most MAX_DRAWN of them)."""
    from tinyrace.experiment import plots

    pictures = []
    crashes = crash_ends()
    tracks: dict[str, Any] = header.get("tracks") or {}
    for key in list(tracks)[:MAX_TRACK_PICTURES]:
        entry = tracks[key]
        background = track_background(run_dir, key, entry["image"])
        if background is None:
            continue
        extent = picture_extent(entry["frame"], background.shape)
        mine = [r for r in results if r.track == key]
        chosen = [mine[k] for k in drawn(len(mine))]
        paths = []
        for result in chosen:
            trace = _trace(run_dir, result)
            if trace is not None:
                points = trace_points(trace, extent)
                hits, crashed = trace["obstacle_hit"] > 0, result.end in crashes
                paths.append(
                    plots.Path2D(f"ep {result.episode}", points, trace["speed"], hits, crashed)
                )
        lap_line = entry.get("lap_line")
        unit = entry.get("unit", "")
        size = 10.0 if len(tracks) == 1 else 6.5  # [in] wide: two pictures side by side
        figure = plots.trajectories(background[..., ::-1], extent, paths, lap_line, unit, size)
        episodes = ", ".join(p.label.removeprefix("ep ") for p in paths) or "none"
        if len(episodes) > 200:  # runs of numbers joined: "0-99"
            episodes = plots._episodes_text([p.label.removeprefix("ep ") for p in paths], 200)
        caption = f"Track {key}: the path of episode(s) {episodes}, coloured by speed."
        caption += drawn_note(len(chosen), len(mine))
        if lap_line is None and any(r.laps for r in mine):
            caption += " Laps here are counted by progress round the track's drawn trajectory."
        if key == list(tracks)[-1] and len(tracks) > MAX_TRACK_PICTURES:
            caption += drawn_note(MAX_TRACK_PICTURES, len(tracks), "tracks").replace(
                "evenly spaced", "the first ones"
            )
        name = f"report_track_{key}.png"
        wide = len(tracks) == 1
        pictures.append(picture(name, caption, figure, wide, "Where the car went"))
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


def _figure(picture: Picture) -> str:
    source = base64.b64encode(picture.data).decode()
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
    pictures: Sequence[Picture],
    notes: Sequence[str],
    unit: str,
) -> str:
    title = f"tinyrace run {header.get('started', '')}"
    planned = header.get("episodes_planned", len(results))
    head, rows = table_rows(results, unit)
    stats_head, stats = summary_rows(header.get("summary") or {}, unit)
    figures = figures_html(pictures, {"Over time": notes} if notes else {})
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{html.escape(title)}</title>
<style>{STYLE}</style></head><body>
<h1>{html.escape(title)}</h1>
<p>Experiment: {html.escape(experiment_name(header))};
{len(results)} of {planned} episode(s) finished; track kind:
{html.escape(str(header.get("track_kind", "?")))}; lengths in {html.escape(unit)}.</p>
{state_html(header)}
{speed_html(results)}
<h2>Episodes</h2>
{table_html(head, rows, text=[len(head) - 1])}
{files_html(results)}
<h2>Summary</h2>
{table_html(stats_head, stats, text=[0])}
<h2>Charts</h2>
{figures}
</body></html>
"""


def experiment_name(header: dict[str, Any]) -> str:
    """The experiment file's name (a shipped one's full path names site-packages: noise)."""
    source = str(header.get("experiment", ""))
    return Path(source).name if source.endswith((".yaml", ".yml")) else source


def speed_html(results: Sequence[EpisodeResult]) -> str:
    """The simulation's speed (video writing left out) apart from the run's wall time."""
    if not results:
        return ""
    steps = sum(r.steps for r in results)
    simulated = sum(r.steps / max(r.steps_per_second, 1e-9) for r in results)
    walls = [r.wall_seconds for r in results if r.wall_seconds is not None]
    text = (
        f"Simulation: {steps / max(simulated, 1e-9):,.0f} steps/s over {steps:,} steps "
        "(the env and the driver; drawing and writing videos left out)."
    )
    if len(walls) == len(results):
        text += (
            f" Wall time of the episodes: {sum(walls):.1f} s "
            f"({steps / max(sum(walls), 1e-9):,.0f} steps/s with videos, traces and pictures)."
        )
    return f"<p>{html.escape(text)}</p>"


def files_html(results: Sequence[EpisodeResult]) -> str:
    """Each episode's video and trace, linked (files beside the report)."""
    rows = [(r.episode, r.video, r.trace) for r in results if r.video or r.trace]
    if not rows:
        return ""
    body = "\n".join(
        f"<tr><td class=num>{episode}</td><td>{_link(video)}</td><td>{_link(trace)}</td></tr>"
        for episode, video, trace in rows
    )
    return (
        "<h3>Files per episode</h3>\n<table>\n<thead><tr><th scope=col>ep</th>"
        "<th scope=col>video</th><th scope=col>trace (CSV, one row per step)</th></tr></thead>"
        f"\n<tbody>\n{body}\n</tbody>\n</table>"
    )


def _link(name: str | None) -> str:
    if not name:
        return "-"
    from urllib.parse import quote

    return f"<a href='{html.escape(quote(name))}'>{html.escape(name)}</a>"


def state_html(header: dict[str, Any]) -> str:
    """The page's warnings: the run was interrupted, or stopped by an error."""
    state = []
    if header.get("interrupted"):
        state.append(f"<p class=warn>Interrupted by {html.escape(str(header.get('signal')))}.</p>")
    if header.get("error"):
        state.append(f"<p class=warn>Stopped by an error: {html.escape(header['error'])}</p>")
    return "".join(state)


def figures_html(pictures: Sequence[Picture], notes: Mapping[str, Sequence[str]]) -> str:
    """The pictures inline under a heading per section (in first-seen order), each
    section's ``notes`` after its pictures."""
    sections: dict[str, list[str]] = {}
    for shown in pictures:
        sections.setdefault(shown.section, []).append(_figure(shown))
    for section, texts in notes.items():
        sections.setdefault(section, []).extend(
            f"<p class=note>{html.escape(n)}</p>" for n in texts
        )
    return "\n".join(
        f"<h3>{html.escape(name)}</h3>\n" + "\n".join(parts) for name, parts in sections.items()
    )
