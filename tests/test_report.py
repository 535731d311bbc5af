"""report.html: self-contained (inline pictures, no network, no scripts); HTML tables; the
charts' axes titled with units, no empty panel, "no lap finished" said where no lap was,
legends naming only what is drawn; ``tinyrace report`` rebuilds it from the files."""

from __future__ import annotations

import base64
import dataclasses
import json
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path

import cv2
import numpy as np

from tinyrace import cli
from tinyrace.env import TinyRaceEnv
from tinyrace.examples import CONFIGS_DIR, TRACKS_DIR
from tinyrace.experiment import experiment_from_dict, load_experiment, run_experiment
from tinyrace.experiment.record import read_trace
from tinyrace.experiment.report import CTE_LEFT_OUT, REPORT_FILE, picture_extent
from tinyrace.render.track_picture import PictureFrame, procedural_picture

ROOT = Path(__file__).resolve().parents[1]


class Page(HTMLParser):
    """What a reader sees of report.html: tables (cells by row), images, captions, notes."""

    def __init__(self, text: str):
        super().__init__()
        self.tables: list[list[list[str]]] = []
        self.images: list[dict[str, str]] = []
        self.captions: list[str] = []
        self.notes: list[str] = []
        self.tags: list[str] = []
        self._cell: list[str] | None = None
        self._text: list[str] | None = None
        self._into: list[str] | None = None
        self.feed(text)

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        self.tags.append(tag)
        values = {k: v or "" for k, v in attrs}
        if tag == "table":
            self.tables.append([])
        elif tag == "tr":
            self.tables[-1].append([])
        elif tag in ("td", "th"):
            self._cell = []
        elif tag == "img":
            self.images.append(values)
        elif tag == "figcaption" or (tag == "p" and values.get("class") == "note"):
            self._text = []
            self._into = self.captions if tag == "figcaption" else self.notes

    def handle_endtag(self, tag: str) -> None:
        if tag in ("td", "th") and self._cell is not None:
            self.tables[-1][-1].append("".join(self._cell).strip())
            self._cell = None
        elif tag in ("figcaption", "p") and self._text is not None and self._into is not None:
            self._into.append("".join(self._text).strip())
            self._text = self._into = None

    def handle_data(self, data: str) -> None:
        for sink in (self._cell, self._text):
            if sink is not None:
                sink.append(data)


def run(tmp_path: Path, name: str, episodes: int, max_steps: int | None):
    experiment = load_experiment(CONFIGS_DIR / f"{name}.yaml")
    config = dataclasses.replace(
        experiment.config,
        episodes=episodes,
        max_steps=max_steps,
        output=dataclasses.replace(experiment.config.output, video=False),
    )
    experiment = dataclasses.replace(experiment, config=config)
    return run_experiment(experiment, tmp_path, show_progress=False)


def page_of(result) -> Page:
    return Page((result.run_dir / REPORT_FILE).read_text())


def decoded(image: dict[str, str]) -> np.ndarray:
    prefix = "data:image/png;base64,"
    assert image["src"].startswith(prefix)
    data = np.frombuffer(base64.b64decode(image["src"][len(prefix) :]), np.uint8)
    picture = cv2.imdecode(data, cv2.IMREAD_COLOR)
    assert picture is not None
    return picture


def test_the_report_is_self_contained_with_html_tables(tmp_path: Path):
    result = run(tmp_path, "carracing", episodes=2, max_steps=60)
    page = page_of(result)
    assert "script" not in page.tags and "pre" not in page.tags
    # two tracks (one per seed), returns, lap times, the time series
    assert len(page.images) == 5
    assert all(decoded(image).shape[0] > 100 and image["alt"] for image in page.images)
    for name in ("report_returns.png", "report_lap_times.png", "report_time_series.png"):
        assert (result.run_dir / name).is_file()
    episodes, files, summary = page.tables
    assert files[0] == ["ep", "video", "trace (CSV, one row per step)"]
    assert [row[0] for row in files[1:]] == ["0", "1"]
    assert [row[2] for row in files[1:]] == [e.trace for e in result.episodes]
    assert episodes[0] == [
        "ep", "return", "steps", "tiles", "laps", "lap [s]", "hits", "|cte| [u]", "end"
    ]  # fmt: skip
    assert [row[0] for row in episodes[1:]] == ["0", "1"]
    for row, episode in zip(episodes[1:], result.episodes, strict=True):
        assert row[1] == f"{episode.episode_return:.1f}" and row[2] == "60"
        assert row[3] == f"{episode.tiles_visited}/{episode.tiles_total}"
        assert row[5] == "-" and row[8] == "max_steps"  # no lap in 60 steps
    assert summary[0] == ["metric", "mean", "std"]
    assert "lap time [s]" not in [row[0] for row in summary]  # nothing to average
    assert "mean |cross-track error| [u]" in [row[0] for row in summary]


