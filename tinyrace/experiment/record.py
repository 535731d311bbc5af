"""What an experiment keeps of each episode: its metrics, its trace (one row per step, for the
report) and its video, all taken from what the episode loop shows the observer."""

from __future__ import annotations

import csv
import io
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from gymnasium import spaces

from tinyrace.actions import DISCRETE_CONTROLS
from tinyrace.config.bounds import MAX_RUN_FILE_BYTES
from tinyrace.config.yaml_file import read_bytes
from tinyrace.experiment.files import write_text
from tinyrace.experiment.route import RouteWatch
from tinyrace.experiment.video import VideoWriter

TRACE_COLUMNS = (
    "step",  # 0 is the reset
    "t",  # [s] since reset
    "x",  # [track units] the car's reference point
    "y",
    "heading",  # [rad]
    "speed",  # [track units/s]
    "steer",  # the driver's steering, -1..1 (+ right); 0 at the reset
    "reward",
    "cte",  # [track units] the env's (image tracks with use_cte, metric tracks), else the
    # distance to the centreline (procedural); empty without a line
    "obstacle_hit",  # 1 when the footprint touched an obstacle colour
    "wheels_on_grass",  # procedural tracks
    "laps",  # laps finished so far
)


class EpisodeRecorder:
    """An ``EpisodeObserver``: tallies the episode, keeps its trace, writes its video.

    ``frame`` gives the picture to put in the video after the reset and after each step;
    ``on_step`` is called after each step with the recorder (progress, stop requests).
    ``watch`` gives, after the reset, the track's reference line: the cross-track error
    where the env reports none, and laps where the env counts none (image tracks).
    """

    def __init__(
        self,
        space: spaces.Space[Any],
        dt: float,
        video: VideoWriter | None = None,
        frame: Callable[[Any], np.ndarray] | None = None,
        on_step: Callable[[EpisodeRecorder], None] | None = None,
        watch: Callable[[], RouteWatch | None] | None = None,
    ):
        self.space = space
        self.dt = dt  # [s] per step
        self.video, self.frame = video, frame
        self.on_step = on_step
        self.watch = watch
        self.route: RouteWatch | None = None
        self.laps = 0
        self.lap_steps: list[int] = []  # the step that finished each lap
        self.episode_return = 0.0
        self.steps = 0
        self.frames = 0  # written to the video
        self.obstacle_hits = 0
        self.end = "max_steps"
        self.info: dict[str, Any] = {}
        self.rows: list[tuple[Any, ...]] = []

    def start(self, observation: Any, info: dict[str, Any]) -> None:
        self.route = self.watch() if self.watch is not None else None
        self._record(0.0, 0.0, info)
        self._film(observation)

    def step(
        self,
        action: Any,
        observation: Any,
        reward: float,
        terminated: bool,
        truncated: bool,
        info: dict[str, Any],
    ) -> None:
        self.episode_return += reward
        self.steps += 1
        self.obstacle_hits += bool(info.get("obstacles_hit"))
        if terminated or truncated:
            self.end = info.get("termination", "step_limit") if terminated else "step_limit"
        if self.end == "lap_finished":  # the env counted it
            self._lap_done(1)
        self._record(self._steer(action), reward, info)
        self._film(observation)
        if self.on_step is not None:
            self.on_step(self)

    def _record(self, steer: float, reward: float, info: dict[str, Any]) -> None:
        self.info = info
        x, y, heading = info.get("pose", (np.nan, np.nan, np.nan))
        cte = info.get("cte")
        if self.route is not None and np.isfinite(x) and np.isfinite(y):
            if cte is None:
                cte = self.route.distance(x, y)
            if "tiles_total" not in info:  # the env counts no laps here
                self._lap_done(self.route.laps(x, y))
        self.rows.append(
            (
                self.steps,
                self.steps * self.dt,
                x,
                y,
                heading,
                info.get("speed", np.nan),
                steer,
                reward,
                "" if cte is None else cte,
                int(bool(info.get("obstacles_hit"))),
                info.get("wheels_on_grass", ""),
                self.laps,
            )
        )

    def _lap_done(self, laps: int) -> None:
        while self.laps < laps:
            self.laps += 1
            self.lap_steps.append(self.steps)

    def _film(self, observation: Any) -> None:
        if self.video is not None and self.frame is not None:
            self.video.write(self.frame(observation))
            self.frames += 1

    def _steer(self, action: Any) -> float:
        if isinstance(self.space, spaces.Discrete):
            return float(DISCRETE_CONTROLS[int(action)][0])
        return float(np.asarray(action, float).reshape(-1)[0])

    @property
    def mean_abs_cte(self) -> float | None:
        """[track units] over the steps (the reset excluded); None without a cte."""
        column = TRACE_COLUMNS.index("cte")
        ctes = [abs(row[column]) for row in self.rows[1:] if row[column] != ""]
        return sum(ctes) / len(ctes) if ctes else None

    @property
    def lap_time(self) -> float | None:
        """[s] from the reset to the step that finished the first lap; None without a lap."""
        return self.lap_steps[0] * self.dt if self.lap_steps else None

    def close(self) -> None:
        """Finish the video (also after an interruption: the file still plays)."""
        if self.video is not None:
            self.video.close()

    def write_trace(self, path: Path) -> None:
        handle = io.StringIO(newline="")
        writer = csv.writer(handle)
        writer.writerow(TRACE_COLUMNS)
        writer.writerows(_rounded(row) for row in self.rows)
        write_text(path, handle.getvalue())


def _rounded(row: tuple[Any, ...]) -> tuple[Any, ...]:
    return tuple(round(v, 6) if isinstance(v, float) else v for v in row)


def read_trace(path: Path) -> dict[str, np.ndarray]:
    """A trace file as columns of floats (NaN where a value is missing)."""
    data = read_bytes(path, MAX_RUN_FILE_BYTES, "a trace")  # a regular file only
    rows = list(csv.DictReader(io.StringIO(data.decode("utf-8"), newline="")))
    return {
        key: np.array([float(r[key]) if r.get(key) not in ("", None) else np.nan for r in rows])
        for key in TRACE_COLUMNS
    }
