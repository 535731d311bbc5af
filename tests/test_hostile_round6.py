"""Hostile input, sixth round: what the fifth round left open, and a helper's campaign on
the training surface.

A centreline header that names x and y but not both widths is refused (the widths fell
back to the default); a road wider to the inside of a curve than the curve's radius is
refused, named at the file's line or at ``default_width`` (it folded over itself); free
space measured around ROS-map waypoints is cut where a curve is tighter; a speckled map is
refused from a bound counted band by band, before its rectangles are built; a key path
names the section as the file writes it (``track.file`` under ``track: {...}``).
"""

from __future__ import annotations

import math
import os
import sys
from pathlib import Path

import cv2
import gymnasium as gym
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import tinyrace  # noqa: F401  (registers the ids)
from tinyrace.config import ConfigError
from tinyrace.config.bounds import MAX_INNER_WIDTH_OVER_RADIUS
from tinyrace.config.load import load_env_config
from tinyrace.tracks import polyline
from tinyrace.tracks.centerline_csv import read_loop
from tinyrace.tracks.metric import load_metric_track
from tinyrace.tracks.ros_map import fewest_rects, pixel_rects
from tinyrace.validate import validate_path

ROOT = Path(__file__).resolve().parents[1]


def circle_rows(radius: float, count: int = 120, widths: tuple[float, float] | None = None) -> str:
    angles = np.linspace(0.0, 2 * math.pi, count, endpoint=False)
    tail = "" if widths is None else f",{widths[0]},{widths[1]}"
    return "".join(f"{radius * math.cos(a):.6f},{radius * math.sin(a):.6f}{tail}\n" for a in angles)


def problems_of(error: pytest.ExceptionInfo[ConfigError]) -> list[tuple[str, str, str]]:
    return [(p.source, p.path, p.allowed) for p in error.value.problems]


# -- a header naming x and y but not the widths ----------------------------------------------


@pytest.mark.parametrize(
    ("header", "named"),
    [
        ("x,y,w_r,w_l", "'w_r' and 'w_l' are not width names"),
        ("x_m,y_m,width_right,width_left", "'width_right' and 'width_left' are not width names"),
        ("x_m,y_m,w_tr_right_m,speed", "one width named alone is not read"),
        ("# x_m,y_m,half_width,w_tr_left_m", "'half_width' is not a width name"),
    ],
)
def test_a_header_naming_the_widths_otherwise_is_refused(tmp_path, header, named):
    path = tmp_path / "c.csv"
    path.write_text(header + "\n" + circle_rows(60.0, widths=(4.0, 4.0)))
    with pytest.raises(ConfigError) as caught:
        read_loop(path, "t.yaml", "track.file")
    ((source, key, allowed),) = problems_of(caught)
    assert (source, key) == (str(path), "header")
    assert named in allowed and "w_tr_right_m / w_right / w_right_m" in allowed


@pytest.mark.parametrize(
    "header",
    [
        "x_m,y_m,w_tr_right_m,w_tr_left_m",
        "# x_m, y_m, w_tr_right_m, w_tr_left_m",
        "x,y,w_right,w_left",
    ],
)
def test_a_header_naming_both_widths_reads_them(tmp_path, header):
    path = tmp_path / "c.csv"
    path.write_text(header + "\n" + circle_rows(60.0, widths=(3.0, 5.0)))
    loop = read_loop(path, "t.yaml", "track.file")
    assert loop.widths is not None and np.allclose(loop.widths, [3.0, 5.0])


def test_a_header_of_x_and_y_alone_or_a_raceline_takes_the_default_width(tmp_path):
    path = tmp_path / "c.csv"
    path.write_text("x_m,y_m\n" + circle_rows(60.0))
    assert read_loop(path, "t.yaml", "track.file").widths is None
    raceline = tmp_path / "r.csv"
    rows = circle_rows(60.0).splitlines()
    raceline.write_text(
        "# s_m; x_m; y_m; psi_rad; kappa_radpm; vx_mps; ax_mps2\n"
        + "".join(f"{i};{r.replace(',', ';')};0;0;5;0\n" for i, r in enumerate(rows))
    )
    loop = read_loop(raceline, "t.yaml", "track.file")
    assert loop.widths is None and np.allclose(loop.points[0], [60.0, 0.0])


