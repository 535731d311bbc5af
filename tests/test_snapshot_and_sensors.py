"""The world snapshot is a copy of the car's state; sensors observe snapshots and tracks."""

from __future__ import annotations

import numpy as np
import pytest

from tinyrace.errors import ConfigError
from tinyrace.sensors.registry import SENSOR_TYPES, sensor_type


def test_a_snapshot_is_a_copy_that_later_steps_leave_alone(carracing):
    for _ in range(30):
        carracing.step(np.array([0.3, 1.0, 0.0], np.float32))
    unwrapped = carracing.unwrapped
    snapshot = unwrapped.snapshot()
    assert snapshot.steps == 30 and snapshot.car.model == "dynamic"
    assert snapshot.car.pose == unwrapped.car.pose
    assert snapshot.car.speed == pytest.approx(unwrapped.car.speed)
    assert len(snapshot.car.wheels) == 4 and snapshot.car.wheels[2].omega > 0  # rear drive
    carracing.step(np.array([0.0, 1.0, 0.0], np.float32))
    assert unwrapped.car.pose != snapshot.car.pose
    with pytest.raises(AttributeError):  # read-only
        snapshot.car.pose = (0.0, 0.0, 0.0)  # type: ignore[misc]


def test_a_camera_sensor_sees_what_the_observation_holds(image_track_env):
    observation, *_ = image_track_env.step(np.array([0.2], np.float32))
    unwrapped = image_track_env.unwrapped
    (camera,) = unwrapped.sensors
    seen = camera.observe(unwrapped.snapshot(), unwrapped.layout, unwrapped.np_random)
    assert camera.space.contains(seen)
    assert np.array_equal(seen, observation[camera.id])


def test_unknown_sensor_types_are_refused_with_the_valid_names():
    assert "birdseye_camera" in SENSOR_TYPES
    with pytest.raises(ConfigError) as caught:
        sensor_type("radar", "env.yaml", "sensors[0].type")
    (problem,) = caught.value.problems
    assert (problem.source, problem.path, problem.value) == ("env.yaml", "sensors[0].type", "radar")
    assert "birdseye_camera" in problem.allowed
