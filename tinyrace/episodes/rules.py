"""The rule parts an episode is composed of, one class per rule, each judging one car.

A track lists the parts of its episodes (``Track.rules.parts``, names in ``RULES``); the
episode builds one instance of each part per car. A part puts what it needs into the
world once per track (``furnish``: tiles, obstacle cells, walls, cones), then after every
step reads that car's contacts and state and writes its findings into the car's
``StepFacts`` (``judge``), and adds its keys to the car's ``info``. Parts never touch
the pymunk space, and nothing here asks which kind of track it is.

How to add a rule part: a class with ``furnish``, ``judge`` and ``info`` (the ``Rule``
protocol below) and one ``RULES`` entry; a track source names it in its ``TrackRules``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, Protocol

import numpy as np

from tinyrace.cars.state import CarState, footprint_corners
from tinyrace.tracks.base import Track
from tinyrace.world.facts import StepFacts
from tinyrace.world.world import Contacts, World

Info = dict[str, Any]


class Rule(Protocol):
    """One rule of an episode, for one car."""

    def judge(self, contacts: Contacts, car: CarState, facts: StepFacts) -> None:
        """Read the car's contacts and state after a step; write the findings into ``facts``."""

    def info(self, info: Info) -> None:
        """Add this rule's keys to the car's info (as of the last step)."""


class TileProgress:
    """Tiles visited once each, in the order first visited, and the lap rule: a lap ends
    when every tile is visited, or back on tile 0 after ``lap_complete_percent`` of them."""

    def __init__(self, tiles: int, lap_percent: float) -> None:
        self.visited = np.zeros(tiles, bool)
        self.visited_count = 0
        self.visit_order: list[int] = []  # tiles in the order first visited (pictures repaint)
        self.lap_percent = lap_percent

    def new_lap(self) -> None:
        """Every tile to visit again (a race of several laps goes on after a lap)."""
        self.visited[:] = False
        self.visited_count = 0

    def _visit(self, tiles: Sequence[int], facts: StepFacts) -> None:
        """Mark ``tiles`` (reached in this order during the step) visited; the lap rule."""
        n = len(self.visited)
        facts.tiles_total = n
        for tile in tiles:
            if not self.visited[tile]:
                self.visited[tile] = True
                self.visited_count += 1
                self.visit_order.append(tile)
                facts.tiles.append(tile)
                facts.new_tiles += 1
            if tile == 0 and self.visited_count / n > self.lap_percent:
                facts.lap_finished = True
        if self.visited_count == n:
            facts.lap_finished = True


class TileTouches(TileProgress):
    """CarRacing's progress: road tiles are sensors; a tile a wheel touches is visited (paid
    once); laps as ``TileProgress``. Wheels on no tile are on the grass."""

    @staticmethod
    def furnish(world: World, track: Track) -> None:
        world.add_tiles(_tiles(track))

    def __init__(self, track: Track) -> None:
        super().__init__(len(_tiles(track)), track.rules.lap_complete_percent)
        self.wheels_on_grass = 0  # as of the last step

    def judge(self, contacts: Contacts, car: CarState, facts: StepFacts) -> None:
        self._visit(contacts.new_tile_touches, facts)
        facts.wheels_on_grass = self.wheels_on_grass = _on_grass(contacts.wheel_tiles)

    def info(self, info: Info) -> None:
        info["tiles_visited"] = self.visited_count
        info["tiles_total"] = len(self.visited)
        info["wheels_on_grass"] = self.wheels_on_grass  # contacts change only in a step