# -- a road wider than its curve ---------------------------------------------------------------


@pytest.mark.parametrize("radius", [20.0, 60.0])
@pytest.mark.parametrize("width", [3.0, 15.0])
def test_inner_width_over_radius_on_a_circle_is_width_over_radius(radius, width):
    angles = np.linspace(0.0, 2 * math.pi, 2000, endpoint=False)
    loop = radius * np.column_stack((np.cos(angles), np.sin(angles)))  # counter-clockwise
    widths = np.column_stack((np.full(2000, 1.0), np.full(2000, width)))  # inside: the left
    ratio = polyline.inner_width_over_radius(loop, widths)
    assert np.allclose(ratio, width / radius, rtol=1e-3)
    clockwise = polyline.inner_width_over_radius(loop[::-1], widths)  # inside: the right
    assert np.allclose(clockwise, 1.0 / radius, rtol=1e-3)


def test_inner_width_over_radius_is_zero_on_a_straight_and_ignores_a_kink_narrower_than_the_road():
    square = np.array([[0.0, 0.0], [100.0, 0.0], [100.0, 100.0], [0.0, 100.0]])
    loop, _ = polyline.resample(square, 1.0)
    ratio = polyline.inner_width_over_radius(loop, np.full((len(loop), 2), 4.0))
    assert ratio[20:80].max() == 0.0  # the middle of the first side
    # a square corner turns 90 degrees within the road's own width: 4 m over 8 m of arc
    assert ratio.max() == pytest.approx(4.0 * (math.pi / 2) / 8.0, rel=0.15)


def centerline_folder(tmp_path: Path, rows: str, track: str) -> Path:
    (tmp_path / "c.csv").write_text(rows)
    (tmp_path / "track.yaml").write_text(track)
    return tmp_path


def test_a_road_wider_than_its_curve_is_refused_at_the_files_line(tmp_path):
    folder = centerline_folder(
        tmp_path,
        circle_rows(60.0, widths=(100.0, 100.0)),  # the helper's cl_width_bigger_than_radius
        "track: {type: centerline, file: c.csv, spacing: 2.0}\n",
    )
    with pytest.raises(ConfigError) as caught:
        gym.make("tinyrace/TinyRace-v0", environment=str(folder))
    ((source, key, allowed),) = problems_of(caught)
    assert source == str(folder / "c.csv") and key.startswith("line ")
    assert f"at most {MAX_INNER_WIDTH_OVER_RADIUS:g} x the curve's radius" in allowed
    assert "100 m to the left of a curve of radius 60 m" in allowed
    problems, _ = validate_path(folder)
    assert len(problems) == 1 and "folds over itself" in problems[0]


def test_a_default_width_wider_than_the_curve_is_named_as_written(tmp_path):
    folder = centerline_folder(
        tmp_path,
        "x_m,y_m\n" + circle_rows(6.0),
        "track: {type: centerline, file: c.csv, spacing: 0.5, default_width: 20}\n",
    )
    with pytest.raises(ConfigError) as caught:
        gym.make("tinyrace/TinyRace-v0", environment=str(folder))
    ((source, key, allowed),) = problems_of(caught)
    assert (source, key) == (str(folder / "track.yaml"), "track.default_width")
    assert "10 m to the left of a curve of radius" in allowed and "narrower width" in allowed
    (folder / "track.yaml").write_text(
        "track: {type: centerline, file: c.csv, spacing: 0.5, default_width: 10}\n"
    )
    env = gym.make("tinyrace/TinyRace-v0", environment=str(folder))
    env.reset(seed=0)
    env.close()


