"""The Formula Student Driverless simulator's cone map CSV.

Rows ``tag,x,y,direction,x_variance,y_variance,covariance`` in metres; tags
``blue`` (left edge in the driving direction), ``yellow`` (right edge), ``orange``
(extra marks), ``big_orange`` (the start/finish line) and ``unknown``; one row tagged
``car_start`` (EUFS's simulator writes one in each of its tracks) is no cone but the car's
start pose, ``x, y, direction`` [m, m, rad]. The road is derived from the cones: each edge
is put in order around the loop, the centreline is the middle between the edges, the widths
are the distances to them, and the start line is at the centreline point nearest the big
orange cones, where the car starts unless a ``car_start`` row places it.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tinyrace.config.bounds import (
    MAX_CONE_OFF_ROAD,
    MAX_CONE_ROAD_POINTS,
    MAX_CONES,
    MAX_COORDINATE,
)
from tinyrace.errors import ConfigError, Problem, capped
from tinyrace.tracks import polyline
from tinyrace.tracks.csv_rows import cell_number, read_text, split_cells

CLASSES = ("blue", "yellow", "orange", "big_orange", "unknown")  # class id = index + 1
RADII = {"blue": 0.115, "yellow": 0.115, "orange": 0.115, "big_orange": 0.145, "unknown": 0.115}
MIN_EDGE_CONES = 3
_COLUMNS = ("tag", "x", "y", "direction", "x_variance", "y_variance", "covariance")
CAR_START = "car_start"  # the tag of the row that places the car (EUFS's tracks)
MAX_HEADING = 1e9  # [rad] the most a car_start's direction may be (as track.spawn's heading)


@dataclass(frozen=True)
class Cones:
    """Every cone of a map: positions [m], class names, and the file line of each."""

    path: str
    positions: np.ndarray  # (K, 2) [m]
    tags: tuple[str, ...]  # one of CLASSES per cone
    lines: tuple[int, ...]  # file line of each cone (from 1)
    start: tuple[float, float, float] | None = None  # the car_start row's pose [m, m, rad]
    start_line: int = 0  # its file line

    def of(self, tag: str) -> np.ndarray:
        """Indices of the cones of class ``tag``."""
        return np.array([i for i, t in enumerate(self.tags) if t == tag], int)

    @property
    def radii(self) -> np.ndarray:
        """(K,) [m] base radius of each cone, by class."""
        return np.array([RADII[t] for t in self.tags])

    @property
    def class_ids(self) -> np.ndarray:
        """(K,) int class id of each cone: 1 + its index in CLASSES."""
        return np.array([CLASSES.index(t) + 1 for t in self.tags], int)


def read_cones(path: Path, source: str, key: str, scale: float = 1.0) -> Cones:
    """Read a cone map (cells separated by ',', ';' or tabs, as in a centreline CSV); a
    bad row is a ConfigError naming the file, line and column."""
    text = read_text(path, source, key)
    positions: list[tuple[float, float]] = []
    tags: list[str] = []
    lines: list[int] = []
    problems: list[Problem] = []
    start: tuple[float, float, float] | None = None
    start_line = 0
    for number, raw in enumerate(text.splitlines(), start=1):
        cells = list(split_cells(raw))  # separated as a centreline CSV's rows may be
        if not raw.strip() or raw.lstrip().startswith("#") or cells[0].lower() == "tag":
            continue
        if cells[0].lower() == CAR_START:
            if start_line:
                allowed = (
                    f"expected one {CAR_START} row (the car's start pose); line {start_line} is one"
                )
                problems.append(Problem(str(path), f"line {number}", ",".join(cells), allowed))
            else:
                start, start_line = _car_start(str(path), number, cells, problems), number
            continue
        cone = _cone(str(path), number, cells, problems)
        if cone is not None:
            positions.append(cone[1])
            tags.append(cone[0])
            lines.append(number)
        if len(positions) > MAX_CONES:
            allowed = f"expected at most {MAX_CONES:,} cones (tinyrace's bound)"
            raise ConfigError(Problem(str(path), f"line {number}", f"cone {len(tags):,}", allowed))
    problems += _repeated(str(path), positions, lines)
    if problems:
        raise ConfigError(capped(problems))
    array = np.array(positions, np.float64).reshape(-1, 2) * scale
    far = np.flatnonzero(~(np.abs(array) <= MAX_COORDINATE).all(axis=1))
    if len(far):
        allowed = f"expected x and y within +-{MAX_COORDINATE:g} m after scale (scale {scale:g})"
        where = f"line {lines[far[0]]}"
        raise ConfigError(Problem(str(path), where, array[far[0]].tolist(), allowed))
    if start is not None:
        start = (start[0] * scale, start[1] * scale, start[2])
        if max(abs(start[0]), abs(start[1])) > MAX_COORDINATE:
            allowed = (
                f"expected x and y within +-{MAX_COORDINATE:g} m after scale (scale {scale:g})"
            )
            raise ConfigError(Problem(str(path), f"line {start_line}", list(start), allowed))
    return Cones(str(path), array, tuple(tags), tuple(lines), start, start_line)


def check_cones_near_road(cones: Cones, road: ConeRoad) -> None:
    """Refuse a cone farther than ``MAX_CONE_OFF_ROAD`` from the road's middle line (a stray
    row: the playfield, and the ground's pixels, would stretch to reach it)."""
    nearest = road.centerline[_nearest(road.centerline, cones.positions)]
    off = np.hypot(*(cones.positions - nearest).T)
    far = np.flatnonzero(off > MAX_CONE_OFF_ROAD)
    if len(far) == 0:
        return
    worst = int(far[np.argmax(off[far])])
    others = f" ({len(far) - 1} more cone(s) as far)" if len(far) > 1 else ""
    allowed = (
        f"expected every cone within {MAX_CONE_OFF_ROAD:g} m of the road between the blue and "
        f"yellow cones; this {cones.tags[worst]} cone is {off[worst]:,.0f} m from it{others}"
    )
    where = f"line {cones.lines[worst]}"
    raise ConfigError(Problem(cones.path, where, cones.positions[worst].tolist(), allowed))


