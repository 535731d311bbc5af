"""The recipes of docs/ARCHITECTURE.md, each done once from this file alone: a track source
(its config and its source, one ``register`` call), rule parts (each its class and its
``RulePart`` entry, one ``register`` call) and a sensor type (its config and its builder,
one ``register`` call). Each toy drives through ``gym.make``, and is taken away when its
test ends.

The toys: a ``ring`` track (a circle of road in metres with a wall box in its middle),
whose rule parts are the playfield and a ``finish_gate`` (the lap ends when the rear
axle passes a gate a quarter of the way round), a ``speed_limit`` rule part with its own
knobs (a ``rules:`` entry), facts, reward term (``speeding``) and end reason
(``speeding``), and a ``compass`` sensor (the car's heading as a unit vector).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar, Literal

import gymnasium as gym
import numpy as np
import pytest
from gymnasium import spaces

import tinyrace  # noqa: F401  (registers the env ids)
from tinyrace.cars.state import CarState
from tinyrace.config import EnvConfig
from tinyrace.config.knobs import REQUIRED, knob
from tinyrace.config.schema import METRE_CAR, TrackFacts
from tinyrace.config.sensors import SensorDefaults
from tinyrace.drivers.centerline import CenterlineDriver
from tinyrace.episodes.rules import RULES, Info, RuleBase, RulePart
from tinyrace.episodes.rules import register as register_rule
from tinyrace.episodes.rules import unregister as unregister_rule
from tinyrace.errors import ConfigError
from tinyrace.rewards import ENDS, TERMS, Design, End, Term
from tinyrace.sensors import registry as sensor_registry
from tinyrace.sensors.base import SensorContext, SensorType, TopDown
from tinyrace.tracks import registry as track_registry
from tinyrace.tracks.base import PaintedGround, Track, TrackDraw, TrackRules, pick_index
from tinyrace.world.facts import StepFacts
from tinyrace.world.snapshot import Snapshot
from tinyrace.world.world import Contacts

# -- a track source: its config dataclass and its source ------------------------------------


@dataclass(frozen=True)
class RingTrackConfig(TrackFacts):
    """A ``track`` of ``type: ring``: a circle of road, in metres."""

    unit: ClassVar[str] = "m"
    car_sizes: ClassVar[Mapping[str, float]] = METRE_CAR
    carracing_rules: ClassVar[bool] = False
    start_key: ClassVar[str] = "radius"

    type: Literal["ring"] = knob("ring", "track kind")
    radius: float = knob(30.0, "radius of the road's middle", "m", low=10.0, high=500.0)
    width: float = knob(8.0, "road width", "m", low=2.0, high=20.0)


class RingSource:
    """One ring per config track; the start on its right-hand side, driving left round."""

    kind: str = "ring"
    painted: PaintedGround | None = None

    def __init__(self, config: EnvConfig, base_dir: Path, source: str):
        self.tracks = tuple(_ring(c) for c in config.tracks if isinstance(c, RingTrackConfig))

    def draw(self, rng: np.random.Generator, options: Mapping[str, object]) -> TrackDraw:
        index = pick_index(options, "track", len(self.tracks), rng)
        return TrackDraw(self.tracks[index], index, 0)


def _ring(config: RingTrackConfig) -> Track:
    angles = np.linspace(0.0, 2 * math.pi, 360, endpoint=False)
    line = config.radius * np.stack([np.cos(angles), np.sin(angles)], axis=1)  # [m]
    line.flags.writeable = False
    edge = config.radius + config.width
    return Track(
        kind="ring",
        unit="m",
        metres_per_unit=1.0,
        y_down=False,
        bounds=(-edge, -edge, edge, edge),
        spawns=((config.radius, 0.0, math.pi / 2),),  # heading +y: counter-clockwise
        centerline=line,
        walls=np.array([[-3.0, -3.0, 3.0, 3.0]]),  # a box in the middle, far from the road
        rules=TrackRules(("playfield", "finish_gate")),
        ground_pixels_per_unit=4.0,
    )


# -- a rule part ---------------------------------------------------------------------------


class FinishGate(RuleBase):
    """The lap ends when the car's rear axle passes the gate: the ray from the ring's
    middle through its centreline point a quarter of the way round."""

    def __init__(self, track: Track, settings: None) -> None:
        assert track.centerline is not None
        gate = track.centerline[len(track.centerline) // 4]
        self.gate_angle = math.atan2(gate[1], gate[0])  # [rad]
        self.passed_at: float | None = None  # [rad] where the rear axle was when it passed

    def judge(self, contacts: Contacts, car: CarState, facts: StepFacts) -> None:
        x, y = car.rear_axle
        angle = math.atan2(y, x)
        if self.passed_at is None and angle >= self.gate_angle:
            self.passed_at = angle
        facts.lap_finished = self.passed_at is not None

    def info(self, info: Info) -> None:
        info["gate_passed"] = self.passed_at is not None


# -- a rule part with its own knobs, facts, reward term and end reason ---------------------


@dataclass(frozen=True)
class SpeedLimitConfig:
    """A ``rules:`` entry of ``type: speed_limit``: a speed not to pass."""

    type: Literal["speed_limit"] = knob("speed_limit", "rule part")
    limit: float = knob(10.0, "the top speed allowed", "track units/s", low=0.0)
    penalty: float = knob(0.5, "subtracted per second, per track unit/s over the limit", low=0.0)
    seconds: float = knob(
        0.4, "time over the limit that ends the episode", "s", low=0.0, low_open=True
    )


class SpeedLimit(RuleBase):
    """One car's speeding: how far over the limit now, and for how long so far."""

    def __init__(self, track: Track, settings: SpeedLimitConfig) -> None:
        self.limit, self.steps_over, self.seconds = settings.limit, 0, 0.0

    def judge(self, contacts: Contacts, car: CarState, facts: StepFacts) -> None:
        over = max(0.0, car.speed - self.limit)  # [track units/s]
        self.steps_over += over > 0
        self.seconds = self.steps_over * facts.dt  # [s]
        facts.more["speed_limit"] = (over, self.seconds)

    def info(self, info: Info) -> None:
        info["speeding_seconds"] = self.seconds


