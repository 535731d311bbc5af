"""Issue 31.5: a generated campaign over the metre formats, the sensors list, the vector
arguments and ``tinyrace show`` / ``report`` on them.

Centreline CSVs, cone map CSVs and ROS maps (YAML + PNG/PGM) are generated from valid ones
and damaged (separators, headers, hostile numbers, degenerate shapes, huge scales and
spacings), each with a ``sensors:`` list drawn with hostile knobs. Every case runs in a
worker process under an address-space limit and an alarm (tests/hostile_worker.py, the
workers of tests/test_hostile_campaign.py) and must end in a ConfigError naming a file of
the case (or the sensor) or in an env that resets and steps with finite observations inside
its observation space; no input file's bytes may change. The generator is seeded: the same
cases run every time. The case count and the outcomes are printed.
"""

from __future__ import annotations

import collections
import json
import math
import random
import shutil
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest
import yaml
from test_hostile_campaign import WORKERS, Campaign, digests, unchanged

SEED = 31
SECONDS = 20  # [s] per case: a valid track of 100,000 points (the bound) builds in ~10 s
CASES = {"centerline": 300, "cone_map": 260, "ros_map": 260, "vector": 60, "argv": 80, "report": 60}
MIN_CASES = 1000

# -- numbers and text a careless or hostile user writes -----------------------------------------
HOSTILE_NUMBERS = [
    "nan", "inf", "-inf", "1e300", "1e308", "-1e308", "1e-320", "0", "-0", "", "x", "1_0",
    "99999999999999999999999", "0x10", "1,5", " 3 ", "+7", "1e7", "-1e7",
]  # fmt: skip
YAML_NUMBERS = [
    0, -1, 1e-9, 1e-6, 0.01, 1.0, 1e3, 1e6, 1e9, 1e300, "1e9", "x", None, True, [1], 2**70,
]  # fmt: skip


def loop_points(rng: random.Random, count: int, size: float) -> np.ndarray:
    """(count, 2) [m] a wobbly ellipse in driving order (counter-clockwise)."""
    t = np.linspace(0.0, 2 * math.pi, count, endpoint=False)
    a, b = size * rng.uniform(0.6, 1.0), size * rng.uniform(0.4, 0.8)
    wobble = 1 + 0.1 * np.sin(rng.randint(2, 5) * t)
    return np.column_stack((a * wobble * np.cos(t), b * wobble * np.sin(t)))


def rows_text(rows: list[list[str]], separator: str) -> str:
    return "".join(separator.join(row) + "\n" for row in rows)


def damage_cells(rng: random.Random, rows: list[list[str]], times: int) -> None:
    for _ in range(times):
        if not rows:
            return
        row = rng.choice(rows)
        if row:
            row[rng.randrange(len(row))] = rng.choice(HOSTILE_NUMBERS)


