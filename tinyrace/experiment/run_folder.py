"""Reading a run folder back for ``tinyrace report``: every file checked, as it may be edited.

results.json, episodes.csv and the traces are read within byte bounds (``MAX_RUN_FILE_BYTES``
each, fields of at most ``MAX_CSV_FIELD`` characters); every value the report uses is checked
for its type, and a problem is a ConfigError naming the file, the field (and line) and what
was expected. The files the report writes never replace one it read.
"""

from __future__ import annotations

import csv
import io
import json
import math
import re
from collections.abc import Collection
from dataclasses import fields as fields_of
from pathlib import Path
from typing import Any

import numpy as np

from tinyrace.config.bounds import MAX_CSV_FIELD, MAX_EPISODES, MAX_RUN_FILE_BYTES, id_problem
from tinyrace.config.yaml_file import read_bytes
from tinyrace.errors import ConfigError, Problem
from tinyrace.experiment.files import check_writable
from tinyrace.experiment.race_results import CarResult
from tinyrace.experiment.record import TRACE_COLUMNS
from tinyrace.experiment.results import EPISODES_FILE, RESULTS_FILE, EpisodeResult

KEY = re.compile(r"[A-Za-z0-9_.-]{1,64}")  # a track key, also part of a picture's file name
FILE_NAME = re.compile(r"[A-Za-z0-9_.+-]{1,128}")  # a file the run folder holds (no folders)
INTEGER = re.compile(r"-?[0-9]{1,20}")  # a whole number as a CSV writes it: ASCII digits
NUMBER = re.compile(r"-?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][-+]?[0-9]+)?")  # likewise
MAX_NUMBER = 1e12  # |a number| the report reads (a return, a time, a mean); beyond: edited
FRAME_SCALE = (1e-6, 1e6)  # [px per track unit] |sx|, |sy| of a track picture's frame
MAX_FRAME_OFFSET = 1e7  # [px] |ox|, |oy|: where a track's origin is on its picture
MAX_UNIT = 32  # [characters] a unit's name (track_unit): it titles the charts' axes
NON_NEGATIVE = (  # the fields of episodes.csv that count or measure: 0 or more
    "steps", "tiles_visited", "tiles_total", "laps", "obstacle_hits", "mean_abs_cte",
    "lap_time", "wall_hits", "wall_seconds", "lap_times", "best_lap", "cars_hit",
    "cones_hit",
)  # fmt: skip
POSITIVE = ("steps_per_second",)  # more than 0
TRACE_NAME = "a trace file name (episode_NNN_trace.csv: a name ending in _trace.csv)"
VIDEO_NAME = "a video file name (episode_NNN.mp4 or .webm)"


def plain_name(text: object) -> bool:
    """A plain file name of the run folder: no folder, not '.' or '..'."""
    return (
        isinstance(text, str) and FILE_NAME.fullmatch(text) is not None and text not in {".", ".."}
    )


def _problem(path: Path, field: str, value: object, allowed: str) -> ConfigError:
    return ConfigError(Problem(str(path), field, value, allowed))


def _text(path: Path, encoding: str = "utf-8") -> str:
    """The file as text; ``utf-8-sig`` (the CSVs): a byte-order mark at the start is
    skipped (Excel's "CSV UTF-8" writes one)."""
    data = read_bytes(path, MAX_RUN_FILE_BYTES, "a run file")
    try:
        return data.decode(encoding)
    except UnicodeDecodeError as exc:
        raise _problem(path, "", path.name, f"expected UTF-8 text (byte {exc.start})") from None


