"""Races in the CLI: ``tinyrace run`` of an experiment with several cars, a driver per car;
its files (results.json and episodes.csv per car, each car's trace, one video, the report
with every car's path and positions), the errors that name a car, and the run folder
check of ``tinyrace report``."""

from __future__ import annotations

import csv
import dataclasses
import json
import math
import os
import re
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import imageio_ffmpeg
import numpy as np
import pytest

from tinyrace import cli
from tinyrace.drivers.centerline import Route, offset_line
from tinyrace.errors import ConfigError
from tinyrace.examples import CONFIGS_DIR
from tinyrace.experiment import (
    experiment_from_dict,
    load_experiment,
    rebuild_report,
    run_experiment,
)
from tinyrace.experiment.race_drivers import car_drivers
from tinyrace.experiment.race_results import RACE_TRACE_COLUMNS, CarResult
from tinyrace.experiment.record import TRACE_COLUMNS
from tinyrace.experiment.results import EpisodeResult
from tinyrace.race import RaceEnv
from tinyrace.race.drive import car_seed

ROOT = Path(__file__).resolve().parents[1]
RACES = {"circuit_race": 4, "f1tenth_race": 2}  # the shipped races and their cars
TESTS = Path(__file__).resolve().parent


def shortened(name: str, max_steps: int | None = 40, video: bool = True, episodes: int = 1):
    experiment = load_experiment(CONFIGS_DIR / f"{name}.yaml")
    output = dataclasses.replace(experiment.config.output, video=video)
    config = dataclasses.replace(
        experiment.config, max_steps=max_steps, episodes=episodes, output=output
    )
    return dataclasses.replace(experiment, config=config)


def race(raw_env: dict, **keys) -> dict:
    """A small race on the f1tenth loop: two cars unless ``raw_env`` says otherwise."""
    env = {"environment": "f1tenth_loop", "race": {"num_agents": 2}, "cameras": [], **raw_env}
    return {"env": env, "episodes": 1, "max_steps": 5, "output": {"video": False}, **keys}


