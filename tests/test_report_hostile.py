"""``tinyrace report`` on tampered run folders (a hostile-input campaign's findings): every
edit the report cannot draw is refused with the file, the key (or line and column), the
value and what is allowed; no warning is printed, no file is changed on a refusal; many
episodes or tracks take bounded time; an interrupted report leaves the old one whole."""

from __future__ import annotations

import hashlib
import json
import re
import shutil
import warnings
from collections.abc import Callable
from pathlib import Path

import pytest
from test_report import run

from tinyrace import cli
from tinyrace.experiment import files, plots, report
from tinyrace.experiment.report import MAX_DRAWN

Edit = Callable[[Path], None]


def _run(root: Path, name: str, episodes: int, max_steps: int) -> Path:
    return run(root, name, episodes, max_steps).run_dir  # test_report's run, without video


@pytest.fixture(scope="module")
def single(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _run(tmp_path_factory.mktemp("single"), "formula_student", 2, 12)


@pytest.fixture(scope="module")
def race(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _run(tmp_path_factory.mktemp("race"), "f1tenth_race", 2, 8)


def copied(folder: Path, tmp_path: Path) -> Path:
    copy = tmp_path / "run"
    shutil.copytree(folder, copy)
    return copy


def digests(folder: Path) -> dict[str, str]:
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.iterdir())}


def header(edit: Callable[[dict], object]) -> Edit:
    def apply(folder: Path) -> None:
        data = json.loads((folder / "results.json").read_text())
        edit(data)
        (folder / "results.json").write_text(json.dumps(data))

    return apply


def cell(column: str, value: str, row: int = 1, name: str = "episodes.csv") -> Edit:
    """episodes.csv's (or a trace's) cell of ``column`` in data row ``row`` (line row + 1)."""

    def apply(folder: Path) -> None:
        lines = (folder / name).read_text().splitlines()
        cells = lines[row].split(",")
        cells[lines[0].split(",").index(column)] = value
        lines[row] = ",".join(cells)
        (folder / name).write_text("\n".join(lines) + "\n", encoding="utf-8")

    return apply


def frame(value: list[object]) -> Edit:
    return header(lambda h: h["tracks"]["track0"].__setitem__("frame", value))


def refused(folder: Path, capsys: pytest.CaptureFixture[str]) -> str:
    """The one-line error of ``tinyrace report`` (exit 2), no warning, no file changed."""
    before = digests(folder)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a warning of matplotlib or numpy fails the test
        code = cli.main(["report", str(folder)])
    out, err = capsys.readouterr()
    assert code == 2, (out, err)
    assert err.startswith("tinyrace: error: ") and err.count("\n") == 1, err
    assert "Traceback" not in err and ".tinyrace-" not in err, err
    assert digests(folder) == before  # neither its inputs nor the old report changed
    return err


