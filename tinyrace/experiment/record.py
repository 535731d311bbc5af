"""What an experiment keeps of each episode: its metrics, its trace (one row per step, for the
report) and its video, all taken from what the episode loop shows the observer."""

from __future__ import annotations

import csv
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from gymnasium import spaces

from tinyrace.actions import DISCRETE_CONTROLS
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
    "cte",  # [px] image tracks with use_cte; empty otherwise
    "obstacle_hit",  # 1 when the footprint touched an obstacle colour
    "wheels_on_grass",  # procedural tracks
)


class EpisodeRecorder:
    """An ``EpisodeObserver``: tallies the episode, keeps its trace, writes its video.

    ``frame`` gives the picture to put in the video after the reset and after each step;
    ``on_step`` is called after each step with the recorder (progress, stop requests).
    """

    def __init__(
        self,
        space: spaces.Space[Any],
        dt: float,
        video: VideoWriter | None = None,
        frame: Callable[[Any], np.ndarray] | None = None,
        on_step: Callable[[EpisodeRecorder], None] | None = None,
    ):
        self.space = space
        self.dt = dt  # [s] per step
        self.video, self.frame = video, frame
        self.on_step = on_step
        self.episode_return = 0.0
        self.steps = 0
        self.frames = 0  # written to the video
        self.obstacle_hits = 0
        self.end = "max_steps"
        self.info: dict[str, Any] = {}
        self.rows: list[tuple[Any, ...]] = []

    def start(self, observation: Any, info: dict[str, Any]) -> None:
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
        self._record(self._steer(action), reward, info)
        self._film(observation)
        if terminated or truncated:
            self.end = info.get("termination", "step_limit") if terminated else "step_limit"
        if self.on_step is not None:
            self.on_step(self)

    def _record(self, steer: float, reward: float, info: dict[str, Any]) -> None:
        self.info = info
        x, y, heading = info.get("pose", (np.nan, np.nan, np.nan))
        cte = info.get("cte")
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
            )
        )

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
        """[px] over the steps (the reset excluded); None without a cte."""
        column = TRACE_COLUMNS.index("cte")
        ctes = [abs(row[column]) for row in self.rows[1:] if row[column] != ""]
        return sum(ctes) / len(ctes) if ctes else None

    @property
    def lap_time(self) -> float | None:
        """[s] from the reset to the step that finished the lap; None without a lap."""
        return self.steps * self.dt if self.end == "lap_finished" else None

    def close(self) -> None:
        """Finish the video (also after an interruption: the file still plays)."""
        if self.video is not None:
            self.video.close()

    def write_trace(self, path: Path) -> None:
        with path.open("w", newline="") as handle:
            writer = csv.writer(handle)
            writer.writerow(TRACE_COLUMNS)
            writer.writerows(_rounded(row) for row in self.rows)


def _rounded(row: tuple[Any, ...]) -> tuple[Any, ...]:
    return tuple(round(v, 6) if isinstance(v, float) else v for v in row)


def read_trace(path: Path) -> dict[str, np.ndarray]:
    """A trace file as columns of floats (NaN where a value is missing)."""
    with path.open(newline="") as handle:
        rows = list(csv.DictReader(handle))
    return {
        key: np.array([float(r[key]) if r.get(key) not in ("", None) else np.nan for r in rows])
        for key in TRACE_COLUMNS
    }