def test_free_space_around_waypoints_is_cut_where_the_curve_is_tighter(tmp_path):
    """A ROS map of an empty room: the clearance around a tight loop of waypoints (4 m) is
    wider than the loop's radius (3 m). The tiles are cut to the radius instead of folding."""
    picture = np.full((200, 200), 254, np.uint8)
    picture[0, :] = picture[-1, :] = picture[:, 0] = picture[:, -1] = 0
    cv2.imwrite(str(tmp_path / "room.png"), picture)
    (tmp_path / "room.yaml").write_text(
        "image: room.png\nresolution: 0.1\norigin: [-10.0, -10.0, 0.0]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\n"
    )
    (tmp_path / "w.csv").write_text(circle_rows(3.0, count=60))
    (tmp_path / "track.yaml").write_text(
        "track: {type: ros_map, file: room.yaml, waypoints: w.csv, spacing: 0.25}\n"
    )
    env = gym.make("tinyrace/TinyRace-v0", environment=str(tmp_path))
    env.reset(seed=0)
    env.close()
    loaded = load_env_config(environment=tmp_path)
    circuit = load_metric_track(loaded.config.tracks[0], 0, loaded.base_dir, loaded.source).circuit
    assert circuit is not None
    ratio = polyline.inner_width_over_radius(circuit.centerline, circuit.widths)
    assert ratio.max() <= 1.05
    assert circuit.widths.max() > 2.5  # cut to about the radius, not to nothing


# -- a speckled map, refused from a bound --------------------------------------------------------


@given(
    arrays(bool, st.tuples(st.integers(1, 30), st.integers(1, 30))),
    st.integers(1, 8),
    st.integers(1, 3),
)
def test_fewest_rects_is_a_lower_bound_on_the_rectangles(mask, band, grow):
    mask = np.repeat(np.repeat(mask, grow, axis=0), grow, axis=1)
    at_least = fewest_rects(mask, band)
    assert at_least <= len(pixel_rects(mask))
    assert at_least == fewest_rects(mask)  # the bands do not change the count
    if not mask.any():
        assert at_least == 0


def test_fewest_rects_counts_isolated_cells_exactly():
    mask = np.zeros((40, 40), bool)
    mask[::2, ::2] = True
    assert fewest_rects(mask, 7) == len(pixel_rects(mask)) == 400


# -- key paths as the file writes them -----------------------------------------------------------


@pytest.mark.parametrize(
    ("text", "key"),
    [
        ("track: {type: centerline, file: nope.csv}\n", "track.file"),
        ("track:\n  - {type: centerline, file: nope.csv}\n", "track[0].file"),
        ("tracks: {type: centerline, file: nope.csv}\n", "tracks.file"),
        ("tracks:\n  - {type: centerline, file: nope.csv}\n", "tracks[0].file"),
        (
            "tracks:\n  - {type: centerline, file: c.csv}\n"
            "  - {type: centerline, file: nope.csv}\n",
            "tracks[1].file",
        ),
        ("track: {type: centerline, file: c.csv, spacing: -1}\n", "track.spacing"),
        ("track: {type: procedural}\nsensor: {id: l, type: lidar, beams: 0}\n", "sensor.beams"),
        (
            "track: {type: procedural}\nsensors:\n  - {id: l, type: lidar, beams: 0}\n",
            "sensors[0].beams",
        ),
    ],
)
def test_a_key_path_names_the_section_as_the_file_writes_it(tmp_path, text, key):
    (tmp_path / "c.csv").write_text(circle_rows(60.0))
    (tmp_path / "track.yaml").write_text(text)
    with pytest.raises(ConfigError) as caught:
        gym.make("tinyrace/TinyRace-v0", environment=str(tmp_path))
    assert [p.path for p in caught.value.problems] == [key]