def _speeding(facts: StepFacts, design: Design) -> float | None:
    over, _ = facts.more["speed_limit"]
    return -design.settings["speed_limit"].penalty * over * facts.dt if over else None


def _configured(design: Design) -> bool:
    return "speed_limit" in design.settings


def _banned(facts: StepFacts, design: Design) -> bool:
    return bool(facts.more["speed_limit"][1] >= design.settings["speed_limit"].seconds)


SPEED_LIMIT = RulePart(
    "speed_limit",
    SpeedLimit,
    terms=(Term("speeding", _speeding, can_pay=_configured),),
    ends=(End("speeding", _banned),),
    config=SpeedLimitConfig,
)


# -- a sensor type: its config dataclass and its sensor ------------------------------------


@dataclass(frozen=True)
class CompassConfig(SensorDefaults):
    """``sensors[i]`` of ``type: compass``: the car's heading as a unit vector."""

    id: str = knob(REQUIRED, "observation key of this sensor")
    type: Literal["compass"] = knob("compass", "sensor type")
    noise: float = knob(0.0, "std of Gaussian noise on each component", low=0.0, high=1.0)


class Compass:
    """(cos, sin) of the car's heading [rad from +x, counter-clockwise], noise from ``rng``."""

    def __init__(self, config: CompassConfig):
        self.id, self.noise = config.id, config.noise
        self.space = spaces.Box(-2.0, 2.0, (2,), np.float32)

    def reset(self, track: Track) -> None:
        pass

    def observe(self, snapshot: Snapshot, track: Track, rng: np.random.Generator) -> np.ndarray:
        heading = snapshot.car.pose[2]
        clean = np.array([math.cos(heading), math.sin(heading)])
        noisy: np.ndarray = clean + rng.normal(0.0, self.noise, 2) if self.noise > 0 else clean
        clipped: np.ndarray = np.clip(noisy, -2.0, 2.0)
        return clipped.astype(np.float32)

    def describe(self) -> str:
        return "the car's heading as a unit vector"

    def top_down(self, snapshot: Snapshot, track: Track) -> TopDown | None:
        return None  # no picture from above


def build_compass(entry: CompassConfig, context: SensorContext) -> Compass:
    return Compass(entry)


# -- the recipes, done from here -----------------------------------------------------------


@pytest.fixture
def compass() -> Iterator[None]:
    sensor_registry.register(SensorType("compass", CompassConfig, build_compass, doc="heading"))
    yield
    sensor_registry.unregister("compass")


@pytest.fixture
def ring() -> Iterator[None]:
    track_registry.register(RingTrackConfig, RingSource)
    register_rule(RulePart("finish_gate", FinishGate))
    yield
    track_registry.unregister("ring")
    unregister_rule("finish_gate")


@pytest.fixture
def speed_limit() -> Iterator[None]:
    register_rule(SPEED_LIMIT)
    yield
    unregister_rule("speed_limit")


