"""An experiment file: which env, which driver, how many episodes, what to write.

```yaml
env:                        # a track folder or track.yaml, plus overrides of any track key
  environment: ../example_tracks/formula_student    # relative to this file; omit: procedural
  sim: {step_limit: 600}
driver: centerline          # random | constant | centerline | module:callable
drivers: {car_1: random}    # races (race.num_agents > 1): a driver per car; the rest: driver
episodes: 5
seed: 0
output: {dir: runs, video: true, view: overview}
```
"""

from __future__ import annotations

from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

from tinyrace.config.bounds import MAX_EPISODES
from tinyrace.config.knobs import knob


@dataclass(frozen=True)
class OutputConfig:
    """``output``: where results go and which videos are written."""

    dir: str = knob("runs", "parent directory of the run directories (relative to the cwd)")
    video: bool = knob(True, "write one mp4 per episode")
    view: str = knob(
        "default",
        "what the video shows: default (CarRacing's view / the track overview), sensors (a "
        "map of the lidar rays, cones and lookahead, the perspective views beside it) or the "
        "id of a camera or image sensor",
    )
    fps: float | None = knob(
        None, "video frame rate; null: the simulation's fps", "Hz", low=1, high=1000
    )
    video_episodes: int | None = knob(
        None, "write videos of the first this many episodes only (null: all)", low=0
    )


@dataclass(frozen=True)
class ExperimentConfig:
    """A whole experiment file."""

    env: dict[str, Any] = knob(
        MappingProxyType({}),
        "environment: a track folder (key 'environment') and/or inline track.yaml sections",
    )
    driver: str = knob(
        "centerline", "random, constant, centerline, or module:callable (your own policy)"
    )
    driver_args: dict[str, Any] = knob(
        MappingProxyType({}),
        "keyword arguments for the driver (the centerline driver's knobs, in CarRacing's "
        "units scaled by the car's wheelbase: docs/experiments.md)",
    )
    drivers: dict[str | int, Any] = knob(
        MappingProxyType({}),
        "races: a driver per car, by car name (car_1) or index (1): a driver as in 'driver', "
        "or {driver: ..., driver_args: {...}}; cars not listed drive 'driver'",
    )
    episodes: int = knob(5, "how many episodes", low=1, high=MAX_EPISODES)
    seed: int = knob(0, "episode i is reset with seed + i", low=0)
    max_steps: int | None = knob(
        None, "stop an episode after this many steps (null: the env's own limits)", "steps", low=1
    )
    output: OutputConfig = knob(OutputConfig(), "results, tables and videos")
