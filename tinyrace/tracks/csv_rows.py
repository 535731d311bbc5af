"""Delimited numeric text (CSV with ``#`` comments), read with line and column numbers.

Every problem names the file, the line and the column (both counted from 1), so that
a user can open the file at the faulty cell.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tinyrace.config.bounds import MAX_DATA_BYTES, MAX_ROWS
from tinyrace.config.yaml_file import read_bytes
from tinyrace.errors import ConfigError, Problem, capped


@dataclass(frozen=True)
class Table:
    """The numeric rows of a file: values, the line of each row, and the header names."""

    path: str  # the file, for messages
    values: np.ndarray  # (rows, columns) float64
    lines: np.ndarray  # (rows,) int, the file line of each row (from 1)
    header: tuple[str, ...]  # column names from the last comment line, lower case ("" if none)

    def where(self, row: int, column: int | None = None, name: str = "") -> str:
        """The Problem path of a row (and column): 'line 7, column 3 (w_tr_left_m)'."""
        text = f"line {int(self.lines[row])}"
        if column is not None:
            text += f", column {column + 1}"
        return f"{text} ({name})" if name else text

    def problem(self, row: int, column: int | None, value: object, allowed: str) -> Problem:
        name = self.header[column] if column is not None and column < len(self.header) else ""
        return Problem(self.path, self.where(row, column, name), value, allowed)


def read_text(path: Path, source: str, key: str) -> str:
    """The file's text; a missing, unreadable, oversize or non-regular file (a FIFO, a
    device) is a problem of ``key`` in ``source``, found before the file is read whole."""
    try:
        data = read_bytes(path, MAX_DATA_BYTES, "a track data file")
    except ConfigError as error:
        allowed = error.problems[0].allowed
        raise ConfigError(Problem(source, key, str(path), allowed)) from None
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        allowed = f"expected UTF-8 text (byte {exc.start} is not)"
        raise ConfigError(Problem(source, key, str(path), allowed)) from None


def read_table(path: Path, source: str, key: str, columns: tuple[int, ...]) -> Table:
    """Numeric rows of a ``,``, ``;`` or tab separated file; each row must have one of
    ``columns`` counts of cells. Blank lines and ``#`` comments are skipped; the last comment
    before the first row is taken as the header. More than ``MAX_ROWS`` rows are refused."""
    text = read_text(path, source, key)
    fast = _fast_table(text, str(path), columns)
    if fast is not None:
        return fast
    rows: list[list[float]] = []
    lines: list[int] = []
    header: tuple[str, ...] = ()
    problems: list[Problem] = []
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line:
            continue
        if line.startswith("#"):
            if not rows:
                header = split_cells(line.lstrip("#"))
            continue
        if len(rows) >= MAX_ROWS:
            bound = f"expected at most {MAX_ROWS:,} rows of numbers (tinyrace's bound)"
            raise ConfigError(Problem(str(path), f"line {number}", f"row {len(rows) + 1:,}", bound))
        if rows:  # the common case first: as many finite numbers as the first row
            row = _fast_numbers(line, len(rows[0]))
            if row is not None:
                rows.append(row)
                lines.append(number)
                continue
        cells = split_cells(line)
        if not rows and not lines and _is_header(cells):
            header = cells  # a header line without '#'
            continue
        allowed = (len(rows[0]),) if rows else columns  # every row as wide as the first
        row = _numbers(str(path), number, cells, allowed, problems)
        if row is not None:
            rows.append(row)
            lines.append(number)
    if problems:
        raise ConfigError(capped(problems))
    width = len(rows[0]) if rows else columns[0]
    values = np.array(rows, np.float64).reshape(len(rows), width)
    return Table(str(path), values, np.array(lines, int), tuple(h.lower() for h in header))


def _fast_table(text: str, path: str, columns: tuple[int, ...]) -> Table | None:
    """The table of a well-formed file (one separator, rows of one allowed width, finite
    numbers, at most MAX_ROWS), converted by numpy at once; None: read it row by row."""
    data: list[str] = []
    numbers: list[int] = []
    header: tuple[str, ...] = ()
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line:
            continue
        if line[0] == "#":
            if not data:
                header = split_cells(line.lstrip("#"))
            continue
        data.append(line)
        numbers.append(number)
        if len(data) > MAX_ROWS + 1:
            return None
    if data and _is_header(split_cells(data[0])):
        header, data, numbers = split_cells(data[0]), data[1:], numbers[1:]
    if not data or len(data) > MAX_ROWS:
        return None
    first = data[0]
    if any("_" in line for line in data):  # 6_0: Python's float reads 60; the careful way names it
        return None
    separator = ";" if ";" in first else "," if "," in first or "\t" not in first else "\t"
    width = first.count(separator) + 1
    if width not in columns or any(line.count(separator) != width - 1 for line in data):
        return None
    try:
        values = np.array([c for line in data for c in line.split(separator)], np.float64)
    except ValueError:
        return None
    if not np.isfinite(values).all():
        return None
    lower = tuple(h.lower() for h in header)
    return Table(path, values.reshape(len(data), width), np.array(numbers, int), lower)


def _fast_numbers(line: str, width: int) -> list[float] | None:
    """The row's ``width`` finite numbers, or None when the careful reading must say why."""
    separator = ";" if ";" in line else "," if "," in line or "\t" not in line else "\t"
    if "_" in line:  # 6_0: Python's float reads 60; the careful way names it
        return None
    try:
        values = [float(cell) for cell in line.split(separator)]
    except ValueError:
        return None
    total = sum(values)
    return values if len(values) == width and total - total == 0 else None