def read_header(run_dir: Path) -> dict[str, Any]:
    """results.json, with every field the report uses checked."""
    path = run_dir / RESULTS_FILE
    text = _text(path)
    try:
        header = json.loads(text)
    except (ValueError, RecursionError) as exc:
        reason = str(exc)[:120]
        raise _problem(path, "", RESULTS_FILE, f"expected JSON ({reason})") from None
    if not isinstance(header, dict):
        raise _problem(path, "", type(header).__name__, "expected a JSON object of run fields")
    for field, kinds, what in _HEADER_FIELDS:
        value = header.get(field)
        if field in header and (
            not isinstance(value, kinds) or (isinstance(value, bool) and kinds is not bool)
        ):
            raise _problem(path, field, value, f"expected {what}")
    planned = header.get("episodes_planned", 1)
    if not 1 <= planned <= MAX_EPISODES:
        raise _problem(path, "episodes_planned", planned, f"expected 1 to {MAX_EPISODES:,}")
    unit = header.get("track_unit", "")
    if len(unit) > MAX_UNIT:
        allowed = f"expected a unit's name of at most {MAX_UNIT} characters (u, px or m)"
        raise _problem(path, "track_unit", unit, allowed)
    if "cars" in header:  # a race: its cars, and a summary per car
        names = _check_cars(path, header["cars"])
        summary = header.get("summary") or {}
        if not isinstance(summary, dict) or not set(summary) <= set(names):
            allowed = f"expected an object of {{car: {{metric: {{mean, std}}}}}} for {names}"
            raise _problem(path, "summary", summary, allowed)
        for car, stats in summary.items():
            _check_summary(path, stats, f"summary.{car}")
    else:
        _check_summary(path, header.get("summary"))
    tracks = header.get("tracks") or {}
    most = header.get("episodes_planned", MAX_EPISODES)
    if len(tracks) > most:  # a run saves a track's picture once, for an episode on it
        allowed = f"expected at most one track per planned episode (episodes_planned: {most:,})"
        raise _problem(path, "tracks", _Said(f"{len(tracks):,} entries"), allowed)
    for key, entry in tracks.items():
        _check_track(path, key, entry)
    return header


def _check_summary(path: Path, summary: object, where: str = "summary") -> None:
    if summary is None:
        return
    if not isinstance(summary, dict):
        raise _problem(path, where, summary, "expected an object of {metric: {mean, std}}")
    for key, stats in summary.items():
        ok = isinstance(stats, dict) and all(_finite(stats.get(k)) for k in ("mean", "std"))
        if not ok and where == "summary" and _per_car(stats):
            allowed = (
                "expected a list of the race's cars: a race's results.json lists its cars "
                f"(its summary is per car: summary.{key})"
            )
            raise _problem(path, "cars", NOT_THERE, allowed)
        if not ok:
            allowed = f"expected {{mean: number, std: number}} (numbers within ±{MAX_NUMBER:g})"
            raise _problem(path, f"{where}.{key}", stats, allowed)


class _Said:
    """A value described in words, as a message shows it (a key that is not there)."""

    def __init__(self, text: str):
        self.text = text

    def __repr__(self) -> str:
        return self.text


NOT_THERE = _Said("no such key")


def _per_car(stats: object) -> bool:
    """A race's summary entry of one car: {metric: {mean, std}}."""
    return (
        isinstance(stats, dict)
        and bool(stats)
        and all(isinstance(v, dict) and "mean" in v for v in stats.values())
    )


COLOR = re.compile(r"#[0-9a-fA-F]{6}")
MAX_CARS = 16


def _check_cars(path: Path, cars: object) -> list[str]:
    """A race's ``cars``: each with its name (``id``) and colour; returns the names."""
    expected = "expected a list of 1 to 16 cars, each {id: name, color: '#rrggbb', driver}"
    if not isinstance(cars, list) or not 0 < len(cars) <= MAX_CARS:
        raise _problem(path, "cars", cars, expected)
    names: list[str] = []
    for index, car in enumerate(cars):
        where = f"cars[{index}]"
        if not isinstance(car, dict):
            raise _problem(path, where, car, expected)
        name = car.get("id")
        wrong = id_problem(name)
        if wrong is not None or name in names:
            allowed = f"{wrong or 'expected each car once'} (a car id of race.cars)"
            raise _problem(path, f"{where}.id", name, allowed)
        color = car.get("color")
        if not (isinstance(color, str) and COLOR.fullmatch(color)):
            raise _problem(path, f"{where}.color", color, "expected a colour '#rrggbb'")
        if not isinstance(car.get("driver", ""), str):
            raise _problem(path, f"{where}.driver", car.get("driver"), "expected a driver name")
        names.append(str(name))
    return names


