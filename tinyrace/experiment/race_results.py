"""What a race run keeps: a row per car and episode (lap times, best lap, final position,
contacts), results.json and episodes.csv of those rows, and the tables printed and shown.

One car's run keeps its own formats (``results.py``); a race's results.json says ``cars``
(each car's name, colour and driver), its ``episodes`` hold each episode's ``order`` and
its cars' rows, its ``summary`` is per car; episodes.csv has one row per car and episode.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from dataclasses import fields as fields_of
from pathlib import Path
from typing import Any

from tinyrace.experiment.record import TRACE_COLUMNS
from tinyrace.experiment.results import fixed_width, mean_std, write_results

LIST_SEPARATOR = " "  # lists (lap times, cars touched) in one CSV cell
RACE_TRACE_COLUMNS = (  # a car's trace in a race
    *TRACE_COLUMNS,
    "position",  # the car's place after this step (1 leading; each car its own, see race_record)
    "cars_hit",  # the cars it touched at this step, apart by spaces
)


@dataclass
class CarResult:
    """What one car did in one episode of a race."""

    episode: int
    seed: int
    car: str  # its name (the race's agent)
    position: int  # final place: laps, then the earlier finish, then progress (1 = winner)
    episode_return: float
    steps: int  # the steps it raced (to its end, or the race's)
    laps: int  # laps finished
    lap_times: list[float] = field(default_factory=list)  # [s] of each finished lap
    best_lap: float | None = None  # [s] the fastest of them; None without a lap
    tiles_visited: int | None = None  # tracks with progress tiles
    tiles_total: int | None = None
    cars_hit: int = 0  # contacts with other cars (each new touch counts once)
    cars_touched: list[str] = field(default_factory=list)  # the cars it touched
    wall_hits: int | None = None  # tracks with walls: steps on which a wall stopped it
    cones_hit: int | None = None  # cone maps: cones it knocked over
    obstacle_hits: int = 0  # steps on which it touched an obstacle colour
    mean_abs_cte: float | None = None  # [track units] where the track has a reference line
    end: str = "max_steps"  # lap_finished, out_of_bounds, collision, step_limit, max_steps
    driver: str = ""  # its driver's spec
    track: str = ""  # the track picture (a key of results.json "tracks")
    video: str | None = None  # the episode's video (every car in it)
    trace: str | None = None  # this car's per-step trace


CAR_COLUMNS = (  # key, title, format
    ("episode", "ep", "{:d}"),
    ("position", "pos", "{:d}"),
    ("car", "car", "{}"),
    ("driver", "driver", "{}"),
    ("episode_return", "return", "{:.1f}"),
    ("steps", "steps", "{:d}"),
    ("laps", "laps", "{:d}"),
    ("best_lap", "best lap [s]", "{:.2f}"),
    ("cars_hit", "car hits", "{:d}"),
    ("wall_hits", "walls", "{:d}"),
    ("cones_hit", "cones", "{:d}"),
    ("end", "end", "{}"),
)
TEXT_COLUMNS = ("car", "driver", "end")
CAR_SUMMARIZED = (  # key, title
    ("position", "position"),
    ("episode_return", "return"),
    ("laps", "laps"),
    ("best_lap", "best lap [s]"),
    ("cars_hit", "car hits"),
    ("wall_hits", "wall hits [steps]"),
    ("cones_hit", "cones hit"),
)


@dataclass
class RaceEpisode:
    """One episode of a race: its steps, the finishing order and each car's row."""

    episode: int
    seed: int
    steps: int
    order: list[str]  # the cars by final position, winner first
    cars: list[CarResult]
    steps_per_second: float = 0.0
    track: str = ""
    video: str | None = None

    @property
    def winner(self) -> str:
        return self.order[0] if self.order else ""


def car_rows(episodes: Sequence[RaceEpisode]) -> list[CarResult]:
    """Every car's row of every episode, in order."""
    return [car for episode in episodes for car in episode.cars]


def _cell(result: CarResult, key: str, fmt: str) -> str:
    value = getattr(result, key)
    return "-" if value is None else fmt.format(value)


def car_table_rows(rows: Sequence[CarResult]) -> tuple[list[str], list[list[str]]]:
    """The cars table's titles and cells ('-': not measured), each episode's cars in their
    finishing order; columns no car measured (walls, cones) are left out."""
    rows = sorted(rows, key=lambda r: (r.episode, r.position))
    columns = [
        c for c in CAR_COLUMNS
        if c[0] not in ("wall_hits", "cones_hit") or any(getattr(r, c[0]) for r in rows)
    ]  # fmt: skip
    return [t for _, t, _ in columns], [[_cell(r, k, f) for k, _, f in columns] for r in rows]


def car_table(rows: Sequence[CarResult]) -> str:
    """A fixed-width table, one row per car and episode."""
    return fixed_width(*car_table_rows(rows))


def car_summary(rows: Sequence[CarResult]) -> dict[str, dict[str, dict[str, float]]]:
    """Per car: mean and (population) standard deviation of each metric over the episodes,
    and ``wins`` (its episodes in first place)."""
    stats: dict[str, dict[str, dict[str, float]]] = {}
    for car in dict.fromkeys(r.car for r in rows):
        mine = [r for r in rows if r.car == car]
        stats[car] = {}
        for key, _ in CAR_SUMMARIZED:
            values = [getattr(r, key) for r in mine if getattr(r, key) is not None]
            if values:
                stats[car][key] = mean_std(values)
        wins = float(sum(r.position == 1 for r in mine))
        stats[car]["wins"] = {"mean": wins, "std": 0.0}
    return stats


def car_summary_rows(
    stats: dict[str, dict[str, dict[str, float]]],
) -> tuple[list[str], list[list[str]]]:
    """The summary table: a row per car with its wins and mean metrics."""
    keys = [k for k, _ in CAR_SUMMARIZED if any(k in s for s in stats.values())]
    titles = ["car", "wins", *(f"mean {t}" for k, t in CAR_SUMMARIZED if k in keys)]
    rows = []
    for car, s in stats.items():
        cells = [car, f"{s.get('wins', {}).get('mean', 0):.0f}"]
        cells += [f"{s[k]['mean']:.2f}" if k in s else "-" for k in keys]
        rows.append(cells)
    return titles, rows


def summary_text(stats: dict[str, dict[str, dict[str, float]]]) -> str:
    return fixed_width(*car_summary_rows(stats), rule=False)


def csv_row(result: CarResult) -> dict[str, Any]:
    """A row of episodes.csv: lists as one cell, their items apart by a space."""
    row = asdict(result)
    for key in ("lap_times", "cars_touched"):
        row[key] = LIST_SEPARATOR.join(str(round(v, 6)) if isinstance(v, float) else str(v)
                                       for v in row[key])  # fmt: skip
    return row


def write_race_files(
    run_dir: Path, episodes: Sequence[RaceEpisode], header: dict[str, Any]
) -> dict[str, Any]:
    """results.json (everything, each episode with its cars) and episodes.csv (a row per car
    and episode); returns the payload."""
    rows = car_rows(episodes)
    payload = {
        **header,
        "episodes": [{**asdict(e), "winner": e.winner} for e in episodes],
        "summary": car_summary(rows),
    }
    names = [f.name for f in fields_of(CarResult)]
    write_results(run_dir, payload, names, (csv_row(r) for r in rows))
    return payload
