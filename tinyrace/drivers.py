"""Built-in drivers: policies that need no training, for baselines, demos and tests.

A driver is set up once per episode with ``reset(env)`` (after ``env.reset``)
and then asked for one action per step with ``act(observation, info)``. Drivers
speak the env's own action space: they think in CarRacing's controls
``(steer, gas, brake)`` (steer -1 full left .. +1 full right) and convert to a
Box, or to the nearest action of CarRacing's Discrete(5).

>>> import gymnasium as gym, tinyrace
>>> from tinyrace.drivers import make_driver
>>> env = gym.make("tinyrace/CarRacing-v0")
>>> driver = make_driver("centerline")
>>> observation, info = env.reset(seed=0)
>>> driver.reset(env)
>>> observation, reward, terminated, truncated, info = env.step(driver.act(observation, info))
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any, Protocol, runtime_checkable

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from tinyrace.actions import DISCRETE_CONTROLS

Controls = tuple[float, float, float]  # (steer -1..1, +1 right; gas 0..1; brake 0..1)


@runtime_checkable
class Driver(Protocol):
    """What every driver offers; ``reset`` is called after each ``env.reset``."""

    def reset(self, env: gym.Env) -> None: ...

    def act(self, observation: Any, info: dict[str, Any]) -> Any: ...


class ActionAdapter:
    """Turns ``(steer, gas, brake)`` into an action of ``space``.

    Box(3,): the controls themselves, clipped; Box(1,): the steering only (the
    kinematic car); Discrete(5): the nearest of CarRacing's five actions, after
    capping gas and brake at what those actions can give.
    """

    def __init__(self, space: spaces.Space):
        self.space = space
        if isinstance(space, spaces.Discrete):
            self._choices = np.array(DISCRETE_CONTROLS[: space.n], float)
            self._cap = self._choices.max(axis=0)  # gas 0.2, brake 0.8: the most on offer
        elif not (isinstance(space, spaces.Box) and space.shape in ((3,), (1,))):
            raise ValueError(f"drivers know Box(3,), Box(1,) and Discrete(5) actions, not {space}")

    def __call__(self, controls: Controls) -> Any:
        steer, gas, brake = controls
        if isinstance(self.space, spaces.Discrete):
            wanted = np.minimum((steer, gas, brake), self._cap)
            wanted[0] = max(wanted[0], -self._cap[0])
            return int(np.argmin(np.square(self._choices - wanted).sum(axis=1)))
        low, high = self.space.low, self.space.high
        values = (steer,) if self.space.shape == (1,) else (steer, gas, brake)
        return np.clip(np.array(values, np.float32), low, high)


class ConstantDriver:
    """Always the same action (in the env's own action space)."""

    def __init__(self, action: Any = (0.0, 0.0, 0.0)):
        self.action = action
        self._value: Any = None

    def reset(self, env: gym.Env) -> None:
        space = env.action_space
        if isinstance(space, spaces.Discrete):
            self._value = int(self.action)
        else:
            self._value = np.asarray(self.action, space.dtype)

    def act(self, observation: Any, info: dict[str, Any]) -> Any:
        return self._value


class RandomDriver:
    """Uniform samples of the action space, seeded from the env's ``np_random``."""

    def __init__(self) -> None:
        self._space: spaces.Space | None = None

    def reset(self, env: gym.Env) -> None:
        self._space = env.action_space
        # a child generator: reproducible per seed, and the env's own stream is left alone
        self._space.seed(int(env.unwrapped.np_random.integers(2**31)))

    def act(self, observation: Any, info: dict[str, Any]) -> Any:
        return self._space.sample()


class CenterlineDriver:
    """Pure pursuit on the track's centreline, with a speed profile from its curvature.

    Steering aims at the centreline point ``lookahead`` ahead of the nearest one;
    the target speed at each point is the highest that keeps the lateral
    acceleration under ``lateral_accel`` there and allows braking (at
    ``brake_accel``) for every curve further on. Gas below the target, coast
    near it, brake when well above.

    Reads ``env.unwrapped.track.centerline`` ((N, 2), in driving order) at reset
    and the car's ``info["pose"]`` (x, y, heading; heading counter-clockwise from
    +x, y up) each step.
    """

    def __init__(
        self,
        lookahead: float = 9.0,  # [u] pursuit distance at standstill
        lookahead_per_speed: float = 0.12,  # [s] extra pursuit distance per u/s
        wheelbase: float = 3.24,  # [u] CarRacing's car, axle to axle
        max_wheel_angle: float = 0.4,  # [rad] a steer action of 1 asks for 1 rad; lock is 0.4
        top_speed: float = 95.0,  # [u/s]
        lateral_accel: float = 140.0,  # [u/s^2] cornering grip used by the speed profile
        brake_accel: float = 90.0,  # [u/s^2] deceleration planned for curves ahead
        brake_margin: float = 4.0,  # [u/s] brake only this much above the target
        gas_gain: float = 0.2,  # [s/u] gas per u/s below the target speed
        corner_gas_cut: float = 0.7,  # fraction of gas taken away at full lock
    ):
        self.gas_gain = gas_gain
        self.corner_gas_cut = corner_gas_cut
        self.lookahead = lookahead
        self.lookahead_per_speed = lookahead_per_speed
        self.wheelbase = wheelbase
        self.max_wheel_angle = max_wheel_angle
        self.top_speed = top_speed
        self.lateral_accel = lateral_accel
        self.brake_accel = brake_accel
        self.brake_margin = brake_margin
        self.points = np.zeros((0, 2))
        self.target_speeds = np.zeros(0)
        self._spacing = 1.0  # [u] mean distance between centreline points
        self._nearest = 0
        self._adapt: ActionAdapter | None = None

    def reset(self, env: gym.Env) -> None:
        track = env.unwrapped.track
        self.points = np.asarray(track.centerline, float)
        steps = np.linalg.norm(np.roll(self.points, -1, axis=0) - self.points, axis=1)
        self._spacing = float(steps.mean())
        self.target_speeds = speed_profile(
            self.points, self.top_speed, self.lateral_accel, self.brake_accel
        )
        self._nearest = -1  # unknown: search the whole lap once
        self._adapt = ActionAdapter(env.action_space)

    def act(self, observation: Any, info: dict[str, Any]) -> Any:
        return self._adapt(self.controls(info["pose"], info["speed"]))

    def controls(self, pose: Sequence[float], speed: float) -> Controls:
        """(steer, gas, brake) for the car at ``pose`` moving at ``speed`` [u/s]."""
        x, y, heading = pose
        nearest = self._find_nearest(x, y)
        ahead = self.lookahead + self.lookahead_per_speed * speed  # [u]
        target = self.points[(nearest + round(ahead / self._spacing)) % len(self.points)]
        bearing = math.atan2(target[1] - y, target[0] - x) - heading
        bearing = (bearing + math.pi) % (2 * math.pi) - math.pi  # [rad] + is to the left
        distance = math.hypot(target[0] - x, target[1] - y)
        curvature = 2.0 * math.sin(bearing) / max(distance, 1e-6)  # [1/u] pure pursuit
        wheel_angle = math.atan(self.wheelbase * curvature)  # [rad] + turns left
        steer = -min(max(wheel_angle, -self.max_wheel_angle), self.max_wheel_angle)
        # look at the speed limit a little ahead: the car reacts with a delay
        limit = self.target_speeds[(nearest + 2) % len(self.points)]
        # full gas with the wheels turned spins a rear-wheel-drive car: less gas, more lock
        grip_left = 1.0 - self.corner_gas_cut * abs(steer) / self.max_wheel_angle
        gas = min(max((limit - speed) * self.gas_gain, 0.0), 1.0) * grip_left
        brake = 0.8 if speed > limit + self.brake_margin else 0.0
        return steer, gas, brake

    def _find_nearest(self, x: float, y: float) -> int:
        """Nearest centreline index, searched near the last one (tracks may pass close by)."""
        n = len(self.points)
        if self._nearest < 0:
            candidates = np.arange(n)
        else:
            candidates = np.arange(self._nearest - 5, self._nearest + 25) % n
        offsets = self.points[candidates] - (x, y)
        best = int(candidates[np.argmin(np.einsum("ij,ij->i", offsets, offsets))])
        self._nearest = best
        return best


def speed_profile(
    points: np.ndarray, top_speed: float, lateral_accel: float, brake_accel: float
) -> np.ndarray:
    """(N,) target speeds [u/s] along a closed polyline: grip-limited, braking-feasible."""
    forward = np.roll(points, -1, axis=0) - points
    headings = np.arctan2(forward[:, 1], forward[:, 0])
    turn = np.angle(np.exp(1j * (headings - np.roll(headings, 1))))  # [rad] wrapped
    spacing = np.linalg.norm(forward, axis=1)  # [u]
    # curvature over a few points: single steps are noisy on sharp corners
    kernel = np.ones(5)
    turn_sum = np.convolve(np.concatenate((turn[-2:], turn, turn[:2])), kernel, "valid")
    curvature = np.abs(turn_sum) / (5 * spacing.mean())  # [1/u]
    speeds = np.minimum(top_speed, np.sqrt(lateral_accel / np.maximum(curvature, 1e-9)))
    # braking: v_i^2 <= v_{i+1}^2 + 2 a d, swept backwards twice round the closed lap
    n = len(speeds)
    for k in range(2 * n - 1, -1, -1):
        i, j = k % n, (k + 1) % n
        speeds[i] = min(speeds[i], math.sqrt(speeds[j] ** 2 + 2 * brake_accel * spacing[i]))
    return speeds


DriverFactory = Callable[..., Driver]

DRIVERS: dict[str, DriverFactory] = {
    "random": RandomDriver,
    "constant": ConstantDriver,
    "centerline": CenterlineDriver,
}


def make_driver(name: str, **kwargs: Any) -> Driver:
    """A driver by registry name; raises ValueError listing the valid names."""
    factory = DRIVERS.get(name)
    if factory is None:
        raise ValueError(f"unknown driver {name!r}; valid drivers: {', '.join(sorted(DRIVERS))}")
    return factory(**kwargs)


def run_episode(
    env: gym.Env, driver: Driver, seed: int | None = None, max_steps: int | None = None
) -> tuple[float, int, dict[str, Any]]:
    """Drive one episode; returns (return, steps, last info)."""
    observation, info = env.reset(seed=seed)
    driver.reset(env)
    total, steps = 0.0, 0
    while max_steps is None or steps < max_steps:
        observation, reward, terminated, truncated, info = env.step(driver.act(observation, info))
        total += float(reward)
        steps += 1
        if terminated or truncated:
            break
    return total, steps, info
