"""Start poses that fit: the car's footprint at every spawn must touch no wall and no cone
(tracks in metres) and cover no pixel of an obstacle colour (picture tracks), or the config
is refused (``prepare``: ``gym.make`` and ``tinyrace validate`` alike), naming the pose's
file and key.

The footprint is the car's outline as the world sees it (``World.footprints`` of the car
built at the spawn: its whole body where the model has one, e.g. the single-track car's
0.58 m, not only from axle to axle); walls are the track's solid boxes or quads (what
stops the car), cones discs of their base radius. Touching (an overlap of at most
``world.TOUCH``) is no hit, in these checks as in the world.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from tinyrace.cars.registry import CarModel, model_of
from tinyrace.cars.state import CarState
from tinyrace.config import CarConfig, EnvConfig
from tinyrace.errors import Problem
from tinyrace.tracks.base import Pose, Track, as_quads
from tinyrace.world.world import TOUCH, World


@dataclass(frozen=True)
class StartFit:
    """How one spawn fits: the footprint's corners and its clearances [track units]."""

    track_index: int
    spawn: tuple[float, float, float]  # (x, y [track units], heading [rad])
    corners: np.ndarray  # (4, 2) [track units]
    size: tuple[float, float]  # (length, width) [track units] of the footprint
    wall_clearance: float  # [track units] to the nearest wall; < 0: overlapping (inf: none)
    cone_clearance: float  # [track units] to the nearest cone's edge; < 0: overlapping
    unit: str = "m"  # the track's unit
    obstacles: tuple[int, ...] = ()  # the obstacle colours it covers a pixel of (pictures)
    number: int = 0  # which of the track's spawns

    @property
    def free(self) -> bool:
        """Clear of walls, cones and obstacle colours, or only touching walls and cones."""
        return min(self.wall_clearance, self.cone_clearance) >= -TOUCH and not self.obstacles


def start_fits(config: EnvConfig, tracks: Sequence[Track], car_model: CarModel) -> list[StartFit]:
    """The fit of the car of ``config`` at every spawn of every track with walls, cones or
    obstacle colours."""
    fits = []
    for index, track in enumerate(tracks):
        pictured = track.obstacle_test is not None and len(track.obstacle_test.cells) > 0
        if not len(track.walls) and not len(track.cones) and not pictured:
            continue
        for number, spawn in enumerate(track.spawns):
            world = World()
            world.add_car(car_model.build(world.space, spawn, config.car, track))
            (corners,) = world.footprints()
            walls = _wall_clearance(corners, track.wall_quads)
            cones = _cone_clearance(corners, track.cones[:, :2], track.cone_radii)
            covered = tuple(_obstacles_under(track, corners))
            size = quad_size(corners)
            fits.append(
                StartFit(index, spawn, corners, size, walls, cones, track.unit, covered, number)
            )
    return fits


def start_problems(config: EnvConfig, fits: list[StartFit], source: str) -> list[Problem]:
    """A Problem for each spawn whose footprint touches a wall or a cone, named by the key
    the pose came from (``spawn``, else the file whose first point it is)."""
    problems = []
    for fit in fits:
        if fit.free:
            continue
        track = config.tracks[fit.track_index]
        spawn = getattr(track, "spawn", None)
        given = spawn is not None
        key = "spawn" if given else track.start_key  # the file whose first point it is
        where = f"tracks[{fit.track_index}].{key}"
        if fit.obstacles:
            problems.append(_obstacle_problem(config, fit, source, where, key))
            continue
        x, y, heading = fit.spawn
        length, width = fit.size
        unit = fit.unit
        what = "a wall" if fit.wall_clearance <= 0 else "a cone"
        pose = f"[{x:.3f}, {y:.3f}, {heading:.3f}]"
        advice = "move the spawn (track.spawn)" if given else track.start_advice
        allowed = (
            f"expected a start pose where the car's footprint ({length:.2f} x {width:.2f} "
            f"{unit}, length x width, at {pose} [{unit}, {unit}, rad]) overlaps no wall or "
            f"cone; it overlaps {what}: {advice}, or make the car smaller "
            f"({', '.join(model_of(config).size_keys)})"
        )
        value = list(spawn) if spawn is not None else getattr(track, key)
        problems.append(Problem(source, where, value, allowed))
    return problems


