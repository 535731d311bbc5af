"""The command's contract: a user error is one line, ``tinyrace: error: ...`` naming the file,
key or argument, exit 2, no traceback unless --debug; run folders are where they should be."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from tinyrace import cli
from tinyrace.examples import CONFIGS_DIR

ROOT = Path(__file__).resolve().parents[1]
CAROLO = str(CONFIGS_DIR / "carolo_cup.yaml")


def experiment(tmp_path: Path, **keys) -> str:
    """An experiment file in tmp_path: a short CarRacing run without video, plus ``keys``."""
    raw = {"episodes": 2, "max_steps": 5, "output": {"video": False}, **keys}
    path = tmp_path / "exp.yaml"
    path.write_text(yaml.safe_dump(raw))
    return str(path)


def one_error_line(capsys, *parts: str) -> str:
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1, captured.err
    assert lines[0].startswith("tinyrace: error: ")
    assert "Traceback" not in captured.err
    for part in parts:
        assert part in lines[0]
    return lines[0]


@pytest.mark.parametrize(
    ("driver", "args", "says"),
    [
        ("drivers_for_tests:shaped_policy", {}, "shape (2,)"),
        ("drivers_for_tests:nan_policy", {}, "not finite"),
        ("drivers_for_tests:failing_policy", {}, "RuntimeError: the policy broke"),
        ("drivers_for_tests:failing_factory", {}, "no model file"),
        ("drivers_for_tests:shaped_policy", {"colour": 3}, "colour"),
        ("constant", {"action": "fast"}, "fast"),
    ],
)
def test_bad_drivers_are_one_line_and_leave_no_run_folder(
    driver, args, says, tmp_path: Path, capsys
):
    path = experiment(tmp_path, driver=driver, driver_args=args)
    out = tmp_path / "runs"
    assert cli.main(["run", path, "--quiet", "-o", str(out)]) == 2
    one_error_line(capsys, "exp.yaml", "driver", says)
    assert not out.exists()


def test_a_driver_failing_later_keeps_the_finished_episodes(tmp_path: Path, capsys):
    path = experiment(tmp_path, driver="drivers_for_tests:failing_policy", driver_args={"after": 7})
    assert cli.main(["run", path, "--quiet", "-o", str(tmp_path / "runs")]) == 2
    one_error_line(capsys, "episode 1", "act() at step 2")
    (run_dir,) = (tmp_path / "runs").iterdir()
    results = json.loads((run_dir / "results.json").read_text())
    assert len(results["episodes"]) == 1 and "the policy broke" in results["error"]


@pytest.mark.parametrize(
    ("argv", "says"),
    [
        (["--episodes", "0"], "argument --episodes"),
        (["--episodes", "-2"], "argument --episodes"),
        (["--seed", "-1"], "argument --seed"),
        (["--seed", "one"], "argument --seed"),
        (["--frobnicate"], "--frobnicate"),
    ],
)
def test_bad_arguments(argv: list[str], says: str, capsys):
    assert cli.main(["run", CAROLO, *argv]) == 2
    one_error_line(capsys, says)


def test_out_pointing_at_a_file(tmp_path: Path, capsys):
    afile = tmp_path / "results.txt"
    afile.write_text("mine")
    assert cli.main(["run", CAROLO, "-o", str(afile)]) == 2
    one_error_line(capsys, "-o/--out", "results.txt")
    assert afile.read_text() == "mine"


@pytest.mark.parametrize(
    ("content", "says"),
    [
        (b"\x89PNG\r\n\x1a\n\x00\x00", "UTF-8 text"),  # the bounded YAML reader's words
        (b"key: [1, 2\n", "invalid YAML"),
        (b"just words\n", "expected a mapping"),
    ],
)
def test_a_file_that_is_not_an_experiment(content: bytes, says: str, tmp_path: Path, capsys):
    path = tmp_path / "notyaml.yaml"
    path.write_bytes(content)
    assert cli.main(["run", str(path)]) == 2
    one_error_line(capsys, "notyaml.yaml", says)


def test_debug_shows_the_traceback(tmp_path: Path):
    path = experiment(tmp_path, driver="drivers_for_tests:failing_factory")
    env = {"PYTHONPATH": f"{ROOT}{':'}{ROOT / 'tests'}"}
    plain, debug = (
        subprocess.run(
            [sys.executable, "-m", "tinyrace", *flags, "run", path, "--quiet"],
            capture_output=True,
            text=True,
            timeout=120,
            env=env,
            cwd=tmp_path,
        )
        for flags in ([], ["--debug"])
    )
    assert plain.returncode == 2 and "Traceback" not in plain.stderr
    assert len(plain.stderr.strip().splitlines()) == 1
    assert debug.returncode != 0 and "Traceback" in debug.stderr
    assert "no model file" in debug.stderr


def test_quiet_prints_nothing_and_json_prints_the_summary(tmp_path: Path, capsys):
    path = experiment(tmp_path)
    assert cli.main(["run", path, "--quiet", "-o", str(tmp_path / "a")]) == 0
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err == ""
    assert cli.main(["run", path, "--json", "--quiet", "-o", str(tmp_path / "b")]) == 0
    data = json.loads(capsys.readouterr().out)
    assert len(data["episodes"]) == 2 and data["interrupted"] is False
    assert {"mean", "std"} <= set(data["summary"]["episode_return"])
    assert Path(data["run_dir"]).parent == tmp_path / "b"


def test_runs_started_in_the_same_second_get_different_folders(tmp_path: Path, capsys):
    path = experiment(tmp_path, episodes=1)
    for _ in range(3):
        assert cli.main(["run", path, "--quiet", "-o", str(tmp_path / "runs")]) == 0
    assert len(list((tmp_path / "runs").iterdir())) == 3


def test_run_folders_go_to_the_current_folder(tmp_path: Path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["run", "--episodes", "1", "--no-video", "--quiet"]) == 0  # shipped default
    (run_dir,) = (tmp_path / "runs").iterdir()
    assert run_dir.name.startswith("carracing-")
    assert not (CONFIGS_DIR / "runs").exists() and not (CONFIGS_DIR.parent / "runs").exists()


def test_a_folder_that_is_no_track_is_not_run(tmp_path: Path, capsys):
    """Tracks run with the default driver (tests/test_run_targets.py); other folders don't."""
    assert cli.main(["run", str(tmp_path)]) == 2
    one_error_line(capsys, "NAME_OR_PATH", "holds no track.yaml", "expected an experiment file")