def _ring_env(**kwargs: Any) -> gym.Env[Any, Any]:
    kwargs.setdefault("tracks", [{"type": "ring", "radius": 30.0}])
    sensors = [{"id": "state", "type": "state"}, *kwargs.pop("sensors", [])]
    return gym.make("tinyrace/TinyRace-v0", sensors=sensors, **kwargs)


def test_a_track_source_and_a_rule_part_added_from_a_test_file_drive_through_gym_make(ring):
    env = _ring_env()
    driver = CenterlineDriver()
    observation, info = env.reset(seed=1)
    driver.reset(env)
    assert env.unwrapped.track.kind == "ring" and env.unwrapped.config.facts.unit == "m"
    assert info["gate_passed"] is False
    start = env.unwrapped.car.pose
    steps, terminated, truncated = 0, False, False
    while not (terminated or truncated) and steps < 2000:
        observation, _, terminated, truncated, info = env.step(driver.act(observation, info))
        steps += 1
    assert terminated and info["gate_passed"] is True and not truncated
    x, y, _ = env.unwrapped.car.pose
    along = math.atan2(y, x) - math.atan2(start[1], start[0])  # [rad] driven round the ring
    assert math.pi / 2 <= along < math.pi / 2 + 0.3  # it ended at the gate, not long after
    assert abs(math.hypot(x, y) - 30.0) < 4.0  # on the road the driver followed
    assert steps > 50  # a quarter of 188 m is some driving, not a spawn inside the gate
    env.close()


def test_a_registered_track_type_is_checked_like_a_built_in_one(ring):
    with pytest.raises(ConfigError) as caught:
        _ring_env(tracks=[{"type": "ring", "radius": 3.0}])
    assert "tracks[0].radius" in str(caught.value) and ">= 10" in str(caught.value)
    with pytest.raises(ConfigError) as caught:
        _ring_env(tracks=[{"type": "rung"}])
    assert "did you mean 'ring'" in str(caught.value)


def test_a_sensor_type_added_from_a_test_file_observes_through_gym_make(compass, ring):
    env = _ring_env(sensors=[{"id": "north", "type": "compass"}])
    assert env.observation_space["north"] == spaces.Box(-2.0, 2.0, (2,), np.float32)
    driver = CenterlineDriver()
    observation, info = env.reset(seed=1)
    driver.reset(env)
    for _ in range(40):
        heading = env.unwrapped.car.pose[2]
        expected = np.array([math.cos(heading), math.sin(heading)], np.float32)
        np.testing.assert_array_equal(observation["north"], expected)
        observation, *_, info = env.step(driver.act(observation, info))
    assert observation["north"][0] < -0.05  # turned left round the ring: now heading -x a bit
    env.close()


def test_a_registered_sensor_type_is_checked_like_a_built_in_one(compass):
    with pytest.raises(ConfigError) as caught:
        gym.make("tinyrace/TinyRace-v0", sensors=[{"id": "c", "type": "compass", "noise": 3}])
    assert "sensors[0].noise" in str(caught.value) and "<= 1" in str(caught.value)
    with pytest.raises(ConfigError) as caught:
        gym.make("tinyrace/TinyRace-v0", sensors=[{"id": "c", "type": "compas"}])
    assert "did you mean 'compass'" in str(caught.value)
    noisy = gym.make("tinyrace/TinyRace-v0", sensors=[{"id": "c", "type": "compass", "noise": 0.1}])
    first, again = noisy.reset(seed=3)[0]["c"], noisy.reset(seed=3)[0]["c"]
    np.testing.assert_array_equal(first, again)  # noise from the env's generator only
    assert abs(np.hypot(*first) - 1.0) > 1e-6  # and there is noise
    noisy.close()


