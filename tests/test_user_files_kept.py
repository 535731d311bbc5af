"""Issue 12.1: no command changes what the user wrote (show's output never lands on an input)."""

from __future__ import annotations

import hashlib
import shutil
from pathlib import Path

import pytest

from tinyrace import cli
from tinyrace.examples import TRACKS_DIR


def _digests(folder: Path) -> dict[str, str]:
    return {
        str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(folder.rglob("*"))
        if p.is_file()
    }


@pytest.fixture
def track(tmp_path: Path) -> Path:
    folder = tmp_path / "formula_student"
    shutil.copytree(TRACKS_DIR / "formula_student", folder)
    return folder


@pytest.mark.parametrize("force", [False, True])
def test_show_inside_the_track_folder_never_writes_over_its_image(track, monkeypatch, force):
    monkeypatch.chdir(track)
    before = _digests(track)
    argv = ["show", str(track)] + (["--force"] if force else [])
    assert cli.main(argv) != 0  # the default name is the track's own image
    assert _digests(track) == before


def test_show_refuses_an_existing_file_without_force(track, tmp_path: Path):
    output = tmp_path / "mine.png"
    output.write_bytes(b"the user's own picture")
    assert cli.main(["show", str(track), "-o", str(output)]) != 0
    assert output.read_bytes() == b"the user's own picture"
    assert cli.main(["show", str(track), "-o", str(output), "--force"]) == 0
    assert output.read_bytes().startswith(b"\x89PNG")


def test_show_writes_into_a_track_folder_only_when_forced(track):
    output = track / "overview.png"
    before = _digests(track)
    assert cli.main(["show", str(track), "-o", str(output)]) != 0
    assert _digests(track) == before
    assert cli.main(["show", str(track), "-o", str(output), "--force"]) == 0
    assert output.is_file()


@pytest.mark.parametrize("name", ["track.yaml", "formula_student.png"])
def test_show_never_writes_over_an_input_even_when_forced(track, name: str, capsys):
    before = _digests(track)
    assert cli.main(["show", str(track), "-o", str(track / name), "--force"]) != 0
    assert _digests(track) == before
    assert "-o/--output" in capsys.readouterr().err


def test_show_default_name_outside_the_track_folder(track, tmp_path: Path, monkeypatch):
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    assert cli.main(["show", str(track)]) == 0
    assert (work / "formula_student.png").is_file()
    assert cli.main(["show", str(track)]) != 0  # a second time: the file exists now


def test_run_inside_a_track_folder_writes_nothing_there(track, monkeypatch, capsys):
    monkeypatch.chdir(track)
    before = _digests(track)
    assert cli.main(["run", "carolo_cup", "--episodes", "1", "--no-video", "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("tinyrace: error: output.dir") and "track folder" in err
    assert _digests(track) == before and not (track / "runs").exists()


def test_run_out_into_a_track_folder_only_when_forced(track, tmp_path: Path, capsys):
    argv = ["run", "carolo_cup", "--episodes", "1", "--no-video", "--quiet"]
    argv += ["--seed", "0", "-o", str(track / "runs")]
    assert cli.main(argv) == 2
    assert "-o/--out" in capsys.readouterr().err and not (track / "runs").exists()
    experiment = tmp_path / "short.yaml"
    experiment.write_text("env: {environment: carolo_cup, sim: {step_limit: 5}}\nepisodes: 1\n")
    forced = ["run", str(experiment), "--no-video", "--quiet", "-o", str(track / "runs")]
    assert cli.main([*forced, "--force"]) == 0
    assert len(list((track / "runs").iterdir())) == 1
