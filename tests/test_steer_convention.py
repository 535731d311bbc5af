"""One steering convention per kind of track, whatever the car model (docs/conventions.md):
a positive steering command turns right on CarRacing's procedural tracks (as CarRacing)
and on image tracks (as tinycarlo), left on tracks in metres (as ROS, F1TENTH and
CommonRoad); CarRacing's Discrete(5) ``right`` turns right everywhere."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import tinyrace  # noqa: F401  (registers the env ids)
from tinyrace.actions import GAS, RIGHT
from tinyrace.cars.registry import CAR_MODELS, POSITIVE_STEER_TURNS
from tinyrace.config.schema import track_types_in

TRACKS = {  # one shipped track of every kind: (environment, its unit)
    "procedural": (None, "u"),
    "image": ("formula_student", "px"),
    "centerline": ("circuit", "m"),
    "cone_map": ("autocross", "m"),
    "ros_map": ("f1tenth_loop", "m"),
}
POSITIVE = {  # a positive steering command of each action kind, moving the car
    "pedals": [0.6, 0.6, 0.0],
    "steer": [0.6],
    "steer_throttle": [0.6, 0.6],
    "angle_speed": [0.3, 3.0],
    "rate_accel": [2.0, 4.0],
}
SHIPPED = sorted(
    name for name, m in CAR_MODELS.items() if m.build.__module__.startswith("tinyrace.")
)
CASES = [
    (model, actions, kind)
    for model in SHIPPED
    for actions in sorted(CAR_MODELS[model].action_kinds)
    for kind, (_, unit) in TRACKS.items()
    if unit in CAR_MODELS[model].track_units
]


def turn_after(model: str, actions: str, kind: str) -> str:
    """Where the car turns (left or right, as seen from its seat) under a positive command
    (CarRacing's ``right`` for Discrete(5), after a little gas)."""
    environment, _ = TRACKS[kind]
    keys: dict[str, Any] = {} if environment is None else {"environment": environment}
    env = gym.make("tinyrace/TinyRace-v0", car={"model": model, "actions": actions}, **keys)
    raw: Any = env.unwrapped
    _, info = env.reset(seed=0)
    heading = info["pose"][2]
    spec = raw.action_spec
    action: Any
    for step in range(40):
        if spec.kind == "discrete":
            action = GAS if step < 10 else RIGHT
        else:
            action = np.array(POSITIVE[spec.kind], np.float32)
        _, _, terminated, truncated, info = env.step(action)
        assert not (terminated or truncated)
    env.close()
    change = info["pose"][2] - heading  # [rad] counter-clockwise with y up
    assert abs(change) > 0.02, f"the car hardly turned ({change} rad)"
    left = change > 0 if not raw.layout.y_down else change < 0
    return "left" if left else "right"


def test_every_shipped_model_and_track_kind_is_covered():
    assert {kind for _, _, kind in CASES} == set(TRACKS)
    assert {model for model, _, _ in CASES} == set(SHIPPED) >= {"dynamic", "single_track"}
    units = {unit for _, unit in TRACKS.values()}
    assert set(track_types_in(frozenset(units))) >= set(TRACKS)


@pytest.mark.parametrize(("model", "actions", "kind"), CASES)
def test_a_positive_command_turns_as_the_track_kind_says(model, actions, kind):
    _, unit = TRACKS[kind]
    expected = "right" if actions == "discrete" else POSITIVE_STEER_TURNS[unit]
    assert turn_after(model, actions, kind) == expected


@pytest.mark.parametrize(("model", "actions", "kind"), CASES)
def test_the_car_facts_give_drivers_the_same_sign(model, actions, kind):
    """Drivers and the keyboard turn a wanted angle into an action by ``steer_per_rad``
    (action per rad to the right): its sign is the convention's."""
    environment, unit = TRACKS[kind]
    keys = {} if environment is None else {"environment": environment}
    env = gym.make("tinyrace/TinyRace-v0", car={"model": model, "actions": actions}, **keys)
    right_positive = actions == "discrete" or POSITIVE_STEER_TURNS[unit] == "right"
    assert (env.unwrapped.car_facts.steer_per_rad > 0) == right_positive
    env.close()