SINGLE_REFUSED: list[tuple[str, Edit, str]] = [
    # F6: a huge integer is no float
    ("frame_bigint", frame([10**400, 0, 1, 0]), "results.json: tracks.track0.frame: got ["),
    (
        "summary_bigint",
        header(lambda h: h["summary"].__setitem__("steps", {"mean": 10**400, "std": 0})),
        "results.json: summary.steps: got {",
    ),
    # F8, F9: sizes matplotlib cannot draw, or draws with warnings
    ("frame_tiny", frame([1e-308, 0, 1e-308, 0]), "tracks.track0.frame: got [1e-308, 0,"),
    ("frame_huge", frame([1e308, 1e308, 1e308, -1e308]), "tracks.track0.frame: got [1e+308"),
    ("frame_zero", frame([0, 0, 1, 0]), "tracks.track0.frame: got [0, 0, 1, 0]"),
    ("return_neg_huge", cell("episode_return", "-1.7e308"), "line 2, episode_return: got"),
    ("return_huge", cell("episode_return", "1e308"), "line 2, episode_return: got 1e+308"),
    (
        "track_unit_huge",
        header(lambda h: h.__setitem__("track_unit", "m" * 1_000_000)),
        "results.json: track_unit: got 'mmmm",
    ),
    ("track_unit_int", header(lambda h: h.__setitem__("track_unit", 5)), "track_unit: got 5"),
    # F11: a trace or video column naming another run file blames episodes.csv
    ("trace_results", cell("trace", "results.json"), "line 2, trace: got 'results.json'"),
    ("trace_video", cell("trace", "episode_000.mp4"), "line 2, trace: got 'episode_000.mp4'"),
    ("trace_episodes", cell("trace", "episodes.csv"), "line 2, trace: got 'episodes.csv'"),
    ("video_results", cell("video", "results.json"), "line 2, video: got 'results.json'"),
    # F24: '.' and '..' are no file names
    ("trace_dot", cell("trace", "."), "line 2, trace: got '.'"),
    ("trace_dotdot", cell("trace", ".."), "line 2, trace: got '..'"),
    (
        "image_dot",
        header(lambda h: h["tracks"]["track0"].__setitem__("image", ".")),
        "results.json: tracks.track0.image: got '.'; expected a file name",
    ),
    # F14: values no run writes
    ("episode_dup", cell("episode", "0", row=2), "line 3, episode: got 0; expected each"),
    ("track_unknown", cell("track", "track9"), "line 2, track: got 'track9'"),
    ("steps_neg", cell("steps", "-5"), "line 2, steps: got -5; expected a whole number from 0"),
    ("laps_neg", cell("laps", "-7"), "line 2, laps: got -7"),
    ("lap_time_neg", cell("lap_time", "-1.5"), "line 2, lap_time: got -1.5"),
    ("cte_neg", cell("mean_abs_cte", "-4"), "line 2, mean_abs_cte: got -4.0"),
    ("wall_hits_neg", cell("wall_hits", "-1"), "line 2, wall_hits: got -1"),
    ("wall_seconds_neg", cell("wall_seconds", "-1"), "line 2, wall_seconds: got -1.0"),
    ("sps_zero", cell("steps_per_second", "0"), "line 2, steps_per_second: got 0.0"),
    ("sps_neg", cell("steps_per_second", "-100"), "line 2, steps_per_second: got -100.0"),
    (
        "tiles_over_total",
        lambda d: (cell("tiles_visited", "500")(d), cell("tiles_total", "3")(d)),
        "line 2, tiles_visited: got 500; expected at most tiles_total (3)",
    ),
    (
        "tiles_total_zero",
        lambda d: (cell("tiles_visited", "5")(d), cell("tiles_total", "0")(d)),
        "line 2, tiles_visited: got 5; expected at most tiles_total (0)",
    ),
    ("steps_underscore", cell("steps", "1_000"), "line 2, steps: got '1_000'"),
    ("steps_arabic_digits", cell("steps", "\u0663\u0660"), "line 2, steps: got '\u0663\u0660'"),
    ("return_underscore", cell("episode_return", "1_0.5"), "line 2, episode_return: got '1_0.5'"),
    (
        "planned_neg",
        header(lambda h: h.__setitem__("episodes_planned", -5)),
        "results.json: episodes_planned: got -5; expected 1 to 1,000,000",
    ),
    (
        "planned_huge",
        header(lambda h: h.__setitem__("episodes_planned", 10**400)),
        "results.json: episodes_planned: got <an integer of",
    ),
    (
        "planned_bool",
        header(lambda h: h.__setitem__("episodes_planned", True)),
        "results.json: episodes_planned: got True",
    ),
    ("episodes_empty", lambda d: (d / "episodes.csv").write_bytes(b""), "episodes.csv: line 1"),
    (
        "trace_empty",
        lambda d: (d / "episode_000_trace.csv").write_bytes(b""),
        "episode_000_trace.csv: line 1",
    ),
    # F7: a bound on the tracks, naming the key
    (
        "tracks_many",
        header(
            lambda h: h.__setitem__("tracks", {f"t{i}": h["tracks"]["track0"] for i in range(9)})
        ),
        "results.json: tracks: got 9 entries; expected at most one track per planned",
    ),
]


