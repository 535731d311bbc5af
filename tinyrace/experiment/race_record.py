"""What a race run keeps of each episode, watching the race loop: a ``CarRecorder`` per car
(its trace with its place and the cars it touched, its laps and lap times, its contacts)
and the ``RaceRecorder`` over them (the standings after every step, the video).

A car's place is decided by its laps, then (between cars with as many laps) by the earlier
finish of its last one, then by how far round the track's line it is (tiles visited on a
track without one), then by who got that far first, then by its place on the grid.
"""

from __future__ import annotations

import csv
import io
import math
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from gymnasium import spaces

from tinyrace.experiment.files import write_text
from tinyrace.experiment.race_results import RACE_TRACE_COLUMNS
from tinyrace.experiment.record import EpisodeRecorder
from tinyrace.experiment.route import RouteWatch, route_watch
from tinyrace.experiment.video import VideoWriter
from tinyrace.race import RaceEnv


class CarRecorder(EpisodeRecorder):
    """One car's recorder in a race: its trace (with its place and the cars it touched), its
    laps and lap times, its contacts with other cars."""

    def __init__(self, space: spaces.Space[Any], dt: float, watch: Callable[[], Any]):
        super().__init__(space, dt, watch=watch)
        self.extras: list[tuple[int, str]] = []  # (position, cars touched) per trace row
        self.cars_hit = 0
        self.touched: dict[str, None] = {}  # in the order first touched
        self._best = 0.0  # the most progress so far
        self.reached = 0  # the step it got there: of two cars as far on, the first is ahead

    def step(
        self,
        action: Any,
        observation: Any,
        reward: float,
        terminated: bool,
        truncated: bool,
        info: dict[str, Any],
    ) -> None:
        super().step(action, observation, reward, terminated, truncated, info)
        self._follow(info)
        laps = info.get("laps")
        if isinstance(laps, int) and not isinstance(laps, bool):  # the env counts laps
            self._lap_done(laps)
        if self.progress > self._best:
            self._best, self.reached = self.progress, self.steps
        hit = [str(car) for car in info.get("cars_hit") or ()]
        self.cars_hit += len(hit)
        self.touched.update(dict.fromkeys(hit))

    def start(self, observation: Any, info: dict[str, Any]) -> None:
        super().start(observation, info)
        self._follow(info)

    def _follow(self, info: dict[str, Any]) -> None:
        """Where the car is along the track's line (the route watch follows it)."""
        x, y, _ = info.get("pose", (math.nan, math.nan, math.nan))
        if self.route is not None and math.isfinite(x) and math.isfinite(y):
            self.route.laps(x, y)

    @property
    def lap_times(self) -> list[float]:
        """[s] each finished lap's time: the env's ``lap_times`` where it gives them, else
        from the steps that finished them."""
        given = self.info.get("lap_times")
        if isinstance(given, (list, tuple)) and all(_number(t) for t in given):
            return [float(t) for t in given]
        ends = self.lap_steps
        starts = [0, *ends][: len(ends)]
        return [round((end - start) * self.dt, 9) for start, end in zip(starts, ends, strict=True)]

    @property
    def best_lap(self) -> float | None:
        """[s] the env's ``best_lap`` where it gives one, else the fastest lap time."""
        given = self.info.get("best_lap")
        if isinstance(given, (int, float)) and not isinstance(given, bool):
            return float(given)
        times = self.lap_times
        return min(times) if times else None

    def standing(self, index: int) -> tuple[float, ...]:
        """The sort key of the car's place (smaller is ahead); ``index``: its grid slot."""
        finished = self.lap_steps[-1] if self.lap_steps else 0
        return (-self.laps, finished, -self.progress, self.reached, index)

    @property
    def progress(self) -> float:
        """How far round the track the car is: [route points] along the track's line from
        the start line, else (a track without a closed line) the tiles it visited."""
        route: RouteWatch | None = self.route
        if route is not None and route.closed:
            return float(route.along)
        return float(self.info.get("tiles_visited") or 0)

    def write_trace(self, path: Path) -> None:
        handle = io.StringIO(newline="")
        writer = csv.writer(handle)
        writer.writerow(RACE_TRACE_COLUMNS)
        for row, extra in zip(self.rows, self.extras, strict=True):
            cells = (round(v, 6) if isinstance(v, float) else v for v in row)
            writer.writerow((*cells, *extra))
        write_text(path, handle.getvalue())


def _number(value: object) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


class RaceRecorder:
    """A ``RaceObserver``: each car's recorder, the standings, the episode's video."""

    def __init__(
        self,
        race: RaceEnv,
        video: VideoWriter | None,
        on_step: Callable[[RaceRecorder], None] | None = None,
    ):
        self.race = race
        self.video = video
        self.on_step = on_step
        core = race.core
        watch: Callable[[], Any] = lambda: route_watch(core)  # noqa: E731
        self.cars = {
            agent: CarRecorder(race.action_space(agent), core.dt, watch)
            for agent in race.possible_agents
        }
        self.steps = 0
        self.film_seconds = 0.0  # [s] spent drawing and writing video frames

    def start(self, observations: dict[str, Any], infos: dict[str, Any]) -> None:
        for agent, recorder in self.cars.items():
            recorder.start(observations[agent], infos[agent])
        self._after(infos)

    def step(
        self,
        actions: dict[str, Any],
        observations: dict[str, Any],
        rewards: dict[str, float],
        terminations: dict[str, bool],
        truncations: dict[str, bool],
        infos: dict[str, Any],
    ) -> None:
        self.steps += 1
        for agent, info in infos.items():
            self.cars[agent].step(
                actions[agent],
                observations[agent],
                float(rewards[agent]),
                terminations[agent],
                truncations[agent],
                info,
            )
        self._after(infos)
        if self.on_step is not None:
            self.on_step(self)

    def _after(self, infos: dict[str, Any]) -> None:
        """Each racing car's place and contacts into its trace; the frame into the video."""
        order = self.order()
        for agent, info in infos.items():
            hit = " ".join(str(car) for car in info.get("cars_hit") or ())
            self.cars[agent].extras.append((order.index(agent) + 1, hit))
        if self.video is not None:
            started = time.perf_counter()
            frame = self.race.render()  # the race was made with render_mode rgb_array
            if frame is None:
                raise RuntimeError("the race rendered no frame for the video")
            self.video.write(frame)
            self.film_seconds += time.perf_counter() - started

    def order(self) -> list[str]:
        """The cars by place, leader first."""
        slots = {agent: i for i, agent in enumerate(self.cars)}
        return sorted(self.cars, key=lambda agent: self.cars[agent].standing(slots[agent]))

    @property
    def leader(self) -> CarRecorder:
        """The leading car still racing (else the leader): what the progress bar shows."""
        racing = [agent for agent in self.order() if agent in self.race.agents]
        return self.cars[(racing or self.order())[0]]

    def close(self) -> None:
        """Finish the video (also after an interruption: the file still plays)."""
        if self.video is not None:
            self.video.close()
