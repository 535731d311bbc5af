"""Following a line: CarRacing's centreline, or an image track's drawn trajectory."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, cast

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from tinyrace.cars import CARRACING_WHEELBASE
from tinyrace.drivers.base import ActionAdapter, Controls
from tinyrace.drivers.loop import number_argument

if TYPE_CHECKING:
    from tinyrace.env import TinyRaceEnv


SCALED = ": CarRacing's units, 1 u = the car's wheelbase / 3.24"  # the knobs' unit, in errors


@dataclass(frozen=True)
class Route:
    """The line a driver follows, with what it needs to read poses and speeds on it."""

    points: np.ndarray  # (N, 2) [track units] in driving order
    closed: bool  # the last point joins the first
    y_down: bool  # image tracks: y grows downwards and headings grow clockwise
    unit: float  # [track units per u]: distances and speeds scale with the car
    steer_lock: float  # [rad] the front wheels' largest angle
    steer_per_rad: float  # steering action per rad of wheel angle to the right
    grip: float = math.inf  # [track units/s^2] what the tyres hold (inf: no slip model)


def route_of(env: gym.Env) -> Route:
    """The route of the env's current track: the procedural centreline, or the trajectory
    drawn into an image track (``reward_design.cross_track_error.use_cte``), put in order
    from the car's pose."""
    unwrapped = cast("TinyRaceEnv", env.unwrapped)
    track, car, facts = unwrapped.track, unwrapped.car, unwrapped.car_facts
    unit = car.footprint[0] / CARRACING_WHEELBASE  # the car's wheelbase sets the scale
    steering = {
        "steer_lock": facts.steer_lock,
        "steer_per_rad": facts.steer_per_rad,
        "grip": facts.grip,
    }
    if track.centerline is not None:
        return Route(np.asarray(track.centerline, float), True, False, unit, **steering)
    if track.reference_note is not None:  # a track that says why it has no line
        raise ValueError(f"the centerline driver needs a line to follow: {track.reference_note}")
    pixels = track.trajectory_points
    if pixels is None or len(pixels) == 0:
        raise ValueError(
            "the centerline driver needs a line to follow: a procedural track, or an image "
            "track with reward_design.cross_track_error.use_cte and its trajectory_color"
        )
    spacing = 0.25 * car.footprint[0]  # [px] a quarter of the wheelbase
    points, closed = order_path(np.asarray(pixels, float), car.pose, spacing)
    return Route(points, closed, True, unit, **steering)


def order_path(
    pixels: np.ndarray, pose: Sequence[float], spacing: float
) -> tuple[np.ndarray, bool]:
    """Points ``spacing`` apart along a drawn line (an unordered (K, 2) pixel set), starting
    near ``pose`` and leaving it along its heading; and whether the line closes."""
    cells, inverse = np.unique(np.floor(pixels / spacing), axis=0, return_inverse=True)
    inverse = inverse.ravel()
    counts = np.bincount(inverse, minlength=len(cells))[:, None]
    points = (
        np.column_stack(
            [np.bincount(inverse, weights=pixels[:, k], minlength=len(cells)) for k in (0, 1)]
        )
        / counts
    )  # the mean pixel of each grid cell
    x, y, heading = pose
    direction = np.array([math.cos(heading), math.sin(heading)])
    current = int(np.argmin(np.hypot(points[:, 0] - x, points[:, 1] - y)))
    free = np.ones(len(points), bool)
    order = [current]
    free[current] = False
    while True:
        offsets = points - points[current]
        distance = np.hypot(offsets[:, 0], offsets[:, 1])
        near = free & (distance < 2.5 * spacing)
        ahead = near & (offsets @ direction > 0)
        candidates = np.flatnonzero(ahead if ahead.any() else near)
        if len(candidates) == 0:
            break
        step = int(candidates[np.argmin(distance[candidates])])
        direction = offsets[step] / max(distance[step], 1e-9)
        free[distance < 0.75 * spacing] = False  # a thick line leaves neighbours to skip
        current = step
        order.append(step)
        free[step] = False
    path = points[order]
    closed = len(path) > 2 and np.hypot(*(path[-1] - path[0])) < 3 * spacing
    if closed:
        path = np.concatenate((path, path[:1]))
    # even spacing: grid cells cut by the line leave some means close together
    arc = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(path, axis=0).T))))
    at = np.arange(0.0, arc[-1] - (0.5 * spacing if closed else -1e-9), spacing)
    even = np.column_stack((np.interp(at, arc, path[:, 0]), np.interp(at, arc, path[:, 1])))
    return even, bool(closed)


