"""The racetrack-database centreline CSV: ``# x_m,y_m,w_tr_right_m,w_tr_left_m``.

One closed loop in driving order, in metres. The last point is not a copy of the first
in the database; a file written as a loop (F1TENTH's racelines: the last row repeats the
first) is read with that last row dropped. The same reader takes simpler waypoint
files: ``x, y`` only (with a default width), or a raceline ``s; x; y; psi; kappa; vx;
ax`` whose positions are columns 2 and 3. Headings are computed from the points, never read.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from tinyrace.config.bounds import MAX_COORDINATE, MIN_ROAD_WIDTH
from tinyrace.errors import ConfigError, Problem, capped
from tinyrace.tracks import polyline
from tinyrace.tracks.csv_rows import Table, read_table

MIN_POINTS = 4
# Column positions by row width when the header names none: x, y, right width, left width.
_BY_WIDTH = {2: (0, 1, None, None), 4: (0, 1, 2, 3), 6: (1, 2, None, None), 7: (1, 2, None, None)}
_NAMES = {
    "x": ("x_m", "x"),
    "y": ("y_m", "y"),
    "right": ("w_tr_right_m", "w_right", "w_right_m"),
    "left": ("w_tr_left_m", "w_left", "w_left_m"),
}
# A header name that reads as a width: w_r, w_tr_right, width, half_width_left.
_WIDTH_LIKE = re.compile(r"^w(_|$)|width")


@dataclass(frozen=True)
class Loop:
    """Points of a closed loop as read, before resampling."""

    points: np.ndarray  # (N, 2) [m]
    widths: np.ndarray | None  # (N, 2) [m] (right, left), None when the file has none
    table: Table  # the rows, for messages naming lines


def read_loop(path: Path, source: str, key: str, scale: float = 1.0) -> Loop:
    """Read a closed loop of points (and widths when present) from ``path``, times ``scale``.

    A last row that repeats the first (a loop written closed) is dropped. Raises
    ConfigError naming the file, line and column for: a missing file, rows that are not
    finite numbers, fewer than 4 points, negative widths, a point that repeats the one
    before, and a loop that crosses itself.
    """
    table = read_table(path, source, key, tuple(_BY_WIDTH))
    x, y, right, left = _columns(table)
    table = _drop_closing_row(table, (x, y))
    problems = _check_count(table)
    if problems:
        raise ConfigError(problems)
    points = table.values[:, [x, y]] * scale
    widths = None
    if right is not None and left is not None:
        widths = table.values[:, [right, left]] * scale
    problems = _check_size(table, points, widths, scale)
    problems = problems or _check_widths(table, widths, (right, left))
    problems = problems or _check_repeats(table, points) or _check_crossing(table, points)
    if problems:
        raise ConfigError(problems)
    return Loop(points, widths, table)


def _columns(table: Table) -> tuple[int, int, int | None, int | None]:
    """Which columns hold x, y and the widths: by header name (a header as wide as the rows),
    else by row width. A header that names x and y but only one width, or names a column
    that reads as a width under a name not known here (``w_r``), is refused: the widths
    would silently fall back to the default."""
    if len(table.header) != table.values.shape[1]:
        return _BY_WIDTH[table.values.shape[1]]
    found = {
        role: next((table.header.index(n) for n in names if n in table.header), None)
        for role, names in _NAMES.items()
    }
    if found["x"] is None or found["y"] is None:
        return _BY_WIDTH[table.values.shape[1]]
    known = {index for index in found.values() if index is not None}
    unknown = [
        name
        for index, name in enumerate(table.header)
        if index not in known and _WIDTH_LIKE.search(name)
    ]
    if (found["right"] is None) != (found["left"] is None) or (found["right"] is None and unknown):
        names = " and ".join(" / ".join(_NAMES[side]) for side in ("right", "left"))
        what = (
            f"{' and '.join(repr(n) for n in unknown)} "
            + ("is not a width name" if len(unknown) == 1 else "are not width names")
            + " tinyrace reads"
            if unknown
            else "one width named alone is not read"
        )
        allowed = (
            f"expected both widths named, {names}, or neither (then the track's default "
            f"width is used); {what}"
        )
        raise ConfigError(Problem(table.path, "header", ", ".join(table.header), allowed))
    return found["x"], found["y"], found["right"], found["left"]


def _drop_closing_row(table: Table, xy: tuple[int, int]) -> Table:
    """The table without its last row when that row's point repeats the first row's (a
    closed loop written with its first point again at the end)."""
    values = table.values
    if len(values) < 2 or not np.array_equal(values[-1, list(xy)], values[0, list(xy)]):
        return table
    return replace(table, values=values[:-1], lines=table.lines[:-1])


def _check_count(table: Table) -> list[Problem]:
    if len(table.values) >= MIN_POINTS:
        return []
    where = table.where(len(table.values) - 1) if len(table.values) else ""
    allowed = (
        f"expected a closed loop of at least {MIN_POINTS} points (rows of numbers separated "
        "by ',', ';' or tabs)"
    )
    return [Problem(table.path, where, f"{len(table.values)} points", allowed)]


def _check_size(
    table: Table, points: np.ndarray, widths: np.ndarray | None, scale: float
) -> list[Problem]:
    """Coordinates and widths (times ``scale``) within +-MAX_COORDINATE metres."""
    values = points if widths is None else np.hstack((points, widths))
    rows = np.flatnonzero(~(np.abs(values) <= MAX_COORDINATE).all(axis=1))
    allowed = (
        f"expected coordinates and widths within +-{MAX_COORDINATE:g} m after scale "
        f"(scale {scale:g})"
    )
    listed = [table.problem(int(r), None, values[r].tolist(), allowed) for r in rows[:5]]
    return capped(listed, 5, len(rows))


def _check_widths(
    table: Table, widths: np.ndarray | None, columns: tuple[int | None, int | None]
) -> list[Problem]:
    if widths is None:
        return []
    rows, sides = np.nonzero(widths < 0)
    problems = [
        table.problem(r, columns[s], float(widths[r, s]), "expected a width >= 0 [m]")
        for r, s in zip(rows[:20], sides[:20], strict=True)
    ]
    problems = capped(problems, 20, len(rows))
    if problems:
        return problems
    narrow = np.flatnonzero(widths.sum(axis=1) < MIN_ROAD_WIDTH)
    allowed = (
        f"expected a road at least {MIN_ROAD_WIDTH:g} m wide (right + left width; narrower "
        "than any car, the car would start off it)"
    )
    listed = [table.problem(r, columns[0], float(widths[r].sum()), allowed) for r in narrow[:20]]
    return capped(listed, 20, len(narrow))


def _check_repeats(table: Table, points: np.ndarray) -> list[Problem]:
    """A problem on each row that repeats the row before it; the loop's closing segment
    (last row to first) is blamed on the last row, the later line of the file."""
    repeats = np.flatnonzero(polyline.segment_lengths(points) == 0)
    last = len(points) - 1
    problems = []
    for i in repeats[:20]:
        if i < last:
            allowed = f"expected a point apart from the one before (line {table.lines[i]})"
            problems.append(table.problem(int(i) + 1, None, points[i].tolist(), allowed))
        else:
            allowed = (
                f"expected the loop's last point apart from its first (line {table.lines[0]}); "
                "one copy of the first point at the end is dropped, a second is refused"
            )
            problems.append(table.problem(int(i), None, points[i].tolist(), allowed))
    return capped(problems, 20, len(repeats))


def _check_crossing(table: Table, points: np.ndarray) -> list[Problem]:
    try:
        pair = polyline.self_intersection(points)
    except polyline.TooDense as exc:
        allowed = f"expected a loop that does not cross itself; it cannot be checked: {exc}"
        return [Problem(table.path, "", f"{len(points):,} points", allowed)]
    if pair is None:
        return []
    i, j = pair
    n = len(points)
    lines = [int(table.lines[k]) for k in (i, (i + 1) % n, j, (j + 1) % n)]
    where = f"lines {lines[0]}-{lines[1]} and {lines[2]}-{lines[3]}"
    allowed = "expected a loop that does not cross itself (these segments cross)"
    return [Problem(table.path, where, [points[i].tolist(), points[j].tolist()], allowed)]
