"""The tinyrace command: run, validate, show, play; and the YAML reference (docs/reference.md)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import cv2
import pytest

from tinyrace import cli, run_command
from tinyrace.config.reference import END, START, markdown
from tinyrace.examples import CONFIGS_DIR, TRACKS_DIR

ROOT = Path(__file__).resolve().parents[1]


def test_run_a_config(tmp_path: Path, capsys):
    config = CONFIGS_DIR / "carolo_cup.yaml"
    code = cli.main(["run", str(config), "--episodes", "1", "--no-video", "--out", str(tmp_path)])
    out = capsys.readouterr().out
    assert code == 0
    assert "return" in out and "|cte|" in out and "episode_return" in out  # table and summary
    (run_dir,) = tmp_path.iterdir()
    names = {p.name for p in run_dir.iterdir()}
    assert {"results.json", "episodes.csv", "report.html", "episode_000_trace.csv"} <= names
    assert not any(name.endswith((".mp4", ".webm")) for name in names)  # --no-video


def test_run_without_arguments_finds_the_default_experiment(monkeypatch, tmp_path: Path):
    monkeypatch.chdir(tmp_path)  # no configs/ here: the checkout's default is used
    assert run_command.default_experiment() == CONFIGS_DIR / "carracing.yaml"


def test_python_dash_m_runs_the_command():
    done = subprocess.run(
        [sys.executable, "-m", "tinyrace", "validate", str(CONFIGS_DIR / "carracing.yaml")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    path = CONFIGS_DIR / "carracing.yaml"
    assert done.returncode == 0 and done.stdout.startswith(f"OK: {path}: procedural track")


@pytest.mark.parametrize(
    "path",
    [
        *sorted((TRACKS_DIR).glob("*/track.yaml")),
        *sorted((CONFIGS_DIR).glob("*.yaml")),
    ],
    ids=lambda p: f"{p.parent.name}/{p.name}",
)
def test_validate_accepts_every_shipped_file(path: Path, capsys):
    assert cli.main(["validate", str(path)]) == 0
    assert capsys.readouterr().out.startswith("OK:")


def test_validate_prints_every_problem(tmp_path: Path, capsys):
    bad = tmp_path / "track.yaml"
    bad.write_text("sim: {fps: -3, stp_limit: 4}\ncar: {wheelbase: abc}\n")
    assert cli.main(["validate", str(tmp_path)]) == 1
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 4  # three bad keys, and a tinycarlo file (no tracks) needs a camera
    assert any("cameras" in line and "at least one camera" in line for line in lines)
    assert any("sim.fps" in line and "-3" in line for line in lines)
    assert any("sim.stp_limit" in line and "did you mean 'step_limit'" in line for line in lines)
    assert any("car.wheelbase" in line and "'abc'" in line for line in lines)
    assert all(str(bad) in line for line in lines)


def test_validate_reports_image_problems(tmp_path: Path, capsys):
    (tmp_path / "track.yaml").write_text(
        "cameras: [{id: front}]\ntracks: [{image: missing.png, spawns: [[1, 2, 0]]}]\n"
    )
    assert cli.main(["validate", str(tmp_path)]) == 1
    out = capsys.readouterr().out
    assert "tracks[0].image" in out and "missing.png" in out


@pytest.mark.parametrize(
    "target",
    ["procedural", "example_tracks/formula_student", "configs/carracing.yaml"],
)
def test_show_writes_a_picture(target: str, tmp_path: Path, monkeypatch):
    monkeypatch.chdir(ROOT)
    output = tmp_path / "track.png"
    assert cli.main(["show", target, "--seed", "3", "-o", str(output)]) == 0
    image = cv2.imread(str(output))
    assert image is not None and min(image.shape[:2]) > 500


def test_show_procedural_is_the_seeds_track(tmp_path: Path):
    a, b, c = (tmp_path / f"{n}.png" for n in "abc")
    cli.main(["show", "procedural", "--seed", "1", "-o", str(a)])
    cli.main(["show", "procedural", "--seed", "1", "-o", str(b)])
    cli.main(["show", "procedural", "--seed", "2", "-o", str(c)])
    first, again, other = (cv2.imread(str(p)) for p in (a, b, c))
    assert (first == again).all()
    assert first.shape != other.shape or not (first == other).all()  # cropped to the track


def test_play_without_a_display_says_what_is_missing():
    env = {
        k: v
        for k, v in os.environ.items()
        if k not in ("DISPLAY", "WAYLAND_DISPLAY", "SDL_VIDEODRIVER")
    }
    done = subprocess.run(
        [sys.executable, "-m", "tinyrace", "play"],
        capture_output=True,
        text=True,
        timeout=120,
        env=env,
    )
    assert done.returncode == 2
    assert "display" in done.stderr or "pygame" in done.stderr


def test_no_command_prints_help(capsys):
    assert cli.main([]) == 2
    assert "run" in capsys.readouterr().out


def test_the_yaml_reference_page_matches_the_schema():
    page = (ROOT / "docs" / "reference.md").read_text()
    section = page.split(START, 1)[1].split(END, 1)[0].strip()
    fix = "run: python -m tinyrace.config.reference docs/reference.md"
    assert section == markdown().strip(), fix
    assert "](docs/reference.md)" in (ROOT / "README.md").read_text()  # the README links it


def test_readme_quick_start_is_what_ci_runs():
    readme = (ROOT / "README.md").read_text()
    quick_start = readme.split("<!-- needs: checkout -->\n```bash\n", 1)[1].split("```", 1)[0]
    commands = [line.split("  #", 1)[0].strip() for line in quick_start.splitlines()]
    assert commands == [
        "pip install -e . && tinyrace run",
        'pip install -e ".[test]" && python -m pytest -q',
    ]
    ci = (ROOT / ".ci" / "run").read_text()
    for command in commands:  # the two lines CI runs as they are
        assert command in ci
