"""The driver interface, action adapters and the simplest drivers (constant, random)."""

from __future__ import annotations

import copy
import math
from typing import Any, Protocol, cast, runtime_checkable

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from tinyrace.actions import DISCRETE_CONTROLS
from tinyrace.cars import CarRacingCar

Controls = tuple[float, float, float]  # (steer -1..1, +1 right; gas 0..1; brake 0..1)
CONTROLS_EXPECTED = (
    "expected (steer, gas, brake): three finite numbers (steer -1..1, gas and brake 0..1)"
)


def checked_controls(value: object, who: str) -> Controls:
    """``value`` as controls ``(steer, gas, brake)``: three finite real numbers (not true or
    false, not text); anything else is a ValueError naming ``who`` and the value."""
    items: list[object] | None = None
    if isinstance(value, np.ndarray) and value.ndim == 1:
        items = value.tolist()
    elif isinstance(value, (tuple, list)):
        items = list(value)
    numbers = [
        float(x)
        for x in items or ()
        if isinstance(x, (int, float, np.integer, np.floating))
        and not isinstance(x, (bool, np.bool_))
    ]
    if (
        items is None
        or len(items) != 3
        or len(numbers) != 3
        or not all(map(math.isfinite, numbers))
    ):
        text = repr(value)
        text = text if len(text) <= 60 else text[:57] + "..."
        raise ValueError(f"{who}: controls(pose, speed) returned {text}; {CONTROLS_EXPECTED}")
    return numbers[0], numbers[1], numbers[2]


@runtime_checkable
class Driver(Protocol):
    """What every driver offers; ``reset`` is called after each ``env.reset``."""

    def reset(self, env: gym.Env) -> None: ...

    def act(self, observation: Any, info: dict[str, Any]) -> Any: ...


class ActionAdapter:
    """Turns ``(steer, gas, brake)`` into an action of ``space``.

    By the actions' kind (``ActionSpec.kind``; None: by the space's shape): pedals (Box(3,)),
    the controls themselves, clipped; steer (Box(1,)), the steering only (the kinematic car);
    steer_throttle (Box(2,)), steering and throttle = gas - brake (the kinematic car with
    throttle); discrete (Discrete(5)), see ``DiscreteChooser``. The single-track car's
    angle_speed and rate_accel read the steer as the wheel angle [rad] itself (the car model's
    ``steer_per_rad`` makes it so: + left on its y-up tracks) and take
    the ``speed`` pair (target, now) the driver gives: the target itself, or an acceleration
    toward it; rate_accel turns the wheel at the rate that reaches the wanted angle.
    """

    SPEED_GAIN = 5.0  # [1/s] rate_accel: acceleration per unit of speed error

    def __init__(self, space: spaces.Space[Any], dt: float = 1 / 50, kind: str | None = None):
        self.space = space
        self.dt = dt  # [s]
        shape = getattr(space, "shape", None) or ()
        self.kind = kind or _KIND_BY_SHAPE.get(shape, "discrete")
        self.wheel = 0.0  # [rad] rate_accel: the wheel angle its steering rates give, + left
        self._discrete = DiscreteChooser(dt) if isinstance(space, spaces.Discrete) else None
        if self._discrete is None and not (
            isinstance(space, spaces.Box) and space.shape in ((3,), (2,), (1,))
        ):
            raise ValueError(
                f"drivers know Box(3,), Box(2,), Box(1,) and Discrete(5) actions, not {space}"
            )

    def __call__(self, controls: Controls, speed: tuple[float, float] = (0.0, 0.0)) -> Any:
        if self._discrete is not None:
            return self._discrete.choose(controls)
        steer, gas, brake = controls
        box = cast(spaces.Box, self.space)  # __init__ let only Box and Discrete through
        if self.kind == "angle_speed":
            return np.clip(np.array((steer, speed[0]), np.float32), box.low, box.high)
        if self.kind == "rate_accel":
            low, high = float(box.low[0]), float(box.high[0])
            rate = min(max((steer - self.wheel) / self.dt, low), high)
            self.wheel += rate * self.dt
            accel = self.SPEED_GAIN * (speed[0] - speed[1])
            return np.clip(np.array((rate, accel), np.float32), box.low, box.high)
        by_size: dict[tuple[int, ...], tuple[float, ...]] = {
            (1,): (steer,),
            (2,): (steer, gas - brake),
        }
        values = by_size.get(box.shape, controls)
        return np.clip(np.array(values, np.float32), box.low, box.high)


