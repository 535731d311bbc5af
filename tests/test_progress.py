"""The progress bar shows episode, step, return and lap on a terminal; elsewhere one line per
episode; --quiet shows nothing."""

from __future__ import annotations

import io

from gymnasium import spaces

from tinyrace.experiment.progress import Progress
from tinyrace.experiment.record import EpisodeRecorder
from tinyrace.experiment.results import EpisodeResult


class Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def recorder_after(steps: int, reward: float, info: dict) -> EpisodeRecorder:
    recorder = EpisodeRecorder(spaces.Box(-1, 1, (3,)), dt=0.02)
    recorder.start(None, info)
    for _ in range(steps):
        recorder.step([0.1, 0.5, 0.0], None, reward, False, False, info)
    return recorder


def test_the_bar_shows_episode_step_return_and_lap():
    stream = Terminal()
    progress = Progress(episodes=5, limit=1000, stream=stream, interval=0.0)
    progress.start_episode(1)
    info = {"pose": (0.0, 0.0, 0.0), "speed": 3.0, "tiles_visited": 64, "tiles_total": 256}
    progress.update(recorder_after(340, 1.5, info))
    line = stream.getvalue().split("\r")[-1]  # the bar as last drawn
    assert "episode 1 (2/5)" in line and "340/1000" in line
    assert "return 510.0" in line and "lap 25%" in line


def test_image_tracks_have_no_lap_progress():
    stream = Terminal()
    progress = Progress(episodes=1, limit=10, stream=stream, interval=0.0)
    progress.start_episode(0)
    progress.update(recorder_after(3, -1.0, {"pose": (1.0, 2.0, 0.0), "cte": 4.0}))
    line = stream.getvalue().split("\r")[-1]
    assert "lap -" in line and "return -3.0" in line


def test_the_bar_is_cleared_before_the_episode_line():
    stream = Terminal()
    progress = Progress(episodes=2, limit=10, stream=stream, interval=0.0)
    progress.start_episode(0)
    progress.update(recorder_after(3, 1.0, {}))
    result = EpisodeResult(0, 0, 3.0, 3, None, None, 0, 0, None, "max_steps", 100.0)
    progress.end_episode(0, result)
    last = stream.getvalue().splitlines()[-1].split("\r")[-1]
    assert last.startswith("episode 0 (1/2): return 3.0, 3 steps, max_steps")


def test_a_stopped_run_clears_its_bar():
    stream = Terminal()
    progress = Progress(episodes=2, limit=10, stream=stream, interval=0.0)
    progress.start_episode(0)
    progress.update(recorder_after(3, 1.0, {}))
    progress.close()
    progress.close()  # twice: nothing more happens
    drawn = stream.getvalue()
    assert "3/10" in drawn
    assert drawn.split("\r")[-1].strip() == ""  # the bar's line is blanked


def test_quiet_writes_nothing():
    stream = Terminal()
    progress = Progress(episodes=2, limit=10, stream=stream, enabled=False)
    progress.start_episode(0)
    progress.update(recorder_after(3, 1.0, {}))
    result = EpisodeResult(0, 0, 3.0, 3, None, None, 0, 0, None, "max_steps", 100.0)
    progress.end_episode(0, result)
    assert stream.getvalue() == ""


def test_not_a_terminal_one_line_per_episode():
    stream = io.StringIO()
    progress = Progress(episodes=2, limit=10, stream=stream)
    progress.start_episode(0)
    progress.update(recorder_after(3, 1.0, {}))
    result = EpisodeResult(0, 0, 3.0, 3, None, None, 1, 0, None, "lap_finished", 100.0, 0.06)
    progress.end_episode(0, result)
    assert stream.getvalue().startswith("episode 0 (1/2): return 3.0, 3 steps, lap 0.06 s")
    assert stream.getvalue().count("\n") == 1
