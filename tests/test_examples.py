"""Shipped examples found by bare name from any folder; listing and copying them out."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import pytest
import yaml

import tinyrace
from tinyrace import cli
from tinyrace.errors import ConfigError
from tinyrace.examples import (
    CONFIGS_DIR,
    TRACKS_DIR,
    config_names,
    copy_example,
    examples,
    find_example,
    find_experiment,
    track_names,
)
from tinyrace.experiment import load_experiment


@pytest.fixture
def elsewhere(tmp_path: Path, monkeypatch) -> Path:
    """An empty working folder, far from the package."""
    monkeypatch.chdir(tmp_path)
    return tmp_path


def test_every_shipped_file_has_a_name():
    folders = [p for p in TRACKS_DIR.iterdir() if p.is_dir() and p.name != "__pycache__"]
    assert track_names() == sorted(p.name for p in folders)
    assert config_names() == sorted(p.stem for p in CONFIGS_DIR.glob("*.yaml"))
    assert {"formula_student", "carolo_cup", "segmented"} <= set(track_names())
    assert "carracing" in config_names()


@pytest.mark.parametrize("name", track_names())
def test_gym_make_finds_a_shipped_track_by_name(elsewhere, name):
    env = gym.make("tinyrace/TinyRace-v0", environment=name)
    observation, _ = env.reset(seed=0)
    reference = gym.make("tinyrace/TinyRace-v0", environment=str(TRACKS_DIR / name))
    expected, _ = reference.reset(seed=0)
    assert observation.keys() == expected.keys()
    assert all((observation[k] == expected[k]).all() for k in observation)


def test_an_existing_folder_wins_over_a_shipped_name(elsewhere):
    local = elsewhere / "formula_student"
    local.mkdir()
    (local / "track.yaml").write_text(
        "cameras: [{id: mine, resolution: [8, 8], roi: [80, 80]}]\n"
        "tracks: [{plane_size: [300, 300], spawns: [[150, 150, 0]]}]\n"
    )
    env = gym.make("tinyrace/TinyRace-v0", environment="formula_student")
    assert set(env.observation_space.spaces) == {"mine"}


def test_an_unknown_track_name_lists_the_known_ones(elsewhere):
    with pytest.raises(ConfigError) as caught:
        gym.make("tinyrace/TinyRace-v0", environment="formula_studnt")
    (problem,) = caught.value.problems
    assert problem.path == "environment" and problem.value == "formula_studnt"
    assert all(name in problem.allowed for name in track_names())


def test_an_experiment_names_its_track(tmp_path: Path):
    path = tmp_path / "exp.yaml"
    path.write_text("env: {environment: carolo_cup, sim: {step_limit: 7}}\nepisodes: 1\n")
    experiment = load_experiment(path)
    assert Path(experiment.env_kwargs["config"]) == TRACKS_DIR / "carolo_cup" / "track.yaml"
    assert experiment.env_config.sim.step_limit == 7


def test_an_experiment_with_an_unknown_track_lists_the_known_ones(tmp_path: Path):
    path = tmp_path / "exp.yaml"
    path.write_text("env: {environment: nowhere}\n")
    with pytest.raises(ConfigError) as caught:
        load_experiment(path)
    (problem,) = caught.value.problems
    assert problem.source == str(path) and problem.path == "env.environment"
    assert all(name in problem.allowed for name in track_names())


def test_shipped_configs_name_their_tracks_bare():
    for path in CONFIGS_DIR.glob("*.yaml"):
        folder = (yaml.safe_load(path.read_text()).get("env") or {}).get("environment")
        assert folder is None or folder in track_names(), path.name


def test_names_resolve_to_configs_before_tracks_and_paths_win(elsewhere):
    assert find_experiment("carracing") == CONFIGS_DIR / "carracing.yaml"
    assert find_example("formula_student") == CONFIGS_DIR / "formula_student.yaml"
    (elsewhere / "carracing").write_text("episodes: 1\n")
    assert find_experiment("carracing") == Path("carracing")
    assert find_experiment("missing/file.yaml") == Path("missing/file.yaml")  # loader's error
    with pytest.raises(ConfigError, match="multi_camera"):
        find_experiment("nope")


def test_run_by_name_writes_into_the_working_folder(elsewhere, capsys):
    code = cli.main(["run", "carolo_cup", "--episodes", "1", "--no-video", "--quiet"])
    assert code == 0, capsys.readouterr().err
    (run_dir,) = (elsewhere / "runs").iterdir()
    assert run_dir.name.startswith("carolo_cup-")
    assert (run_dir / "results.json").is_file()
    package = Path(tinyrace.__file__).parent
    assert not [d for d in (CONFIGS_DIR, TRACKS_DIR, package) if (d / "runs").exists()]


def test_run_of_an_unknown_name_fails_listing_the_configs(elsewhere, capsys):
    assert cli.main(["run", "carracin"]) != 0
    err = capsys.readouterr().err
    assert "carracin" in err and all(name in err for name in config_names())
    assert not (elsewhere / "runs").exists()


@pytest.mark.parametrize("command", ["validate", "show"])
def test_validate_and_show_take_names(elsewhere, capsys, command):
    assert cli.main([command, "segmented"]) == 0
    out = capsys.readouterr().out
    if command == "validate":  # the shipped config (a name's first meaning), named
        assert out.startswith(f"OK: {CONFIGS_DIR / 'segmented.yaml'}: image track")
    else:
        assert "segmented" in out


def test_examples_lists_one_line_each(capsys):
    assert cli.main(["examples"]) == 0
    lines = capsys.readouterr().out.splitlines()
    listed = [line.split()[:2] for line in lines if line.startswith(("track ", "config "))]
    assert listed == [[e.kind, e.name] for e in examples()]
    assert all(e.summary.endswith(".") and len(e.summary) > 20 for e in examples())


def test_examples_copy_makes_an_editable_copy_and_refuses_to_overwrite(elsewhere, capsys):
    assert cli.main(["examples", "copy", "formula_student", "mine"]) == 0
    copied = elsewhere / "mine"
    assert {p.name for p in copied.iterdir()} == {"formula_student", "formula_student.yaml"}
    original = (TRACKS_DIR / "formula_student" / "track.yaml").read_text()
    assert (copied / "formula_student" / "track.yaml").read_text() == original
    # The copied config's bare name now finds the copied track beside it.
    track = copied / "formula_student" / "track.yaml"
    track.write_text(original.replace("step_limit: 1000", "step_limit: 33"))
    experiment = load_experiment(copied / "formula_student.yaml")
    assert experiment.env_config.sim.step_limit == 33
    assert cli.main(["examples", "copy", "formula_student", "mine"]) != 0
    err = capsys.readouterr().err
    assert "DIR: got 'mine'" in err and "does not exist yet" in err  # DIR as given
    assert track.read_text().count("step_limit: 33") == 1  # not overwritten


def test_copy_of_a_config_only(tmp_path: Path):
    (target,) = copy_example("carracing", tmp_path)
    assert target == tmp_path / "carracing.yaml"
    assert target.read_text() == (CONFIGS_DIR / "carracing.yaml").read_text()


def test_version_comes_from_the_package_metadata(capsys):
    from importlib.metadata import version

    assert tinyrace.__version__ == version("tinyrace")
    with pytest.raises(SystemExit) as done:
        cli.main(["--version"])
    assert done.value.code == 0
    assert capsys.readouterr().out.strip() == f"tinyrace {version('tinyrace')}"
