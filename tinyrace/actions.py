"""Action spaces and their checking: every action becomes plain floats or is refused.

Continuous actions may be any real-valued array-like of the right shape (lists,
tuples, float16/float64 and integer arrays are checked against the bounds, then
cast to float32); a scalar or 0-d array is not of shape (1,). Discrete actions may
be Python or numpy integers, or 0-d integer arrays. Anything else (bools, strings,
complex or object arrays), NaN, infinity or a value outside the space raises
``gymnasium.error.InvalidAction`` naming the space, before anything changes.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.error import InvalidAction

# CarRacing's Discrete(5): action index -> (steer -1..1 [+ right], gas 0..1, brake 0..1),
# each a fraction of full lock, full throttle and full brake.
NOTHING, RIGHT, LEFT, GAS, BRAKE = range(5)  # the action indices
DISCRETE_CONTROLS = (
    (0.0, 0.0, 0.0),
    (0.6, 0.0, 0.0),
    (-0.6, 0.0, 0.0),
    (0.0, 0.2, 0.0),
    (0.0, 0.0, 0.8),
)
_FLOAT32 = np.dtype(np.float32)
ACTION_KINDS = {  # ActionSpec.kind -> what the action's controls are
    "discrete": "CarRacing's Discrete(5): nothing, right, left, gas, brake",
    "pedals": "[steer -1..1 (+ right; + left on tracks in metres), gas 0..1, brake 0..1]",
    "steer": "[steer -1..1 (+ right)]",
    "steer_throttle": "[steer -1..1 (+ left on tracks in metres), throttle -1..1 (< 0 brakes)]",
    "angle_speed": "[steering angle rad (+ left), speed m/s]",
    "rate_accel": "[steering velocity rad/s (+ left), acceleration m/s^2]",
}


@dataclass(frozen=True)
class ActionSpec:
    """How actions look for one car: the gymnasium space and how to read an action."""

    space: spaces.Box | spaces.Discrete
    kind: str  # what the controls mean, in order (see ``ACTION_KINDS``)

    @classmethod
    def box(cls, low: tuple[float, ...], high: tuple[float, ...], kind: str) -> ActionSpec:
        """A float32 Box from ``low`` to ``high`` whose controls mean ``kind``."""
        lows, highs = np.array(low, np.float32), np.array(high, np.float32)
        return cls(spaces.Box(lows, highs, dtype=np.float32), kind)

    @classmethod
    def discrete(cls) -> ActionSpec:
        """CarRacing's Discrete(5) (``DISCRETE_CONTROLS``)."""
        return cls(spaces.Discrete(len(DISCRETE_CONTROLS)), "discrete")

    def __post_init__(self) -> None:
        if isinstance(self.space, spaces.Box):  # plain floats: cheaper to compare per step
            bounds = list(zip(self.space.low.tolist(), self.space.high.tolist(), strict=True))
            object.__setattr__(self, "_bounds", bounds)
            object.__setattr__(self, "_shape", self.space.shape)

    _bounds: list[tuple[float, float]] = dataclasses.field(
        default_factory=list, init=False, repr=False, compare=False
    )  # Box bounds as floats
    _shape: tuple[int, ...] = dataclasses.field(default=(), init=False, repr=False, compare=False)

    def read(self, action: object) -> tuple[float, ...]:
        """The controls of a valid action, in the order of its kind (see ``ACTION_KINDS``)."""
        if self.kind == "discrete":
            return DISCRETE_CONTROLS[self._index(action)]
        # the common case, a float32 array of the space's shape, checked without numpy calls
        # (native float32 is one dtype object; any other dtype takes the general path)
        if type(action) is np.ndarray and action.dtype is _FLOAT32 and action.shape == self._shape:
            values = action.tolist()
            for value, (low, high) in zip(values, self._bounds, strict=True):
                if not low <= value <= high:  # NaN too: checked and refused below
                    break
            else:
                return tuple(values)
        return tuple(self._vector(action).tolist())

    def _index(self, action: object) -> int:
        if isinstance(action, np.ndarray) and action.shape == () and action.dtype.kind in "iu":
            action = action.item()
        if not isinstance(action, (int, np.integer)) or isinstance(action, (bool, np.bool_)):
            raise InvalidAction(f"action {action!r} is not an integer of {self.space}")
        assert isinstance(self.space, spaces.Discrete)
        if not 0 <= action < self.space.n:
            raise InvalidAction(f"action {action!r} is outside {self.space}")
        return int(action)

    def _vector(self, action: object) -> np.ndarray:
        # subclasses (masked arrays, matrices) become plain arrays: tolist() must give floats
        array = action if type(action) is np.ndarray else _as_array(action, self.space)
        if array.dtype.kind not in "fiu":
            raise InvalidAction(
                f"action {action!r} of dtype {array.dtype} is not real-valued; space {self.space}"
            )
        if array.shape != self.space.shape:
            raise InvalidAction(f"action of shape {array.shape} does not fit {self.space}")
        # bounds before the cast: a float64 beyond float32's range would warn as it became inf
        assert isinstance(self.space, spaces.Box)
        if not (np.all(array >= self.space.low) and np.all(array <= self.space.high)):
            raise InvalidAction(f"action {array.tolist()} is outside {self.space} (NaN included)")
        return array.astype(np.float32, copy=False)


def _as_array(action: object, space: spaces.Space[Any]) -> np.ndarray:
    try:
        return np.asarray(action)
    except (TypeError, ValueError) as exc:
        raise InvalidAction(f"action {action!r} is not an array for {space}") from exc
