"""TinyRaceEnv: builds its parts from one config; reset, step, render, close."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.error import ResetNeeded

from tinyrace.config import EnvConfig, LoadedConfig, load_env_config
from tinyrace.episodes.episode import Episode
from tinyrace.episodes.setup import prepare
from tinyrace.errors import ConfigError, Problem, did_you_mean
from tinyrace.ground.grounds import make_ground
from tinyrace.render.pictures import CameraViews, Pictures
from tinyrace.render.setup import make_pictures
from tinyrace.render.window import Window
from tinyrace.rewards import (
    REWARD_TERMS,
    active_terms,
    ends_episode,
    reward_terms,
    shaping_from_config,
)
from tinyrace.sensors.base import Labelled, Sensor, SensorContext
from tinyrace.sensors.registry import build_sensors, default_sensor
from tinyrace.tracks.base import Track
from tinyrace.world.facts import StepFacts
from tinyrace.world.snapshot import Snapshot
from tinyrace.world.world import World

RENDER_MODES = ("human", "rgb_array", "state_pixels")
RESET_OPTIONS = ("randomize", "track", "spawn", "poses")
RESET_SOURCE = "<reset options>"
CARRIED_TERMS = ("tiles",)  # reward of the reset step paid by the first step
CARRIED = {name: REWARD_TERMS[name] for name in CARRIED_TERMS}  # the only terms a reset asks


class TinyRaceEnv(gym.Env):
    """A car on a 2D track seen from above, configured by YAML.

    ## Description
    Composed of parts the config names. The track source by ``tracks[].type``
    (``tinyrace.tracks.registry``): ``procedural`` reproduces Gymnasium's
    CarRacing-v3 (same tracks for the same seed, same rewards), ``image`` loads a tinycarlo
    track folder whose pixel colours are markings, obstacles and a reference trajectory,
    ``centerline`` a reference line with its widths (CSV), ``cone_map`` a cone layout and
    ``ros_map`` an occupancy map of a ROS map server. The car model by ``car.model``
    (``tinyrace.cars.registry``; each track type has a default): ``dynamic`` (CarRacing's
    car with tyre slip), ``kinematic`` (tinycarlo's constant-speed bicycle),
    ``kinematic_throttle`` (a kinematic bicycle with throttle) and ``single_track``
    (CommonRoad's single-track model, F1TENTH's). Parts registered by user code join them.

    ## Action Space
    The car model's (``env.unwrapped.action_spec``): ``dynamic``: Box [steer, gas, brake] or
    CarRacing's Discrete(5); ``kinematic``: Box [steer]; ``kinematic_throttle``: Box [steer,
    throttle]; ``single_track``: Box [steering angle, speed], or raw rates. A positive steer
    turns right on procedural and image tracks, left on tracks in metres
    (docs/conventions.md).

    ## Observation Space
    Every observation is a sensor's (``tinyrace.sensors``; tinycarlo's ``cameras:`` are
    ``birdseye_camera`` sensors). With none configured, the track's default sensor alone as
    a plain Box: on a procedural track ``chase_view``, CarRacing's 96x96x3 RGB view.
    Otherwise a Dict keyed by sensor id, or with ``observation: box`` and one sensor, its
    observation as a plain Box.

    ## Rewards
    Named terms from ``reward_design`` (see ``tinyrace.rewards``), reported in
    ``info["reward_terms"]``.

    ## Episode End
    Terminated when a lap is finished, the car leaves the playfield or image, or
    touches a ``done`` obstacle (``info["termination"]`` says which). Truncated at
    ``sim.step_limit``.
    """

    metadata: dict[str, Any] = {"render_modes": list(RENDER_MODES), "render_fps": 50}  # noqa: RUF012

    def __init__(
        self,
        config: str | Path | Mapping[str, Any] | LoadedConfig | None = None,
        environment: str | Path | None = None,
        render_mode: str | None = None,
        cte_shaping: Callable[[float], float] | None = None,
        verbose: bool = False,
        **overrides: Any,
    ):
        loaded = load_env_config(config, environment, overrides)
        if render_mode is not None and render_mode not in RENDER_MODES:
            raise ConfigError(
                Problem(
                    "<kwargs>",
                    "render_mode",
                    render_mode,
                    f"expected one of: {', '.join(RENDER_MODES)} or None",
                )
            )
        parts = prepare(loaded)
        self.config: EnvConfig = parts.config
        self.render_mode = render_mode
        self.verbose = verbose
        self.track_source = parts.source
        self.course = parts.course
        self.ground = make_ground(self.config, parts.source)  # sensors' and pictures' ground
        self.pictures: Pictures = make_pictures(self.config, self.ground)
        fps = self.config.sim.fps
        assert fps is not None  # resolved by the config loader
        self.dt = 1.0 / fps  # [s]
        self.metadata = {**self.metadata, "render_fps": round(fps)}
        self.action_spec = parts.car_model.actions(self.config.car)  # reads and checks actions
        self.action_space = self.action_spec.space
        self.car_facts = parts.car_model.describe(self.config)
        self._sensor_context = SensorContext(self.config, self.ground, self.car_facts)
        self._config_source = loaded.source
        self._blame = loaded.blame
        self.sensors: list[Sensor] = self.make_sensors()
        self.box_camera = self.box_sensor(self.sensors)
        self.observation_space = self._observation_space()
        self.shaping = (
            _checked_shaping(cte_shaping)
            if cte_shaping is not None
            else shaping_from_config(self.config.reward_design)
        )
        self.terms = active_terms(self.config.reward_design, self.shaping)  # asked per step
        self.episode: Episode | None = None
        self.start_facts: list[StepFacts] = []  # every car's facts of the reset's step
        self.last_facts: list[StepFacts] = []  # every car's facts of the last step
        self.layout: Track = Track("none", "", None, False, (0.0, 0.0, 0.0, 0.0), ())  # at reset
        self._window: Window | None = None
        # the last observation's readings by sensor id, and the episode and step they saw
        self._observed: tuple[Episode, int, dict[str, Any]] | None = None

    def make_sensors(self, car: int = 0) -> list[Sensor]:
        """Car ``car``'s sensors, its cameras among them (the config's for car 0; a race
        car's own, else the shared ones), built anew (one set per car that observes); none
        configured: the track's default sensor."""
        context = self._sensor_context
        at = ""
        if car:
            racer = self.course.racers[car]
            config = dataclasses.replace(
                self.config, car=racer.car.car, cameras=racer.car.cameras, sensors=racer.car.sensors
            )
            context = SensorContext(config, self.ground, racer.model.describe(config))
            at = f"race.cars[{car}]." if self.config.race.cars else ""
        try:
            sensors = build_sensors(context, self._config_source)
        except ConfigError as exc:
            problems = [dataclasses.replace(p, path=f"{at}{p.path}") for p in exc.problems]
            raise ConfigError(self._blame(problems)) from None
        default = None if sensors else default_sensor(context)
        return sensors if default is None else [default]

    def box_sensor(self, sensors: list[Sensor], car: int = 0) -> str | None:
        """The id of the one sensor whose reading is car ``car``'s whole observation (a
        Box): with ``observation: box``, or the track's default sensor when the car has no
        sensor configured; None for a Dict observation."""
        configured = self.config.sensors if car == 0 else self.course.racers[car].car.sensors
        box = self.config.observation == "box" or not configured
        return sensors[0].id if box and len(sensors) == 1 else None

    def _observation_space(self) -> spaces.Space[Any]:
        if self.box_camera is not None:  # ``observation: box``: the one camera's image alone
            return self.sensors[0].space
        return spaces.Dict({sensor.id: sensor.space for sensor in self.sensors})

    # -- gymnasium API -----------------------------------------------------------------------
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        super().reset(seed=seed)
        options = _check_options(options)
        draw = self.track_source.draw(self.np_random, options)
        poses = _check_poses(options.get("poses"), self.config.race.num_agents)
        self.episode = episode = self.course.new_episode(draw, poses, self.np_random)
        self.ground.reset(draw, episode.visit_order)  # before the sensors and pictures read it
        self.pictures.reset(draw)
        self.layout = draw.track
        for sensor in self.sensors:
            sensor.reset(draw.track)
        if self.verbose and draw.track.tiles is not None:  # as CarRacing-v3 reports it
            attempts, tiles = draw.track.attempts, len(draw.track.tiles)
            print(f"Track generation: {attempts} attempt(s) -> {tiles}-tiles track")
        self.t = 0.0  # [s] since reset
        self.steps = 0
        self.score = 0.0  # running reward, shown on CarRacing's dashboard
        self.start_facts = episode.start(self.dt)  # every car's; this env judges the first
        facts = self.start_facts[0]
        self.t += self.dt
        # The reset step is not rewarded; tiles it touched are paid by the first step (as
        # CarRacing does). Only such events carry over, never states like the cte.
        design = self.config.reward_design
        terms = reward_terms(facts, design, self.shaping, False, CARRIED)
        self._carry = {key: value for key, value in terms.items() if key in CARRIED_TERMS}
        self.score += sum(self._carry.values())
        snapshot = self.snapshot()
        observation = self.observe(snapshot)
        if self.render_mode == "human":
            self.render()
        info = self._info({}, snapshot)
        labels = {s.id: s.labels for s in self.sensors if isinstance(s, Labelled) and s.labels}
        if labels:
            info["sensor_labels"] = labels  # classes cameras: names by label
        return observation, info

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        self.control(action)
        self.last_facts = self._episode().step(self.dt)
        return self.conclude(self.last_facts[0])

    # The stepping protocol: a step in parts, for a vector env that moves many cars between
    # them. ``step(a)`` is ``control(a)``; ``world.apply_forces(dt)`` (or a batch sets the
    # cars' forces); ``facts = advance()``; ``conclude(facts)``, itself ``judge(facts)``,
    # then ``observe(snapshot())``, then ``report``. Nothing else of the env is used.
    def control(self, action: Any) -> None:
        """Check ``action`` and hand it to the car (the first part of a step)."""
        episode = self.episode
        if episode is None:
            raise ResetNeeded("call reset() before step()")
        episode.world.control(self.action_spec.read(action))

    @property
    def world(self) -> World:
        """The current episode's world (its cars, their contacts and grip)."""
        return self._episode("the world").world

    def advance(self) -> StepFacts:
        """The rest of a step's physics, once the cars' forces are set (``world.apply_forces``
        or a batch): the world advanced by ``dt``, the episode's rules' facts."""
        self.last_facts = self._episode().advance(self.dt)
        return self.last_facts[0]

    def conclude(self, facts: StepFacts) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        """Rewards, episode end, observation and info of a step whose physics is done."""
        verdict = self.judge(facts)
        snapshot = self.snapshot()
        return self.report(verdict, snapshot, self.observe(snapshot))

    def judge(self, facts: StepFacts) -> Verdict:
        """The step's reward terms and episode end; the clock and the score move on."""
        self.t += self.dt
        self.steps += 1
        terms = reward_terms(facts, self.config.reward_design, self.shaping, True, self.terms)
        carried, self._carry = self._carry, {}
        if carried:
            terms = _add_terms(terms, carried)
        reward = float(sum(terms.values()))
        if not facts.out_of_bounds:  # CarRacing's score ignores the out-of-bounds penalty
            self.score += reward - sum(carried.values())
        reason = ends_episode(facts, self.config.reward_design)
        limit = self.config.sim.step_limit
        truncated = reason is None and limit is not None and self.steps >= limit
        return Verdict(terms, reward, reason, truncated)

    def report(
        self, verdict: Verdict, snapshot: Snapshot, observation: Any
    ) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        """The step's results from its verdict and its observation of ``snapshot``."""
        info = self._info(verdict.terms, snapshot)
        reason = verdict.reason
        if reason is not None:
            info["termination"] = reason
            info["lap_finished"] = reason == "lap_finished"
        if self.render_mode == "human":
            self.render()
        return observation, verdict.reward, reason is not None, verdict.truncated, info

    def observe(self, snapshot: Snapshot) -> Any:
        """The observation of ``snapshot``: every sensor's reading (kept for the pictures of
        this step, which draw no view a second time)."""
        layout, rng = self.layout, self.np_random
        observation = {sensor.id: sensor.observe(snapshot, layout, rng) for sensor in self.sensors}
        self._observed = (self._episode(), self.steps, observation)
        return observation if self.box_camera is None else observation[self.box_camera]

    def snapshot(self) -> Snapshot:
        """A copy of the world's state now (what sensors and pictures read)."""
        return self._episode().world.snapshot(self.t, self.steps, self.score)

    def _episode(self, reading: str = "a snapshot") -> Episode:
        if self.episode is None:
            raise ResetNeeded(f"call reset() before reading {reading}")
        return self.episode

    def _info(self, terms: dict[str, float], snapshot: Snapshot) -> dict[str, Any]:
        info: dict[str, Any] = self._episode().info(snapshot)
        info["reward_terms"] = terms
        return info

    @property
    def track(self) -> Track:
        """The current episode's ``Track`` (``tinyrace.tracks.base``): read-only arrays in
        track units (``unit``): ``centerline``, ``headings``, ``tiles``, ``kerbs``, ``walls``,
        ``cones``, ``picture``, ``occupancy``, ... (None or empty where it has none)."""
        return self._episode("the track").track

    @property
    def car(self) -> Any:
        """The current episode's live car (a pymunk body plus its state); read ``snapshot()``
        for a copy."""
        return self._episode("the car").world.cars[0]

    # -- pictures ------------------------------------------------------------------------------
    def render(self) -> np.ndarray | None:
        if self.render_mode is None:
            gym.logger.warn(
                "render() called without a render_mode; make the env with render_mode='rgb_array'"
            )
            return None
        if self.episode is None:
            raise ResetNeeded("call reset() before render()")
        snapshot = self.snapshot()
        frame: np.ndarray = self.pictures.frame(
            self.render_mode, snapshot, self._camera_views(snapshot)
        )
        if self.render_mode != "human":
            return frame
        if self._window is None:
            self._window = Window("tinyrace", self.metadata["render_fps"])
        self._window.show(frame, realtime=self.config.sim.render_realtime)
        return None

    def _camera_views(self, snapshot: Snapshot) -> CameraViews:
        """Each top-down image sensor's image now (this step's, when it has observed) and
        its track window (None for a view without one), for the overview picture."""
        views = [(s, s.top_down(snapshot, self.layout)) for s in self.sensors]
        shown = [(sensor, top.window) for sensor, top in views if top is not None]
        if not shown:
            return []
        observed = self._observed
        if observed is None or observed[0] is not self.episode or observed[1] != self.steps:
            observed = (self._episode(), self.steps, {})
        images = observed[2]
        return [
            (
                _rgb(
                    images[view.id]
                    if view.id in images
                    else view.observe(snapshot, self.layout, self.np_random)
                ),
                window,
            )
            for view, window in shown
        ]

    def close(self) -> None:
        if self._window is not None:
            self._window.close()
            self._window = None

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        state["_window"] = None  # a window belongs to this process
        state["_observed"] = None  # the last step's readings: not worth the bytes
        return state