def test_a_run_without_a_lap_says_so(tmp_path: Path):
    page = page_of(run(tmp_path, "carracing", episodes=1, max_steps=40))
    assert any("no lap finished" in caption for caption in page.captions)


def test_a_finished_lap_is_charted(tmp_path: Path):
    result = run(tmp_path, "f1tenth", episodes=1, max_steps=None)
    (episode,) = result.episodes
    assert episode.end == "lap_finished" and episode.laps == 1
    header = json.loads((result.run_dir / "results.json").read_text())
    assert episode.lap_time == episode.steps * header["dt"]
    page = page_of(result)
    assert page.tables[0][1][5] == f"{episode.lap_time:.2f}"
    assert not any("no lap finished" in caption for caption in page.captions)


def test_procedural_cross_track_error_is_the_distance_to_the_centreline(tmp_path: Path):
    result = run(tmp_path, "carracing", episodes=1, max_steps=150)
    trace = read_trace(result.run_dir / result.episodes[0].trace)
    assert np.isfinite(trace["cte"]).all()
    # reference: the seed's track centreline, sampled every 1/200 of its segments
    env = TinyRaceEnv()
    env.reset(seed=result.episodes[0].seed)
    centerline = np.asarray(env.track.centerline, float)
    env.close()
    ends = np.roll(centerline, -1, axis=0)
    fractions = np.linspace(0, 1, 200, endpoint=False)[None, :, None]
    dense = (centerline[:, None] + fractions * (ends - centerline)[:, None]).reshape(-1, 2)
    for x, y, cte in zip(trace["x"][::15], trace["y"][::15], trace["cte"][::15], strict=True):
        expected = np.hypot(dense[:, 0] - x, dense[:, 1] - y).min()
        assert abs(cte - expected) < 0.06
    assert trace["cte"].max() > 0.05  # the car is not always on the line
    page = page_of(result)
    assert not page.notes  # every panel has data
    assert any("cross-track error" in caption for caption in page.captions)


def test_a_track_without_a_reference_line_leaves_the_panel_out_and_says_why(tmp_path: Path):
    raw = {
        "env": {
            "environment": str(TRACKS_DIR / "formula_student"),
            "reward_design": {"cross_track_error": {"use_cte": False}},
        },
        "driver": "random",
        "episodes": 1,
        "max_steps": 20,
        "output": {"video": False},
    }
    experiment = experiment_from_dict(raw, "test", tmp_path)
    result = run_experiment(experiment, tmp_path, show_progress=False)
    page = page_of(result)
    assert page.notes == [CTE_LEFT_OUT]
    assert not any("cross-track" in caption for caption in page.captions)
    assert page.tables[0][1][7] == "-"


def test_tinyrace_report_rebuilds_it(tmp_path: Path):
    result = run(tmp_path, "formula_student", episodes=1, max_steps=50)
    report = result.run_dir / REPORT_FILE
    first = report.read_text()
    report.unlink()
    (result.run_dir / "report_returns.png").unlink()
    assert cli.main(["report", str(result.run_dir)]) == 0
    assert report.read_text() == first
    assert (result.run_dir / "report_returns.png").is_file()


def test_the_picture_extent_puts_each_pixel_at_its_track_point():
    frame = PictureFrame(sx=3.2, ox=410.0, sy=-3.2, oy=390.0)  # procedural: y up
    shape = (780, 820, 3)
    left, right, bottom, top = picture_extent((frame.sx, frame.ox, frame.sy, frame.oy), shape)
    points = np.array([[-50.0, 20.0], [100.0, -90.0], [0.0, 0.0]])
    px = frame.pixels(points)
    # imshow puts pixel column c's centre at left + (c + 0.5) * (right - left) / width
    x = left + (px[:, 0] + 0.5) * (right - left) / shape[1]
    y = top + (px[:, 1] + 0.5) * (bottom - top) / shape[0]
    assert np.allclose(np.stack([x, y], axis=1), points)


def test_an_image_track_report_draws_where_the_car_went(tmp_path: Path):
    result = run(tmp_path, "carolo_cup", episodes=1, max_steps=40)
    trace = read_trace(result.run_dir / result.episodes[0].trace)
    assert np.isfinite(trace["cte"][1:]).all()
    assert result.episodes[0].track == "track0"
    assert (result.run_dir / "report_track_track0.png").is_file()