def check_start_on_road(cones: Cones, road: ConeRoad) -> None:
    """Refuse a ``car_start`` pose off the road between the cones (the car would start
    out of its lane, or out of bounds)."""
    if cones.start is None:
        return
    point = np.array(cones.start[:2])
    nearest = polyline.nearest_index(road.centerline, point)
    off = float(np.hypot(*(point - road.centerline[nearest])))
    half = float(road.widths[nearest].max())
    if off <= half:
        return
    x, y = road.centerline[nearest]
    allowed = (
        f"expected the car's start on the road between the cones; it is {off:.2f} m from the "
        f"road's middle at ({x:.2f}, {y:.2f}) m, where the road is {2 * half:.2f} m wide"
    )
    raise ConfigError(Problem(cones.path, f"line {cones.start_line}", list(cones.start), allowed))


def _car_start(
    path: str, number: int, cells: list[str], problems: list[Problem]
) -> tuple[float, float, float] | None:
    """The pose of a ``car_start`` row: x, y and direction (0 when left out), or None."""
    values = []
    for column in (1, 2, 3):
        if column == 3 and (len(cells) <= 3 or not cells[3]):
            values.append(0.0)  # EUFS writes 0: the cars start facing +x
            continue
        value = cell_number(cells[column]) if column < len(cells) else float("nan")
        if not (np.isfinite(value) and (column < 3 or abs(value) <= MAX_HEADING)):
            where = f"line {number}, column {column + 1} ({_COLUMNS[column]})"
            shown = cells[column] if column < len(cells) else None
            unit = "rad" if column == 3 else "m"
            bound = f" within +-{MAX_HEADING:g}" if column == 3 else ""
            allowed = (
                f"expected a finite number{bound} [{unit}]: the car's start pose is x, y, direction"
            )
            problems.append(Problem(path, where, shown, allowed))
            return None
        values.append(value)
    return values[0], values[1], values[2]