def test_a_message_naming_a_key_names_it_as_written(tmp_path):
    (tmp_path / "c.csv").write_text(circle_rows(5.0, count=8))
    (tmp_path / "track.yaml").write_text("track: {type: centerline, file: c.csv, spacing: 30}\n")
    with pytest.raises(ConfigError) as caught:
        gym.make("tinyrace/TinyRace-v0", environment=str(tmp_path))
    ((source, _, allowed),) = problems_of(caught)
    assert source == str(tmp_path / "c.csv")
    assert "3 x track.spacing (90 m)" in allowed and "tracks[0]" not in allowed


@pytest.mark.parametrize(
    ("keys", "key"),
    [
        ({"track": {"type": "centerline", "file": "nope.csv"}}, "track.file"),
        ({"tracks": [{"type": "centerline", "file": "nope.csv"}]}, "tracks[0].file"),
        ({"track": {"type": "centerline", "file": "c.csv", "spacing": -1}}, "track.spacing"),
    ],
)
def test_a_key_given_to_gym_make_is_named_as_given(tmp_path, monkeypatch, keys, key):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "c.csv").write_text(circle_rows(60.0))
    with pytest.raises(ConfigError) as caught:
        gym.make("tinyrace/TinyRace-v0", **keys)
    assert [(p.source, p.path) for p in caught.value.problems] == [("<kwargs>", key)]


def test_a_key_of_an_experiments_env_section_is_named_as_written(tmp_path, capsys):
    from tinyrace.cli import main

    (tmp_path / "e.yaml").write_text(
        "env:\n  track: {type: centerline, file: nope.csv}\nepisodes: 1\n"
    )
    assert main(["run", str(tmp_path / "e.yaml")]) == 2
    assert "e.yaml: env.track.file: got '" in capsys.readouterr().err


# -- the campaign on the training surface ----------------------------------------------------

EXPERIMENT = "env: {environment: formula_student}\nepisodes: 1\nmax_steps: 5\n"
QUIET = ["--quiet"]


def run_cli(argv: list[str], capsys) -> tuple[int, str]:
    from tinyrace.cli import main

    code = main(argv)
    return code, capsys.readouterr().err


def test_an_experiment_whose_name_is_not_utf8_writes_its_results_and_report(tmp_path, capsys):
    name = os.fsdecode(b"caf\xe9.yaml")
    (tmp_path / name).write_text(EXPERIMENT + "output: {video: false}\n")
    code, err = run_cli(["run", str(tmp_path / name), "-o", str(tmp_path / "runs"), *QUIET], capsys)
    assert code == 0, err
    (run,) = (tmp_path / "runs").iterdir()
    assert (run / "results.json").is_file()
    assert "caf\\udce9.yaml" in (run / "report.html").read_text(encoding="utf-8")


@pytest.mark.parametrize(
    ("driver", "said"),
    [
        ("sys:exit", "sys:exit with driver_args {} raised SystemExit"),
        ("mine:exits", "mine:exits with driver_args {} raised SystemExit: 0"),
        ("mine:policy_exits", "act() at step 0 raised SystemExit: 0"),
        ("mine:policy_closes", "act() at step 0 raised GeneratorExit"),
    ],
)
def test_a_driver_that_exits_is_a_driver_error_not_a_silent_success(tmp_path, capsys, driver, said):
    (tmp_path / "mine.py").write_text(
        "import sys\n"
        "def exits():\n    raise SystemExit(0)\n"
        "def policy_exits():\n    return lambda observation, info: sys.exit(0)\n"
        "def policy_closes():\n    def act(observation, info):\n        raise GeneratorExit\n"
        "    return act\n"
    )
    (tmp_path / "e.yaml").write_text(EXPERIMENT + f"driver: {driver}\noutput: {{video: false}}\n")
    code, err = run_cli(
        ["run", str(tmp_path / "e.yaml"), "-o", str(tmp_path / "r"), *QUIET], capsys
    )
    assert code == 2
    assert "e.yaml: driver: got" in err and said in err