def _obstacle_problem(
    config: EnvConfig, fit: StartFit, source: str, where: str, key: str
) -> Problem:
    """A picture track's spawn whose footprint covers pixels of obstacle colours."""
    spawn = getattr(config.tracks[fit.track_index], key)[fit.number]
    obstacles = config.reward_design.color_obstacles
    named = ", ".join(
        f"reward_design.color_obstacles[{k}] (color {obstacles[k].color!r}, reward "
        f"{obstacles[k].reward})"
        for k in fit.obstacles
    )
    length, width = fit.size
    allowed = (
        f"expected a spawn where the car's footprint ({length:.0f} x {width:.0f} "
        f"{fit.unit}, length x width) covers no pixel of an obstacle colour; it covers "
        f"{named}: the car would hit it on its first step. Move the spawn, or paint the "
        "start clear"
    )
    return Problem(source, f"{where}[{fit.number}]", list(spawn), allowed)


def _obstacles_under(track: Track, quad: np.ndarray) -> list[int]:
    """The obstacle colours (indices) with a pixel inside ``quad`` (picture tracks)."""
    test = track.obstacle_test
    if test is None or len(test.cells) == 0:
        return []
    cells = as_quads(test.cells)
    low, high = quad.min(axis=0), quad.max(axis=0)
    near = np.flatnonzero(((cells.min(axis=1) <= high) & (cells.max(axis=1) >= low)).all(axis=1))
    return test.touched(quad, near.tolist()) if near.size else []


def placement_problems(
    track: Track,
    states: Sequence[CarState],
    names: Sequence[str],
    source: str,
    paths: Sequence[str],
    hint: str = "",
    value: object = None,
    *,
    footprints: Sequence[np.ndarray],
) -> list[Problem]:
    """A Problem for each car that starts outside the track's bounds, on a wall or a cone,
    on a map's cell that is not free, or on another car (``footprints``: each car's outline
    as the world sees it, ``World.footprints``), named by its id and by the key
    (``paths[i]``) its pose came from, showing ``value`` (None: the pose). Cars that only
    touch are no problem."""
    corners = list(footprints)
    assert len(corners) == len(states)
    walls = track.wall_quads
    x0, y0, x1, y1 = track.bounds
    free = "" if track.occupancy is None else " on the map's free cells"
    problems = []
    for i, (state, quad) in enumerate(zip(states, corners, strict=True)):
        where = []
        x, y = state.rear_axle if track.rules.bounds_point == "rear_axle" else state.pose[:2]
        if not (x0 <= x <= x1 and y0 <= y <= y1):
            where.append(f"outside the track's bounds {list(track.bounds)}")
        if _overlaps(quad, walls):
            where.append("on a wall")
        if _cone_clearance(quad, track.cones[:, :2], track.cone_radii) < -TOUCH:
            where.append("on a cone")
        if not _on_free_cell(track, state.pose[:2]):
            where.append("on a cell of the map that is not free")
        where += [f"on car {names[j]!r}" for j in range(i) if quads_overlap(quad, corners[j])]
        if where:
            pose = [round(v, 4) for v in state.pose]
            length, width = quad_size(quad)
            allowed = (
                f"car {names[i]!r} would start {' and '.join(where)} (its footprint {length:.2f} "
                f"x {width:.2f} track units at {pose}): expected a start pose clear of the "
                f"walls, cones and the other cars, inside the track{free}{hint}"
            )
            problems.append(Problem(source, paths[i], pose if value is None else value, allowed))
    return problems


