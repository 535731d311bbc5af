"""Issue 31: each example of the third round of hostile input, pinned as a plain test.

Every case ends in a clear error (a ConfigError or ``tinyrace`` exit 2 naming the file or
key) or a working env; no input file changes. The generated campaign over the same formats
is tests/test_hostile_metric_campaign.py.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import shutil
import signal
from pathlib import Path

import cv2
import gymnasium as gym
import numpy as np
import pytest
import yaml

from tinyrace import cli
from tinyrace.config.bounds import MAX_CONES, MAX_ROWS
from tinyrace.env import TinyRaceEnv
from tinyrace.errors import ConfigError
from tinyrace.examples import TRACKS_DIR
from tinyrace.experiment import load_experiment, run_experiment
from tinyrace.tracks import polyline
from tinyrace.tracks.centerline_csv import read_loop


def digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def copy_track(name: str, tmp_path: Path) -> Path:
    folder = tmp_path / name
    shutil.copytree(TRACKS_DIR / name, folder)
    return folder


def centerline_folder(tmp_path: Path, text: str, extra: str = "") -> Path:
    folder = tmp_path / "c"
    folder.mkdir(exist_ok=True)
    (folder / "c.csv").write_text(text)
    (folder / "track.yaml").write_text("track: {type: centerline, file: c.csv" + extra + "}\n")
    return folder


def refused(folder: Path) -> str:
    with pytest.raises(ConfigError) as error:
        env = TinyRaceEnv(environment=str(folder))
        try:
            env.reset(seed=0)
        finally:
            env.close()
    return str(error.value)


def loop_text(points: np.ndarray, separator: str = ",") -> str:
    return "".join(f"{x:.6f}{separator}{y:.6f}\n" for x, y in points)


def ellipse(count: int, a: float = 100.0, b: float = 60.0) -> np.ndarray:
    t = np.linspace(0, 2 * math.pi, count, endpoint=False)
    return np.column_stack((a * np.cos(t), b * np.sin(t)))


# -- a user file changed -----------------------------------------------------------------------
def test_show_never_writes_over_a_ros_maps_picture_even_forced(tmp_path, capsys):
    folder = copy_track("f1tenth_loop", tmp_path)
    before = digest(folder / "map.png")
    assert cli.main(["show", str(folder), "-o", str(folder / "map.png"), "--force"]) == 2
    assert "reads" in capsys.readouterr().err
    assert digest(folder / "map.png") == before


# -- valid input refused -----------------------------------------------------------------------
def test_a_map_saver_pgm_with_its_creator_comment_loads(tmp_path):
    folder = copy_track("f1tenth_loop", tmp_path)
    gray = cv2.imread(str(folder / "map.png"), cv2.IMREAD_GRAYSCALE)
    head = b"P5\n# CREATOR: map_saver.cpp 0.050 m/pix\n%d %d\n255\n" % gray.shape[::-1]
    (folder / "map.pgm").write_bytes(head + gray.tobytes())
    info = yaml.safe_load((folder / "map.yaml").read_text())
    (folder / "map.yaml").write_text(yaml.safe_dump({**info, "image": "map.pgm"}))
    from_pgm = TinyRaceEnv(environment=str(folder))
    from_png = TinyRaceEnv(environment=str(copy_track("f1tenth_loop", tmp_path / "png")))
    occupancy = [env.track_source.tracks[0].occupancy for env in (from_pgm, from_png)]
    assert (occupancy[0].free == occupancy[1].free).all()
    from_pgm.reset(seed=0)
    from_pgm.close(), from_png.close()


def test_an_inline_metric_track_is_read_beside_the_experiment(tmp_path, monkeypatch):
    here = tmp_path / "exp"
    here.mkdir()
    (here / "c.csv").write_text(loop_text(ellipse(80)))
    (here / "e.yaml").write_text(
        yaml.safe_dump({"env": {"track": {"type": "centerline", "file": "c.csv"}}})
    )
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    experiment = load_experiment(here / "e.yaml")
    env = TinyRaceEnv(**experiment.env_kwargs)
    env.reset(seed=0)
    env.close()
    (here / "c.csv").unlink()
    with pytest.raises(ConfigError) as error:
        load_experiment(here / "e.yaml")
    assert str(here / "e.yaml") in str(error.value) and "env.track.file" in str(error.value)


def test_show_dot_inside_a_track_folder_names_the_picture_after_the_folder(
    tmp_path, monkeypatch, capsys
):
    folder = copy_track("circuit", tmp_path)
    monkeypatch.chdir(folder)
    assert cli.main(["show", ".", "--force"]) == 0
    assert (folder / "circuit.png").is_file() and not (folder / ".png").exists()


def test_a_tab_separated_centreline_loads_and_a_bad_separator_is_described(tmp_path):
    folder = centerline_folder(tmp_path, loop_text(ellipse(40), "\t"))
    TinyRaceEnv(environment=str(folder)).close()
    folder = centerline_folder(tmp_path, loop_text(ellipse(40), " "))
    assert "separated by ',', ';' or tabs" in refused(folder)


# -- crashes -----------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "text", ["# x_m,y_m,w_tr_right_m,w_tr_left_m\n", "x_m,y_m,w_tr_right_m,w_tr_left_m\n"]
)
def test_a_header_only_centreline_is_refused(tmp_path, text):
    assert "at least 4 points" in refused(centerline_folder(tmp_path, text))


@pytest.mark.parametrize("size", [1e300, 1e308, 1.7e308])
def test_coordinates_near_the_float_limit_are_refused(tmp_path, size):
    square = np.array([[0, 0], [size, 0], [size, size], [0, size]])
    text = refused(centerline_folder(tmp_path, loop_text(square).replace(".000000", "")))
    assert "c.csv: line 2" in text and "1e+07 m" in text


def test_cones_at_one_point_are_refused(tmp_path):
    folder = tmp_path / "k"
    folder.mkdir()
    (folder / "k.csv").write_text("blue,1,1\n" * 5 + "yellow,1,1\n" * 5)
    (folder / "track.yaml").write_text("track: {type: cone_map, file: k.csv}\n")
    text = refused(folder)  # the same place ten times: the cones written twice, named
    assert "k.csv: line 2" in text
    assert "expected one cone per place; line 1 has a cone there" in text


def test_a_one_cell_ros_map_is_refused(tmp_path):
    folder = copy_track("f1tenth_loop", tmp_path)
    cv2.imwrite(str(folder / "map.png"), np.full((1, 1), 254, np.uint8))
    (folder / "track.yaml").write_text("track: {type: ros_map, file: map.yaml, spawn: [0, 0, 0]}")
    assert "at least 2 x 2 cells" in refused(folder)


def test_a_perspective_camera_on_the_ground_is_refused(tmp_path):
    folder = copy_track("circuit", tmp_path)
    with (folder / "track.yaml").open("a") as handle:
        handle.write("sensors: [{id: p, type: perspective_camera, position: [0, 0, 0]}]\n")
    assert "sensors[0].position" in refused(folder)


def run_folder(tmp_path: Path) -> Path:
    folder = copy_track("circuit", tmp_path)
    (folder / "e.yaml").write_text(
        yaml.safe_dump({"env": {"environment": "."}, "episodes": 1, "max_steps": 5})
        + "output: {video: false}\n"
    )
    return run_experiment(load_experiment(folder / "e.yaml"), tmp_path / "runs", False).run_dir


def test_report_names_the_file_and_field_of_a_hand_edited_run(tmp_path, capsys):
    run = run_folder(tmp_path)
    results = run / "results.json"
    header = json.loads(results.read_text())
    cases = [
        ([], "expected a JSON object"),
        (None, "expected a JSON object"),
        ({**header, "interrupted": "no"}, "interrupted: got 'no'; expected true or false"),
        ({**header, "tracks": {"a/b": header["tracks"]["track0"]}}, "tracks: got 'a/b'"),
        ({**header, "summary": [1]}, "summary: got [1]"),
    ]
    for edited, expected in cases:
        results.write_text(json.dumps(edited))
        assert cli.main(["report", str(run)]) == 2
        err = capsys.readouterr().err
        assert str(results) in err and expected in err, err
    results.write_text(json.dumps(header))
    assert cli.main(["report", str(run)]) == 0


def test_report_refuses_a_report_folder_a_huge_field_and_a_huge_file(tmp_path, capsys):
    run = run_folder(tmp_path)
    (run / "report.html").unlink()
    (run / "report.html").mkdir()
    assert cli.main(["report", str(run)]) == 2
    assert "not a folder" in capsys.readouterr().err
    (run / "report.html").rmdir()
    episodes = (run / "episodes.csv").read_text()
    (run / "episodes.csv").write_text(episodes + "1," + "9" * 200_000 + "\n")
    assert cli.main(["report", str(run)]) == 2
    assert "episodes.csv: line 3" in capsys.readouterr().err
    (run / "episodes.csv").write_text(episodes)
    os.truncate(run / "results.json", 1 << 30)  # sparse: a 1 GiB file read by nothing
    assert cli.main(["report", str(run)]) == 2
    assert "at most 134,217,728 bytes" in capsys.readouterr().err


def test_report_never_writes_over_a_file_it_reads(tmp_path, capsys):
    run = run_folder(tmp_path)
    rows = (run / "episodes.csv").read_text().replace("episode_000_trace.csv", "report.html")
    (run / "episodes.csv").write_text(rows)
    before = digest(run / "report.html")
    assert cli.main(["report", str(run)]) == 2
    err = capsys.readouterr().err
    assert "episodes.csv: line 2, trace: got 'report.html'" in err, err  # the file naming it
    assert digest(run / "report.html") == before


def test_over_long_paths_are_user_errors(tmp_path, capsys):
    long = "/".join(["x" * 200] * 30)
    assert cli.main(["run", str(tmp_path / f"{long}.yaml")]) == 2
    assert "File name too long" in capsys.readouterr().err
    folder = copy_track("circuit", tmp_path)
    assert cli.main(["show", str(folder), "-o", str(tmp_path / f"{long}.png")]) == 2
    err = capsys.readouterr().err
    assert "-o/--output" in err and len(err) < 1000
    assert cli.main(["run", "circuit", "-o", str(tmp_path / long), "--episodes", "1"]) == 2
    assert "-o/--out" in capsys.readouterr().err


def test_a_second_ctrl_c_while_the_files_are_written_does_not_cut_them(tmp_path, monkeypatch):
    from tinyrace.experiment import report

    write = report.write_report

    def interrupted_twice(*args, **kwargs):
        os.kill(os.getpid(), signal.SIGINT)
        os.kill(os.getpid(), signal.SIGINT)
        return write(*args, **kwargs)

    monkeypatch.setattr(report, "write_report", interrupted_twice)
    folder = copy_track("circuit", tmp_path)
    (folder / "e.yaml").write_text(
        yaml.safe_dump({"env": {"environment": "."}, "episodes": 1, "max_steps": 5})
    )
    result = run_experiment(load_experiment(folder / "e.yaml"), tmp_path / "runs", False)
    assert result.interrupted == signal.SIGINT
    assert "</html>" in (result.run_dir / "report.html").read_text()


# -- unbounded ---------------------------------------------------------------------------------
def brute_force_crossing(loop: np.ndarray) -> tuple[int, int] | None:
    n = len(loop)
    for i in range(n):
        for j in range(i + 2, n):
            if i == 0 and j == n - 1:
                continue
            p1, p2, q1, q2 = (loop[k : k + 1] for k in (i, (i + 1) % n, j, (j + 1) % n))
            if polyline._crosses(p1, p2, q1, q2)[0]:
                return i, j
    return None


def test_the_grid_crossing_check_finds_what_all_pairs_find():
    rng = np.random.default_rng(31)
    for trial in range(300):
        n = int(rng.integers(4, 40))
        if trial % 3 == 0:
            loop = rng.integers(0, 5, (n, 2)).astype(float)  # collinear and touching
        elif trial % 3 == 1:
            loop = ellipse(n) * rng.uniform(0.8, 1.2, (n, 1))
            loop[rng.integers(0, n)] *= rng.choice([1.0, 3.0])  # one long spike
        else:
            loop = rng.normal(size=(n, 2)) * 10 ** rng.uniform(-4, 4)
        assert polyline.self_intersection(loop) == brute_force_crossing(loop), trial


def test_a_100k_point_centreline_loads_and_a_crossing_in_it_is_found(tmp_path):
    loop = ellipse(100_000, 2000, 1500)
    folder = centerline_folder(tmp_path, loop_text(loop))
    assert len(read_loop(folder / "c.csv", "s", "k").points) == 100_000
    loop[500] = loop[60_000]  # two segments through the far side
    folder = centerline_folder(tmp_path, loop_text(loop))
    assert "does not cross itself" in refused(folder)


def test_too_many_rows_and_too_many_cones_are_refused(tmp_path):
    folder = centerline_folder(tmp_path, loop_text(ellipse(MAX_ROWS + 1, 1e5, 1e5)))
    assert f"at most {MAX_ROWS:,} rows" in refused(folder)
    (folder / "k.csv").write_text("blue,1,2\n" * (MAX_CONES + 1))
    (folder / "track.yaml").write_text("track: {type: cone_map, file: k.csv}\n")
    assert f"at most {MAX_CONES:,} cones" in refused(folder)


@pytest.mark.parametrize(
    ("extra", "expected"),
    [(", scale: 1.0e+9", "1e+07 m after scale"), (", spacing: 0.05, scale: 30", "spacing")],
)
def test_a_huge_scale_or_small_spacing_is_refused_before_resampling(tmp_path, extra, expected):
    folder = centerline_folder(tmp_path, loop_text(ellipse(400, 2000, 1500)), extra)
    assert expected in refused(folder)


def test_a_tiny_lookahead_spacing_is_refused(tmp_path):
    folder = copy_track("circuit", tmp_path)
    with (folder / "track.yaml").open("a") as handle:
        handle.write("sensors: [{id: ahead, type: lookahead, spacing: 1.0e-9}]\n")
    assert "sensors[id ahead].spacing" in refused(folder)


def test_perspective_cameras_count_against_the_camera_pixel_cap(tmp_path):
    folder = copy_track("circuit", tmp_path)
    cameras = ", ".join(
        f"{{id: p{i}, type: perspective_camera, resolution: [4096, 4096]}}" for i in range(4)
    )
    with (folder / "track.yaml").open("a") as handle:
        handle.write(f"sensors: [{cameras}]\n")
    assert "16,777,216 px together" in refused(folder)


@pytest.mark.parametrize(
    ("kwargs", "key"),
    [({"num_envs": 1000}, "num_envs"), ({"num_envs": 2.5}, "num_envs"),
     ({"num_envs": 2, "workers": "2"}, "workers"),
     ({"num_envs": 2, "parent_steps": "yes"}, "parent_steps"),
     ({"num_envs": 2, "workers": 1, "parent_steps": 1}, "parent_steps")],
)  # fmt: skip
def test_make_vec_arguments_are_checked(kwargs, key):
    with pytest.raises(ConfigError, match=f"<make_vec arguments>: {key}"):
        gym.make_vec("tinyrace/CarRacing-v0", vectorization_mode="vector_entry_point", **kwargs)


def test_episodes_beyond_what_a_file_holds_are_refused(capsys):
    assert cli.main(["run", "circuit", "--episodes", str(10**20)]) == 2
    assert "1,000,000" in capsys.readouterr().err


# -- unclear -----------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "sensors",
    [
        "sensors: [{id: s, type: state}]",  # beside the camera: two observations
        "sensors: [{id: s, type: lidar, hit_classes: true}]",
    ],
)
def test_observation_box_needs_one_array(tmp_path, sensors):
    folder = copy_track("circuit", tmp_path)
    text = (folder / "track.yaml").read_text()
    if "hit_classes" in sensors:
        text = text.split("cameras:")[0]
    (folder / "track.yaml").write_text(text + f"observation: box\n{sensors}\n")
    assert "observation: got 'box'" in refused(folder)