# -- centreline CSVs ---------------------------------------------------------------------------
def centerline_case(rng: random.Random, folder: Path) -> None:
    count = rng.choice([4, 5, 12, 60, 200, 1500])
    points = loop_points(rng, count, rng.choice([20.0, 80.0, 300.0]))
    widths = np.full((count, 2), rng.choice([2.0, 4.0, 6.0]))
    columns = rng.choice([2, 4, 4, 7])
    if columns == 2:
        rows = [[f"{x:.4f}", f"{y:.4f}"] for x, y in points]
        header = "# x_m,y_m"
    elif columns == 4:
        rows = [[f"{x:.4f}", f"{y:.4f}", f"{r:.2f}", f"{le:.2f}"] for (x, y), (r, le) in
                zip(points, widths, strict=True)]  # fmt: skip
        header = "# x_m,y_m,w_tr_right_m,w_tr_left_m"
    else:
        rows = [[str(i), f"{x:.4f}", f"{y:.4f}", "0", "0", "5", "0"] for i, (x, y) in
                enumerate(points)]  # fmt: skip
        header = "# s_m; x_m; y_m; psi_rad; kappa_radpm; vx_mps; ax_mps2"
    damage = "none" if clean(rng) else rng.choice(
        ["cells", "header_only", "few", "repeat", "cross", "negative_width", "huge",
         "header_names", "blank_lines"])  # fmt: skip
    if damage == "cells":
        damage_cells(rng, rows, rng.randint(1, 3))
    elif damage == "header_only":
        rows = []
    elif damage == "few":
        rows = rows[: rng.randint(0, 3)]
    elif damage == "repeat" and len(rows) > 2:
        rows[1] = list(rows[0])
    elif damage == "cross" and len(rows) > 6:
        rows[1], rows[len(rows) // 2] = rows[len(rows) // 2], rows[1]
    elif damage == "negative_width" and columns == 4:
        rows[0][2] = "-1"
    elif damage == "huge":
        rows = [[str(float(c) * 1e299) if c.replace(".", "").lstrip("-").isdigit() else c
                 for c in row] for row in rows]  # fmt: skip
    elif damage == "header_names":
        header = rng.choice(["x,y,w_right,w_left,extra", "# a,b", "x_m;y_m", "#"])
    separator = ";" if columns == 7 else rng.choice([",", ",", ";", "\t", ", "])
    text = rows_text(rows, separator)
    if rng.random() < 0.7:
        text = header + "\n" + text
    if damage == "blank_lines":
        text = text.replace("\n", "\n\n# note\n", 3)
    (folder / "c.csv").write_text(text)
    track: dict[str, Any] = {"type": "centerline", "file": "c.csv"}
    track.update(hostile_knobs(rng, ["spacing", "scale", "default_width", "margin"]))
    write_config(rng, folder, track)


# -- cone maps -----------------------------------------------------------------------------------
def cone_case(rng: random.Random, folder: Path) -> None:
    count = rng.choice([3, 8, 20, 40])
    size = rng.choice([15.0, 30.0])
    inner, outer = loop_points(rng, count, size * 0.8), loop_points(rng, count, size)
    inner = inner * 0.8  # a road between the two
    rows = [["blue", f"{x:.3f}", f"{y:.3f}", "0", "0", "0", "0"] for x, y in outer]
    rows += [["yellow", f"{x:.3f}", f"{y:.3f}", "0", "0", "0", "0"] for x, y in inner]
    start = outer[0] * 1.05  # beside the first blue cone (one cone per place)
    rows += [["big_orange", f"{start[0]:.3f}", f"{start[1]:.3f}", "0", "0", "0", "0"]]
    damage = "none" if clean(rng) else rng.choice(
        ["cells", "one_point", "one_colour", "tags", "short_rows", "huge", "duplicates",
         "far_apart"])  # fmt: skip
    if damage == "cells":
        damage_cells(rng, rows, rng.randint(1, 3))
    elif damage == "one_point":
        rows = [[row[0], "1.0", "1.0"] for row in rows]
    elif damage == "one_colour":
        rows = [row for row in rows if row[0] != "yellow"]
    elif damage == "tags":
        rng.choice(rows)[0] = rng.choice(["BLUE", "purple", "", "big orange", "unknown"])
    elif damage == "short_rows":
        rows = [row[: rng.randint(1, 3)] for row in rows]
    elif damage == "huge":
        rows = [[row[0], row[1] + "e300", row[2]] for row in rows]
    elif damage == "duplicates":
        rows = rows + rows
    elif damage == "far_apart":
        rows = [[row[0], str(float(row[1]) * 50), str(float(row[2]) * 50)] for row in rows]
    text = rows_text(rows, ",")
    if rng.random() < 0.6:
        text = "tag,x,y,direction,x_variance,y_variance,covariance\n" + text
    (folder / "k.csv").write_text(text)
    track: dict[str, Any] = {"type": "cone_map", "file": "k.csv"}
    track.update(hostile_knobs(rng, ["spacing", "scale", "max_cone_gap", "margin"]))
    write_config(rng, folder, track)


# -- ROS maps --------------------------------------------------------------------------------
def corridor(height: int, width: int) -> np.ndarray:
    """A grey map: a free ring corridor inside walls (254 free, 0 occupied)."""
    image = np.zeros((height, width), np.uint8)
    cy, cx = height / 2, width / 2
    yy, xx = np.mgrid[0:height, 0:width]
    r = np.hypot((yy - cy) / max(cy, 1), (xx - cx) / max(cx, 1))
    image[(r > 0.45) & (r < 0.85)] = 254
    return image


def pgm_bytes(image: np.ndarray, comment: bool) -> bytes:
    head = b"P5\n" + (b"# CREATOR: map_saver.cpp 0.050 m/pix\n" if comment else b"")
    return head + b"%d %d\n255\n" % (image.shape[1], image.shape[0]) + image.tobytes()


def ros_case(rng: random.Random, folder: Path) -> None:
    tidy = clean(rng)
    sizes = [(60, 80), (80, 120), (120, 160)] + ([] if tidy else [(1, 1), (2, 2), (1, 40)])
    height, width = rng.choice(sizes)
    image = corridor(height, width)
    form = rng.choice(["png", "pgm", "pgm_comment"])
    name = "map.png" if form == "png" else "map.pgm"
    data = (
        cv2.imencode(".png", image)[1].tobytes()
        if form == "png"
        else pgm_bytes(image, form == "pgm_comment")
    )
    if rng.random() < 0.15 and not tidy:
        data = data[: rng.randrange(len(data))]
    (folder / name).write_bytes(data)
    resolution = 0.1
    info: dict[str, Any] = {
        "image": name,
        "resolution": resolution,
        "origin": [-width * resolution / 2, -height * resolution / 2, 0.0],
        "negate": 0,
        "occupied_thresh": 0.65,
        "free_thresh": 0.196,
    }
    for _ in range(0 if tidy else rng.choice([0, 1, 2])):
        key = rng.choice(list(info))
        info[key] = rng.choice([*YAML_NUMBERS, "map.yaml", "../x.png", [0, 0], [1e300, 0, 0]])
    (folder / "map.yaml").write_text(yaml.safe_dump(info))
    track: dict[str, Any] = {"type": "ros_map", "file": "map.yaml"}
    ring = 0.65 * np.array([width, height]) * resolution / 2  # the corridor's middle [m]
    t = np.linspace(0, 2 * math.pi, rng.choice([4, 30, 100]), endpoint=False)
    line = np.column_stack((ring[0] * np.cos(t), ring[1] * np.sin(t)))
    if rng.random() < 0.6:
        rows = [[f"{x:.3f}", f"{y:.3f}"] for x, y in line]
        damage_cells(rng, rows, rng.choice([0, 0, 1]))
        (folder / "w.csv").write_text("# x_m,y_m\n" + rows_text(rows, rng.choice([",", "\t"])))
        track["waypoints"] = "w.csv"
    else:
        track["spawn"] = rng.choice([[float(line[0][0]), float(line[0][1]), 1.5], [0, 0, 0],
                                     [1e300, 0, 0], None])  # fmt: skip
    track.update(hostile_knobs(rng, ["spacing"]))
    write_config(rng, folder, track)


# -- knobs, sensors and the config -------------------------------------------------------------
def clean(rng: random.Random) -> bool:
    """Whether this case's files are left valid (then only its knobs and sensors may be bad):
    a campaign of refusals alone would not show that valid input works."""
    return rng.random() < 0.45


def hostile_knobs(rng: random.Random, names: list[str]) -> dict[str, Any]:
    knobs: dict[str, Any] = {}
    for name in names:
        if rng.random() < 0.06:
            knobs[name] = rng.choice(YAML_NUMBERS)
    return knobs


SENSOR_KNOBS: dict[str, dict[str, list[Any]]] = {
    "perspective_camera": {
        "resolution": [[8, 12], [16, 16], [1, 1], [4096, 4096], [0, 5], [2.5, 3]],
        "position": [None, [0, 0, 1.0], [0, 0, 0], [0, 0, -1], [1e300, 0, 1]],
        "fov": [60, 90, 1, 170, 180, "x"],
        "pitch": [20, 45, -89, 0, 89, 90],
        "max_range": [None, 5.0, 1e-9],
        "format": ["rgb", "gray", "classes", "hsv"],
    },
    "lidar": {
        "beams": [1, 16, 64, 20001],
        "fov": [270, 360, 1, 361],
        "hit_classes": [False, True],
        "range_std": [0, 0.1, -1],
        "max_range": [None, 5.0, 1e-9, 1e300],
        "cell": [None, 0.5, 0.05, 1e-9],
    },
    "state": {"pose": [False, True]},
    "lookahead": {"points": [1, 10, 1000, 1001], "spacing": [None, 0.5, 1e-9, 1e6, "1e-9"]},
    "cones": {"max_cones": [32, 1, 4097], "false_positives": [0, 5, 1000]},
}
CAMERA = {"id": "front", "resolution": [8, 12], "roi": [10.0, 12.0]}


def sensors(rng: random.Random) -> list[dict[str, Any]]:
    chosen = []
    tidy = rng.random() < 0.5  # the first two values of each knob are valid
    for i in range(rng.choice([0, 0, 1, 1, 2, 3])):
        kind = rng.choice(list(SENSOR_KNOBS))
        entry: dict[str, Any] = {"id": f"s{i}", "type": kind}
        for key, values in SENSOR_KNOBS[kind].items():
            if rng.random() < 0.35:
                entry[key] = rng.choice(values[:2] if tidy else values)
        if kind == "perspective_camera" and "resolution" not in entry:
            entry["resolution"] = [8, 12]
        if kind == "lidar" and "beams" not in entry:
            entry["beams"] = 16
        chosen.append(entry)
    return chosen


def write_config(rng: random.Random, folder: Path, track: dict[str, Any]) -> None:
    config: dict[str, Any] = {
        "track": track,
        "sim": {"step_limit": 20},
        "car": {"model": rng.choice(["kinematic_throttle", "kinematic_throttle", "dynamic"])},
    }
    for key in ("pixels_per_meter",):
        if rng.random() < 0.1 and track["type"] != "ros_map":
            track[key] = rng.choice([0.25, 1.0, 200.0])
    if rng.random() < 0.5:
        config["cameras"] = [dict(CAMERA)]
    listed = sensors(rng)
    if listed:
        config["sensors"] = listed
    if rng.random() < 0.1:
        config["observation"] = "box"
    (folder / "track.yaml").write_text(yaml.safe_dump(config, sort_keys=False, width=10**6))


MAKERS: dict[str, Callable[[random.Random, Path], None]] = {
    "centerline": centerline_case,
    "cone_map": cone_case,
    "ros_map": ros_case,
}

# -- outcomes --------------------------------------------------------------------------------
PSEUDO_SOURCES = ("<sensors>",)  # a sensor whose bound depends on the track: named by its id


def described(folder: Path) -> str:
    """The case's track.yaml and the first lines of its data files, for a failure message."""
    texts = []
    for path in sorted(folder.iterdir()):
        if path.suffix in (".yaml", ".csv"):
            texts.append(f"{path.name}:\n" + "\n".join(path.read_text().splitlines()[:6]))
    return "\n".join(texts)


def check_metric_outcome(outcome: dict[str, Any], folder: Path) -> None:
    assert outcome["outcome"] in ("ok", "config_error"), (outcome, described(folder))
    for source, path, text in outcome["make"]:
        named = source.startswith(str(folder)) or (source in PSEUDO_SOURCES and "sensors" in path)
        assert named, text  # the problem names a file of the case (or the sensor)
        assert len(text) < 2000, text


@pytest.fixture(scope="module")
def campaign():
    root = Path(tempfile.mkdtemp(prefix="tinyrace-hostile-metric-"))
    running = Campaign(root, SECONDS)
    yield running
    running.close()
    shutil.rmtree(root, ignore_errors=True)


def run_batches(campaign: Campaign, kind: str, count: int, make_case) -> None:
    """``count`` cases of ``kind``, WORKERS side by side; ``make_case(i)`` writes one and
    returns (case, folder, check)."""
    for start in range(0, count, WORKERS):
        made = [make_case(i) for i in range(start, min(start + WORKERS, count))]
        before = [inputs(digests(folder)) for _, folder, _ in made]
        outcomes = campaign.run(kind, [case for case, _, _ in made])
        for (case, folder, check), old, outcome in zip(made, before, outcomes, strict=True):
            check(outcome, folder)
            assert unchanged(old, digests(folder)), (case, outcome, "an input file changed")
            shutil.rmtree(folder)


def inputs(found: dict[str, str]) -> dict[str, str]:
    """The case's own files: all but the report's (``tinyrace report`` replaces them)."""
    return {name: digest for name, digest in found.items() if not name.startswith("report")}


def metric_cases(campaign: Campaign, rng: random.Random) -> None:
    for kind in MAKERS:

        def make(_i: int, kind: str = kind):
            folder = campaign.folder()
            MAKERS[kind](rng, folder)
            case = {"kind": "metric", "args": {"folder": str(folder)}}
            return case, folder, check_metric_outcome

        run_batches(campaign, kind, CASES[kind], make)


VECTOR_VALUES = {
    "num_envs": [1, 2, 3, 0, -1, 2.5, "2", True, None, 1000, 10**20, np.int64(2)],
    "workers": [0, 0, 0, -1, "2", 2.5, None, 65, False],
}


def vector_cases(campaign: Campaign, rng: random.Random) -> None:
    track = campaign.folder()
    centerline_track(track)

    def make(_i: int):
        args: dict[str, Any] = {"environment": str(track)}
        for key, values in VECTOR_VALUES.items():
            if rng.random() < 0.9:
                args[key] = rng.choice(values)
        if args.get("workers") in (None, 65) or "workers" not in args:  # valid: no processes
            args["workers"] = 0  # (worker processes start slowly; tests/test_batch_vector.py)
        if "sensors" not in args and rng.random() < 0.3:
            args["sensors"] = sensors(rng) or None
        folder = campaign.folder()

        def check(outcome: dict[str, Any], _folder: Path) -> None:
            assert outcome["outcome"] in ("ok", "config_error"), (args, outcome)
            for source, _path, text in outcome["make"]:
                assert source.startswith(("<", str(track))), text
            if outcome["outcome"] == "ok":
                assert isinstance(args.get("num_envs", 1), (int, np.integer))

        return {"kind": "vector", "args": {"args": args}}, folder, check

    before = digests(track)
    run_batches(campaign, "vector", CASES["vector"], make)
    assert unchanged(before, digests(track))


def centerline_track(folder: Path) -> None:
    """A valid small centreline track."""
    points = loop_points(random.Random(0), 60, 40.0)
    rows = [[f"{x:.3f}", f"{y:.3f}", "3", "3"] for x, y in points]
    (folder / "c.csv").write_text("# x_m,y_m,w_tr_right_m,w_tr_left_m\n" + rows_text(rows, ","))
    config = {"track": {"type": "centerline", "file": "c.csv"}, "sim": {"step_limit": 20}}
    (folder / "track.yaml").write_text(yaml.safe_dump(config))


def argv_cases(campaign: Campaign, rng: random.Random) -> None:
    """``tinyrace show`` on metric track folders, its output aimed at every input, forced."""

    def make(_i: int):
        folder = campaign.folder()
        kind = rng.choice(list(MAKERS))
        MAKERS[kind](rng, folder)
        inputs = sorted(p.name for p in folder.iterdir())
        output = rng.choice([*inputs, "new.png", "sub/new.png", "x" * 300 + ".png"])
        argv = ["show", rng.choice([".", "track.yaml"]), "-o", output]
        argv += ["--force"] if rng.random() < 0.8 else []

        def check(outcome: dict[str, Any], _folder: Path) -> None:
            assert outcome["outcome"] == "exit", (argv, outcome, described(folder))
            assert outcome["code"] in (0, 2), (argv, outcome)
            assert "Traceback" not in outcome["stderr"], (argv, outcome)
            if output in inputs:
                assert outcome["code"] == 2, (argv, outcome)  # never over a file it read

        return {"kind": "argv", "args": {"argv": argv, "cwd": str(folder)}}, folder, check

    run_batches(campaign, "argv", CASES["argv"], make)


# -- hand-edited run folders -------------------------------------------------------------------
RESULTS_EDITS = [
    ("replace", []), ("replace", None), ("replace", "x"), ("replace", {"tracks": []}),
    ("field", "tracks", {"a/b": {"image": "t.png", "frame": [1, 0, 1, 0]}}),
    ("field", "tracks", {"k": {"image": "results.json", "frame": [1, 0, 1, 0]}}),
    ("field", "tracks", {"k": {"image": "episodes.csv", "frame": [1, 0, 1, 0]}}),
    ("field", "tracks", {"k": {"image": "t.png", "frame": [1e300, 0, 1e300, 0]}}),
    ("field", "tracks", {"k": {"image": "t.png", "frame": "x"}}),
    ("field", "summary", {"a": 1}), ("field", "interrupted", "no"),
    ("field", "episodes_planned", 2.5), ("field", "error", 3), ("field", "signal", []),
]  # fmt: skip
CSV_EDITS = ["huge_field", "bad_int", "nan_return", "short_row", "trace_is_report",
             "trace_escape", "empty", "binary"]  # fmt: skip


def report_cases(campaign: Campaign, rng: random.Random) -> None:
    """``tinyrace report`` on a real run folder, hand-edited."""
    from tinyrace.experiment import load_experiment, run_experiment

    track = campaign.folder()
    centerline_track(track)
    experiment = track / "e.yaml"
    experiment.write_text(
        yaml.safe_dump(
            {"env": {"environment": "."}, "episodes": 2, "max_steps": 10}
            | {"output": {"video": False}}
        )
    )
    original = run_experiment(load_experiment(experiment), track / "runs", False).run_dir

    def make(_i: int):
        folder = campaign.folder()
        shutil.rmtree(folder)
        shutil.copytree(original, folder)
        edit = rng.choice(["results", "csv", "report_folder", "none"])
        if edit == "results":
            change = rng.choice(RESULTS_EDITS)
            header = json.loads((folder / "results.json").read_text())
            if change[0] == "replace":
                header = change[1]
            else:
                header[change[1]] = change[2]
            (folder / "results.json").write_text(json.dumps(header))
        elif edit == "csv":
            edit_episodes(folder, rng.choice(CSV_EDITS))
        elif edit == "report_folder":
            (folder / "report.html").unlink()
            (folder / "report.html").mkdir()
        read = {"results.json", "episodes.csv", "track_track0.png",
                "episode_000_trace.csv", "episode_001_trace.csv"}  # fmt: skip

        def check(outcome: dict[str, Any], _folder: Path) -> None:
            assert outcome["outcome"] == "exit", (edit, outcome)
            assert outcome["code"] in (0, 2), (edit, outcome)
            assert "Traceback" not in outcome["stderr"], (edit, outcome)
            if outcome["code"] == 2:  # the file at fault is named, in the run folder
                assert str(folder) in outcome["stderr"], (edit, outcome)

        case = {"kind": "argv", "args": {"argv": ["report", str(folder)], "cwd": str(folder)}}
        return case, folder, _keeping(check, folder, read)

    run_batches(campaign, "report", CASES["report"], make)


def _keeping(check, folder: Path, read: set[str]):
    """The check, and the files the report reads are kept (the digests cover every file,
    but the report may replace its own pictures: only the read ones are compared here)."""
    kept = {name: digest for name, digest in digests(folder).items() if name in read}

    def both(outcome: dict[str, Any], _folder: Path) -> None:
        check(outcome, folder)
        after = digests(folder)
        assert all(after.get(name) == digest for name, digest in kept.items()), outcome

    return both


def edit_episodes(folder: Path, edit: str) -> None:
    path = folder / "episodes.csv"
    lines = path.read_text().splitlines()
    if edit == "huge_field":
        lines.append("2," + "9" * 200_000)
    elif edit == "bad_int":
        lines[1] = "zero" + lines[1][1:]
    elif edit == "nan_return":
        cells = lines[1].split(",")
        cells[2] = "nan"
        lines[1] = ",".join(cells)
    elif edit == "short_row":
        lines[1] = "1,2"
    elif edit == "trace_is_report":
        lines[1] = lines[1].replace("episode_000_trace.csv", "report.html")
    elif edit == "trace_escape":
        lines[1] = lines[1].replace("episode_000_trace.csv", "../../etc/passwd")
    elif edit == "empty":
        lines = []
    path.write_text("\n".join(lines) + "\n")
    if edit == "binary":
        path.write_bytes(b"\xff\xfe\x00" * 100)


def test_hostile_metric_campaign(campaign: Campaign, capsys):
    rng = random.Random(SEED)
    metric_cases(campaign, rng)
    vector_cases(campaign, rng)
    argv_cases(campaign, rng)
    report_cases(campaign, rng)
    total = sum(campaign.counts.values())
    outcomes = collections.Counter(
        {k: v for k, v in campaign.outcomes.items() if not k.startswith("probe")}
    )
    with capsys.disabled():
        print(f"\nhostile metric campaign: {total} cases {dict(campaign.counts)}; {dict(outcomes)}")
    assert total >= MIN_CASES
    for kind in ("centerline", "cone_map", "ros_map", "vector"):  # not refusals only
        assert campaign.outcomes[f"{kind} ok"] > 0, campaign.outcomes
        assert campaign.outcomes[f"{kind} config_error"] > 0, campaign.outcomes
