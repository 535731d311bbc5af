"""Experiment files end to end: every shipped config runs and its driver finishes a lap; the
built-in driver's results; results.json, episodes.csv and videos; validation of experiment
keys."""

from __future__ import annotations

import csv
import dataclasses
import json
from pathlib import Path

import imageio_ffmpeg
import pytest
import yaml

from tinyrace.drivers import load_driver, run_episode
from tinyrace.env import TinyRaceEnv
from tinyrace.errors import ConfigError
from tinyrace.examples import CONFIGS_DIR, TRACKS_DIR
from tinyrace.experiment import experiment_from_dict, load_experiment, run_experiment, video
from tinyrace.experiment.record import EpisodeRecorder
from tinyrace.experiment.route import route_watch
from tinyrace.experiment.runner import DEFAULT_MAX_STEPS

ROOT = Path(__file__).resolve().parents[1]
CONFIGS = sorted((CONFIGS_DIR).glob("*.yaml"))
IMAGE_CONFIGS = ("formula_student", "segmented", "carolo_cup")
# one car's experiments (the races' laps: tests/test_race_runs.py)
ONE_CAR = [p for p in CONFIGS if "race" not in (yaml.safe_load(p.read_text()).get("env") or {})]


def shortened(path: Path, episodes: int = 1, max_steps: int | None = 30, video: bool = False):
    experiment = load_experiment(path)
    config = dataclasses.replace(
        experiment.config,
        episodes=episodes,
        max_steps=max_steps,
        output=dataclasses.replace(experiment.config.output, video=video, video_episodes=1),
    )
    return dataclasses.replace(experiment, config=config)


def test_the_shipped_configs_are_the_documented_ones():
    names = {path.stem for path in CONFIGS}
    assert {
        "carracing",
        "carracing_discrete",
        "domain_randomize",
        "formula_student",
        "segmented",
        "carolo_cup",
        "multi_camera",
    } <= names


def test_multi_camera_has_three_or_more_cameras_one_looking_back():
    cameras = load_experiment(CONFIGS_DIR / "multi_camera.yaml").env_config.cameras
    assert len(cameras) >= 3
    assert any(abs(abs(c.yaw) - 180) < 1e-9 for c in cameras)


@pytest.mark.parametrize("path", CONFIGS, ids=lambda p: p.stem)
def test_every_config_runs_a_few_steps(path: Path, tmp_path: Path):
    result = run_experiment(shortened(path), tmp_path, show_progress=False)
    (episode,) = result.episodes
    assert 1 <= episode.steps <= 30
    data = json.loads((result.run_dir / "results.json").read_text())
    assert data["episodes"][0]["steps"] == episode.steps
    assert result.run_dir.name.startswith(path.stem + "-")


class LapDone(Exception):
    """Stops an episode once its first lap is counted (the rest costs test time only)."""


@pytest.mark.parametrize("path", ONE_CAR, ids=lambda p: p.stem)
def test_every_shipped_driver_finishes_a_lap(path: Path):
    """The first episode of each shipped experiment, as ``tinyrace run`` drives and measures
    it (its driver, seed and step limit; laps as the run counts them), finishes a lap."""
    experiment = load_experiment(path)
    config = experiment.config
    env = TinyRaceEnv(**experiment.env_kwargs)
    try:
        limit = config.max_steps or env.config.sim.step_limit or DEFAULT_MAX_STEPS

        def stop_at_the_lap(recorder: EpisodeRecorder) -> None:
            if recorder.laps:
                raise LapDone

        recorder = EpisodeRecorder(
            env.action_space, env.dt, on_step=stop_at_the_lap, watch=lambda: route_watch(env)
        )
        driver = load_driver(config.driver, **config.driver_args)
        with pytest.raises(LapDone):
            run_episode(env, driver, config.seed, limit, recorder)
    finally:
        env.close()
    assert recorder.laps == 1 and recorder.steps <= limit
    assert recorder.lap_time == pytest.approx(recorder.steps * env.dt)


def decoded(path: Path) -> tuple[dict, list]:
    """The metadata (codec, pixel format, size) and every frame of a video, by ffmpeg."""
    frames = imageio_ffmpeg.read_frames(str(path))
    meta = next(frames)
    return meta, list(frames)


def test_results_files_and_videos(tmp_path: Path):
    experiment = shortened(
        CONFIGS_DIR / "formula_student.yaml", episodes=2, max_steps=40, video=True
    )
    result = run_experiment(experiment, tmp_path, show_progress=False)
    rows = list(csv.DictReader((result.run_dir / "episodes.csv").open()))
    assert [int(r["episode"]) for r in rows] == [0, 1]
    assert all(int(r["steps"]) == 40 and r["end"] == "max_steps" for r in rows)
    summary = json.loads((result.run_dir / "results.json").read_text())["summary"]
    assert {"mean", "std"} <= set(summary["episode_return"])
    assert result.episodes[0].video == "episode_000.mp4"  # only the first episode has a video
    assert result.episodes[1].video is None
    meta, frames = decoded(result.run_dir / "episode_000.mp4")
    assert meta["codec"] == "h264" and meta["pix_fmt"].startswith("yuv420p")
    assert len(frames) == 41  # the reset and every step, the last one included


