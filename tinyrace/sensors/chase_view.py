"""CarRacing's camera: follows the hull and turns with it, zooms in during the first second.

The frame is laid out as the reference's 1000x800 window, then mapped straight
to the requested size (96x96 observation, 600x400 video, 1000x800 window) in one
affine warp of the pre-drawn ground; the car and the dashboard are drawn on top.

``ChaseViewSensor`` is the sensor type ``chase_view``: CarRacing's 96x96 observation, the
default of a procedural track. The render modes' frames draw a ``ChaseView`` of their size.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from gymnasium import spaces

from tinyrace.config.sensors import ChaseViewConfig
from tinyrace.ground.texture import Affine, GroundTexture, as_matrix
from tinyrace.sensors.base import Ground, SensorContext, TopDown
from tinyrace.sensors.machinery.car_sprite import CarSprite
from tinyrace.sensors.machinery.dashboard import Dashboard
from tinyrace.sensors.machinery.draw_cars import CarLooks, draw_names, fill_footprints
from tinyrace.tracks.base import Track
from tinyrace.world.snapshot import Snapshot

WINDOW = (1000, 800)  # [px] the reference's layout size (w, h)
SMALL_VIEW = 160  # [px] views up to this size supersample the car and the instruments
ZOOM = 2.7 * 6.0  # [window px/u] after the first second
START_ZOOM = 0.1 * 6.0  # [window px/u] at t = 0


def zoom_at(t: float) -> float:
    """Window pixels per world unit, t seconds after reset (the reference's zoom-in)."""
    return START_ZOOM * max(1.0 - t, 0.0) + ZOOM * min(t, 1.0)


def chase_matrix(
    position: tuple[float, float], hull_angle: float, zoom: float, size: tuple[int, int]
) -> np.ndarray:
    """World -> output pixels: the car at half width, a quarter height from the bottom, nose up."""
    a, b, ox, c, d, oy = chase_affine(position, hull_angle, zoom, size)
    return np.array([[a, b, ox], [c, d, oy]])


def chase_affine(
    position: tuple[float, float], hull_angle: float, zoom: float, size: tuple[int, int]
) -> Affine:
    """``chase_matrix`` as six plain floats, row by row."""
    sx, sy = size[0] / WINDOW[0], size[1] / WINDOW[1]
    cos_a, sin_a = math.cos(hull_angle), math.sin(hull_angle)
    a, b = sx * zoom * cos_a, sx * zoom * sin_a  # rotate by -hull_angle, then scale
    c, d = sy * zoom * sin_a, -sy * zoom * cos_a  # ... and flip y (screen y points down)
    px, py = position
    # output pixel centres sit half a pixel in; so do the reference's window pixels
    ox = WINDOW[0] / 2 * sx - (a * px + b * py) - 0.5 + 0.5 * sx
    oy = WINDOW[1] * 3 / 4 * sy - (c * px + d * py) - 0.5 + 0.5 * sy
    return (a, b, ox, c, d, oy)


class ChaseView:
    """One output size of CarRacing's view; ``render`` returns a new frame each call."""

    def __init__(
        self,
        size: tuple[int, int],
        texture: GroundTexture,
        dashboard: Dashboard,
        looks: CarLooks | None = None,
    ):
        """``dashboard`` may be shared across episodes; ``looks``: the colours and names of
        a race's cars (the others drawn on the ground, named in views larger than the
        observation). The car's cached pictures are shared by every view of the process
        (``car_sprite``)."""
        self.size = size  # (w, h)
        self.looks = looks
        self.texture = texture
        small = dashboard.factor > 1  # observation-sized: supersample the car and the instruments
        self.sprite = CarSprite(supersample=small)
        self.dashboard = dashboard
        self._ppu_per_zoom = math.sqrt(size[0] * size[1] / (WINDOW[0] * WINDOW[1]))  # per step
        # CarRacing draws skid marks (2 window px wide) in its videos, not in the observation
        self.skid_width = 0 if small else max(1, round(2 * size[1] / WINDOW[1]))

    def render(self, snapshot: Snapshot, score: float, out: np.ndarray | None = None) -> np.ndarray:
        """The view of the controlled car at ``snapshot.t`` seconds after reset, with
        ``score`` on the dashboard: drawn into ``out`` ((h, w, 3) uint8, rows contiguous),
        else into a new array; returns it."""
        car = snapshot.car
        zoom = zoom_at(snapshot.t) / car.scale  # [output px/u] at the reference's window size
        x, y, _ = car.pose
        size = self.size
        world_to_out = chase_affine((x, y), car.hull_angle, zoom, size)
        pixels_per_unit = zoom * self._ppu_per_zoom
        # a new frame each call (it is returned), unless given one; the dashboard paints over
        # its bottom rows, so the ground is sampled above them only
        frame = np.empty((size[1], size[0], 3), np.uint8) if out is None else out
        top = self.dashboard.top
        self.texture.warp_affine(world_to_out, (size[0], top), frame[:top], pixels_per_unit)
        looks = self.looks if len(snapshot.cars) > 1 else None  # a race's
        if looks is not None:  # the other cars on the ground (sensors/machinery/draw_cars.py)
            fill_footprints(frame[:top], as_matrix(world_to_out), snapshot, looks.colors)
        # the car sits still in this frame: its patch depends on zoom and steering only (the
        # zoom-in's values repeat every episode, so they are worth caching too)
        self.sprite.draw(frame, car, world_to_out, self.skid_width, zoom, self._body_to_out)
        if looks is not None and self.skid_width:  # a video's view: every car's name
            draw_names(frame[:top], as_matrix(world_to_out), snapshot, looks)
        self.dashboard.draw(frame, car, score)
        return frame

    def _body_to_out(self, zoom: float) -> Affine:
        """The car body frame -> output pixels at ``zoom``: the car sits still in the
        frame, so this is the view of a car at the origin, turned by 0."""
        return chase_affine((0.0, 0.0), 0.0, zoom, self.size)


def small_dashboard(size: tuple[int, int]) -> Dashboard:
    """The dashboard of a view of ``size`` (w, h): supersampled on small views."""
    return Dashboard(size[0], size[1], supersample=4 if max(size) <= SMALL_VIEW else 1)


class ChaseViewSensor:
    """The ``chase_view`` sensor: CarRacing's view of the car, the score from the snapshot."""

    def __init__(self, config: ChaseViewConfig, ground: Ground, looks: CarLooks | None = None):
        self.config = config
        self.ground = ground
        self.looks = looks  # a race's colours: the other cars drawn on the ground
        height, width = config.resolution
        self.size = (width, height)
        self.space = spaces.Box(0, 255, (height, width, 3), np.uint8)
        # kept across episodes; made at the first observation (the drawing path's choice
        # imports numba, which gym.make does not)
        self.dashboard: Dashboard | None = None
        self.view: ChaseView | None = None  # on the current episode's ground

    @property
    def id(self) -> str:
        return self.config.id

    def describe(self) -> str:
        return "CarRacing's chase view with its dashboard"

    def top_down(self, snapshot: Snapshot, track: Track) -> TopDown | None:
        return None  # its observation is no picture from above

    def reset(self, track: Track) -> None:
        self.view = None  # a new episode has a new ground

    def observe(self, snapshot: Snapshot, track: Track, rng: np.random.Generator) -> np.ndarray:
        return self._view(track).render(snapshot, snapshot.score)

    def _view(self, track: Track) -> ChaseView:
        """The view on the episode's ground now (a new texture: a new view)."""
        texture = self.ground.texture(track)  # asked each step: visited tiles get repainted
        view = self.view
        if view is None or view.texture is not texture:
            if self.dashboard is None:
                self.dashboard = small_dashboard(self.size)
            view = self.view = ChaseView(self.size, texture, self.dashboard, self.looks)
        return view

    def observe_into(
        self, snapshot: Snapshot, track: Track, rng: np.random.Generator, out: np.ndarray
    ) -> np.ndarray:
        """``observe``'s frame drawn into ``out`` (``DrawsInto``)."""
        return self._view(track).render(snapshot, snapshot.score, out)

    def __getstate__(self) -> dict[str, Any]:
        # the texture belongs to the episode; the dashboard is redrawn when next asked
        fresh: dict[str, Any] = {"view": None, "dashboard": None}
        return {**self.__dict__, **fresh}


def build(entry: ChaseViewConfig, context: SensorContext) -> ChaseViewSensor:
    """A ``chase_view`` sensor from its config entry."""
    return ChaseViewSensor(entry, context.ground, CarLooks.of(context.env))
