"""``tinyrace run NAME_OR_PATH``: experiments as written, tracks with the default driver,
copies before shipped examples, and a clear word on anything else."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from tinyrace import cli
from tinyrace.examples import config_names, shipped_track, track_names
from tinyrace.experiment.target import load_target

QUICK = ["--episodes", "1", "--no-video"]


@pytest.fixture
def here(tmp_path: Path, monkeypatch) -> Path:
    """An empty working folder."""
    monkeypatch.chdir(tmp_path)
    return tmp_path


def run_folder(root: Path) -> tuple[Path, dict]:
    (run_dir,) = root.iterdir()
    return run_dir, json.loads((run_dir / "results.json").read_text())


def error_line(capsys) -> str:
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("tinyrace: error: "), captured.err
    return lines[0]


@pytest.mark.parametrize("form", ["folder", "track.yaml"])
def test_a_track_runs_with_the_default_driver(here: Path, capsys, form: str):
    folder = shipped_track("segmented")
    target = folder if form == "folder" else folder / "track.yaml"
    assert cli.main(["run", str(target), *QUICK]) == 0, capsys.readouterr().err
    out = capsys.readouterr().out
    assert f"running the track {folder / 'track.yaml'}" in out and "driver centerline" in out
    run_dir, results = run_folder(here / "runs")
    assert run_dir.name.startswith("segmented-")  # the track folder's name, not "track"
    assert results["config"]["driver"] == "centerline"
    assert results["track_kind"] == "image" and len(results["episodes"]) == 1


def test_a_shipped_track_runs_by_its_name(here: Path, capsys):
    name = next(n for n in track_names() if n not in config_names())  # a track alone
    assert cli.main(["run", name, *QUICK]) == 0, capsys.readouterr().err
    run_dir, results = run_folder(here / "runs")
    assert run_dir.name.startswith(f"{name}-")
    assert results["experiment"] == str(shipped_track(name) / "track.yaml")


def test_after_examples_copy_the_same_name_runs_the_copy(here: Path, capsys):
    assert cli.main(["examples", "copy", "formula_student", "."]) == 0
    copied = yaml.safe_load((here / "formula_student.yaml").read_text())
    copied["max_steps"] = 7  # an edit of the copy, to see that the copy ran
    (here / "formula_student.yaml").write_text(yaml.safe_dump(copied))
    capsys.readouterr()
    assert cli.main(["run", "formula_student", *QUICK]) == 0, capsys.readouterr().err
    assert "running formula_student.yaml" in capsys.readouterr().out
    _, results = run_folder(here / "runs")
    assert results["experiment"] == "formula_student.yaml"
    assert results["episodes"][0]["steps"] == 7
    experiment, track = load_target("formula_student")
    assert not track and Path(experiment.env_kwargs["config"]) == (
        here / "formula_student" / "track.yaml"
    )  # its env.environment found the copied track beside it
    experiment, track = load_target("./formula_student")  # the folder itself: the track
    assert track and experiment.source == str(Path("formula_student") / "track.yaml")


def test_an_experiment_file_runs_as_written(here: Path, capsys):
    (here / "exp.yaml").write_text("episodes: 2\nmax_steps: 3\noutput: {video: false}\n")
    assert cli.main(["run", "exp.yaml", "--quiet"]) == 0, capsys.readouterr().err
    _, results = run_folder(here / "runs")
    assert [e["steps"] for e in results["episodes"]] == [3, 3]


def test_a_folder_without_a_track_says_so(here: Path, capsys):
    assert cli.main(["run", "."]) == 2
    line = error_line(capsys)
    assert "got '.'" in line and "holds no track.yaml and no experiment file" in line
    assert "expected an experiment file, a track folder" in line
    assert not (here / "runs").exists()


def test_a_folder_of_experiments_and_tracks_names_them(here: Path, capsys):
    assert cli.main(["examples", "copy", "formula_student", "mine"]) == 0
    (here / "mine" / "notes.yaml").write_text("just: notes\n")  # no experiment: not named
    capsys.readouterr()
    assert cli.main(["run", "mine"]) == 2
    line = error_line(capsys)
    assert "the experiment files formula_student.yaml" in line and "notes.yaml" not in line
    assert "the track folders formula_student" in line


def test_a_run_folder_is_named_as_one(here: Path, capsys):
    (here / "exp.yaml").write_text("episodes: 1\nmax_steps: 2\noutput: {video: false}\n")
    assert cli.main(["run", "exp.yaml", "--quiet"]) == 0
    run_dir, _ = run_folder(here / "runs")
    for command in (["run", str(run_dir)], ["validate", str(run_dir)]):
        code = cli.main(command)
        text = capsys.readouterr()
        line = text.err.strip() if command[0] == "run" else text.out.strip()
        assert code != 0 and "this is a run folder" in line, line
        assert f"tinyrace report {run_dir}" in line


@pytest.mark.parametrize(
    ("typed", "meant"), [("formula_studnt", "formula_student"), ("f1tenth_lop", "f1tenth_loop")]
)
def test_a_mistyped_name_gets_a_did_you_mean(here: Path, capsys, typed: str, meant: str):
    assert cli.main(["run", typed]) == 2
    line = error_line(capsys)
    assert f"got '{typed}'; did you mean '{meant}'?" in line
    assert all(name in line for name in config_names())  # then every name
