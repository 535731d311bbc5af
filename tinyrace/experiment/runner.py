"""Running an experiment end to end: episodes, driver, videos, metrics, files."""

from __future__ import annotations

import datetime as dt
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from tinyrace.drivers import Driver, load_driver
from tinyrace.env import TinyRaceEnv
from tinyrace.errors import ConfigError, Problem
from tinyrace.experiment.load import Experiment
from tinyrace.experiment.progress import Progress
from tinyrace.experiment.report import EpisodeResult, summary, summary_text, table, write_files
from tinyrace.render.sensor_view import sensor_view

DEFAULT_MAX_STEPS = 1000  # when neither the experiment nor the env sets a limit (CarRacing's)


@dataclass
class RunResult:
    run_dir: Path
    episodes: list[EpisodeResult]

    @property
    def summary(self) -> dict[str, dict[str, float]]:
        return summary(self.episodes)


class _Tally:
    """Accumulates one episode's metrics from the step infos."""

    def __init__(self) -> None:
        self.episode_return = 0.0
        self.steps = 0
        self.obstacle_hits = 0
        self.cte_sum, self.cte_count = 0.0, 0
        self.info: dict[str, Any] = {}

    def add(self, reward: float, info: dict[str, Any]) -> None:
        self.episode_return += reward
        self.steps += 1
        self.obstacle_hits += bool(info.get("obstacles_hit"))
        if info.get("cte") is not None:
            self.cte_sum += abs(info["cte"])
            self.cte_count += 1
        self.info = info


def run_experiment(
    experiment: Experiment, out_root: Path | None = None, show_progress: bool = True
) -> RunResult:
    """Run every episode; write results.json, episodes.csv and videos into a new run directory."""
    config = experiment.config
    run_dir = _new_run_dir(Path(out_root or config.output.dir), experiment.name)
    render_mode = "rgb_array" if config.output.video and config.output.view == "default" else None
    env = TinyRaceEnv(render_mode=render_mode, **experiment.env_kwargs)
    _check_view(experiment, env)
    driver = _driver(config.driver, config.driver_args, experiment.source)
    limit = config.max_steps or env.config.sim.step_limit or DEFAULT_MAX_STEPS
    progress = Progress(config.episodes, enabled=show_progress)
    results = []
    try:
        for episode in range(config.episodes):
            video = _video_path(run_dir, episode, config)
            result = _run_episode(
                env, driver, episode, config.seed + episode, limit, video, progress, config
            )
            results.append(result)
            progress.end_episode(
                episode, f"return {result.episode_return:.1f}, {result.steps} steps, {result.end}"
            )
    finally:
        env.close()
    header = {"experiment": experiment.source, "started": run_dir.name, "config": _plain(config)}
    write_files(run_dir, results, header)
    return RunResult(run_dir, results)


def _run_episode(
    env: TinyRaceEnv,
    driver: Driver,
    episode: int,
    seed: int,
    limit: int,
    video: Path | None,
    progress: Progress,
    config,
) -> EpisodeResult:
    observation, info = env.reset(seed=seed)
    driver.reset(env)
    tally, writer = _Tally(), None
    progress.start_episode()
    started = time.perf_counter()
    end = "max_steps"
    while tally.steps < limit:
        if video is not None:
            writer = _write_frame(
                writer, video, _frame(env, observation, config.output.view), env, config
            )
        action = driver.act(observation, info)
        observation, reward, terminated, truncated, info = env.step(action)
        tally.add(reward, info)
        progress.update(episode, tally.steps, limit)
        if terminated or truncated:
            end = info.get("termination", "step_limit")
            break
    if writer is not None:
        writer.release()
    elapsed = time.perf_counter() - started
    return EpisodeResult(
        episode=episode,
        seed=seed,
        episode_return=tally.episode_return,
        steps=tally.steps,
        tiles_visited=tally.info.get("tiles_visited"),
        tiles_total=tally.info.get("tiles_total"),
        laps=int(end == "lap_finished"),
        obstacle_hits=tally.obstacle_hits,
        mean_abs_cte=tally.cte_sum / tally.cte_count if tally.cte_count else None,
        end=end,
        steps_per_second=tally.steps / elapsed if elapsed > 0 else 0.0,
        video=str(video) if video is not None else None,
    )


def _driver(spec: str, args: dict, source: str) -> Driver:
    """The experiment's driver; problems name the experiment file and its ``driver`` key."""
    try:
        return load_driver(spec, **args)
    except (ValueError, TypeError) as exc:
        raise ConfigError(Problem(source, "driver", spec, str(exc))) from None


def _frame(env: TinyRaceEnv, observation, view: str) -> np.ndarray:
    if view == "sensors":
        return sensor_view(env).render(env.snapshot(), env._track, observation)
    return env.render() if view == "default" else observation[view]


def _write_frame(writer, path: Path, frame: np.ndarray, env: TinyRaceEnv, config):
    if writer is None:
        fps = config.output.fps or env.config.sim.fps
        size = (frame.shape[1], frame.shape[0])
        writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), fps, size)
    code = cv2.COLOR_GRAY2BGR if frame.ndim == 2 else cv2.COLOR_RGB2BGR  # gray / classes images
    writer.write(cv2.cvtColor(frame, code))
    return writer


def _check_view(experiment: Experiment, env: TinyRaceEnv) -> None:
    view = experiment.config.output.view
    ids = [c.id for c in env.config.cameras]
    ids += [
        s.id for s in env.sensors if getattr(s, "space", None) is not None and _is_image(s.space)
    ]
    if view == "sensors" and env.sensors:
        return
    if view != "default" and view not in ids:
        allowed = f"default, sensors (with sensors) or an image id: {', '.join(ids) or '(none)'}"
        raise ConfigError(Problem(experiment.source, "output.view", view, allowed))


def _is_image(space) -> bool:
    shape = getattr(space, "shape", None) or ()
    return getattr(space, "dtype", None) == np.uint8 and len(shape) in (2, 3)


def _video_path(run_dir: Path, episode: int, config) -> Path | None:
    out = config.output
    if not out.video or (out.video_episodes is not None and episode >= out.video_episodes):
        return None
    return run_dir / f"episode_{episode:03d}.mp4"


def _new_run_dir(root: Path, name: str) -> Path:
    stamp = dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    run_dir, n = root / f"{name}-{stamp}", 1
    while run_dir.exists():
        n += 1
        run_dir = root / f"{name}-{stamp}-{n}"
    run_dir.mkdir(parents=True)
    return run_dir


def _plain(config) -> dict:
    import dataclasses

    return dataclasses.asdict(config)


def print_report(result: RunResult) -> None:
    print(table(result.episodes))
    print()
    print(summary_text(result.summary))
    print(f"\nresults: {result.run_dir}")