def grid_check(
    track: Track, cars: Sequence[tuple[CarModel, CarConfig]]
) -> Callable[[int, Pose], bool]:
    """``fits(k, pose)`` for the start grid (``start.grid_poses``): whether car ``k``'s
    footprint (``cars[k]``'s model built as its config says) at ``pose`` lies inside the
    track's bounds, clear of its walls, cones and obstacle colours and of the cars placed
    before it; a place that fits is taken (remembered). The pole (car 0) always fits: its
    place is the spawn's, which the config's own checks judge."""
    outlines: list[np.ndarray] = []  # built at the first call (a kept grid asks none)
    placed: list[np.ndarray] = []
    x0, y0, x1, y1 = track.bounds
    walls = track.wall_quads
    cones, radii = track.cones[:, :2], track.cone_radii

    def fits(k: int, pose: Pose) -> bool:
        if not outlines:
            outlines.extend(_outlines(track, cars))
        quad = _at(outlines[k], pose)
        if k == 0:
            placed.append(quad)
            return True
        inside = bool(((quad >= (x0, y0)) & (quad <= (x1, y1))).all())
        clear = (
            inside
            and not _overlaps(quad, walls)
            and _cone_clearance(quad, cones, radii) >= -TOUCH
            and not _on_obstacle(track, quad)
            and _on_free_cell(track, pose[:2])
            and not any(quads_overlap(quad, other) for other in placed)
        )
        if clear:
            placed.append(quad)
        return clear

    return fits


def _outlines(track: Track, cars: Sequence[tuple[CarModel, CarConfig]]) -> list[np.ndarray]:
    """Each car's footprint built at the pose (0, 0, 0), in a scratch world."""
    world = World()
    for model, car in cars:
        world.add_car(model.build(world.space, (0.0, 0.0, 0.0), car, track))
    return world.footprints()


def _at(outline: np.ndarray, pose: Pose) -> np.ndarray:
    """``outline`` (a footprint at the pose (0, 0, 0)) moved to ``pose``."""
    x, y, heading = pose
    c, s = math.cos(heading), math.sin(heading)
    return np.asarray(outline @ np.array([[c, s], [-s, c]]) + (x, y), np.float64)


def _on_free_cell(track: Track, point: Sequence[float]) -> bool:
    """Whether ``point`` lies on a free cell of the track's map (no map: True)."""
    return track.occupancy is None or bool(track.occupancy.is_free(np.array([point[:2]]))[0])


def _on_obstacle(track: Track, quad: np.ndarray) -> bool:
    """Whether a pixel of an obstacle colour lies inside ``quad`` (picture tracks)."""
    return bool(_obstacles_under(track, quad))