class Verdict(NamedTuple):
    """A step's judgement (``TinyRaceEnv.judge``): its reward terms and their sum, why the
    episode ends (or None) and whether the step limit truncates it."""

    terms: dict[str, float]
    reward: float
    reason: str | None
    truncated: bool


def _rgb(image: np.ndarray) -> np.ndarray:
    """Gray and class-label images as RGB, for pictures."""
    return image if image.ndim == 3 else np.repeat(image[..., None], 3, axis=2)


def _check_options(options: object) -> dict[str, Any]:
    """The reset options, checked: known keys, ``randomize`` a bool, indices whole numbers.

    Image tracks check the index ranges when they pick; a procedural track has one track and
    one start, index 0.
    """
    if options is None:
        return {}
    if not isinstance(options, Mapping):
        raise ConfigError(Problem(RESET_SOURCE, "", options, "expected a dict or None"))
    for key, value in options.items():
        if key not in RESET_OPTIONS:
            hint = did_you_mean(key, RESET_OPTIONS)
            allowed = f"unknown option; {hint}valid: {', '.join(RESET_OPTIONS)}"
            raise ConfigError(Problem(RESET_SOURCE, _key_text(key), value, allowed))
        if key == "randomize" and not isinstance(value, (bool, np.bool_)):
            raise ConfigError(Problem(RESET_SOURCE, key, value, "expected true or false"))
    return dict(options)