@pytest.mark.parametrize(
    ("edit", "said"), [c[1:] for c in SINGLE_REFUSED], ids=[c[0] for c in SINGLE_REFUSED]
)
def test_a_tampered_run_is_refused_naming_file_key_and_value(
    single: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], edit: Edit, said: str
):
    folder = copied(single, tmp_path)
    edit(folder)
    err = refused(folder, capsys)
    assert said in err and "; expected " in err, err
    assert str(folder) in err


def test_the_untouched_run_is_rebuilt_without_a_warning(
    single: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
):
    folder = copied(single, tmp_path)
    first = (folder / "report.html").read_text()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert cli.main(["report", str(folder)]) == 0
    assert capsys.readouterr().err == ""
    assert (folder / "report.html").read_text() == first
    assert not [p for p in folder.iterdir() if p.name.startswith(files.TEMP_PREFIX)]


def test_a_byte_order_mark_before_a_csv_is_read_past(
    single: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
):
    """F12: Excel's "CSV UTF-8" starts with a BOM; the report reads it as the run wrote it."""
    folder = copied(single, tmp_path)
    first = (folder / "report.html").read_text()
    for name in ("episodes.csv", "episode_000_trace.csv"):
        (folder / name).write_bytes(b"\xef\xbb\xbf" + (folder / name).read_bytes())
    assert cli.main(["report", str(folder)]) == 0, capsys.readouterr().err
    assert (folder / "report.html").read_text() == first


RACE_REFUSED: list[tuple[str, Edit, str]] = [
    # F13: a race without its cars
    (
        "no_cars",
        header(lambda h: h.pop("cars")),
        "results.json: cars: got no such key; expected a list of the race's cars",
    ),
    (
        "no_cars_nor_summary",
        header(lambda h: (h.pop("cars"), h.pop("summary"))),
        "results.json: cars: got no such key; expected a list of the race's cars",
    ),
    # F14
    (
        "same_car_twice",
        cell("car", "car_0", row=2),
        "line 3, car: got 'car_0'; expected each car once",
    ),
    (
        "car_missing",
        lambda d: (d / "episodes.csv").write_text(
            "\n".join(
                x for k, x in enumerate((d / "episodes.csv").read_text().splitlines()) if k != 2
            )
            + "\n"
        ),
        "episodes.csv: line 2, episode: got 0; expected a row for each car",
    ),
    (
        "positions_both_1",
        cell("position", "1", row=2),
        "line 3, position: got 1; expected the places",
    ),
    (
        "extra_episode_row",
        lambda d: (d / "episodes.csv").write_text(
            (d / "episodes.csv").read_text()
            + "5,"
            + (d / "episodes.csv").read_text().splitlines()[1].split(",", 1)[1]
            + "\n"
        ),
        "line 6, episode: got 5; expected a row for each car",
    ),
    (
        "car_not_in_csv",
        header(lambda h: h["cars"].append({"id": "car_9", "color": "#00ff00", "driver": "x"})),
        "has none for car_9",
    ),
    ("lap_times_neg", cell("lap_times", "-1 -2"), "line 2, lap_times: got -1.0"),
    ("best_lap_neg", cell("best_lap", "-3"), "line 2, best_lap: got -3.0"),
    ("cars_hit_neg", cell("cars_hit", "-1"), "line 2, cars_hit: got -1"),
    (
        "trace_position_99",
        cell("position", "99", row=5, name="episode_000_car_0_trace.csv"),
        "episode_000_car_0_trace.csv: line 6, position: got '99'; expected a place from 1 to 2",
    ),
]


@pytest.mark.parametrize(
    ("edit", "said"), [c[1:] for c in RACE_REFUSED], ids=[c[0] for c in RACE_REFUSED]
)
def test_a_tampered_race_is_refused_naming_file_key_and_value(
    race: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], edit: Edit, said: str
):
    folder = copied(race, tmp_path)
    edit(folder)
    err = refused(folder, capsys)
    assert said in err, err