@pytest.mark.parametrize(
    ("args", "key", "said"),
    [
        ("{offset: .nan}", "driver_args.offset", "got nan; expected a finite number"),
        ("{offset: .inf}", "driver_args.offset", "got inf; expected a finite number"),
        ("{top_speed: 0}", "driver_args.top_speed", "expected a finite number > 0"),
        ("{corner_gas_cut: 2}", "driver_args.corner_gas_cut", "<= 1"),
    ],
)
def test_a_built_in_drivers_argument_is_named_under_driver_args(tmp_path, capsys, args, key, said):
    (tmp_path / "e.yaml").write_text(EXPERIMENT + f"driver: centerline\ndriver_args: {args}\n")
    code, err = run_cli(
        ["run", str(tmp_path / "e.yaml"), "-o", str(tmp_path / "r"), *QUIET], capsys
    )
    assert code == 2
    assert f"e.yaml: {key}: " in err and said in err


def test_an_environment_that_is_no_track_file_is_named_at_its_key(tmp_path, capsys):
    (tmp_path / "notes.txt").write_text("secret words\n" * 100)
    (tmp_path / "e.yaml").write_text("env: {environment: notes.txt}\nepisodes: 1\n")
    code, err = run_cli(["run", str(tmp_path / "e.yaml"), *QUIET], capsys)
    assert code == 2
    assert "e.yaml: env.environment: got 'notes.txt'" in err
    assert "holds a text of 1,299 characters, not a mapping" in err
    assert "secret" not in err


def test_make_vec_takes_gymnasiums_autoreset_mode_next_step_only():
    from gymnasium.vector import AutoresetMode

    for accepted in (AutoresetMode.NEXT_STEP, "NextStep"):
        vector = gym.make_vec(
            "tinyrace/CarRacing-v0",
            2,
            vectorization_mode="vector_entry_point",
            workers=0,
            autoreset_mode=accepted,
        )
        assert vector.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
        vector.close()
    for refused in (AutoresetMode.SAME_STEP, AutoresetMode.DISABLED, "bogus"):
        with pytest.raises(ConfigError) as caught:
            gym.make_vec(
                "tinyrace/CarRacing-v0",
                2,
                vectorization_mode="vector_entry_point",
                workers=0,
                autoreset_mode=refused,
            )
        ((source, key, allowed),) = problems_of(caught)
        assert (source, key) == ("<make_vec arguments>", "autoreset_mode")
        assert "NEXT_STEP" in allowed


def test_a_run_folder_where_no_file_can_be_made_is_named_before_running(tmp_path, capsys):
    if not Path("/proc/self").is_dir():
        pytest.skip("needs Linux's /proc (root may write there by its permissions)")
    (tmp_path / "e.yaml").write_text(EXPERIMENT + "output: {dir: /proc/tinyrace_runs}\n")
    code, err = run_cli(["run", str(tmp_path / "e.yaml"), *QUIET], capsys)
    assert code == 2
    assert "output.dir (run folders): '/proc/tinyrace_runs': expected a folder where a file" in err


@pytest.mark.parametrize(
    ("text", "line", "said"),
    [
        ("episodes: 1\nseed: \x07 3\n", "line 2", "U+0007 (a control character)"),
        ("episodes: 1\x00\n", "line 1", "UTF-16 file? save it as UTF-8"),
        ("episodes: 1\n\n\nseed: 3\x1b\n", "line 4", "U+001B"),
    ],
)
def test_a_character_yaml_refuses_is_named_with_its_line(tmp_path, text, line, said):
    from tinyrace.config.yaml_file import read_yaml

    (tmp_path / "e.yaml").write_text(text)
    with pytest.raises(ConfigError) as caught:
        read_yaml(tmp_path / "e.yaml")
    ((source, key, allowed),) = problems_of(caught)
    assert (source, key) == (str(tmp_path / "e.yaml"), line)
    assert said in allowed and "cannot be in a YAML file" in allowed
    assert caught.value.problems[0].value != ""  # the line, not ''