def _check_poses(value: object, count: int) -> list[tuple[float, float, float]] | None:
    """The ``poses`` reset option: one finite (x, y, heading) per car [track units, rad]."""
    if value is None:
        return None
    try:  # numbers only: true/false and text are no coordinates (the config refuses them too)
        raw = np.asarray(value, dtype=object)
        numbers = all(
            isinstance(x, (int, float, np.number)) and x is not True and x is not False
            for x in raw.flat
        )
        poses = raw.astype(np.float64) if numbers else np.zeros(0)
    except (TypeError, ValueError, OverflowError):
        poses = np.zeros(0)
    if poses.shape != (count, 3) or not np.isfinite(poses).all():
        allowed = f"expected {count} finite (x, y, heading) poses of numbers, one per car"
        raise ConfigError(Problem(RESET_SOURCE, "poses", _short(value), allowed))
    return [(float(x), float(y), float(h)) for x, y, h in poses.tolist()]


def _short(value: object) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _key_text(key: object) -> str:
    text = key if isinstance(key, str) else repr(key)
    return text if len(text) <= 40 else text[:37] + "..."


def _checked_shaping(shaping: object) -> Callable[[float], float]:
    """The ``cte_shaping`` kwarg: a callable whose every result must be a finite number."""
    if not callable(shaping):
        allowed = (
            "expected a function cte [px] -> reward, or None "
            "(reward_design.cross_track_error.shaping names the built-in ones)"
        )
        raise ConfigError(Problem("<kwargs>", "cte_shaping", shaping, allowed))
    return _CheckedShaping(shaping)


@dataclass(frozen=True)
class _CheckedShaping:
    """Calls the user's shaping; a result that is not a finite number is a ConfigError."""

    shaping: Callable[[float], Any]

    def __call__(self, cte: float) -> float:
        value = self.shaping(cte)
        number = isinstance(value, (int, float, np.number)) and not isinstance(value, bool)
        if not (number and np.isfinite(value)):
            allowed = "expected the cte_shaping function to return a finite number"
            raise ConfigError(Problem("<kwargs>", "cte_shaping", value, allowed))
        return float(value)


def _add_terms(a: dict[str, float], b: dict[str, float]) -> dict[str, float]:
    return {key: a.get(key, 0.0) + b.get(key, 0.0) for key in {**a, **b}}