class CenterlineDriver:
    """Pure pursuit on the track's centre line, with a speed profile from its curvature.

    Steering aims at the route point ``lookahead`` ahead of the nearest one; the
    target speed at each point is the highest that keeps the lateral acceleration
    under ``lateral_accel`` there and allows braking (at ``brake_accel``) for every
    curve further on. Gas below the target (less with the wheels turned: a
    rear-wheel-drive car spins under full gas in a curve), coast near it, brake
    when well above.

    The route is the procedural track's ``centerline`` or an image track's drawn
    trajectory (see ``route_of``); the pose is ``info["pose"]`` (x, y, heading).
    Lengths, speeds and accelerations below are in CarRacing's units (u, u/s, u/s^2) scaled
    by the car: 1 u = the car's wheelbase / ``CARRACING_WHEELBASE`` (3.24 u), so on
    CarRacing's tracks u itself, and on metric tracks 0.102 m for a 0.33 m F1TENTH car (42 u/s
    = 4.3 m/s) or 0.77 m for a 2.5 m car; ``offset`` alone is in track units, and
    ``lookahead_per_speed`` [s] multiplies the speed in track units/s (docs/experiments.md
    lists every knob). The kinematic car's speed is fixed: there the driver only steers. A
    car with a tyre model (``grip``) keeps the profile's lateral and braking accelerations
    under ``grip_share`` of its grip; a car whose actions are a steering angle and a speed
    (the single-track car) is given the profile's speed. ``offset`` [track units] moves the
    line followed to the left (negative: right) of the route: cars of a race on lanes of
    their own.
    """

    def __init__(
        self,
        lookahead: float = 3.0,  # [u] pursuit distance at standstill
        lookahead_per_speed: float = 0.22,  # [s] extra pursuit distance per track unit/s
        top_speed: float = 95.0,  # [u/s]
        lateral_accel: float = 140.0,  # [u/s^2] cornering grip used by the speed profile
        brake_accel: float = 90.0,  # [u/s^2] deceleration planned for curves ahead
        brake_margin: float = 8.0,  # [u/s] brake only this much above the target
        gas_gain: float = 0.2,  # [s/u] gas per u/s below the target speed
        corner_gas_cut: float = 0.7,  # fraction of gas taken away at full lock
        grip_share: float = 0.35,  # of the tyres' grip the speed profile plans with
        offset: float = 0.0,  # [track units] follow a line this far left of the route (- right)
    ):
        self.grip_share = number_argument("grip_share", grip_share, low=0.0, above=True)
        self.offset = number_argument("offset", offset, unit="track units, + left")
        self.lookahead = number_argument("lookahead", lookahead, 0.0, unit=f"u{SCALED}")
        self.lookahead_per_speed = number_argument(
            "lookahead_per_speed", lookahead_per_speed, 0.0, unit="s"
        )
        self.top_speed = number_argument(
            "top_speed", top_speed, unit=f"u/s{SCALED}", low=0.0, above=True
        )
        self.lateral_accel = number_argument(
            "lateral_accel", lateral_accel, unit=f"u/s^2{SCALED}", low=0.0, above=True
        )
        self.brake_accel = number_argument(
            "brake_accel", brake_accel, unit=f"u/s^2{SCALED}", low=0.0, above=True
        )
        self.brake_margin = number_argument("brake_margin", brake_margin, 0.0, unit=f"u/s{SCALED}")
        self.gas_gain = number_argument("gas_gain", gas_gain, 0.0, unit=f"s/u{SCALED}")
        self.corner_gas_cut = number_argument("corner_gas_cut", corner_gas_cut, 0.0, 1.0)
        self.route: Route | None = None
        self.target_speeds = np.zeros(0)  # [track units/s] per route point
        self._spacing = 1.0  # [track units] mean distance between route points
        self._nearest = -1
        self._adapt: ActionAdapter | None = None

    def reset(self, env: gym.Env) -> None:
        unwrapped = cast("TinyRaceEnv", env.unwrapped)  # in a race: its car's CarView
        self.follow(route_of(env), env.action_space, unwrapped.dt, unwrapped.action_spec.kind)

    def follow(
        self, route: Route, action_space: spaces.Space[Any], dt: float, kind: str | None = None
    ) -> None:
        """Start on ``route`` (what ``reset`` does with the env's route); ``dt`` [s] per step;
        ``kind`` the actions' (``ActionSpec.kind``; None: read from the space's shape)."""
        if self.offset:
            route = dataclasses.replace(route, points=offset_line(route, self.offset))
        self.route = route
        steps = np.linalg.norm(np.diff(route.points, axis=0), axis=1)
        self._spacing = float(steps.mean()) if len(steps) else 1.0
        self.target_speeds = speed_profile(
            route.points,
            self.top_speed * route.unit,
            min(self.lateral_accel * route.unit, self.grip_share * route.grip),
            min(self.brake_accel * route.unit, self.grip_share * route.grip),
            route.closed,
        )
        self._nearest = -1  # unknown: search the whole route once
        self._adapt = ActionAdapter(action_space, dt, kind)
        self._speed = (0.0, 0.0)  # [track units/s] (target, now) at the last controls

    def act(self, observation: Any, info: dict[str, Any]) -> Any:
        if self._adapt is None:
            raise RuntimeError("call reset(env) before act()")
        controls = self.controls(info["pose"], info["speed"])
        return self._adapt(controls, self._speed)

    def controls(self, pose: Sequence[float], speed: float) -> Controls:
        """(steer, gas, brake) for the car at ``pose`` moving at ``speed`` [track units/s]."""
        route = self._following()
        x, y, heading = pose
        nearest = self._find_nearest(x, y)
        ahead = (self.lookahead * route.unit + self.lookahead_per_speed * speed) / self._spacing
        target = route.points[self._index(nearest + round(ahead))]
        bearing = math.atan2(target[1] - y, target[0] - x) - heading
        bearing = (bearing + math.pi) % (2 * math.pi) - math.pi  # [rad] toward growing heading
        distance = math.hypot(target[0] - x, target[1] - y)
        curvature = 2.0 * math.sin(bearing) / max(distance, 1e-6)  # [1/track unit]
        wheel = math.atan(CARRACING_WHEELBASE * route.unit * curvature)  # [rad]
        wheel = min(max(wheel, -route.steer_lock), route.steer_lock)
        right = wheel if route.y_down else -wheel  # growing headings turn right on y-down
        steer = right * route.steer_per_rad
        # look at the speed limit a little ahead: the car reacts with a delay
        limit = self.target_speeds[self._index(nearest + 2)]
        grip_left = 1.0 - self.corner_gas_cut * abs(wheel) / route.steer_lock
        gas_gain = self.gas_gain / route.unit
        gas = min(max((limit - speed) * gas_gain, 0.0), 1.0) * grip_left
        brake = 0.8 if speed > limit + self.brake_margin * route.unit else 0.0
        self._speed = (float(limit), speed)
        return steer, gas, brake

    def _following(self) -> Route:
        if self.route is None:
            raise RuntimeError("call reset(env) or follow(route, ...) first")
        return self.route

    def _index(self, i: int) -> int:
        route = self._following()
        n = len(route.points)
        return i % n if route.closed else min(i, n - 1)

    def _find_nearest(self, x: float, y: float) -> int:
        """Nearest route index, searched near the last one (a track may pass close by)."""
        route = self._following()
        n = len(route.points)
        if self._nearest < 0:
            candidates = np.arange(n)
        else:
            candidates = np.arange(self._nearest - 5, self._nearest + 25)
            candidates = candidates % n if route.closed else candidates.clip(0, n - 1)
        offsets = route.points[candidates] - (x, y)
        best = int(candidates[np.argmin(np.einsum("ij,ij->i", offsets, offsets))])
        self._nearest = best
        return best


