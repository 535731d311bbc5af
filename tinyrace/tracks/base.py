"""The track contract: what every track source produces, and the protocol of a source.

A ``Track`` is read-only data in the track's own unit (``unit``: CarRacing's ``u`` on the
procedural track, ``px`` on tinycarlo image folders, ``m`` on metric sources), with its
scale to metres where known. The world builds its static shapes from it (surfaces,
colour-layer cells, walls, cones), sensors and pictures read it, rewards never see it.

How to add a track source (one new kind of ``track.type``):
1. Write ``tinyrace/tracks/<kind>.py`` with a class that satisfies ``TrackSource``: its
   constructor takes ``(config: EnvConfig, base_dir: Path, source: str)``, loads every
   file once and raises ``ConfigError`` listing every problem; ``draw(rng, options)``
   returns the ``TrackDraw`` of a new episode, drawing from ``rng`` only.
2. Its config dataclass (a ``TrackFacts`` with ``type: Literal["<kind>"]``): for a kind in
   the package in ``tinyrace/config/tracks.py``, added to the family there (so that
   ``import tinyrace`` alone knows it); for one from outside, beside its source.
3. One ``register(config, Source)`` in ``tinyrace/tracks/registry.py``. Its ``Track`` says
   what it holds (unit, reference line, walls, cones, picture, ...): cars, rules, sensors
   and pictures choose by that, never by the kind.
docs/ARCHITECTURE.md's recipe does it whole, with what else a kind in the package needs.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from tinyrace.errors import ConfigError, Problem
from tinyrace.tracks.circuit import Circuit
from tinyrace.tracks.ros_map import OccupancyMap

Pose = tuple[float, float, float]  # (x, y [track units], heading [rad] from +x)
Box = tuple[float, float, float, float]  # (x0, y0, x1, y1) [track units]
RGB = tuple[float, float, float]  # 0-255 per channel


def _no_boxes() -> np.ndarray:
    return np.zeros((0, 4))


def as_quads(walls: np.ndarray) -> np.ndarray:
    """(M, 4, 2) corners of walls given as (M, 4) boxes x0, y0, x1, y1 (counter-clockwise
    from the lower left) or already as (M, 4, 2) quads."""
    walls = np.asarray(walls, np.float64)
    if walls.ndim == 3:
        return walls
    b = walls.reshape(-1, 4)
    return np.stack([b[:, [0, 1]], b[:, [2, 1]], b[:, [2, 3]], b[:, [0, 3]]], axis=1)


@dataclass(frozen=True, eq=False)
class Surface:
    """Ground of one grip: convex quads (N, 4, 2) [track units], e.g. the road tiles.

    A wheel on no surface is off the road and gets ``Track.off_road_friction``.
    """

    name: str  # "road", "kerb", ...
    friction: float  # fraction of the road's friction limit (road 1.0)
    quads: np.ndarray  # (N, 4, 2) float [track units]


@dataclass(frozen=True, eq=False)
class ColorLayer:
    """The pixels of one colour of a picture track and what they mean.

    ``cells`` summarises the pixels as boxes for the physics' broad phase (obstacles);
    ``points`` lists them (trajectories) when the source keeps them.
    """

    name: str  # e.g. "obstacle 0", "trajectory", "marking"
    role: str  # "marking" | "obstacle" | "trajectory" | "cone"
    color: tuple[int, int, int]  # RGB
    cells: np.ndarray = field(default_factory=_no_boxes)  # (M, 4) boxes [track units]
    points: np.ndarray | None = None  # (K, 2) pixel coordinates (x, y), when kept


@dataclass(frozen=True)
class TrackRules:
    """The rules of an episode on a track: which rule parts it is made of (names in
    ``tinyrace.episodes.rules.RULES``, in the order they judge a step) and their knobs.

    The track source says this; the episode composes the parts without asking the kind."""

    parts: tuple[str, ...]
    reset_step: bool = False  # a reset steps the physics once (CarRacing); else it only looks
    bounds_point: str = "pose"  # the car's point judged against ``bounds``: pose | rear_axle
    lap_complete_percent: float = 0.95  # back on tile 0 after this fraction closes a lap
    wall_hit_ends: bool = False  # touching a wall ends the episode
    cone_hit_ends: bool = False  # knocking a cone over ends the episode
    info_labels: tuple[str, ...] = ()  # episode labels in info: "track", "spawn", "unit"


@dataclass(frozen=True)
class PaintedGround:
    """A ground painted from a track's tiles and kerbs over a grass pattern (CarRacing's),
    anew for each track: what the pictures of such a track are drawn from."""

    playfield: float  # [track units] the painted square spans -playfield..playfield in x and y
    pixels_per_unit: float  # [px per track unit] the texture the cameras sample


class ObstacleTest(Protocol):
    """The narrow phase of the obstacle-colour rule: which obstacles a footprint touches."""

    cells: np.ndarray  # (M, 4) boxes [track units] around obstacle pixels, world sensor order

    def touched(self, corners: np.ndarray, cells: Iterable[int]) -> list[int]:
        """Obstacle indices (ascending) with a pixel of ``cells`` inside ``corners``."""
        ...


class DistanceTo(Protocol):
    """A reference the cross-track error is measured to (e.g. a trajectory's pixels)."""

    def query(self, x: float, y: float) -> tuple[float, float, float]:
        """(distance, nearest x, nearest y) for the point (x, y) [track units]."""
        ...


@dataclass(frozen=True, eq=False)
class Track:
    """One track, as every part above the track sources sees it. Arrays are read-only."""

    kind: str  # the ``track.type`` of the source that made it
    unit: str  # "u" (CarRacing), "px" (tinycarlo image) or "m"
    metres_per_unit: float | None  # [m per track unit]; None when the source does not know
    y_down: bool  # True: x right, y down, heading clockwise on screen (image tracks)
    bounds: Box  # leaving this box ends the episode (out_of_bounds) [track units]
    spawns: tuple[Pose, ...]  # start poses; a TrackDraw says which one this episode uses
    centerline: np.ndarray | None = None  # (N, 2) reference line, point 0 at the start
    tiles: np.ndarray | None = None  # (N, 4, 2) progress tiles; tile i ends at point i
    surfaces: tuple[Surface, ...] = ()  # grip by area; nothing here: grip 1 everywhere
    off_road_friction: float = 1.0  # grip where no surface is (CarRacing's grass: 0.6)
    layers: tuple[ColorLayer, ...] = ()  # colour meanings of a picture track
    picture: np.ndarray | None = None  # (H, W, 4) uint8 RGBx of a picture track
    walls: np.ndarray = field(default_factory=_no_boxes)  # solid walls [track units]: (M, 4)
    # boxes x0, y0, x1, y1 or (M, 4, 2) convex quads (a ROS map's pixels); see ``wall_quads``
    cones: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))  # (K, 3): x, y, class
    palette: Mapping[str, RGB] = field(default_factory=dict)  # ground colours by name
    rules: TrackRules = TrackRules(())  # the episode's rule parts on this track
    circuit: Circuit | None = None  # the road around the reference line (widths, headings)
    cone_radii: np.ndarray = field(default_factory=lambda: np.zeros(0))  # (K,) [track units]
    obstacle_test: ObstacleTest | None = None  # obstacle colours' pixels, when there are any
    trajectory: DistanceTo | None = None  # what the cte is measured to, when not the circuit
    reference_note: str | None = None  # why the track has no reference line, when it has none
    headings: np.ndarray | None = None  # (N,) [rad] direction of travel at each centreline point
    kerbs: np.ndarray = field(default_factory=lambda: np.zeros((0, 4, 2)))  # (K, 4, 2) quads
    kerb_red: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))  # (K,) red or white
    occupancy: OccupancyMap | None = None  # a map's cells (free, occupied), when it is one
    painted: PaintedGround | None = None  # its ground is painted from tiles and kerbs
    ground_pixels_per_unit: float | None = None  # [px per track unit] a drawn ground's texture
    drawn_per_reset: bool = False  # made anew at every reset: nothing keeps or shares it
    attempts: int = 1  # how many tries its generator needed
    path: str = ""  # the file it was read from, for messages ("" when generated)

    @property
    def wall_quads(self) -> np.ndarray:
        """(M, 4, 2) [track units] the walls as convex quads, whichever form they came in."""
        return as_quads(self.walls)

    @property
    def obstacles(self) -> tuple[ColorLayer, ...]:
        """The colour layers a car must avoid, in ``reward_design.color_obstacles`` order."""
        return tuple(layer for layer in self.layers if layer.role == "obstacle")

    @property
    def trajectory_points(self) -> np.ndarray | None:
        """(K, 2) pixel coordinates (x, y) of a drawn trajectory, when the track keeps one."""
        return next((la.points for la in self.layers if la.role == "trajectory"), None)

    @property
    def picture_size(self) -> tuple[int, int]:
        """(width, height) [px] of the track's picture ((0, 0) without one)."""
        return (0, 0) if self.picture is None else (self.picture.shape[1], self.picture.shape[0])


