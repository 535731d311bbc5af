"""Issue 12.4: image paths in a track folder stay inside it unless the config opts in; own
drivers (``module:callable``) import from the experiment file's folder, from any command."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

import tinyrace
from tinyrace import cli
from tinyrace.config.paths import OPT_IN_KEY
from tinyrace.env import TinyRaceEnv
from tinyrace.errors import ConfigError
from tinyrace.experiment import load_experiment

CAMERA = {"id": "front", "resolution": [12, 16], "roi": [24, 32]}


def _image(path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(path), np.zeros((64, 64, 3), np.uint8))


def _track(folder: Path, image: str, opt_in: bool = False) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    config = {"cameras": [CAMERA], "tracks": [{"image": image, "spawns": [[20, 20, 0]]}]}
    if opt_in:
        config["files"] = {"paths_outside_folder": True}
    (folder / "track.yaml").write_text(yaml.safe_dump(config))
    return folder


def _refused(folder: Path) -> str:
    with pytest.raises(ConfigError) as caught:
        TinyRaceEnv(environment=folder)
    (problem,) = caught.value.problems
    assert problem.path == "tracks[0].image" and problem.source == str(folder / "track.yaml")
    return str(problem)


@pytest.fixture
def outside(tmp_path: Path) -> Path:
    image = tmp_path / "elsewhere" / "secret.png"
    _image(image)
    return image


def test_dot_dot_is_refused_unless_opted_in(tmp_path: Path, outside: Path):
    name = "../elsewhere/secret.png"
    assert "climbs out with '..'" in _refused(_track(tmp_path / "track", name))
    TinyRaceEnv(environment=_track(tmp_path / "track", name, opt_in=True)).reset(seed=0)


def test_an_absolute_path_is_refused_unless_opted_in(tmp_path: Path, outside: Path):
    text = _refused(_track(tmp_path / "track", str(outside)))
    assert "absolute" in text and OPT_IN_KEY in text
    TinyRaceEnv(environment=_track(tmp_path / "track", str(outside), opt_in=True)).reset(seed=0)


def test_a_symlink_out_of_the_folder_is_refused(tmp_path: Path, outside: Path):
    folder = _track(tmp_path / "track", "link.png")
    os.symlink(outside, folder / "link.png")
    assert "a symlink leads to" in _refused(folder)


def test_a_symlink_inside_the_folder_is_fine(tmp_path: Path):
    folder = _track(tmp_path / "track", "link.png")
    _image(folder / "images" / "real.png")
    os.symlink(folder / "images" / "real.png", folder / "link.png")
    TinyRaceEnv(environment=folder).reset(seed=0)


@pytest.mark.parametrize("opt_in", [False, True])
def test_a_nul_byte_is_always_refused(tmp_path: Path, opt_in: bool):
    folder = _track(tmp_path / "track", "a\x00.png", opt_in=opt_in)
    assert "NUL byte" in _refused(folder)


def test_validate_refuses_the_same_path(tmp_path: Path, outside: Path, capsys):
    folder = _track(tmp_path / "track", "../elsewhere/secret.png")
    assert cli.main(["validate", str(folder)]) != 0
    assert "tracks[0].image" in capsys.readouterr().out


def test_an_experiments_inline_image_stays_in_its_folder(tmp_path: Path, outside: Path):
    experiment = tmp_path / "exp" / "run.yaml"
    experiment.parent.mkdir()
    # a spawn inside the 64 px picture: loading an experiment builds its env too
    track = {"image": "../elsewhere/secret.png", "spawns": [[32.0, 32.0, 0.0]]}
    env = {"cameras": [CAMERA], "track": track}
    experiment.write_text(yaml.safe_dump({"env": env, "episodes": 1}))
    with pytest.raises(ConfigError, match=r"env\.track\[0\]\.image"):
        load_experiment(experiment)
    env["files"] = {"paths_outside_folder": True}
    experiment.write_text(yaml.safe_dump({"env": env, "episodes": 1}))
    assert load_experiment(experiment).env_config.tracks[0].image == str(outside)


POLICY = """
import numpy as np

def make():
    return lambda observation, info: np.array([0.0, 0.5, 0.0], np.float32)
"""


def _experiment_with_own_driver(folder: Path, driver: str) -> Path:
    folder.mkdir()
    (folder / "my_policy.py").write_text(POLICY)
    config = {"driver": driver, "episodes": 1, "max_steps": 3, "output": {"video": False}}
    (folder / "exp.yaml").write_text(yaml.safe_dump(config))
    return folder / "exp.yaml"


def test_own_driver_imports_from_the_experiment_folder_as_the_console_script(tmp_path: Path):
    experiment = _experiment_with_own_driver(tmp_path / "exp", "my_policy:make")
    work = tmp_path / "work"
    work.mkdir()
    # -P: like a console script, the current folder is not on sys.path
    main = "import sys; from tinyrace.cli import main; sys.exit(main())"
    argv = ["run", str(experiment), "--quiet", "--out", str(work / "runs")]
    here = Path(tinyrace.__file__).resolve().parents[1]  # the tinyrace this test imported
    env = {**os.environ, "PYTHONPATH": str(here)}
    done = subprocess.run(
        [sys.executable, "-P", "-c", main, *argv],
        cwd=work,
        capture_output=True,
        text=True,
        timeout=120,
        env=env,
    )
    assert done.returncode == 0, done.stderr
    assert "my_policy" not in sys.modules  # imported in the child only


@pytest.mark.parametrize(
    "driver, expected",
    [("teleport", "centerline"), ("no_module_here:make", "no_module_here"), ("a:b:c", "names")],
)
def test_validate_refuses_a_driver_that_cannot_run(tmp_path: Path, driver: str, expected, capsys):
    experiment = _experiment_with_own_driver(tmp_path / "exp", driver)
    assert cli.main(["validate", str(experiment)]) != 0
    captured = capsys.readouterr()
    assert "driver" in captured.out + captured.err and expected in captured.out + captured.err