def _repeated(path: str, positions: list[tuple[float, float]], lines: list[int]) -> list[Problem]:
    """A problem for each cone at the very place of an earlier one (a row written twice)."""
    first: dict[tuple[float, float], int] = {}
    problems = []
    for position, line in zip(positions, lines, strict=True):
        if position in first:
            allowed = f"expected one cone per place; line {first[position]} has a cone there"
            problems.append(Problem(path, f"line {line}", list(position), allowed))
        first.setdefault(position, line)
    return problems


def _cone(
    path: str, number: int, cells: list[str], problems: list[Problem]
) -> tuple[str, tuple[float, float]] | None:
    if len(cells) < 3:
        allowed = f"expected at least tag,x,y of {','.join(_COLUMNS)}"
        problems.append(Problem(path, f"line {number}", ",".join(cells), allowed))
        return None
    tag = cells[0].lower()
    if tag not in CLASSES:
        allowed = f"expected a tag among: {', '.join(CLASSES)} (or one {CAR_START} row)"
        problems.append(Problem(path, f"line {number}, column 1 (tag)", cells[0], allowed))
        return None
    values = []
    for column in (1, 2):
        value = cell_number(cells[column])
        if not np.isfinite(value):
            where = f"line {number}, column {column + 1} ({_COLUMNS[column]})"
            problems.append(Problem(path, where, cells[column], "expected a finite number [m]"))
            return None
        values.append(value)
    return tag, (values[0], values[1])


@dataclass(frozen=True)
class ConeRoad:
    """The road between the cones: a closed centreline with widths, start at point 0."""

    centerline: np.ndarray  # (N, 2) [m] in driving order (blue on the left)
    widths: np.ndarray  # (N, 2) [m] to the right (yellow) and to the left (blue)


def road_between(cones: Cones, spacing: float, max_gap: float) -> ConeRoad:
    """The centreline between the blue and yellow edges, sampled about ``spacing`` [m] apart.

    Each edge is ordered by chaining nearest cones; a gap longer than ``max_gap`` [m]
    between neighbours is an error (the cones do not close a loop).
    """
    blue = _edge_loop(cones, "blue", max_gap)
    yellow = _edge_loop(cones, "yellow", max_gap)
    for tag, edge in (("blue", blue), ("yellow", yellow)):
        _check_edge_length(cones, tag, polyline.perimeter(edge), spacing)
    dense_blue, _ = polyline.resample(blue, spacing / 4)
    dense_yellow, _ = polyline.resample(yellow, spacing / 4)
    guide, _ = polyline.resample(blue, spacing)
    left = dense_blue[_nearest(dense_blue, guide)]
    right = dense_yellow[_nearest(dense_yellow, guide)]
    right = dense_yellow[_nearest(dense_yellow, 0.5 * (left + right))]  # opposite the middle
    middle = 0.5 * (left + right)
    half = np.hypot(*(left - right).T) / 2
    widths = np.column_stack((half, half))
    if _blue_on_right(middle, left):
        middle, widths = middle[::-1].copy(), widths[::-1].copy()
    start = _start_point(cones, middle)
    return ConeRoad(np.roll(middle, -start, axis=0), np.roll(widths, -start, axis=0))


