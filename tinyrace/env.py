"""TinyRaceEnv: builds its parts from one config; reset, step, render, close."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.error import ResetNeeded

from tinyrace.config import EnvConfig, LoadedConfig, load_env_config
from tinyrace.env_checks import check_options, check_poses, checked_shaping, flag
from tinyrace.episodes.episode import Episode
from tinyrace.episodes.referee import CarStep, Referee
from tinyrace.episodes.setup import prepare
from tinyrace.errors import ConfigError, Problem
from tinyrace.ground.grounds import make_ground
from tinyrace.render.pictures import CameraViews, Pictures
from tinyrace.render.setup import make_pictures
from tinyrace.render.window import Window
from tinyrace.sensors.base import Labelled, Sensor, SensorContext, drawer
from tinyrace.sensors.registry import build_sensors, default_sensor
from tinyrace.tracks.base import Track
from tinyrace.world.snapshot import Snapshot
from tinyrace.world.world import World

RENDER_MODES = ("human", "rgb_array", "state_pixels")


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
    Named terms of the track's rule parts (``tinyrace.episodes.rules``), weighted by
    ``reward_design`` (and the ``rules:`` entries' knobs), reported in
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
        verbose = flag(verbose, "verbose")  # before the config: any object was taken as a flag
        loaded = load_env_config(config, environment, overrides)
        if render_mode is not None and render_mode not in RENDER_MODES:
            raise ConfigError(
                Problem(
                    "<kwargs>",
                    "render_mode",
                    render_mode,
                    f"expected one of: {', '.join(RENDER_MODES)} or None (gym.make also takes "
                    "rgb_array_list and state_pixels_list: the frames since the last render())",
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
        self.metadata = {**self.metadata, "render_fps": round(fps)}
        self.action_spec = parts.car_model.actions(self.config.car)  # reads and checks actions
        self.action_space = self.action_spec.space
        self.car_facts = parts.car_model.describe(self.config)
        self._sensor_context = SensorContext(self.config, self.ground, self.car_facts)
        self._config_source = loaded.source
        self._blame = loaded.blame
        self.sensors: list[Sensor] = self.make_sensors()
        self.box_camera = self.box_sensor(self.sensors)
        # the Box observation's one sensor, when it can draw into a given array (``observe``)
        first = self.sensors[0]
        self._into = drawer(first) if self.box_camera is not None else None
        self.draws_into = self._into is not None
        self.observation_space = self._observation_space()
        shaping = None if cte_shaping is None else checked_shaping(cte_shaping)
        self.referee = Referee(self.config, shaping)  # judges every step of every episode
        self.dt = self.referee.dt  # [s]
        self.episode: Episode | None = None
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
            config = self.car_config(car)
            context = SensorContext(
                config, self.ground, self.course.racers[car].model.describe(config)
            )
            at = f"race.cars[{car}]." if self.config.race.cars else ""
        try:
            sensors = build_sensors(context, self._config_source)
        except ConfigError as exc:
            problems = [dataclasses.replace(p, path=f"{at}{p.path}") for p in exc.problems]
            raise ConfigError(self._blame(problems)) from None
        default = None if sensors else default_sensor(context)
        return sensors if default is None else [default]

    def car_config(self, car: int = 0) -> EnvConfig:
        """The config as car ``car`` sees it: its own car, cameras and sensors (a race's
        ``race.cars`` entry, else the shared sections) over the rest (``config`` is car 0's)."""
        if car == 0:
            return self.config
        own = self.course.racers[car].car
        return dataclasses.replace(
            self.config, car=own.car, cameras=own.cameras, sensors=own.sensors
        )

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
        options = check_options(options)
        draw = self.track_source.draw(self.np_random, options)
        poses = check_poses(options.get("poses"), self.config.race.num_agents)
        self.episode = episode = self.course.new_episode(draw, poses, self.np_random)
        self.ground.reset(draw, episode.visit_order)  # before the sensors and pictures read it
        self.pictures.reset(draw)
        self.layout = draw.track
        for sensor in self.sensors:
            sensor.reset(draw.track)
        if self.verbose and draw.track.tiles is not None:  # as CarRacing-v3 reports it
            attempts, tiles = draw.track.attempts, len(draw.track.tiles)
            print(f"Track generation: {attempts} attempt(s) -> {tiles}-tiles track")
        episode.start(self.referee)  # the reset's step: not rewarded, its tiles carried
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
        episode = self.episode
        if episode is None:
            raise ResetNeeded("call reset() before step()")
        episode.world.control(self.action_spec.read(action))  # checked, to the car
        return self.conclude(episode.step())  # the episode steps and judges every car

    # A step in parts, for a vector env that sets many cars' forces at once between them:
    # ``control(a)``; the car's forces (``world.apply_forces(dt)``, or a batch's);
    # ``cars = advance()``; ``conclude(cars)``: ``observe(snapshot())``, then ``report``.
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

    def advance(self) -> list[CarStep | None]:
        """The rest of a step once the cars' forces are set (``world.apply_forces`` or a
        batch): the episode's step, each car judged."""
        return self._episode().advance()

    def conclude(self, cars: list[CarStep | None]) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        """Observation and results of a step the episode has judged (``cars``: each car's)."""
        snapshot = self.snapshot()
        return self.report(cars[0], snapshot, self.observe(snapshot))

    def report(
        self, car: CarStep | None, snapshot: Snapshot, observation: Any
    ) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        """The step's results from this env's car's judgement and its observation."""
        assert car is not None  # the env's own car is never taken out of its episode
        info = self._info(car.terms, snapshot)
        reason = car.reason
        if reason is not None:
            info["termination"] = reason
            info["lap_finished"] = reason == "lap_finished"
        if self.render_mode == "human":
            self.render()
        return observation, car.reward, reason is not None, car.truncated, info

    def observe(self, snapshot: Snapshot, out: np.ndarray | None = None) -> Any:
        """The observation of ``snapshot``: every sensor's reading (kept for the pictures of
        this step, which draw no view a second time). ``out``: an array of the observation
        space's shape that a Box observation's sensor draws into when it can
        (``DrawsInto``: a vector env's row); then the observation is ``out``."""
        layout, rng = self.layout, self.np_random
        into = self._into
        if out is not None and into is not None:
            observation = {self.sensors[0].id: into.observe_into(snapshot, layout, rng, out)}
        else:
            observation = {s.id: s.observe(snapshot, layout, rng) for s in self.sensors}
        episode = self._episode()
        self._observed = (episode, episode.steps, observation)
        return observation if self.box_camera is None else observation[self.box_camera]

    def snapshot(self) -> Snapshot:
        """A copy of the world's state now (what sensors and pictures read)."""
        return self._episode().snapshot()

    @property
    def steps(self) -> int:
        """Steps since the reset (the episode's one counter; 0 before a reset)."""
        return 0 if self.episode is None else self.episode.steps

    @property
    def t(self) -> float:
        """[s] of sim time since the reset (its own step counted)."""
        return 0.0 if self.episode is None else self.episode.t

    @property
    def score(self) -> float:
        """The car's running reward, shown on CarRacing's dashboard."""
        return 0.0 if self.episode is None else self.episode.scores[0]

    @property
    def shaping(self) -> Callable[[float], float] | None:
        """The cross-track-error shaping (``cte_shaping``, else ``reward_design``'s)."""
        return self.referee.design.shaping

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


def _rgb(image: np.ndarray) -> np.ndarray:
    """Gray and class-label images as RGB, for pictures."""
    return image if image.ndim == 3 else np.repeat(image[..., None], 3, axis=2)
