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
from dataclasses import fields as fields_of
from pathlib import Path
from typing import Any

import numpy as np

from tinyrace.config.bounds import MAX_CSV_FIELD, MAX_RUN_FILE_BYTES, id_problem
from tinyrace.config.yaml_file import read_bytes
from tinyrace.errors import ConfigError, Problem
from tinyrace.experiment.files import check_writable
from tinyrace.experiment.race_results import CarResult
from tinyrace.experiment.record import TRACE_COLUMNS
from tinyrace.experiment.results import EPISODES_FILE, RESULTS_FILE, EpisodeResult

KEY = re.compile(r"[A-Za-z0-9_.-]{1,64}")  # a track key, also part of a picture's file name
FILE_NAME = re.compile(r"[A-Za-z0-9_.+-]{1,128}")  # a file the run folder holds (no folders)


def _problem(path: Path, field: str, value: object, allowed: str) -> ConfigError:
    return ConfigError(Problem(str(path), field, value, allowed))


def _text(path: Path) -> str:
    data = read_bytes(path, MAX_RUN_FILE_BYTES, "a run file")
    try:
        return data.decode("utf-8")
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
        if field in header and not isinstance(header[field], kinds):
            raise _problem(path, field, header[field], f"expected {what}")
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
        if not ok:
            raise _problem(path, f"{where}.{key}", stats, "expected {mean: number, std: number}")


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
    if not (isinstance(image, str) and FILE_NAME.fullmatch(image) and image != ".."):
        raise _problem(path, f"{where}.image", image, "expected a file name in the run folder")
    frame = entry.get("frame")
    if not (isinstance(frame, list) and len(frame) == 4 and all(map(_finite, frame))):
        raise _problem(path, f"{where}.frame", frame, "expected [sx, ox, sy, oy] numbers")
    if frame[0] == 0 or frame[2] == 0:
        raise _problem(path, f"{where}.frame", frame, "expected scales sx and sy other than 0")
    lap = entry.get("lap_line")
    if lap is not None and not _points(lap, 2):
        raise _problem(path, f"{where}.lap_line", lap, "expected null or [[x, y], [x, y]]")
    if not isinstance(entry.get("unit", ""), str):
        raise _problem(path, f"{where}.unit", entry.get("unit"), "expected a unit name")


def _finite(value: object) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


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
    ("episodes_planned", int, "a whole number"),
    ("track_kind", str, "a track kind (text)"),
    ("tracks", (dict, type(None)), "an object of {key: track picture}"),
)


def _csv_rows(path: Path) -> list[tuple[int, dict[str, str]]]:
    """(line, row) of a CSV with a header, fields bounded; a malformed file names its line."""
    reader = csv.DictReader(io.StringIO(_text(path), newline=""))
    rows = []
    limit = csv.field_size_limit()
    csv.field_size_limit(MAX_CSV_FIELD)
    try:
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


def read_episodes(run_dir: Path) -> list[EpisodeResult]:
    """episodes.csv, one EpisodeResult per row; a bad cell names its line and column."""
    path = run_dir / EPISODES_FILE
    return [_episode(path, line, row) for line, row in _csv_rows(path)]


def read_cars(run_dir: Path, names: list[str]) -> list[CarResult]:
    """A race's episodes.csv, one CarResult per row (car and episode); a bad cell names its
    line and column, a car that is not one of ``names`` (results.json's cars) too."""
    path = run_dir / EPISODES_FILE
    rows = []
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
        rows.append(CarResult(**values))
    return rows


def _episode(path: Path, line: int, row: dict[str, str]) -> EpisodeResult:
    return EpisodeResult(**_values(EpisodeResult, path, line, row, ("track",)))


def _values(
    cls: type, path: Path, line: int, row: dict[str, str], texts: tuple[str, ...]
) -> dict[str, Any]:
    """The fields of ``cls`` read from a CSV row; ``texts`` may be empty."""
    values: dict[str, Any] = {}
    for f in fields_of(cls):
        text = row.get(f.name, "")
        kind = str(f.type)
        optional = "None" in kind
        if text == "" and (optional or f.name in texts):
            values[f.name] = None if optional else ""
            continue
        try:
            values[f.name] = _cell(kind, text)
        except ValueError:
            what = "a whole number" if kind.startswith("int") else "a finite number"
            what = f"numbers apart by spaces ({what}s)" if kind.startswith("list") else what
            what += " or empty" if optional else ""
            raise _problem(path, f"line {line}, {f.name}", text[:80], f"expected {what}") from None
        if f.name in ("video", "trace") and not FILE_NAME.fullmatch(text):
            allowed = "expected a file name in the run folder (or empty)"
            raise _problem(path, f"line {line}, {f.name}", text[:80], allowed)
    if values["episode"] < 0 or values["episode"] > 10**9:
        raise _problem(path, f"line {line}, episode", values["episode"], "expected 0 to 1e9")
    return values


def _cell(kind: str, text: str) -> Any:
    if kind.startswith("list["):  # items apart by spaces: numbers, or names
        item = kind[len("list[") : -1]
        return [_cell(item, part) for part in text.split()]
    if kind.startswith("int"):
        if len(text) > 20:
            raise ValueError(text)
        return int(text)
    if kind.startswith("float"):
        value = float(text)
        if not math.isfinite(value):
            raise ValueError(text)
        return value
    return text


def read_trace(path: Path, keys: tuple[str, ...] = TRACE_COLUMNS) -> dict[str, np.ndarray]:
    """A trace file as columns of floats (NaN where a value is missing or not a number)."""
    rows = [row for _, row in _csv_rows(path)]
    columns = {}
    for key in keys:
        cells = []
        for row in rows:
            try:
                cells.append(float(row.get(key) or "nan"))
            except ValueError:
                cells.append(math.nan)
        columns[key] = np.array(cells, np.float64)
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
