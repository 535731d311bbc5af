"""Every problem at once, each named where it came from, no message inside another; and
"did you mean" wherever a name is looked up."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import pytest
import yaml

import tinyrace  # noqa: F401  (registers the ids)
from tinyrace import cli
from tinyrace.config import load_env_config
from tinyrace.drivers import make_driver
from tinyrace.errors import ConfigError, Problem, did_you_mean, one_line
from tinyrace.examples import copy_example
from tinyrace.experiment import experiment_from_dict, load_experiment, run_experiment
from tinyrace.validate import check_output, validate_path

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def track(tmp_path: Path) -> Path:
    """A copy of the formula_student track folder (its track.yaml and picture)."""
    copy_example("formula_student", tmp_path)
    (tmp_path / "formula_student.yaml").unlink()
    return tmp_path / "formula_student"


def write(path: Path, raw: dict) -> Path:
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    return path


def located(problems: list[Problem]) -> list[tuple[str, str]]:
    return [(Path(p.source).name, p.path) for p in problems]


# -- all at once -------------------------------------------------------------------------------
def test_experiment_and_env_problems_come_in_one_message(track: Path, capsys):
    experiment = write(
        track.parent / "exp.yaml",
        {
            "env": {"environment": "formula_student", "sim": {"step_limit": 0}},
            "driver": "centerlin",
            "episodes": 0,
        },
    )
    assert cli.main(["validate", str(experiment)]) == 1
    lines = capsys.readouterr().out.splitlines()
    assert [line.split(": got")[0] for line in lines] == [
        f"{experiment}: episodes",
        f"{experiment}: driver",
        f"{experiment}: env.sim.step_limit",  # an override: named in the experiment
    ]


def test_experiment_and_file_problems_come_in_one_message(track: Path):
    (track / "formula_student.png").unlink()  # the track's picture is gone
    raw = {"env": {"environment": "formula_student"}, "episodes": 0, "output": {"view": "x"}}
    experiment = write(track.parent / "exp.yaml", raw)
    problems, _ = validate_path(experiment)
    assert [line.split(": got")[0] for line in problems] == [
        f"{experiment}: episodes",
        f"{experiment}: output.view",
        f"{track / 'track.yaml'}: tracks[0].image",  # the file's own problem, its own file
    ]


def test_a_value_is_blamed_where_it_was_written(track: Path):
    """The track file's own mistakes name the track file; the experiment's overrides of it
    name the experiment file, under env."""
    raw = yaml.safe_load((track / "track.yaml").read_text())
    raw["sim"] = {**raw.get("sim", {}), "fps": -1}
    write(track / "track.yaml", raw)
    overrides = {"environment": "formula_student", "car": {"wheelbase": "long"}}
    with pytest.raises(ConfigError) as caught:
        experiment_from_dict({"env": overrides}, "exp.yaml", track.parent)
    assert located(caught.value.problems) == [
        ("track.yaml", "sim.fps"),
        ("exp.yaml", "env.car.wheelbase"),
    ]


@pytest.mark.parametrize(
    ("kwargs", "path"),
    [
        ({"sim": {"fpz": 30}}, "sim.fpz"),
        ({"steering": 1}, "steering"),
        ({"cameras": [{"id": "a", "resolution": [0, 10]}]}, "cameras[0].resolution[0]"),
        ({"track": {"image": "nope.png"}}, "track.image"),  # singular key, file problem: as given
    ],
)
def test_a_keyword_argument_is_never_blamed_on_track_yaml(track: Path, kwargs: dict, path: str):
    with pytest.raises(ConfigError) as caught:
        gym.make("tinyrace/TinyRace-v0", environment=str(track), **kwargs)
    problems = caught.value.problems
    assert any(p.path == path for p in problems), problems
    assert all(p.source == "<kwargs>" for p in problems), problems


def test_the_track_files_problems_and_the_kwargs_come_together(track: Path):
    raw = yaml.safe_load((track / "track.yaml").read_text())
    raw["car"] = {"velocity": "fast"}
    write(track / "track.yaml", raw)
    with pytest.raises(ConfigError) as caught:
        load_env_config(environment=track, overrides={"sim": {"fps": 0}})
    assert located(caught.value.problems) == [
        ("<kwargs>", "sim.fps"),
        ("track.yaml", "car.velocity"),
    ]


def test_a_folder_given_as_config_or_a_file_as_environment_says_which_keyword(track: Path):
    with pytest.raises(ConfigError) as caught:
        gym.make("tinyrace/TinyRace-v0", environment=str(track / "track.yaml"))
    (problem,) = caught.value.problems
    assert problem.source == "<kwargs>" and problem.path == "environment"
    assert "this is a file: give a YAML config file as config=" in problem.allowed


# -- no message inside another -----------------------------------------------------------------
def test_one_line_flattens_a_config_error():
    error = ConfigError([Problem("a.yaml", "x", 1, "no"), Problem("b.yaml", "y", 2, "nope")])
    assert "\n" in str(error)
    assert one_line(error) == "a.yaml: x: got 1; no; b.yaml: y: got 2; nope"
    assert one_line(OSError("disk\nfull")) == "OSError: disk full"


def test_a_refused_picture_path_is_one_message(tmp_path: Path):
    with pytest.raises(ConfigError) as caught:
        check_output(tmp_path / "picture.txt", (), False)
    (problem,) = caught.value.problems
    assert "ConfigError" not in problem.allowed and "invalid configuration" not in problem.allowed


def test_a_drivers_config_error_is_quoted_on_one_line(tmp_path: Path):
    (tmp_path / "bad_driver.py").write_text(
        "from tinyrace.errors import ConfigError, Problem\n"
        "def make():\n"
        "    raise ConfigError([Problem('inner.yaml', 'k', 1, 'no'), Problem('i', 'j', 2, 'n')])\n"
    )
    raw = {"driver": "bad_driver:make", "episodes": 1, "output": {"video": False}}
    experiment = experiment_from_dict(raw, "exp.yaml", tmp_path)
    with pytest.raises(ConfigError) as caught:
        run_experiment(experiment, tmp_path / "runs", show_progress=False)
    (problem,) = caught.value.problems
    assert "\n" not in problem.allowed and "configuration problems" not in problem.allowed
    assert "inner.yaml: k: got 1; no; i: j: got 2; n" in problem.allowed


# -- did you mean --------------------------------------------------------------------------------
def test_did_you_mean_offers_only_close_names():
    assert did_you_mean("lidr", ["lidar", "state"]) == "did you mean 'lidar'? "
    assert did_you_mean("xyz", ["lidar", "state"]) == ""
    assert did_you_mean(3, ["lidar"]) == ""


@pytest.mark.parametrize(
    ("config", "path", "meant"),
    [
        ({"sensors": [{"type": "lidr", "id": "l"}]}, "sensors[0].type", "lidar"),
        ({"car": {"model": "dynamc"}}, "car.model", "dynamic"),
        ({"car": {"actions": "discrte"}}, "car.actions", "discrete"),
        ({"track": {"type": "procedurl"}}, "track.type", "procedural"),
        ({"sim": {"step_limt": 5}}, "sim.step_limt", "step_limit"),
    ],
)
def test_env_names_get_a_did_you_mean(config: dict, path: str, meant: str):
    with pytest.raises(ConfigError) as caught:
        gym.make("tinyrace/TinyRace-v0", **config)
    (problem,) = caught.value.problems
    assert problem.path == path and f"did you mean '{meant}'?" in problem.allowed


def test_experiment_names_get_a_did_you_mean(tmp_path: Path):
    raw = {"driver": "centreline", "env": {"environment": "formula_studnt"}}
    with pytest.raises(ConfigError) as caught:
        load_experiment(write(tmp_path / "exp.yaml", raw))
    hints = {p.path: p.allowed for p in caught.value.problems}
    assert "did you mean 'centerline'?" in hints["driver"]
    assert "did you mean 'formula_student'?" in hints["env.environment"]
    with pytest.raises(ValueError, match="did you mean 'random'"):
        make_driver("randm")


@pytest.mark.parametrize(
    ("argv", "meant"),
    [
        (["validate", "segmentd"], "segmented"),
        (["show", "carolo_cp"], "carolo_cup"),
        (["examples", "copy", "autocros"], "autocross"),
    ],
)
def test_command_line_names_get_a_did_you_mean(tmp_path, monkeypatch, capsys, argv, meant):
    monkeypatch.chdir(tmp_path)
    assert cli.main(argv) == 2
    assert f"did you mean '{meant}'?" in capsys.readouterr().err


def test_reset_options_get_a_did_you_mean():
    env = gym.make("tinyrace/TinyRace-v0")
    with pytest.raises(ConfigError, match="did you mean 'spawn'"):
        env.reset(seed=0, options={"spwan": 0})
    env.close()
