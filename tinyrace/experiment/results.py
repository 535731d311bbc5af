"""Per-episode table, summary (mean and std), results.json and episodes.csv; read back."""

from __future__ import annotations

import csv
import io
import json
import math
from collections.abc import Iterable, Sequence
from dataclasses import asdict, dataclass
from dataclasses import fields as fields_of
from pathlib import Path
from typing import Any

from tinyrace.experiment.files import write_text

RESULTS_FILE = "results.json"
EPISODES_FILE = "episodes.csv"


@dataclass
class EpisodeResult:
    """What one episode achieved."""

    episode: int
    seed: int
    episode_return: float
    steps: int
    tiles_visited: int | None  # procedural tracks
    tiles_total: int | None
    laps: int  # laps finished (the env's lap ends the episode where it counts laps)
    obstacle_hits: int  # steps on which the footprint touched an obstacle colour
    mean_abs_cte: float | None  # [track units] where the track has a reference line
    end: str  # lap_finished, out_of_bounds, obstacle, step_limit, max_steps
    steps_per_second: float
    lap_time: float | None = None  # [s] reset to the first lap's end; None without a lap
    track: str = ""  # which track picture the episode ran on (a key of results.json "tracks")
    video: str | None = None  # file name in the run folder
    trace: str | None = None  # the per-step trace file (record.TRACE_COLUMNS)
    wall_hits: int | None = None  # tracks in metres: steps on which a wall stopped the car


COLUMNS = (
    ("episode", "ep", "{:d}"),
    ("episode_return", "return", "{:.1f}"),
    ("steps", "steps", "{:d}"),
    ("tiles", "tiles", "{}"),
    ("laps", "laps", "{:d}"),
    ("lap_time", "lap [s]", "{:.2f}"),
    ("obstacle_hits", "hits", "{:d}"),
    ("wall_hits", "walls", "{:d}"),
    ("mean_abs_cte", "|cte|", "{:.2f}"),
    ("end", "end", "{}"),
)
SUMMARIZED = (  # key, title ({unit}: the track's length unit)
    ("episode_return", "return"),
    ("steps", "steps"),
    ("laps", "laps"),
    ("lap_time", "lap time [s]"),
    ("obstacle_hits", "obstacle hits [steps]"),
    ("wall_hits", "wall hits [steps]"),
    ("mean_abs_cte", "mean |cross-track error| [{unit}]"),
    ("steps_per_second", "speed of the simulation [steps/s]"),
)


ONLY_MEASURED = ("wall_hits",)  # columns shown only when an episode measured them


def _cell(result: EpisodeResult, key: str, fmt: str) -> str:
    if key == "tiles":
        return "-" if result.tiles_total is None else f"{result.tiles_visited}/{result.tiles_total}"
    value = getattr(result, key)
    return "-" if value is None else fmt.format(value)


def table_rows(
    results: Sequence[EpisodeResult], unit: str = ""
) -> tuple[list[str], list[list[str]]]:
    """The episode table's column titles (lengths in ``unit``) and one row of cells per
    episode ('-': not measured); a column only some tracks measure (walls) is left out
    when no episode measured it."""
    columns = [c for c in COLUMNS if c[0] not in ONLY_MEASURED or _measured(results, c[0])]
    titles = [f"{title} [{unit}]" if key == "mean_abs_cte" and unit else title
              for key, title, _ in columns]  # fmt: skip
    return titles, [[_cell(r, key, fmt) for key, _, fmt in columns] for r in results]


def _measured(results: Sequence[EpisodeResult], key: str) -> bool:
    return any(getattr(r, key) is not None for r in results)


def table(results: Sequence[EpisodeResult]) -> str:
    """A fixed-width table, one row per episode."""
    titles, cells = table_rows(results)
    return fixed_width(titles, cells)


def fixed_width(titles: Sequence[str], cells: Sequence[Sequence[str]], rule: bool = True) -> str:
    """Titles and cells as right-aligned columns two spaces apart; ``rule``: a line of dashes
    under the titles. Shared by one car's and a race's printed tables."""
    rows = [titles, *cells]
    widths = [max(len(row[i]) for row in rows) for i in range(len(titles))]
    lines = ["  ".join(cell.rjust(w) for cell, w in zip(row, widths, strict=True)) for row in rows]
    if rule:
        lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def summary(results: Sequence[EpisodeResult]) -> dict[str, dict[str, float]]:
    """Mean and (population) standard deviation of each numeric metric over the episodes."""
    stats = {}
    for key, _ in SUMMARIZED:
        values = [getattr(r, key) for r in results if getattr(r, key) is not None]
        if values:
            stats[key] = mean_std(values)
    return stats


def mean_std(values: Sequence[float]) -> dict[str, float]:
    """``{"mean": ..., "std": ...}`` of ``values`` (not empty; the population std)."""
    mean = sum(values) / len(values)
    std = math.sqrt(sum((v - mean) ** 2 for v in values) / len(values))
    return {"mean": mean, "std": std}


def summary_rows(
    stats: dict[str, dict[str, float]], unit: str = ""
) -> tuple[list[str], list[list[str]]]:
    """The summary table's column titles and one row per metric: title, mean, std."""
    titles = dict(SUMMARIZED)
    rows = [
        [
            titles.get(key, key).format(unit=unit or "track units"),
            f"{s['mean']:.2f}",
            f"{s['std']:.2f}",
        ]
        for key, s in stats.items()
    ]
    return ["metric", "mean", "std"], rows


def summary_text(stats: dict[str, dict[str, float]]) -> str:
    return "\n".join(f"{key:>18}: {s['mean']:.2f} ± {s['std']:.2f}" for key, s in stats.items())


def write_files(
    run_dir: Path, results: Sequence[EpisodeResult], header: dict[str, Any]
) -> dict[str, Any]:
    """results.json (everything) and episodes.csv (one row per episode); returns the payload."""
    rows = [asdict(r) for r in results]
    payload = {**header, "episodes": rows, "summary": summary(results)}
    write_results(run_dir, payload, [f.name for f in fields_of(EpisodeResult)], rows)
    return payload


def write_results(
    run_dir: Path, payload: dict[str, Any], columns: Sequence[str], rows: Iterable[dict[str, Any]]
) -> None:
    """results.json (``payload``) and episodes.csv (``rows`` under ``columns``) into
    ``run_dir``: one car's runs and races alike."""
    write_text(run_dir / RESULTS_FILE, json.dumps(payload, indent=2, default=str) + "\n")
    handle = io.StringIO(newline="")
    writer = csv.DictWriter(handle, fieldnames=columns)
    writer.writeheader()
    writer.writerows(rows)
    write_text(run_dir / EPISODES_FILE, handle.getvalue())
