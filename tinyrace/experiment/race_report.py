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
    crash_ends,
    drawn,
    drawn_note,
    figures_html,
    length_unit,
    picture,
    picture_extent,
    report_inputs,
    save_report,
    state_html,
    table_html,
    trace_points,
    track_background,
)
from tinyrace.experiment.run_folder import check_outputs, read_trace

Trace = dict[str, np.ndarray]


def write_race_report(run_dir: Path, header: dict[str, Any], rows: Sequence[CarResult]) -> Path:
    """Draw the charts, save them as PNG and write report.html; returns its path.

    Refused (a ConfigError) when one of the files to write is one the report reads."""
    episodes = sorted({r.episode for r in rows})
    charted = [episodes[k] for k in drawn(len(episodes), MAX_RACE_EPISODES)]
    outputs = [REPORT_FILE]
    outputs += [f"report_{what}_{e:03d}.png" for e in charted for what in ("paths", "positions")]
    check_outputs(run_dir, outputs, report_inputs(header, rows))
    colors = {car["id"]: car["color"] for car in header.get("cars") or []}
    pictures: list[Picture] = []
    for episode in charted:
        mine = [r for r in rows if r.episode == episode]
        traces = {r.car: _trace(run_dir, r, len(colors) or len(mine)) for r in mine}
        pictures += _episode_pictures(run_dir, header, episode, mine, traces, colors)
    note = drawn_note(len(charted), len(episodes)).strip()
    return save_report(run_dir, pictures, _html(header, rows, pictures, note))


MAX_RACE_EPISODES = 20  # episodes charted (two pictures each), evenly spaced over the run


def _trace(run_dir: Path, result: CarResult, cars: int) -> Trace | None:
    path = run_dir / result.trace if result.trace else None
    if path is None or not path.is_file():
        return None
    places = {"position": (1.0, float(cars), f"a place from 1 to {cars} (the race's cars)")}
    return read_trace(path, RACE_TRACE_COLUMNS[:-1], places)  # cars_hit: names, not drawn


def _episode_pictures(
    run_dir: Path,
    header: dict[str, Any],
    episode: int,
    rows: Sequence[CarResult],
    traces: dict[str, Trace | None],
    colors: dict[str, str],
) -> list[Picture]:
    """The episode's track with every car's path, and its positions over time."""
    from tinyrace.experiment import race_plots

    pictures = []
    crashes = crash_ends()
    section = f"Episode {episode}"
    traced = [(r, t) for r in rows if (t := traces[r.car]) is not None]
    key = rows[0].track
    entry = (header.get("tracks") or {}).get(key)
    background = track_background(run_dir, key, entry["image"]) if entry else None
    if entry is not None and background is not None:
        extent = picture_extent(entry["frame"], background.shape)
        lines = []
        for row, trace in traced:
            points = trace_points(trace, extent)
            color = colors.get(row.car, "#808080")
            crashed = row.end in crashes
            x, y = points[:, 0], points[:, 1]
            lines.append(race_plots.CarLine(row.car, color, x, y, crashed=crashed))
        lap_line = entry.get("lap_line")
        unit = entry.get("unit", "")
        figure = race_plots.car_paths(background[..., ::-1], extent, lines, lap_line, unit)
        caption = f"Episode {episode} on track {key}: every car's path, each in its colour."
        name = f"report_paths_{episode:03d}.png"
        pictures.append(picture(name, caption, figure, True, section))
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
    pictures.append(picture(name, caption, figure, True, section))
    return pictures


def _html(
    header: dict[str, Any], rows: Sequence[CarResult], pictures: Sequence[Picture], note: str
) -> str:
    title = f"tinyrace race {header.get('started', '')}"
    cars = [str(car["id"]) for car in header.get("cars") or []]
    episodes = len({r.episode for r in rows})
    planned = header.get("episodes_planned", episodes)
    unit = length_unit(header)
    head, cells = car_table_rows(rows)
    text = [k for k, title in enumerate(head) if title in ("car", "driver", "end")]
    stats_head, stats = car_summary_rows(header.get("summary") or {})
    figures = figures_html(pictures, {"Charts": [note]} if note else {})
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{html.escape(title)}</title>
<style>{STYLE}</style></head><body>
<h1>{html.escape(title)}</h1>
<p>Experiment: {html.escape(str(header.get("experiment", "")))};
{episodes} of {planned} episode(s) finished; {len(cars)} cars: {html.escape(", ".join(cars))};
track kind: {html.escape(str(header.get("track_kind", "?")))}; lengths in {html.escape(unit)}.</p>
{state_html(header)}
<h2>Cars</h2>
<p>One row per car and episode, in finishing order: position (laps, then the earlier
finish, then progress), return, laps, best lap, contacts with other cars, walls and cones,
how its race ended.</p>
{table_html(head, cells, text=text)}
<h2>Summary per car</h2>
{table_html(stats_head, stats, text=[0])}
<h2>Charts</h2>
{figures}
</body></html>
"""