def split_cells(line: str) -> tuple[str, ...]:
    """The cells of a row separated by ';', ',' or tabs (the first of these it holds)."""
    separator = ";" if ";" in line else "," if "," in line or "\t" not in line else "\t"
    return tuple(cell.strip() for cell in line.split(separator))


def _is_header(cells: tuple[str, ...]) -> bool:
    """A first line whose cells are all names (no numbers) is a header; numbers split by
    spaces (``1.0 2.0``) or with a decimal comma (``1,5``) are a row this reader does not
    take, and are named as such."""
    return all(cell and not _is_number(cell) and not _misread(cell) for cell in cells)


def _misread(cell: str) -> str:
    """Why ``cell`` holds numbers in a form the reader does not take ("" when it does not)."""
    parts = cell.split()
    if len(parts) > 1 and all(_is_number(part) for part in parts):
        return "separated by ',', ';' or tabs, not spaces"
    if "," in cell and _is_number(cell.replace(",", ".")):
        return "with a decimal point, not a comma"
    if "_" in cell and _is_number(cell):
        return "without '_' (Python reads 6_0 as 60)"
    return ""


def cell_number(cell: str) -> float:
    """The number a cell holds; NaN when it holds none, or one written with ``_``, which
    Python's float reads (6_0 as 60) and a track file does not mean."""
    if "_" in cell:
        return math.nan
    try:
        return float(cell)
    except ValueError:
        return math.nan


def _is_number(cell: str) -> bool:
    try:
        float(cell)
    except ValueError:
        return False
    return True


def _numbers(
    path: str,
    number: int,
    cells: tuple[str, ...],
    columns: tuple[int, ...],
    problems: list[Problem],
) -> list[float] | None:
    """The row's floats, or None with its problems recorded (wrong count, not a finite number)."""
    if len(cells) not in columns:
        counts = " or ".join(str(c) for c in columns)
        allowed = f"expected {counts} numbers separated by ',', ';' or tabs"
        misread = next((why for why in map(_misread, cells) if why), "")
        if misread:
            allowed = f"expected {counts} numbers {misread}"
        problems.append(Problem(path, f"line {number}", ",".join(cells), allowed))
        return None
    values = []
    for column, cell in enumerate(cells):
        value = cell_number(cell)
        if not math.isfinite(value):
            where = f"line {number}, column {column + 1}"
            allowed = f"expected a finite number {_misread(cell)}".rstrip()
            problems.append(Problem(path, where, cell, allowed))
            return None
        values.append(value)
    return values