def _edge_loop(cones: Cones, tag: str, max_gap: float) -> np.ndarray:
    """The cones of one edge in order around the loop (nearest neighbour chain); big orange
    cones join the edge whose cones are nearest to them (they stand on the start line)."""
    index = cones.of(tag)
    if len(index):
        index = np.concatenate((index, _start_cones_beside(cones, tag)))
    if len(index) < MIN_EDGE_CONES:
        allowed = f"expected at least {MIN_EDGE_CONES} {tag} cones (the {tag} edge of the road)"
        raise ConfigError(Problem(cones.path, "", f"{len(index)} {tag} cones", allowed))
    points = cones.positions[index]
    free = np.ones(len(points), bool)
    order = [0]
    free[0] = False
    for _ in range(len(points) - 1):
        distance = np.hypot(*(points - points[order[-1]]).T)
        distance[~free] = np.inf
        step = int(np.argmin(distance))
        if distance[step] > max_gap:
            _gap_error(cones, index[order[-1]], tag, float(distance[step]), max_gap)
        order.append(step)
        free[step] = False
    closing = float(np.hypot(*(points[order[-1]] - points[order[0]])))
    if closing > max_gap:
        _gap_error(cones, index[order[-1]], tag, closing, max_gap)
    return np.asarray(points[order], float)


def _check_edge_length(cones: Cones, tag: str, length: float, spacing: float) -> None:
    """An edge that goes round a loop at least 3 spacings long, in at most
    MAX_CONE_ROAD_POINTS spacings (each point is matched against the other edge's)."""
    if length >= 3 * spacing and length / spacing <= MAX_CONE_ROAD_POINTS:
        return
    if length < 3 * spacing:
        allowed = (
            f"expected the {tag} cones to go round a loop at least 3 x track.spacing "
            f"({3 * spacing:g} m) long (these enclose {length:.3g} m)"
        )
    else:
        allowed = (
            f"expected a track.spacing >= {length / MAX_CONE_ROAD_POINTS:.3g} m for a {tag} "
            f"edge of {length:.0f} m (at most {MAX_CONE_ROAD_POINTS:,} points along it)"
        )
    raise ConfigError(Problem(cones.path, "", f"{tag} edge of {length:.3g} m", allowed))


def _start_cones_beside(cones: Cones, tag: str) -> np.ndarray:
    """Indices of the big orange cones nearer to a ``tag`` cone than to the other edge's."""
    big = cones.of("big_orange")
    edges = np.concatenate((cones.of("blue"), cones.of("yellow")))
    if len(big) == 0 or len(edges) == 0:
        return np.zeros(0, int)
    nearest = edges[_nearest(cones.positions[edges], cones.positions[big])]
    return np.asarray(big[np.array([cones.tags[i] == tag for i in nearest], bool)], int)


def _gap_error(cones: Cones, cone: int, tag: str, gap: float, max_gap: float) -> None:
    allowed = (
        f"expected the {tag} cones to close a loop with neighbours at most {max_gap:g} m apart; "
        f"the next {tag} cone after this one is {gap:.2f} m away"
    )
    where = f"line {cones.lines[cone]}"
    raise ConfigError(Problem(cones.path, where, cones.positions[cone].tolist(), allowed))


def _nearest(points: np.ndarray, queries: np.ndarray) -> np.ndarray:
    """Index into ``points`` of the nearest point to each query (in chunks: bounded memory)."""
    found = []
    for start in range(0, len(queries), 256):
        chunk = queries[start : start + 256]
        d2 = ((chunk[:, None, :] - points[None, :, :]) ** 2).sum(axis=2)
        found.append(np.argmin(d2, axis=1))
    return np.concatenate(found)


def _blue_on_right(middle: np.ndarray, left: np.ndarray) -> bool:
    """Whether, driving along ``middle`` in its order, the blue points lie mostly on the right."""
    normal = polyline.left_normals(middle)
    return float(np.sum(np.sum((left - middle) * normal, axis=1))) < 0


def _start_point(cones: Cones, middle: np.ndarray) -> int:
    """The centreline point nearest the big orange cones (or orange ones; else point 0)."""
    for tag in ("big_orange", "orange"):
        index = cones.of(tag)
        if len(index):
            return polyline.nearest_index(middle, cones.positions[index].mean(axis=0))
    return 0
