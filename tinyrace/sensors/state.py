"""State core: the car's own motion as one float32 vector, in the car's frame.

Car frame: x ahead, y to the left; angles and rates are positive to the left
(counter-clockwise seen from above) on y-up and y-down tracks alike. Components, in order:

| name | unit | meaning |
|---|---|---|
| speed_long | track units/s | body velocity along the car's heading |
| speed_lat | track units/s | body velocity to the car's left |
| yaw_rate | rad/s | turn rate, + left |
| steer | rad | front-wheel angle, + left |
| wheel_speed_{fl,fr,rl,rr} | track units/s | rim speed (spin x radius), dynamic car only |
| slip_{fl,fr,rl,rr} | track units/s | rim speed less body speed along the wheel, dynamic car |
| x, y | track units | reference point, with ``pose`` (bounds below) |
| heading | rad | in the track's own convention, wrapped to [-pi, pi), with ``pose`` |

Bounds of x and y: on procedural tracks the playfield (leaving it ends the episode) widened by
one step's top travel and the car's length, so that even the last pose is inside; elsewhere
unbounded, because the track's extent (a picture's size, a centreline's or a map's reach) is
read when a track is drawn at reset, after the observation space is fixed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from gymnasium import spaces

from tinyrace.cars.state import CarFacts, CarState
from tinyrace.config import EnvConfig
from tinyrace.config.sensors import StateConfig
from tinyrace.sensors.base import SensorContext, TopDown
from tinyrace.tracks.base import Track
from tinyrace.world.snapshot import Snapshot

WHEELS = ("fl", "fr", "rl", "rr")
MOTION = ("speed_long", "speed_lat", "yaw_rate", "steer")


def fields(wheels: bool, pose: bool) -> tuple[str, ...]:
    """Names of the vector's components, in order."""
    names: tuple[str, ...] = MOTION
    if wheels:
        names += tuple(f"wheel_speed_{w}" for w in WHEELS) + tuple(f"slip_{w}" for w in WHEELS)
    if pose:
        names += ("x", "y", "heading")
    return names


def state_vector(car: CarState, y_down: bool, wheels: bool, pose: bool) -> np.ndarray:
    """The components named by ``fields(wheels, pose)`` for ``car``, float32."""
    x, y, heading = car.pose
    vx, vy = car.velocity
    c, s = math.cos(heading), math.sin(heading)
    turn = -1.0 if y_down else 1.0  # y-down headings grow clockwise: left is negative
    speed_long = vx * c + vy * s
    speed_lat = turn * (vy * c - vx * s)
    values = [speed_long, speed_lat, turn * car.yaw_rate, turn * car.steer]
    if wheels:
        rims = [w.omega * w.radius for w in car.wheels]
        ground = [
            speed_long * math.cos(turn * w.steer) + speed_lat * math.sin(turn * w.steer)
            for w in car.wheels
        ]
        values += rims + [rim - g for rim, g in zip(rims, ground, strict=True)]
    if pose:
        values += [x, y, (heading + math.pi) % (2 * math.pi) - math.pi]
    return np.array(values, np.float32)


@dataclass(frozen=True)
class Limits:
    """Bounds of the vector's components that the car model cannot pass."""

    speed: float  # [track units/s] top speed (the dynamic car's per-step travel cap)
    yaw_rate: float  # [rad/s]
    steer: float  # [rad] full lock
    extent: float = math.inf  # [track units] |x| and |y| of the pose (see the module's doc)

    def bounds(self, names: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray]:
        """(low, high) float32 per component; wheel rims may spin up to 10x the top speed."""
        by_name = {"speed_long": self.speed, "speed_lat": self.speed, "yaw_rate": self.yaw_rate}
        by_name.update(steer=self.steer, heading=math.pi, x=self.extent, y=self.extent)
        high = np.array(
            [by_name.get(n, 10 * self.speed) for n in names], np.float32
        )  # wheel_speed_*, slip_*
        return -high, high


def limits(env: EnvConfig, car: CarFacts) -> Limits:
    """The configured car's limits: top speed, yaw rate, steering lock and pose extent."""
    fps = env.sim.fps or 50.0
    motion = Limits(car.top_speed, car.yaw_rate, car.steer_lock)
    extents = [track.pose_extent() for track in env.tracks]
    if None in extents:
        return motion
    # the playfield bounds the body's centre after a step (the next one ends the episode)
    playfield = max(e for e in extents if e is not None)
    return replace(motion, extent=playfield + motion.speed / fps + car.length)


class StateSensor:
    """``type: state``: the controlled car's motion (see the module's table), float32."""

    def __init__(self, config: StateConfig, wheels: bool, y_down: bool, bounds: Limits):
        self.config = config
        self.wheels = wheels
        self.y_down = y_down
        self.fields = fields(wheels, config.pose)
        low, high = bounds.bounds(self.fields)
        self.space = spaces.Box(low, high, dtype=np.float32)

    @property
    def id(self) -> str:
        return self.config.id

    def describe(self) -> str:
        return "the car's " + ", ".join(self.fields)

    def top_down(self, snapshot: Snapshot, track: Track) -> TopDown | None:
        return None  # its observation is no picture from above

    def reset(self, track: Track) -> None:
        self.y_down = track.y_down

    def observe(self, snapshot: Snapshot, track: Track, rng: np.random.Generator) -> np.ndarray:
        vector = state_vector(snapshot.car, self.y_down, self.wheels, self.config.pose)
        np.minimum(vector, self.space.high, out=vector)  # np.clip's wrapper costs more
        clamped: np.ndarray = np.maximum(vector, self.space.low, out=vector)
        return clamped


def build(config: StateConfig, context: SensorContext) -> StateSensor:
    """The state sensor of ``config``: wheel speeds and slips when the car models wheels."""
    env = context.env
    bounds = limits(env, context.car)
    return StateSensor(config, context.car.wheels, y_down=env.facts.y_down, bounds=bounds)