def test_show_has_no_black_bands(tmp_path: Path):
    config = load_experiment(CONFIGS_DIR / "carracing.yaml").env_config
    for seed in (0, 3, 7):
        image = procedural_picture(config, seed)
        edges = np.concatenate([image[0], image[-1], image[:, 0], image[:, -1]])
        assert (edges.max(axis=1) > 40).all()  # grass or road everywhere at the border


def test_envs_need_neither_matplotlib_nor_tqdm():
    code = (
        "import sys, gymnasium as gym, tinyrace, tinyrace.experiment\n"
        "env = gym.make('tinyrace/CarRacing-v0')\n"
        "env.reset(seed=0)\n"
        "env.step(env.action_space.sample())\n"
        "print(sorted(m for m in ('matplotlib', 'tqdm') if m in sys.modules))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, check=True
    )
    assert done.stdout.strip() == "[]"


def legend_names(figure) -> list[str]:
    return [text.get_text() for legend in figure.legends for text in legend.get_texts()]


def a_path(crashed: bool, hit_at: int | None = None):
    from tinyrace.experiment import plots

    t = np.linspace(0.0, 1.0, 20)
    hits = np.zeros(20, bool)
    if hit_at is not None:
        hits[hit_at] = True
    points = np.stack([20 + 150 * t, 20 + 50 * t], axis=1)
    return plots.Path2D("ep 0", points, 10 * t, hits, crashed)


def test_legends_name_only_what_is_drawn():
    from tinyrace.experiment import plots

    picture = np.zeros((100, 200, 3), np.uint8)
    extent = (0.0, 200.0, 100.0, 0.0)
    image_track = plots.trajectories(picture, extent, [a_path(False)], None, "px")
    assert legend_names(image_track) == ["start"]  # no lap line where none is drawn
    lap_line = np.array([[10.0, 10.0], [10.0, 40.0]])
    paths = [a_path(True, 5), a_path(True, 7)]
    procedural = plots.trajectories(picture, extent, paths, lap_line, "u")
    names = legend_names(procedural)
    assert sorted(names) == ["crash", "lap line (start/finish)", "obstacle hit", "start"]
    drawn = {line.get_label() for line in procedural.axes[0].get_lines()}
    assert set(names) <= drawn


def test_every_axis_is_titled_with_its_unit():
    from tinyrace.experiment import plots

    picture = np.zeros((100, 200, 3), np.uint8)
    track = plots.trajectories(picture, (0.0, 200.0, 100.0, 0.0), [a_path(False)], None, "px")
    (ax,) = track.axes
    (scale,) = ax.child_axes  # the colour scale, inset beside the picture
    assert (ax.get_xlabel(), ax.get_ylabel(), scale.get_ylabel()) == (
        "x [px]", "y [px]", "speed [px/s]"
    )  # fmt: skip
    laps = plots.bars([12.5, None], ["0", "1"], "lap time [s]", plots.NO_LAP)
    assert (laps.axes[0].get_xlabel(), laps.axes[0].get_ylabel()) == ("episode", "lap time [s]")
    t = np.linspace(0.0, 2.0, 11)
    series = [plots.Series("0", t, {"speed [u/s]": t, "cross-track error [u]": t})]
    chart = plots.time_series(series, ["speed [u/s]", "cross-track error [u]"])
    assert [a.get_ylabel() for a in chart.axes] == ["speed [u/s]", "cross-track error [u]"]
    assert chart.axes[-1].get_xlabel() == "time since reset [s]"


def test_a_lap_chart_without_laps_says_no_lap_finished():
    from tinyrace.experiment import plots

    none = plots.bars([None, None], ["0", "1"], "lap time [s]", plots.NO_LAP)
    assert [text.get_text() for text in none.axes[0].texts] == ["no lap finished"]
    assert len(none.axes[0].patches) == 0
    some = plots.bars([None, 14.2], ["0", "1"], "lap time [s]", plots.NO_LAP)
    assert [text.get_text() for text in some.axes[0].texts] == ["no lap finished"]  # episode 0
    assert [round(bar.get_height(), 1) for bar in some.axes[0].patches] == [14.2]


def test_episodes_starting_at_one_place_share_a_label():
    from tinyrace.experiment import plots

    picture = np.zeros((100, 200, 3), np.uint8)
    first, second = a_path(False), a_path(False)
    second.label = "ep 1"
    figure = plots.trajectories(picture, (0.0, 200.0, 100.0, 0.0), [first, second], None, "px")
    assert [text.get_text() for text in figure.axes[0].texts] == ["ep 0, 1"]