_KIND_BY_SHAPE: dict[tuple[int, ...], str] = {(3,): "pedals", (2,): "steer_throttle", (1,): "steer"}


class DiscreteChooser:
    """The nearest of CarRacing's five actions to wanted ``(steer, gas, brake)``.

    Nearest in effect, not in value: a discrete turn asks for 0.6 rad, beyond the
    0.4 rad lock, and the steering servo moves at most 3 rad/s, so the chooser
    predicts the front wheels' angle after each action (the wanted steer is read
    as a wheel angle in rad, + right) and compares that; the pedals are compared
    in units of what their action gives (gas 0.2, brake 0.8). One action per
    step cannot steer and accelerate at once, so the pedal error left over (up to
    half an action) is carried to the next step (error diffusion): the pedals
    average out, and a small steering need still wins against a pedal now and then.
    """

    def __init__(self, dt: float, car: CarRacingCar | None = None):
        self.dt = dt  # [s]
        self.car = car or CarRacingCar()
        self.choices = np.array(DISCRETE_CONTROLS, float)
        self.pedals = self.choices[:, 1:] / self.choices[:, 1:].max(axis=0)  # one action = 1
        self.wheel = 0.0  # [rad] + right: the front wheels' angle, as predicted
        self._pedal_error = np.zeros(2)

    def choose(self, controls: Controls) -> int:
        steer, gas, brake = controls
        reach = self.car.steer_speed * self.dt  # [rad] the most the wheels turn in one step
        error = self.choices[:, 0] - self.wheel
        turn = np.sign(error) * np.minimum(self.car.steer_gain * np.abs(error) * self.dt, reach)
        limit = self.car.steer_limit
        wheels = np.clip(self.wheel + turn, -limit, limit)
        goal = np.clip((gas / 0.2, brake / 0.8), 0.0, 1.0) + self._pedal_error
        cost = np.square((wheels - steer) / reach) + np.square(self.pedals - goal).sum(axis=1)
        index = int(np.argmin(cost))
        self.wheel = float(wheels[index])
        self._pedal_error = np.clip(goal - self.pedals[index], -0.5, 0.5)
        return index


class ConstantDriver:
    """Always the same action (in the env's own action space): ``action``, or by default the
    one nearest to doing nothing (0 clipped into a Box, the first of a Discrete), whatever
    the car's actions are."""

    def __init__(self, action: Any = None):
        self.action = action
        self._value: Any = None

    def reset(self, env: gym.Env) -> None:
        space = env.action_space
        if isinstance(space, spaces.Discrete):
            self._value = int(space.start if self.action is None else self.action)
        elif self.action is None and isinstance(space, spaces.Box):
            self._value = np.clip(np.zeros(space.shape), space.low, space.high).astype(space.dtype)
        else:
            self._value = np.asarray(self.action, space.dtype)

    def act(self, observation: Any, info: dict[str, Any]) -> Any:
        return self._value


class RandomDriver:
    """Uniform samples of the action space.

    Seeded per episode from ``seed`` (or the env's seed) and the episode count, on
    its own copy of the space: the env's random streams are left alone.
    """

    def __init__(self, seed: int | None = None) -> None:
        self.seed = seed
        self._space: spaces.Space[Any] | None = None
        self._episodes = 0

    def reset(self, env: gym.Env) -> None:
        self._space = copy.deepcopy(env.action_space)
        seed = self.seed if self.seed is not None else env.unwrapped.np_random_seed
        entropy = np.random.SeedSequence([max(int(seed), 0), self._episodes])
        self._space.seed(int(entropy.generate_state(1)[0]))
        self._episodes += 1

    def act(self, observation: Any, info: dict[str, Any]) -> Any:
        if self._space is None:
            raise RuntimeError("call reset(env) before act()")
        return self._space.sample()