def _check_track(path: Path, key: str, entry: object) -> None:
    where = f"tracks.{key}"
    if not KEY.fullmatch(key):
        allowed = "expected a track key of letters, digits, '_', '.' or '-' (it names a file)"
        raise _problem(path, "tracks", key, allowed)
    if not isinstance(entry, dict):
        raise _problem(path, where, entry, "expected an object with image and frame")
    image = entry.get("image")
    if not plain_name(image):
        allowed = "expected a file name in the run folder (no folder, not '.' or '..')"
        raise _problem(path, f"{where}.image", image, allowed)
    frame = entry.get("frame")
    low, high = FRAME_SCALE
    if not (
        isinstance(frame, list)
        and len(frame) == 4
        and all(map(_finite, frame))
        and all(low <= abs(frame[k]) <= high for k in (0, 2))
        and all(abs(frame[k]) <= MAX_FRAME_OFFSET for k in (1, 3))
    ):
        allowed = (
            f"expected [sx, ox, sy, oy]: scales sx, sy of {low:g} to {high:g} px per track unit "
            f"(either sign), offsets ox, oy within ±{MAX_FRAME_OFFSET:g} px"
        )
        raise _problem(path, f"{where}.frame", frame, allowed)
    lap = entry.get("lap_line")
    if lap is not None and not _points(lap, 2):
        allowed = f"expected null or [[x, y], [x, y]] (numbers within ±{MAX_NUMBER:g})"
        raise _problem(path, f"{where}.lap_line", lap, allowed)
    unit = entry.get("unit", "")
    if not (isinstance(unit, str) and len(unit) <= MAX_UNIT):
        allowed = f"expected a unit's name of at most {MAX_UNIT} characters (u, px or m)"
        raise _problem(path, f"{where}.unit", unit, allowed)