def quads_overlap(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether two convex quads overlap by more than a touch (``world.TOUCH``)."""
    return _overlaps(a, np.asarray(b, np.float64)[None])


def _overlaps(polygon: np.ndarray, quads: np.ndarray) -> bool:
    """Whether the convex ``polygon`` overlaps any of the (M, 4, 2) convex ``quads`` by
    more than a touch (only the quads whose bounding boxes meet its own are tested)."""
    if len(quads) == 0:
        return False
    polygon = np.asarray(polygon, np.float64)
    low, high = polygon.min(axis=0) - TOUCH, polygon.max(axis=0) + TOUCH
    near = ((quads.min(axis=1) <= high) & (quads.max(axis=1) >= low)).all(axis=1)
    if not near.any():
        return False
    return bool(_separations(polygon, quads[near]).min() < -TOUCH)


def quad_size(quad: np.ndarray) -> tuple[float, float]:
    """(length, width) of a rectangle given by its 4 corners in order (its longer side first)."""
    first, second = (float(np.hypot(*(quad[k + 1] - quad[k]))) for k in (0, 1))
    return max(first, second), min(first, second)


def _wall_clearance(corners: np.ndarray, quads: np.ndarray) -> float:
    """[m] the smallest distance between the convex polygon ``corners`` and the (M, 4, 2)
    convex quads; negative (the overlap along the best separating axis) when one
    overlaps; inf without quads."""
    if len(quads) == 0:
        return math.inf
    polygon = np.asarray(corners, np.float64)
    quads = np.asarray(quads, np.float64)
    separation = _separations(polygon, quads)  # per quad: > 0 apart (a lower bound)
    overlapping = separation <= 0
    if overlapping.any():
        return float(separation.min())
    # apart: the exact distance between the polygon and each quad (corner to edge, both ways)
    return float(min(_distance(polygon, quad) for quad in quads[np.argsort(separation)[:8]]))


def _separations(polygon: np.ndarray, quads: np.ndarray) -> np.ndarray:
    """(M,) per quad, the largest gap along a separating axis between the convex
    ``polygon`` and the quad: > 0 apart, <= 0 overlapping by that much."""
    # separating axes: the polygon's edge normals and each quad's
    axes = np.concatenate(
        (np.broadcast_to(_normals(polygon), (len(quads), 4, 2)), _normals(quads)), 1
    )
    along_quad = np.einsum("mkd,mad->mka", quads, axes)  # (M, 4 corners, A axes)
    along_polygon = np.einsum("kd,mad->mka", polygon, axes)
    gap = np.maximum(
        along_quad.min(axis=1) - along_polygon.max(axis=1),
        along_polygon.min(axis=1) - along_quad.max(axis=1),
    )  # (M, A): > 0 on an axis that separates
    return np.asarray(gap.max(axis=1))


def _normals(polygons: np.ndarray) -> np.ndarray:
    """(..., K, 2) unit normals of the edges of convex polygons (..., K, 2)."""
    edges = np.roll(polygons, -1, axis=-2) - polygons
    normals = np.stack((-edges[..., 1], edges[..., 0]), axis=-1)
    length = np.hypot(normals[..., 0], normals[..., 1])[..., None]
    return np.asarray(normals / np.where(length > 0, length, 1.0))


def _distance(a: np.ndarray, b: np.ndarray) -> float:
    """[m] between two disjoint convex polygons: the nearest corner-to-edge distance."""
    return min(_points_to_edges(a, b), _points_to_edges(b, a))


def _points_to_edges(points: np.ndarray, polygon: np.ndarray) -> float:
    start = polygon
    edge = np.roll(polygon, -1, axis=0) - polygon  # (E, 2)
    offset = points[:, None, :] - start[None, :, :]  # (P, E, 2)
    t = np.clip((offset * edge).sum(-1) / (edge * edge).sum(-1), 0, 1)
    nearest = start[None] + t[..., None] * edge[None]
    return float(np.hypot(*(points[:, None, :] - nearest).transpose(2, 0, 1)).min())


def _cone_clearance(corners: np.ndarray, centres: np.ndarray, radii: np.ndarray) -> float:
    """[m] from the polygon ``corners`` to the nearest cone's edge; negative when a cone
    overlaps it; inf without cones."""
    if len(centres) == 0:
        return math.inf
    polygon = np.asarray(corners, np.float64)
    centres = np.asarray(centres, np.float64)
    edges = np.roll(polygon, -1, axis=0) - polygon
    offset = centres[:, None, :] - polygon[None]
    t = np.clip((offset * edges).sum(-1) / (edges * edges).sum(-1), 0, 1)
    nearest = polygon[None] + t[..., None] * edges[None]
    to_edge = np.hypot(*(centres[:, None, :] - nearest).transpose(2, 0, 1)).min(axis=1)
    cross = edges[None, :, 0] * offset[..., 1] - edges[None, :, 1] * offset[..., 0]
    inside = (cross >= 0).all(axis=1) | (cross <= 0).all(axis=1)
    distance = np.where(inside, -to_edge, to_edge) - np.asarray(radii, np.float64)
    return float(distance.min())