class CentrelineProgress(TileProgress):
    """Progress along a reference line read from a file: the tiles the car's rear axle
    passed since the last step (forward, on the road) are visited; laps as
    ``TileProgress``; the cross-track error is the distance to the centreline [m]."""

    REACH = 60.0  # [m] how far along the line the nearest point is searched from the last

    @staticmethod
    def furnish(world: World, track: Track) -> None:
        pass

    def __init__(self, track: Track) -> None:
        circuit = track.circuit
        assert circuit is not None  # a track lists this part only with a reference line
        super().__init__(len(circuit.tiles), track.rules.lap_complete_percent)
        self.circuit = circuit
        self.nearest = -1  # centreline index near the car (-1: search all)
        self.tile = -1  # the tile under the car at the last step (-1: none yet)
        self.cte: float | None = None
        self.on_road = True

    def judge(self, contacts: Contacts, car: CarState, facts: StepFacts) -> None:
        n = facts.tiles_total = len(self.visited)
        previous, (index, lateral) = self.tile, self._locate(*car.rear_axle)
        self.tile = index
        self.cte = facts.cte = abs(lateral)
        right, left = self.circuit.widths[index]
        self.on_road = bool(-right <= lateral <= left)
        if self.on_road:
            self._visit([index] if previous < 0 else _between(previous, index, n), facts)

    def _locate(self, x: float, y: float) -> tuple[int, float]:
        """(tile index, signed lateral offset [m], + left) of a point, searched near the last."""
        circuit = self.circuit
        points = circuit.centerline
        n = len(points)
        if self.nearest < 0:
            candidates = np.arange(n)
        else:
            reach = max(int(self.REACH / circuit.spacing), 8)  # [points]
            candidates = np.arange(self.nearest - reach, self.nearest + reach) % n
        offsets = points[candidates] - (x, y)
        nearest = int(candidates[np.argmin(np.einsum("ij,ij->i", offsets, offsets))])
        heading = circuit.headings[nearest]
        dx, dy = x - points[nearest, 0], y - points[nearest, 1]
        along = dx * math.cos(heading) + dy * math.sin(heading)
        lateral = -dx * math.sin(heading) + dy * math.cos(heading)
        tile = nearest if along >= 0 else (nearest - 1) % n
        self.nearest = nearest
        return tile, lateral

    def info(self, info: Info) -> None:
        info["tiles_visited"] = self.visited_count
        info["tiles_total"] = len(self.visited)
        info["on_road"] = self.on_road
        if self.cte is not None:
            info["cte"] = self.cte  # [m]


class NoReference:
    """A track without a reference line: no progress, and info says why there is no cte."""

    @staticmethod
    def furnish(world: World, track: Track) -> None:
        pass

    def __init__(self, track: Track) -> None:
        self.note = track.reference_note or "no reference line"

    def judge(self, contacts: Contacts, car: CarState, facts: StepFacts) -> None:
        pass

    def info(self, info: Info) -> None:
        info["tiles_visited"] = 0
        info["tiles_total"] = 0
        info["on_road"] = True
        info["cte_unavailable"] = self.note


class Grass:
    """Wheels off the road tiles grip as on grass (a car with wheels on a road from a file)."""

    @staticmethod
    def furnish(world: World, track: Track) -> None:
        world.add_tiles(_tiles(track))

    def __init__(self, track: Track) -> None:
        pass

    def judge(self, contacts: Contacts, car: CarState, facts: StepFacts) -> None:
        facts.wheels_on_grass = _on_grass(contacts.wheel_tiles)

    def info(self, info: Info) -> None:
        pass


class Playfield:
    """Leaving the track's ``bounds`` (judged at ``rules.bounds_point``) ends the episode."""

    @staticmethod
    def furnish(world: World, track: Track) -> None:
        pass

    def __init__(self, track: Track) -> None:
        self.bounds = track.bounds
        self.at_rear_axle = track.rules.bounds_point == "rear_axle"

    def judge(self, contacts: Contacts, car: CarState, facts: StepFacts) -> None:
        x, y = car.rear_axle if self.at_rear_axle else car.pose[:2]
        x0, y0, x1, y1 = self.bounds
        facts.out_of_bounds = not (x0 <= x <= x1 and y0 <= y <= y1)

    def info(self, info: Info) -> None:
        pass