def _finite(value: object) -> bool:
    """A JSON number within ±MAX_NUMBER (compared exactly: a huge integer is no float)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return False
    return -MAX_NUMBER <= value <= MAX_NUMBER  # False for NaN


def _points(value: object, count: int) -> bool:
    return (
        isinstance(value, list)
        and len(value) == count
        and all(isinstance(p, list) and len(p) == 2 and all(map(_finite, p)) for p in value)
    )


_HEADER_FIELDS: tuple[tuple[str, type | tuple[type, ...], str], ...] = (
    ("experiment", str, "the experiment file's name (text)"),
    ("started", str, "the run's start (text)"),
    ("interrupted", bool, "true or false"),
    ("signal", (str, type(None)), "a signal name or null"),
    ("error", (str, type(None)), "an error's text or null"),
    ("episodes_planned", int, f"a whole number from 1 to {MAX_EPISODES:,}"),
    ("track_kind", str, "a track kind (text)"),
    ("track_unit", str, "a unit's name (u, px or m)"),
    ("tracks", (dict, type(None)), "an object of {key: track picture}"),
)


def _csv_rows(path: Path) -> list[tuple[int, dict[str, str]]]:
    """(line, row) of a CSV with a header, fields bounded; a malformed file names its line.
    A byte-order mark at the start is skipped; a file without a header line is refused."""
    reader = csv.DictReader(io.StringIO(_text(path, "utf-8-sig"), newline=""))
    rows = []
    limit = csv.field_size_limit()
    csv.field_size_limit(MAX_CSV_FIELD)
    try:
        if not reader.fieldnames:
            raise _problem(path, "line 1", "", "expected a header line naming the columns")
        for row in reader:
            if None in row or None in row.values():
                allowed = f"expected one value per column of the header ({reader.fieldnames})"
                raise _problem(path, f"line {reader.line_num}", "", allowed)
            rows.append((reader.line_num, row))
    except csv.Error as exc:
        allowed = f"expected CSV with fields of at most {MAX_CSV_FIELD:,} characters ({exc})"
        raise _problem(path, f"line {reader.line_num + 1}", "", allowed) from None
    finally:
        csv.field_size_limit(limit)
    return rows


def read_episodes(run_dir: Path, tracks: Collection[str] | None = None) -> list[EpisodeResult]:
    """episodes.csv, one EpisodeResult per row; a bad cell names its line and column, as
    does an episode listed twice or (``tracks``: results.json's) run on a track not listed."""
    path = run_dir / EPISODES_FILE
    rows = _csv_rows(path)
    if rows and {"car", "position"} <= set(rows[0][1]):  # a race's rows
        allowed = "expected a list of the race's cars: a race's results.json lists its cars"
        raise _problem(run_dir / RESULTS_FILE, "cars", NOT_THERE, allowed)
    results: list[EpisodeResult] = []
    seen: dict[int, int] = {}  # episode -> its line
    for line, row in rows:
        result = EpisodeResult(**_values(EpisodeResult, path, line, row, ("track",)))
        if result.episode in seen:
            allowed = f"expected each episode once (line {seen[result.episode]} has it)"
            raise _problem(path, f"line {line}, episode", result.episode, allowed)
        seen[result.episode] = line
        _check_track_key(path, line, result.track, tracks)
        results.append(result)
    return results


def _check_track_key(path: Path, line: int, key: str, tracks: Collection[str] | None) -> None:
    if key and tracks is not None and key not in tracks:
        listed = ", ".join(list(tracks)[:8]) + (", ..." if len(tracks) > 8 else "")
        allowed = f"expected a track of {RESULTS_FILE}'s tracks ({listed or 'none'}) or empty"
        raise _problem(path, f"line {line}, track", key[:80], allowed)


def read_cars(
    run_dir: Path, names: list[str], tracks: Collection[str] | None = None
) -> list[CarResult]:
    """A race's episodes.csv, one CarResult per row (car and episode); a bad cell names its
    line and column, a car that is not one of ``names`` (results.json's cars) too. Each
    episode has a row for each car, their positions 1 to N once each."""
    path = run_dir / EPISODES_FILE
    rows = []
    episodes: dict[int, dict[str, int]] = {}  # episode -> car -> its line
    places: dict[int, dict[int, int]] = {}  # episode -> position -> its line
    for line, row in _csv_rows(path):
        values = _values(CarResult, path, line, row, ("track", "car", "driver", "end"))
        if values["car"] not in names:
            allowed = f"expected one of the cars of {RESULTS_FILE}: {', '.join(names)}"
            raise _problem(path, f"line {line}, car", values["car"][:80], allowed)
        if not 1 <= values["position"] <= len(names):
            allowed = f"expected a place from 1 to {len(names)}"
            raise _problem(path, f"line {line}, position", values["position"], allowed)
        for touched in values["cars_touched"]:
            if touched not in names:
                allowed = f"expected cars of {RESULTS_FILE}: {', '.join(names)}"
                raise _problem(path, f"line {line}, cars_touched", touched[:80], allowed)
        episode, car, position = values["episode"], values["car"], values["position"]
        cars = episodes.setdefault(episode, {})
        if car in cars:
            allowed = f"expected each car once in episode {episode} (line {cars[car]} has it)"
            raise _problem(path, f"line {line}, car", car, allowed)
        cars[car] = line
        taken = places.setdefault(episode, {})
        if position in taken:
            allowed = (
                f"expected the places 1 to {len(names)} once each in episode {episode} "
                f"(line {taken[position]} has {position})"
            )
            raise _problem(path, f"line {line}, position", position, allowed)
        taken[position] = line
        _check_track_key(path, line, values["track"], tracks)
        rows.append(CarResult(**values))
    for episode, cars in episodes.items():
        missing = [name for name in names if name not in cars]
        if missing:
            allowed = (
                f"expected a row for each car of {RESULTS_FILE} ({', '.join(names)}) in each "
                f"episode: episode {episode} has none for {', '.join(missing)}"
            )
            raise _problem(path, f"line {min(cars.values())}, episode", episode, allowed)
    return rows


def _values(
    cls: type, path: Path, line: int, row: dict[str, str], texts: tuple[str, ...]
) -> dict[str, Any]:
    """The fields of ``cls`` read from a CSV row; ``texts`` may be empty. Numbers as a CSV
    writes them (ASCII), within ±MAX_NUMBER; counts and times 0 or more."""
    values: dict[str, Any] = {}
    for f in fields_of(cls):
        text = row.get(f.name, "")
        kind = str(f.type)
        optional = "None" in kind
        where = f"line {line}, {f.name}"
        if text == "" and (optional or f.name in texts):
            values[f.name] = None if optional else ""
            continue
        low = 0.0 if f.name in NON_NEGATIVE + POSITIVE else -MAX_NUMBER
        what = "a whole number" if "int" in kind else "a number"
        what += {0.0: " from 0", -MAX_NUMBER: f" from {-MAX_NUMBER:g}"}[low]
        what = what.replace("from 0", "above 0") if f.name in POSITIVE else what
        what += f" to {MAX_NUMBER:g} (ASCII digits)"
        try:
            value = values[f.name] = _cell(kind, text)
        except ValueError:
            what = f"numbers apart by spaces (each {what})" if kind.startswith("list") else what
            what += " or empty" if optional else ""
            raise _problem(path, where, text[:80], f"expected {what}") from None
        numbers = value if isinstance(value, list) else [value]
        for number in numbers:
            if isinstance(number, (int, float)) and not (
                low <= number <= MAX_NUMBER and (number > 0 or f.name not in POSITIVE)
            ):
                raise _problem(path, where, number, f"expected {what}")
        if f.name == "video" and not (plain_name(text) and text.endswith((".mp4", ".webm"))):
            raise _problem(path, where, text[:80], f"expected {VIDEO_NAME} or empty")
        if f.name == "trace" and not (plain_name(text) and text.endswith("_trace.csv")):
            raise _problem(path, where, text[:80], f"expected {TRACE_NAME} or empty")
    if values["episode"] < 0 or values["episode"] > 10**9:
        raise _problem(path, f"line {line}, episode", values["episode"], "expected 0 to 1e9")
    visited, total = values.get("tiles_visited"), values.get("tiles_total")
    if visited is not None and total is not None and visited > total:
        allowed = f"expected at most tiles_total ({total}): a track has no more tiles to visit"
        raise _problem(path, f"line {line}, tiles_visited", visited, allowed)
    return values


def _cell(kind: str, text: str) -> Any:
    if kind.startswith("list["):  # items apart by spaces: numbers, or names
        item = kind[len("list[") : -1]
        return [_cell(item, part) for part in text.split()]
    if kind.startswith("int"):
        if not INTEGER.fullmatch(text):
            raise ValueError(text)
        return int(text)
    if kind.startswith("float"):
        if not NUMBER.fullmatch(text):
            raise ValueError(text)
        return float(text)
    return text


def read_trace(
    path: Path,
    keys: tuple[str, ...] = TRACE_COLUMNS,
    ranges: dict[str, tuple[float, float, str]] | None = None,
) -> dict[str, np.ndarray]:
    """A trace file as columns of floats (NaN where a value is missing or not a number);
    a number of a column of ``ranges`` ({key: (low, high, what)}) outside is refused."""
    rows = _csv_rows(path)
    columns = {}
    for key in keys:
        cells = []
        for _, row in rows:
            try:
                cells.append(float(row.get(key) or "nan"))
            except ValueError:
                cells.append(math.nan)
        columns[key] = np.array(cells, np.float64)
    for key, (low, high, what) in (ranges or {}).items():
        column = columns[key]
        with np.errstate(invalid="ignore"):
            outside = np.flatnonzero(np.isfinite(column) & ((column < low) | (column > high)))
        if len(outside):
            line, row = rows[int(outside[0])]
            raise _problem(path, f"line {line}, {key}", row[key][:80], f"expected {what}")
    return columns


def check_outputs(run_dir: Path, outputs: list[str], inputs: dict[str, str]) -> None:
    """The report's files: never one it reads (``inputs``: name -> the file naming it), never
    a folder."""
    read = {(run_dir / name).resolve(): named_in for name, named_in in inputs.items()}
    for name in outputs:
        target = run_dir / name
        if target.resolve() in read:
            allowed = f"expected a run file apart from the report's own ({name} is written by it)"
            raise _problem(run_dir / read[target.resolve()], "", name, allowed)
        check_writable(target)  # not a link, folder or special file
