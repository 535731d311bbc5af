"""report.html: self-contained (inline pictures, no network, no scripts), with the trajectory
pictures, returns, lap times and time series; ``tinyrace report`` rebuilds it from the files."""

from __future__ import annotations

import base64
import dataclasses
import json
import re
from pathlib import Path

import cv2
import numpy as np

from tinyrace import cli
from tinyrace.examples import CONFIGS_DIR
from tinyrace.experiment import load_experiment, run_experiment
from tinyrace.experiment.record import read_trace
from tinyrace.experiment.report import REPORT_FILE
from tinyrace.render.track_picture import PictureFrame, procedural_picture


def run(tmp_path: Path, name: str, episodes: int, max_steps: int | None):
    experiment = load_experiment(CONFIGS_DIR / f"{name}.yaml")
    config = dataclasses.replace(
        experiment.config,
        episodes=episodes,
        max_steps=max_steps,
        output=dataclasses.replace(experiment.config.output, video=False),
    )
    experiment = dataclasses.replace(experiment, config=config)
    return run_experiment(experiment, tmp_path, show_progress=False)


def inline_images(page: str) -> list[np.ndarray]:
    blobs = re.findall(r"src='data:image/png;base64,([A-Za-z0-9+/=]+)'", page)
    return [
        cv2.imdecode(np.frombuffer(base64.b64decode(b), np.uint8), cv2.IMREAD_COLOR) for b in blobs
    ]


def test_the_report_is_self_contained(tmp_path: Path):
    result = run(tmp_path, "carracing", episodes=2, max_steps=60)
    page = (result.run_dir / REPORT_FILE).read_text()
    assert "<script" not in page.lower()
    assert not re.search(r"(src|href)=['\"]?(https?:|//)", page)  # nothing loaded from afar
    images = inline_images(page)
    # two tracks (one per seed), returns, lap times, one time series per episode
    assert len(images) == 6 and all(image is not None for image in images)
    for name in ("report_returns.png", "report_lap_times.png", "report_episode_001.png"):
        assert (result.run_dir / name).is_file()


def test_trajectories_are_drawn_where_the_car_went(tmp_path: Path):
    result = run(tmp_path, "carracing", episodes=1, max_steps=200)
    run_dir = result.run_dir
    background = cv2.imread(str(run_dir / "track_seed0.png"))
    drawn = cv2.imread(str(run_dir / "report_track_seed0.png"))
    assert background.shape == drawn.shape
    trace = read_trace(run_dir / result.episodes[0].trace)
    assert len(trace["x"]) == 201 and np.isfinite(trace["speed"]).all()
    # every point of the path is drawn where the track picture's frame puts the car
    entry = json.loads((run_dir / "results.json").read_text())["tracks"]["seed0"]
    pixels = PictureFrame(*entry["frame"]).pixels(np.stack([trace["x"], trace["y"]], axis=-1))
    changed = np.abs(drawn.astype(int) - background.astype(int)).sum(axis=2) > 60
    for x, y in np.round(pixels[::10]).astype(int):
        assert changed[y - 1 : y + 2, x - 1 : x + 2].any()
    assert changed.mean() < 0.2  # a path, not a repainted picture


def test_tinyrace_report_rebuilds_it(tmp_path: Path, capsys):
    result = run(tmp_path, "formula_student", episodes=1, max_steps=50)
    report = result.run_dir / REPORT_FILE
    first = report.read_text()
    report.unlink()
    (result.run_dir / "report_returns.png").unlink()
    assert cli.main(["report", str(result.run_dir)]) == 0
    assert report.read_text() == first
    assert (result.run_dir / "report_returns.png").is_file()


def test_an_image_track_report_has_the_cte_plot(tmp_path: Path):
    result = run(tmp_path, "carolo_cup", episodes=1, max_steps=40)
    trace = read_trace(result.run_dir / result.episodes[0].trace)
    assert np.isfinite(trace["cte"][1:]).all()
    assert result.episodes[0].track == "track0"
    assert (result.run_dir / "report_track_track0.png").is_file()


def test_show_has_no_black_bands(tmp_path: Path):
    config = load_experiment(CONFIGS_DIR / "carracing.yaml").env_config
    for seed in (0, 3, 7):
        image = procedural_picture(config, seed)
        edges = np.concatenate([image[0], image[-1], image[:, 0], image[:, -1]])
        assert (edges.max(axis=1) > 40).all()  # grass or road everywhere at the border
