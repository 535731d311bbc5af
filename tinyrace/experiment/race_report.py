"""``report.html`` of a race's run folder, as ``report.py`` writes one car's: the cars'
table and summary, and per episode every car's path over the track (each in its colour)
and each car's position over time. Built from the run's files only, so ``tinyrace report
RUN_DIR`` rebuilds it."""

from __future__ import annotations

import html
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from tinyrace.experiment.race_results import (
    RACE_TRACE_COLUMNS,
    CarResult,
    car_summary_rows,
    car_table_rows,
)
from tinyrace.experiment.report import (  # the page's parts, shared with one car's report
    REPORT_FILE,
    STYLE,
    Picture,
    _background,
    _extent,
    _figure,
    _near,
    _table,
    _unit,
)
from tinyrace.experiment.results import EPISODES_FILE, RESULTS_FILE
from tinyrace.experiment.run_folder import check_outputs, read_trace

CRASHES = ("out_of_bounds", "obstacle", "collision")
Trace = dict[str, np.ndarray]


def write_race_report(run_dir: Path, header: dict[str, Any], rows: Sequence[CarResult]) -> Path:
    """Draw the charts, save them as PNG and write report.html; returns its path.

    Refused (a ConfigError) when one of the files to write is one the report reads."""
    from tinyrace.experiment.plots import png

    episodes = sorted({r.episode for r in rows})
    outputs = [REPORT_FILE]
    outputs += [f"report_{what}_{e:03d}.png" for e in episodes for what in ("paths", "positions")]
    check_outputs(run_dir, outputs, _inputs(header, rows))
    colors = {car["id"]: car["color"] for car in header.get("cars") or []}
    traces = {(r.episode, r.car): _trace(run_dir, r) for r in rows}
    pictures: list[Picture] = []
    for episode in episodes:
        mine = [r for r in rows if r.episode == episode]
        pictures += _episode_pictures(run_dir, header, episode, mine, traces, colors)
    blobs = []
    for picture in pictures:
        data = png(picture.figure)
        (run_dir / picture.name).write_bytes(data)
        blobs.append((picture, data))
    path = run_dir / REPORT_FILE
    path.write_text(_html(header, rows, blobs), encoding="utf-8")
    return path


def _inputs(header: dict[str, Any], rows: Sequence[CarResult]) -> dict[str, str]:
    """The run files the report reads, each with the file that names it."""
    names = {RESULTS_FILE: RESULTS_FILE, EPISODES_FILE: EPISODES_FILE}
    names |= {name: EPISODES_FILE for r in rows for name in (r.trace, r.video) if name}
    tracks = (header.get("tracks") or {}).values()
    return names | {entry["image"]: RESULTS_FILE for entry in tracks}


def _trace(run_dir: Path, result: CarResult) -> Trace | None:
    path = run_dir / result.trace if result.trace else None
    if path is None or not path.is_file():
        return None
    return read_trace(path, RACE_TRACE_COLUMNS[:-1])  # cars_hit holds names: not drawn


def _episode_pictures(
    run_dir: Path,
    header: dict[str, Any],
    episode: int,
    rows: Sequence[CarResult],
    traces: dict[tuple[int, str], Trace | None],
    colors: dict[str, str],
) -> list[Picture]:
    """The episode's track with every car's path, and its positions over time."""
    from tinyrace.experiment import race_plots

    pictures = []
    section = f"Episode {episode}"
    traced = [(r, t) for r in rows if (t := traces[(episode, r.car)]) is not None]
    key = rows[0].track
    entry = (header.get("tracks") or {}).get(key)
    background = _background(run_dir, key, entry["image"]) if entry else None
    if entry is not None and background is not None:
        extent = _extent(entry["frame"], background.shape)
        lines = []
        for row, trace in traced:
            points = _near(np.stack([trace["x"], trace["y"]], axis=-1), extent)
            color = colors.get(row.car, "#808080")
            crashed = row.end in CRASHES
            x, y = points[:, 0], points[:, 1]
            lines.append(race_plots.CarLine(row.car, color, x, y, crashed=crashed))
        lap_line = entry.get("lap_line")
        unit = entry.get("unit", "")
        figure = race_plots.car_paths(background[..., ::-1], extent, lines, lap_line, unit)
        caption = f"Episode {episode} on track {key}: every car's path, each in its colour."
        pictures.append(Picture(f"report_paths_{episode:03d}.png", caption, figure, True, section))
    lines = [
        race_plots.CarLine(r.car, colors.get(r.car, "#808080"), t["t"], t["position"])
        for r, t in traced
    ]
    figure = race_plots.positions(lines, len(colors) or len(rows))
    caption = (
        f"Episode {episode}: each car's position over time (by laps, then progress round the "
        "track); a line ends where its car left the race."
    )
    name = f"report_positions_{episode:03d}.png"
    pictures.append(Picture(name, caption, figure, True, section))
    return pictures


def _html(
    header: dict[str, Any], rows: Sequence[CarResult], blobs: list[tuple[Picture, bytes]]
) -> str:
    title = f"tinyrace race {header.get('started', '')}"
    state = []
    if header.get("interrupted"):
        state.append(f"<p class=warn>Interrupted by {html.escape(str(header.get('signal')))}.</p>")
    if header.get("error"):
        state.append(f"<p class=warn>Stopped by an error: {html.escape(header['error'])}</p>")
    cars = [str(car["id"]) for car in header.get("cars") or []]
    episodes = len({r.episode for r in rows})
    planned = header.get("episodes_planned", episodes)
    unit = _unit(header)
    head, cells = car_table_rows(rows)
    text = [k for k, title in enumerate(head) if title in ("car", "driver", "end")]
    stats_head, stats = car_summary_rows(header.get("summary") or {})
    sections: dict[str, list[str]] = {}
    for picture, data in blobs:
        sections.setdefault(picture.section, []).append(_figure(picture, data))
    figures = "\n".join(
        f"<h3>{html.escape(name)}</h3>\n" + "\n".join(parts) for name, parts in sections.items()
    )
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{html.escape(title)}</title>
<style>{STYLE}</style></head><body>
<h1>{html.escape(title)}</h1>
<p>Experiment: {html.escape(str(header.get("experiment", "")))};
{episodes} of {planned} episode(s) finished; {len(cars)} cars: {html.escape(", ".join(cars))};
track kind: {html.escape(str(header.get("track_kind", "?")))}; lengths in {html.escape(unit)}.</p>
{"".join(state)}
<h2>Cars</h2>
<p>One row per car and episode, in finishing order: position (laps, then the earlier
finish, then progress), return, laps, best lap, contacts with other cars, walls and cones,
how its race ended.</p>
{_table(head, cells, text=text)}
<h2>Summary per car</h2>
{_table(stats_head, stats, text=[0])}
<h2>Charts</h2>
{figures}
</body></html>
"""