def csv_rows(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as handle:
        return list(csv.DictReader(handle))


@pytest.mark.parametrize("name", sorted(RACES))
def test_a_shipped_race_writes_every_cars_results(name: str, tmp_path: Path):
    experiment = shortened(name)
    cars = RACES[name]
    agents = list(experiment.agents)
    assert experiment.is_race and len(agents) == cars
    result = run_experiment(experiment, tmp_path, show_progress=False)
    run = result.run_dir
    data = json.loads((run / "results.json").read_text())
    assert [car["id"] for car in data["cars"]] == agents
    assert len({car["color"] for car in data["cars"]}) == cars  # each car its own colour
    (episode,) = data["episodes"]
    assert sorted(episode["order"]) == sorted(agents) and episode["winner"] == episode["order"][0]
    assert [row["car"] for row in episode["cars"]] == agents
    assert set(data["summary"]) == set(agents)
    rows = csv_rows(run / "episodes.csv")
    assert list(rows[0]) == [f.name for f in dataclasses.fields(CarResult)]
    assert [row["car"] for row in rows] == agents
    assert sorted(int(row["position"]) for row in rows) == list(range(1, cars + 1))
    for row in rows:
        assert int(row["steps"]) == 40 and row["end"] == "max_steps" and row["laps"] == "0"
        assert row["lap_times"] == "" and row["best_lap"] == ""
        trace = csv_rows(run / row["trace"])
        assert list(trace[0]) == list(RACE_TRACE_COLUMNS) and len(trace) == 41
        assert int(trace[-1]["position"]) == int(row["position"])  # the last place is final
        assert float(trace[-1]["x"]) != float(trace[0]["x"])  # every car drove
    by_place = sorted(rows, key=lambda row: int(row["position"]))
    assert episode["order"] == [row["car"] for row in by_place]
    assert rows[0]["video"] == "episode_000.mp4" and (run / "episode_000.mp4").stat().st_size
    assert len({row["video"] for row in rows}) == 1  # one video with every car
    report = (run / "report.html").read_text()
    assert all(agent in report for agent in agents)
    for picture in ("report_paths_000.png", "report_positions_000.png"):
        assert (run / picture).read_bytes().startswith(b"\x89PNG")
        assert picture in report or "data:image/png" in report
    before = report
    assert rebuild_report(run) == run / "report.html"  # from the run's files alone
    assert (run / "report.html").read_text() == before


@pytest.mark.parametrize("name", sorted(RACES))
def test_every_car_of_a_shipped_race_finishes_its_lap(name: str, tmp_path: Path):
    """The whole race, as ``tinyrace run`` runs it: every car finishes a lap; its lap time is
    the steps to the end of its lap, and the places follow the lap times."""
    result = run_experiment(shortened(name, max_steps=None, video=False), tmp_path, False)
    (episode,) = result.episodes
    dt = json.loads((result.run_dir / "results.json").read_text())["dt"]
    for car in episode.cars:
        assert car.end == "lap_finished" and car.laps == 1
        assert car.lap_times == [pytest.approx(car.steps * dt)]
        assert car.best_lap == pytest.approx(car.steps * dt)
        assert car.cars_hit == 0 and car.wall_hits == 0  # each car keeps to its lane
    by_time = sorted(episode.cars, key=lambda car: car.steps)
    assert [car.car for car in by_time] == episode.order
    assert [car.position for car in by_time] == list(range(1, len(by_time) + 1))


def test_a_faster_car_behind_overtakes(tmp_path: Path):
    """The f1tenth race's car_1 starts second and is faster: its trace shows it pass."""
    result = run_experiment(shortened("f1tenth_race", max_steps=None, video=False), tmp_path)
    trace = csv_rows(result.run_dir / "episode_000_car_1_trace.csv")
    places = [int(row["position"]) for row in trace]
    assert places[0] == 2 and places[-1] == 1


def test_drivers_by_name_and_index_and_the_default(tmp_path: Path):
    raw = race({}, driver="centerline", drivers={1: "random"})
    experiment = experiment_from_dict(raw, "race.yaml", tmp_path)
    drivers, problems = car_drivers(experiment.config, experiment.agents, "race.yaml")
    assert problems == []
    assert [(d.agent, d.spec, d.key) for d in drivers] == [
        ("car_0", "centerline", "driver"),
        ("car_1", "random", "drivers.1"),
    ]
    raw = race({}, drivers={"car_0": {"driver": "constant", "driver_args": {"action": [0, 1, 0]}}})
    experiment = experiment_from_dict(raw, "race.yaml", tmp_path)
    drivers, _ = car_drivers(experiment.config, experiment.agents, "race.yaml")
    assert (drivers[0].spec, drivers[0].args) == ("constant", {"action": [0, 1, 0]})
    assert drivers[1].spec == "centerline"


def test_an_unknown_driver_for_one_car_names_the_car_and_the_drivers(tmp_path: Path, capsys):
    raw = race({"race": {"num_agents": 3}}, drivers={"car_2": "centreline"})
    with pytest.raises(ConfigError) as error:
        experiment_from_dict(raw, "race.yaml", tmp_path)
    (problem,) = error.value.problems
    assert problem.path == "drivers.car_2" and problem.value == "centreline"
    assert "car car_2's driver" in problem.allowed
    assert "did you mean 'centerline'" in problem.allowed
    assert (
        "centerline, constant, random" in problem.allowed and "module:callable" in problem.allowed
    )
    path = tmp_path / "race.yaml"
    path.write_text(json.dumps(raw))
    assert cli.main(["run", str(path), "-o", str(tmp_path / "runs"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "drivers.car_2" in err and "car car_2" in err
    assert not (tmp_path / "runs").exists()


@pytest.mark.parametrize(
    ("drivers", "path", "allowed"),
    [
        ({"car_5": "random"}, "drivers.car_5", "expected a car of the race: car_0, car_1"),
        ({7: "random"}, "drivers.7", "or its index, 0 to 1"),
        ({"car_1": "random", 1: "constant"}, "drivers.1", "names car car_1 too"),
        ({"car_1": 3}, "drivers.car_1", "car car_1's driver: expected a driver name"),
        ({"car_1": {"drvier": "random"}}, "drivers.car_1.drvier", "{driver: ..., driver_args"),
        ({"car_1": {"driver": "random", "driver_args": 3}}, "drivers.car_1.driver_args", "mapping"),
        ({"car_1": {"driver": "nope:make"}}, "drivers.car_1.driver", "car car_1's driver"),
    ],
)
def test_bad_drivers_name_the_key_and_the_car(drivers, path, allowed, tmp_path: Path):
    with pytest.raises(ConfigError) as error:
        experiment_from_dict(race({}, drivers=drivers), "race.yaml", tmp_path)
    (problem,) = error.value.problems
    assert problem.path == path and allowed in problem.allowed


def test_per_car_drivers_need_a_race(tmp_path: Path):
    raw = race({"race": {"num_agents": 1}}, drivers={"car_0": "random"})
    with pytest.raises(ConfigError, match=r"drivers: .*expected no per-car drivers for one car"):
        experiment_from_dict(raw, "race.yaml", tmp_path)


def test_a_race_video_is_the_overview(tmp_path: Path):
    raw = race({"sensors": [{"id": "state", "type": "state"}]}, output={"view": "sensors"})
    message = re.escape("output.view: got 'sensors'; expected default")
    with pytest.raises(ConfigError, match=message):
        experiment_from_dict(raw, "race.yaml", tmp_path)


def test_a_failing_driver_names_its_car_and_leaves_no_run_folder(tmp_path: Path):
    raw = race({}, drivers={"car_1": "drivers_for_tests:failing_policy"})
    experiment = experiment_from_dict(raw, "race.yaml", TESTS)
    with pytest.raises(ConfigError) as error:
        run_experiment(experiment, tmp_path / "runs", show_progress=False)
    (problem,) = error.value.problems
    assert problem.path == "drivers.car_1" and "car car_1's driver" in problem.allowed
    assert "the policy broke" in problem.allowed
    assert not (tmp_path / "runs").exists()


def test_random_drivers_of_two_cars_drive_differently(tmp_path: Path):
    raw = race({}, driver="random", max_steps=6)
    result = run_experiment(experiment_from_dict(raw, "race.yaml", tmp_path), tmp_path)
    steers = [
        [row["steer"] for row in csv_rows(result.run_dir / f"episode_000_car_{i}_trace.csv")]
        for i in range(2)
    ]
    assert steers[0] != steers[1]
    assert car_seed(0, 0) == 0 and len({car_seed(0, 1), car_seed(0, 2), car_seed(1, 1)}) == 3


def test_one_cars_run_keeps_its_formats(tmp_path: Path):
    experiment = load_experiment(CONFIGS_DIR / "f1tenth.yaml")
    config = dataclasses.replace(experiment.config, episodes=1, max_steps=5)
    config = dataclasses.replace(config, output=dataclasses.replace(config.output, video=False))
    experiment = dataclasses.replace(experiment, config=config)
    assert not experiment.is_race and experiment.agents == ("car_0",)
    result = run_experiment(experiment, tmp_path, show_progress=False)
    data = json.loads((result.run_dir / "results.json").read_text())
    assert "cars" not in data and set(data["summary"]) >= {"episode_return", "steps"}
    rows = csv_rows(result.run_dir / "episodes.csv")
    assert list(rows[0]) == [f.name for f in dataclasses.fields(EpisodeResult)]
    trace = csv_rows(result.run_dir / rows[0]["trace"])
    assert list(trace[0]) == list(TRACE_COLUMNS)


@pytest.fixture(scope="module")
def race_folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("race")
    return run_experiment(shortened("f1tenth_race", max_steps=8, video=False), root).run_dir


def _edited(folder: Path, tmp_path: Path, name: str, old: str, new: str) -> Path:
    copy = tmp_path / "run"
    shutil.copytree(folder, copy)
    text = (copy / name).read_text()
    assert old in text
    (copy / name).write_text(text.replace(old, new, 1))
    return copy


@pytest.mark.parametrize(
    ("name", "old", "new", "where"),
    [
        ("episodes.csv", ",car_1,", ",car_9,", "line 3, car: got 'car_9'"),
        ("episodes.csv", "\n0,0,car_0,1,", "\n0,0,car_0,7,", "line 2, position: got 7"),
        ("episodes.csv", ",max_steps,", ",max_steps,", None),
        ("results.json", '"color": "#0072b2"', '"color": "blue"', "cars[1].color: got 'blue'"),
        ("results.json", '"id": "car_1"', '"id": "car_0"', "cars[1].id: got 'car_0'"),
        ("results.json", '"cars": [', '"cars": 3, "x": [', "cars: got 3"),
    ],
)
def test_the_run_folder_check_accepts_races_and_refuses_bad_edits(
    race_folder: Path, tmp_path: Path, name: str, old: str, new: str, where: str | None
):
    copy = _edited(race_folder, tmp_path, name, old, new)
    if where is None:
        assert cli.main(["report", str(copy)]) == 0  # untouched: rebuilt
        return
    with pytest.raises(ConfigError, match=re.escape(f"{name}: {where}")):
        rebuild_report(copy)


def test_lap_times_cells_are_numbers(race_folder: Path, tmp_path: Path):
    copy = tmp_path / "run"
    shutil.copytree(race_folder, copy)
    rows = csv_rows(copy / "episodes.csv")
    rows[0]["lap_times"] = "12.5 abc"
    with (copy / "episodes.csv").open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    message = re.escape("line 2, lap_times: got '12.5 abc'; expected numbers")
    with pytest.raises(ConfigError, match=message):
        rebuild_report(copy)


@pytest.mark.parametrize("y_down", [False, True])
def test_an_offset_lane_is_beside_the_route_on_the_drivers_left(y_down: bool):
    """Round a circle counter-clockwise (y up; clockwise on screen when y points down), the
    driver's left is the centre: a lane 2 to the left has radius 8, one to the right 12."""
    angles = np.linspace(0, 2 * math.pi, 400, endpoint=False)
    points = 10 * np.column_stack((np.cos(angles), np.sin(angles)))
    route = Route(points, True, y_down, 1.0, 0.4, 1.0)
    inner = np.hypot(*offset_line(route, 2.0).T)
    outer = np.hypot(*offset_line(route, -2.0).T)
    # on y-down pictures the same points run clockwise as seen: the left is outside
    expected = (12.0, 8.0) if y_down else (8.0, 12.0)
    assert inner == pytest.approx(expected[0], abs=1e-3)
    assert outer == pytest.approx(expected[1], abs=1e-3)


def test_the_names_come_from_the_race_env(tmp_path: Path):
    experiment = experiment_from_dict(race({"race": {"num_agents": 3}}), "r.yaml", tmp_path)
    built = RaceEnv(config=experiment.loaded)
    try:
        assert experiment.agents == tuple(built.possible_agents)
    finally:
        built.close()


IMAGE_CTE = {"cross_track_error": {"use_cte": True, "trajectory_color": [255, 255, 255]}}


@pytest.mark.parametrize(
    "env",
    [
        {},  # procedural
        {"environment": "formula_student", "reward_design": IMAGE_CTE},  # image
        {"environment": "autocross"},  # cone_map
    ],
    ids=["procedural", "image", "cone_map"],
)
def test_a_race_runs_on_every_track_kind(env: dict, tmp_path: Path):
    """(centerline and ros_map: the shipped races above.)"""
    raw = {
        "env": {**env, "race": {"num_agents": 3}},
        "drivers": {"car_2": "random"},
        "episodes": 1,
        "max_steps": 12,
        "output": {"video": False},
    }
    result = run_experiment(experiment_from_dict(raw, "race.yaml", tmp_path), tmp_path, False)
    (episode,) = result.episodes
    assert [car.driver for car in episode.cars] == ["centerline", "centerline", "random"]
    assert sorted(car.position for car in episode.cars) == [1, 2, 3]
    assert all(car.steps == 12 for car in episode.cars)
    assert (result.run_dir / "report_paths_000.png").is_file()
    assert (result.run_dir / "report_positions_000.png").is_file()


def test_an_interrupted_race_keeps_its_finished_episodes(tmp_path: Path):
    experiment = tmp_path / "long_race.yaml"
    raw = race(
        {},
        driver="drivers_for_tests:slow_policy",
        driver_args={"delay": 0.01, "size": 2},  # [s] per step of each car
        episodes=50,
        max_steps=30,
        output={"video": True},
    )
    experiment.write_text(json.dumps(raw))
    env = {**os.environ, "PYTHONPATH": f"{ROOT}{os.pathsep}{TESTS}"}
    command = [sys.executable, "-m", "tinyrace", "run", str(experiment), "-o", "runs"]
    process = subprocess.Popen(
        command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, cwd=tmp_path
    )
    try:
        for line in process.stderr:  # one line per finished episode (not a terminal)
            if line.startswith("episode 0 (1/50)"):
                break
        process.send_signal(signal.SIGINT)
        err = process.communicate(timeout=120)[1]
    finally:
        process.kill()
    assert process.returncode == 130, err
    (run_dir,) = (tmp_path / "runs").iterdir()
    results = json.loads((run_dir / "results.json").read_text())
    finished = len(results["episodes"])
    assert results["interrupted"] is True and 1 <= finished < 50
    rows = csv_rows(run_dir / "episodes.csv")
    assert [(int(r["episode"]), r["car"]) for r in rows] == [
        (episode, car) for episode in range(finished) for car in ("car_0", "car_1")
    ]
    assert (run_dir / "report.html").is_file()
    frames = imageio_ffmpeg.read_frames(str(run_dir / f"episode_{finished:03d}.mp4"))
    assert next(frames)["codec"] == "h264" and 1 <= sum(1 for _ in frames) <= 31