def test_a_rule_part_with_its_own_knobs_term_and_end_drives_through_gym_make(
    speed_limit: None,
) -> None:
    rules = [{"type": "speed_limit", "limit": 10.0, "seconds": 0.4}]
    env = gym.make("tinyrace/TinyRace-v0", rules=rules)
    env.reset(seed=0)
    rewards, speeding = [], []
    for _ in range(400):
        _, reward, terminated, truncated, info = env.step(np.array([0.0, 1.0, 0.0], np.float32))
        rewards.append(reward)
        speeding.append(info["reward_terms"].get("speeding", 0.0))
        if terminated or truncated:
            break
    assert terminated and info["termination"] == "speeding" and not truncated
    assert info["speeding_seconds"] == 0.4  # ended on the 20th step over the limit (50 fps)
    paid = [value for value in speeding if value]
    assert len(paid) == 20 and all(value < 0 for value in paid)
    over = [-value / (0.5 / 50) for value in paid]  # [units/s] over the limit: paid per second
    assert all(0.0 < value < 60.0 for value in over), over
    assert paid[-1] < paid[0]  # faster and faster: more to pay
    core: Any = env.unwrapped
    assert core.car.speed > 10.0
    env.close()
    slow = gym.make("tinyrace/TinyRace-v0", rules=[{"type": "speed_limit", "limit": 1000.0}])
    slow.reset(seed=0)
    for _ in range(100):
        _, _, terminated, _, info = slow.step(np.array([0.0, 1.0, 0.0], np.float32))
        assert "speeding" not in info["reward_terms"] and not terminated
    slow.close()


def test_a_rule_parts_knobs_are_checked_like_built_in_ones(speed_limit: None) -> None:
    with pytest.raises(ConfigError) as caught:
        gym.make("tinyrace/TinyRace-v0", rules=[{"type": "speed_limit", "seconds": 0}])
    assert "rules[0].seconds" in str(caught.value) and "> 0" in str(caught.value)
    with pytest.raises(ConfigError) as caught:
        gym.make("tinyrace/TinyRace-v0", rules=[{"limit": 5.0}])  # no part stands for it
    assert "rules[0].type" in str(caught.value) and "speed_limit" in str(caught.value)
    with pytest.raises(ConfigError) as caught:
        gym.make("tinyrace/TinyRace-v0", rules=[{"type": "speed_limt"}])
    assert "rules[0].type" in str(caught.value) and "did you mean 'speed_limit'" in str(
        caught.value
    )


def test_a_rule_part_that_needs_what_the_track_lacks_is_named_at_its_entry() -> None:
    """``RulePart.needs``, as a sensor type's: a ``TrackFacts.holds`` entry."""
    register_rule(dataclasses.replace(SPEED_LIMIT, needs="metric ground"))
    try:
        with pytest.raises(ConfigError) as caught:  # CarRacing's track: a painted ground
            gym.make("tinyrace/TinyRace-v0", rules=[{"type": "speed_limit"}])
        (problem,) = caught.value.problems
        assert (problem.source, problem.path, problem.value) == (
            "<kwargs>",
            "rules[0].type",
            "speed_limit",
        )
        assert "needs a track that holds metric ground, not a procedural track" in problem.allowed
        env = gym.make(
            "tinyrace/TinyRace-v0", environment="circuit", rules=[{"type": "speed_limit"}]
        )
        env.reset(seed=0)
        env.close()
    finally:
        unregister_rule("speed_limit")


def test_an_end_marked_as_a_crash_is_drawn_as_one_in_the_report() -> None:
    """``End.crash``: the report's pictures mark such an ending as a crash, the built-in
    ends (out of bounds, an obstacle, a collision, in one car's report as in a race's) and a
    part's own alike."""
    from tinyrace.experiment.report import crash_ends

    assert crash_ends() == {"out_of_bounds", "obstacle", "collision"}
    crashing = dataclasses.replace(SPEED_LIMIT, ends=(End("speeding", _banned, crash=True),))
    register_rule(crashing)
    try:
        assert crash_ends() == {"out_of_bounds", "obstacle", "collision", "speeding"}
    finally:
        unregister_rule("speed_limit")
    assert "speeding" not in crash_ends()


def test_a_rule_parts_term_and_end_come_after_the_built_in_ones(speed_limit: None) -> None:
    assert list(TERMS)[-1] == "speeding" and list(ENDS)[-1] == "speeding"
    assert next(iter(TERMS)) == "time" and "lap_finished" in list(ENDS)[:-1]


def test_a_toy_type_is_gone_when_its_test_ends() -> None:
    with pytest.raises(ConfigError) as caught:
        _ring_env()
    assert "tracks[0].type" in str(caught.value) and "'ring'" in str(caught.value)
    assert "finish_gate" not in RULES and "speed_limit" not in RULES
    assert "speeding" not in TERMS and "speeding" not in ENDS
    with pytest.raises(ConfigError) as caught:
        gym.make("tinyrace/TinyRace-v0", rules=[{"type": "speed_limit"}])
    assert "rules[0].type" in str(caught.value)
    with pytest.raises(ConfigError) as caught:
        gym.make("tinyrace/TinyRace-v0", sensors=[{"id": "c", "type": "compass"}])
    assert "sensors[0].type" in str(caught.value)