class ObstacleColours:
    """tinycarlo's obstacles: the obstacle colours whose pixels lie under the footprint."""

    @staticmethod
    def furnish(world: World, track: Track) -> None:
        test = track.obstacle_test
        if test is not None:
            world.add_obstacle_cells(test.cells)

    def __init__(self, track: Track) -> None:
        self.test = track.obstacle_test
        self.names = [repr(layer.color) for layer in track.obstacles]  # "#rrggbb" each
        self.hit: list[int] = []

    def judge(self, contacts: Contacts, car: CarState, facts: StepFacts) -> None:
        if contacts.obstacle_cells and self.test is not None:
            facts.obstacles_hit = self.test.touched(footprint_corners(car), contacts.obstacle_cells)
        self.hit = facts.obstacles_hit

    def info(self, info: Info) -> None:
        info["obstacles_hit"] = [self.names[i] for i in self.hit]


class TrajectoryError:
    """The cross-track error: the rear axle's distance to the track's trajectory [units]."""

    @staticmethod
    def furnish(world: World, track: Track) -> None:
        pass

    def __init__(self, track: Track) -> None:
        self.trajectory = track.trajectory
        self.cte: float | None = None

    def judge(self, contacts: Contacts, car: CarState, facts: StepFacts) -> None:
        if self.trajectory is not None:
            x, y = car.rear_axle
            self.cte = facts.cte = self.trajectory.query(x, y)[0]

    def info(self, info: Info) -> None:
        if self.cte is not None:
            info["cte"] = self.cte  # [track units]


class Collisions:
    """Walls stop the car (the world puts it back; a penalty per step, optionally the end);
    cones are knocked over once each (a penalty, optionally the end)."""

    @staticmethod
    def furnish(world: World, track: Track) -> None:
        world.add_cones(track.cones[:, :2], track.cone_radii)
        world.add_walls(track.walls)

    def __init__(self, track: Track) -> None:
        self.wall_ends, self.cone_ends = track.rules.wall_hit_ends, track.rules.cone_hit_ends
        self.knocked: set[int] = set()
        self.walls_hit = 0

    def judge(self, contacts: Contacts, car: CarState, facts: StepFacts) -> None:
        if contacts.crashed:
            facts.wall_hit = True
            self.walls_hit += 1
            facts.collision_ends = self.wall_ends
        new_cones = contacts.cones - self.knocked
        if new_cones:
            self.knocked |= new_cones
            facts.cones_hit = len(new_cones)
            facts.collision_ends |= self.cone_ends

    def info(self, info: Info) -> None:
        info["cones_hit"] = len(self.knocked)
        info["walls_hit"] = self.walls_hit


class RuleType(Protocol):
    """A rule part's class: ``furnish`` the world once per track, one instance per car."""

    def __call__(self, track: Track) -> Rule: ...

    @staticmethod
    def furnish(world: World, track: Track) -> None: ...


RULES: dict[str, RuleType] = {
    "tile_touches": TileTouches,
    "centreline_progress": CentrelineProgress,
    "no_reference": NoReference,
    "grass": Grass,
    "playfield": Playfield,
    "obstacle_colours": ObstacleColours,
    "trajectory_error": TrajectoryError,
    "collisions": Collisions,
}


def rule_type(name: str) -> RuleType:
    """The rule part called ``name``; a KeyError lists the known names."""
    try:
        return RULES[name]
    except KeyError:
        raise KeyError(f"no rule part {name!r}; known: {', '.join(RULES)}") from None


def _tiles(track: Track) -> np.ndarray:
    assert track.tiles is not None  # a track lists a tile rule only when it has tiles
    return track.tiles


def _on_grass(wheel_tiles: Sequence[set[int]]) -> int:
    """How many wheels touch no road tile."""
    return len(wheel_tiles) - sum(map(bool, wheel_tiles))


def _between(previous: int, current: int, n: int) -> list[int]:
    """Tiles from ``previous`` to ``current`` going forward (a short way), ``current`` last."""
    forward = (current - previous) % n
    if forward <= n // 4:
        return [(previous + k) % n for k in range(1, forward + 1)] or [current]
    return [current]  # backwards or a jump: only the tile under the car