def test_a_message_quotes_the_line_yaml_counted(tmp_path):
    """U+2028 ends a line for YAML: the quoted text is the line YAML names."""
    from tinyrace.config.yaml_file import read_yaml

    (tmp_path / "e.yaml").write_text("episodes: 1\u2028seed: 5\nmax_steps: 10\nseed: 4\n")
    with pytest.raises(ConfigError) as caught:
        read_yaml(tmp_path / "e.yaml")
    problem = caught.value.problems[0]
    assert problem.path == "line 4" and problem.value == "seed: 4"
    assert "lines 2 and 4" in problem.allowed


@pytest.mark.parametrize(
    ("names", "text"),
    [
        (["ep 0", "1", "2", "5"], "ep 0-2, 5"),
        (["ep 0", "2"], "ep 0, 2"),
        (["ep 0", *map(str, range(1, 90))], "ep 0-89"),
        (["ep 0", *map(str, range(2, 90, 2))], "ep 0, 2, 4, 6, 8, ... (45 episodes)"),
    ],
)
def test_start_labels_of_many_episodes_stay_short(names, text):
    from tinyrace.experiment.plots import _episodes_text

    assert _episodes_text(names) == text


def test_a_report_of_ninety_episodes_draws_without_a_warning(tmp_path, capsys, recwarn):
    """--quiet printed matplotlib's "constrained_layout not applied" for 90 episodes that
    start at one place: their start label was 90 numbers long."""
    (tmp_path / "e.yaml").write_text(
        "env: {environment: formula_student, cameras: [], sensors: [{id: s, type: state}]}\n"
        "episodes: 90\nmax_steps: 3\noutput: {video: false}\n"
    )
    code, err = run_cli(
        ["run", str(tmp_path / "e.yaml"), "-o", str(tmp_path / "r"), *QUIET], capsys
    )
    assert code == 0 and err == ""
    assert not [w for w in recwarn if "constrained_layout" in str(w.message)]


@pytest.mark.parametrize(
    ("car", "keys"),
    [
        ({"model": "dynamic", "pixels_per_unit": 1000}, "(car.pixels_per_unit)"),
        ({"model": "kinematic_throttle", "wheelbase": 40.0}, "(car.wheelbase, car.track_width)"),
    ],
)
def test_a_car_too_big_for_its_start_names_the_keys_that_size_it(car, keys):
    with pytest.raises(ConfigError) as caught:
        gym.make(
            "tinyrace/TinyRace-v0",
            environment="f1tenth_loop",
            cameras=[],
            sensors=[{"id": "s", "type": "state"}],
            car=car,
        )
    assert caught.value.problems[0].allowed.endswith(f"make the car smaller {keys}")


def test_run_model_is_checked_before_running(tmp_path, capsys, monkeypatch):
    """``tinyrace run NAME --model FILE.zip``: a missing file, a race, or no
    Stable-Baselines3 are named as --model before any episode."""
    monkeypatch.chdir(tmp_path)
    code, err = run_cli(["run", "f1tenth_lidar", "--model", "missing.zip", *QUIET], capsys)
    assert code == 2 and "argument --model: got 'missing.zip'; expected a saved model file" in err
    (tmp_path / "m.zip").write_bytes(b"PK")
    code, err = run_cli(["run", "circuit_race", "--model", "m.zip", *QUIET], capsys)
    assert code == 2 and "a race's cars have drivers of their own" in err
    monkeypatch.setitem(sys.modules, "stable_baselines3", None)  # as if not installed
    code, err = run_cli(["run", "f1tenth_lidar", "--model", "m.zip", *QUIET], capsys)
    assert code == 2 and "argument --model: a model's driver needs " in err
    assert "stable-baselines3: pip install" in err
    assert not (tmp_path / "runs").exists()