@dataclass(frozen=True, eq=False)
class TrackDraw:
    """What a reset drew: the track of the episode, which of its tracks and which spawn."""

    track: Track
    track_index: int
    spawn_index: int

    @property
    def spawn(self) -> Pose:
        return self.track.spawns[self.spawn_index]


class TrackSource(Protocol):
    """Turns an env config into tracks; made once per env, asked once per reset."""

    kind: str  # the ``track.type`` it reads (a label for messages and results)
    tracks: tuple[Track, ...]  # the fixed tracks it draws from; () when each draw makes one
    painted: PaintedGround | None  # the ground of the tracks it makes, when painted per track

    def draw(self, rng: np.random.Generator, options: Mapping[str, object]) -> TrackDraw:
        """The track of a new episode, everything random drawn from ``rng`` in a fixed order.

        ``options`` are the reset options (``track``, ``spawn``, ``randomize``); a source
        draws the same numbers whether or not an option picks the result, so that picking
        changes nothing else. Raises ConfigError when the config cannot make a track.
        """
        ...


def pick_index(
    options: Mapping[str, object], key: str, count: int, rng: np.random.Generator
) -> int:
    """An index below ``count`` drawn from ``rng``, or the one ``options[key]`` picks.

    The number is drawn even when an option picks, so that picking changes nothing else.
    """
    drawn = int(rng.integers(count))
    chosen = options.get(key)
    if chosen is None:
        return drawn
    if (
        isinstance(chosen, bool)
        or not isinstance(chosen, (int, np.integer))
        or not 0 <= chosen < count
    ):
        chosen = None
    if chosen is None:
        allowed = f"expected a {key} index from 0 to {count - 1}"
        raise ConfigError(Problem("<reset options>", key, options.get(key), allowed))
    return int(chosen)