def test_videos_are_faststart_h264(tmp_path: Path):
    experiment = shortened(CONFIGS_DIR / "carracing.yaml", max_steps=12, video=True)
    result = run_experiment(experiment, tmp_path, show_progress=False)
    data = (result.run_dir / "episode_000.mp4").read_bytes()
    assert data.index(b"moov") < data.index(b"mdat")  # the index first: plays while loading
    meta, frames = decoded(result.run_dir / "episode_000.mp4")
    assert meta["codec"] == "h264" and meta["size"] == (600, 400) and len(frames) == 13


def test_odd_frame_sizes_are_padded_not_cropped(tmp_path: Path):
    raw = {
        "env": {
            "environment": str(TRACKS_DIR / "segmented"),
            "cameras": [{"id": "odd", "resolution": [61, 81], "roi": [360, 480]}],
        },
        "episodes": 1,
        "max_steps": 3,
        "output": {"view": "odd"},
    }
    result = run_experiment(experiment_from_dict(raw, "odd.yaml", ROOT), tmp_path, False)
    meta, frames = decoded(result.run_dir / "episode_000.mp4")
    assert meta["size"] == (82, 62) and len(frames) == 4


def test_without_imageio_ffmpeg_videos_are_vp9_webm(tmp_path: Path, monkeypatch):
    monkeypatch.setattr(video, "h264_available", lambda: False)
    experiment = shortened(CONFIGS_DIR / "segmented.yaml", max_steps=7, video=True)
    result = run_experiment(experiment, tmp_path, show_progress=False)
    assert result.episodes[0].video == "episode_000.webm"
    meta, frames = decoded(result.run_dir / "episode_000.webm")
    assert meta["codec"] == "vp9" and meta["size"] == (160, 120) and len(frames) == 8


def test_a_camera_view_video_has_the_camera_size(tmp_path: Path):
    experiment = shortened(CONFIGS_DIR / "segmented.yaml", max_steps=5, video=True)
    result = run_experiment(experiment, tmp_path, show_progress=False)
    meta, frames = decoded(result.run_dir / result.episodes[0].video)
    assert meta["size"] == (160, 120) and len(frames) == 6


def test_the_centreline_driver_finishes_carracing_laps(tmp_path: Path):
    """Issue 4: mean return >= 850 over 5 seeds on the default experiment."""
    experiment = shortened(CONFIGS_DIR / "carracing.yaml", episodes=5, max_steps=1000)
    result = run_experiment(experiment, tmp_path, show_progress=False)
    assert result.summary["episode_return"]["mean"] >= 850
    assert all(e.end == "lap_finished" and e.laps == 1 for e in result.episodes)


@pytest.mark.parametrize("name", IMAGE_CONFIGS)
def test_the_centreline_driver_keeps_to_image_tracks(name: str, tmp_path: Path):
    """Issue 4: mean |cte| under half the track width, step_limit reached without a done."""
    experiment = shortened(CONFIGS_DIR / f"{name}.yaml", max_steps=None)
    result = run_experiment(experiment, tmp_path, show_progress=False)
    (episode,) = result.episodes
    car = experiment.env_config.car
    assert episode.end == "step_limit"
    assert episode.steps == experiment.env_config.sim.step_limit
    assert episode.mean_abs_cte < car.track_width / 2
    assert episode.obstacle_hits == 0


def test_own_driver_from_module_callable(tmp_path: Path):
    raw = {
        "driver": "drivers_for_tests:straight_policy",
        "episodes": 1,
        "max_steps": 5,
        "output": {"video": False},
    }
    experiment = experiment_from_dict(raw, "inline.yaml", ROOT)
    result = run_experiment(experiment, tmp_path, show_progress=False)
    assert result.episodes[0].steps == 5


@pytest.mark.parametrize(
    ("raw", "path", "value"),
    [
        ({"episodes": 0}, "episodes", "0"),
        ({"episods": 3}, "episods", "did you mean 'episodes'"),
        ({"env": {"sim": {"fps": "fast"}}}, "env.sim.fps", "'fast'"),
        ({"env": {"environment": "no/such/folder"}}, "env.environment", "track.yaml"),
        ({"output": {"view": 3}}, "output.view", "3"),
        ({"driver": "nosuchmodule:thing"}, "driver", "nosuchmodule"),
        ({"driver": "teleport"}, "driver", "teleport"),
    ],
)
def test_bad_experiments_name_the_key(raw: dict, path: str, value: str, tmp_path: Path):
    with pytest.raises(ConfigError) as error:
        experiment = experiment_from_dict(raw, "exp.yaml", ROOT)
        run_experiment(experiment, tmp_path, show_progress=False)
    message = str(error.value)
    assert "exp.yaml" in message and path in message and value in message


def test_a_view_that_is_no_camera_is_refused(tmp_path: Path):
    raw = {"env": {"environment": "example_tracks/segmented"}, "output": {"view": "roof"}}
    with pytest.raises(ConfigError, match=r"output\.view.*front_camera"):  # when it is read
        experiment_from_dict(raw, "exp.yaml", ROOT)