def offset_line(route: Route, offset: float) -> np.ndarray:
    """The route's points moved ``offset`` [track units] to the driver's left (negative: to
    the right), across the direction of travel at each point: a lane beside the line."""
    points = np.asarray(route.points, float)
    if len(points) < 2:
        return points
    ahead = np.roll(points, -1, axis=0) if route.closed else np.vstack((points[1:], points[-1:]))
    behind = np.roll(points, 1, axis=0) if route.closed else np.vstack((points[:1], points[:-1]))
    direction = ahead - behind
    direction /= np.maximum(np.linalg.norm(direction, axis=1, keepdims=True), 1e-12)
    left = np.column_stack((-direction[:, 1], direction[:, 0]))  # y up: turned +90 deg
    if route.y_down:  # image tracks: y grows downwards, the driver's left is the other way
        left = -left
    moved: np.ndarray = points + offset * left
    return moved


def speed_profile(
    points: np.ndarray,
    top_speed: float,
    lateral_accel: float,
    brake_accel: float,
    closed: bool = True,
) -> np.ndarray:
    """(N,) target speeds along a polyline: grip-limited and braking-feasible.

    Units follow the points': speeds in units/s, accelerations in units/s^2.
    """
    forward = np.roll(points, -1, axis=0) - points
    if not closed:
        forward[-1] = forward[-2] if len(points) > 1 else (1.0, 0.0)
    headings = np.arctan2(forward[:, 1], forward[:, 0])
    turn = np.angle(np.exp(1j * (headings - np.roll(headings, 1))))  # [rad] wrapped
    if not closed:
        turn[0] = 0.0
    spacing = np.linalg.norm(forward, axis=1)
    # curvature over a few points: single steps are noisy on sharp corners
    kernel = np.ones(5)
    turn_sum = np.convolve(np.concatenate((turn[-2:], turn, turn[:2])), kernel, "valid")
    arc = np.convolve(np.concatenate((spacing[-2:], spacing, spacing[:2])), kernel, "valid")
    curvature = np.abs(turn_sum) / np.maximum(arc, 1e-9)
    speeds = np.minimum(top_speed, np.sqrt(lateral_accel / np.maximum(curvature, 1e-12)))
    # braking: v_i^2 <= v_{i+1}^2 + 2 a d, swept backwards (twice round a closed lap)
    n = len(speeds)
    for k in range(2 * n - 1 if closed else n - 2, -1, -1):
        i, j = k % n, (k + 1) % n
        speeds[i] = min(speeds[i], math.sqrt(speeds[j] ** 2 + 2 * brake_accel * spacing[i]))
    return speeds