def test_the_untouched_race_is_rebuilt(race: Path, tmp_path: Path):
    folder = copied(race, tmp_path)
    first = (folder / "report.html").read_text()
    assert cli.main(["report", str(folder)]) == 0
    assert (folder / "report.html").read_text() == first


def test_a_folder_where_no_file_can_be_made_is_named_not_a_temporary_file(
    single: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch
):
    """F10: a read-only run folder (root ignores the mode: the opener is made to refuse)."""
    folder = copied(single, tmp_path)

    def refuse(*args: object, **kwargs: object) -> tuple[int, str]:
        raise PermissionError(13, "Permission denied", str(folder / ".tinyrace-x"))

    monkeypatch.setattr(files.tempfile, "mkstemp", refuse)
    err = refused(folder, capsys)
    assert f"{folder}: got 'report_" in err, err
    assert "expected a folder where files can be written (Permission denied)" in err


def many_episodes(folder: Path, count: int, planned: int) -> None:
    lines = (folder / "episodes.csv").read_text().splitlines()
    rows = [lines[0]]
    for k in range(count):
        rows.append(f"{k}," + lines[1 + k % 2].split(",", 1)[1])
    (folder / "episodes.csv").write_text("\n".join(rows) + "\n")
    header(lambda h: h.__setitem__("episodes_planned", planned))(folder)


def test_many_episodes_draw_a_bounded_number_of_traces(single: Path, tmp_path: Path, monkeypatch):
    """F7: each picture reads and draws at most MAX_DRAWN episodes' traces, says so, and
    the bars are one collection (5000 episodes took 105 s and 1 GB)."""
    folder = copied(single, tmp_path)
    many_episodes(folder, 1500, 1500)
    read = []
    original = report.read_trace
    monkeypatch.setattr(report, "read_trace", lambda path: read.append(path) or original(path))
    patches = []  # of each bar chart, counted before it is rendered and let go
    original_bars = plots.bars

    def bars(*args):
        figure = original_bars(*args)
        patches.append(len(figure.axes[0].patches))
        return figure

    monkeypatch.setattr(plots, "bars", bars)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert cli.main(["report", str(folder)]) == 0
    assert len(read) <= 2 * MAX_DRAWN  # the track's picture and the time series
    page = (folder / "report.html").read_text()
    captions = re.findall(r"<figcaption>([^<]*)</figcaption>", page)
    assert sum("Drawn: 100 of the 1,500 episodes, evenly spaced" in c for c in captions) == 2
    assert page.count("<tr><td class=num>") >= 1500  # the tables list every episode
    assert patches == [0, 0]  # returns and lap times: no Rectangle per bar


def test_an_interrupted_report_leaves_the_old_report_and_pictures(
    single: Path, tmp_path: Path, monkeypatch
):
    """F7: Ctrl-C while drawing the third picture: the old report and all its pictures stay,
    no temporary file is left."""
    folder = copied(single, tmp_path)
    before = digests(folder)
    rendered = []
    original = plots.png

    def interrupted(figure):
        rendered.append(figure)
        if len(rendered) == 3:
            raise KeyboardInterrupt
        return original(figure)

    monkeypatch.setattr(plots, "png", interrupted)
    with pytest.raises(KeyboardInterrupt):
        report.rebuild_report(folder)
    assert digests(folder) == before


def test_a_failed_write_leaves_every_old_file(tmp_path: Path, monkeypatch):
    """The files are renamed only once all are written: a failure writing the last keeps
    the first as it was and leaves no temporary file."""
    first, second = tmp_path / "a.png", tmp_path / "report.html"
    first.write_bytes(b"old a")
    second.write_bytes(b"old report")
    calls = []
    original = files._temp_copy

    def failing(path: Path, data: bytes) -> str:
        calls.append(path)
        if path == second:
            raise OSError(28, "No space left on device")
        return original(path, data)

    monkeypatch.setattr(files, "_temp_copy", failing)
    with pytest.raises(OSError, match="No space"):
        files.write_files({first: b"new a", second: b"new report"})
    assert calls == [first, second]
    assert first.read_bytes() == b"old a" and second.read_bytes() == b"old report"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.png", "report.html"]
