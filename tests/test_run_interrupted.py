"""SIGINT and SIGTERM during ``tinyrace run``: the finished episodes are written, the run is
marked interrupted, the video being written still plays, and the exit code is 130 / 143."""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import imageio_ffmpeg
import pytest
import yaml

from tinyrace.examples import TRACKS_DIR

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize(("signum", "code"), [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_an_interrupted_run_keeps_its_data(signum: int, code: int, tmp_path: Path):
    experiment = tmp_path / "long.yaml"
    raw = {
        "env": {"environment": str(TRACKS_DIR / "segmented")},
        "driver": "drivers_for_tests:slow_policy",
        "driver_args": {"delay": 0.01, "size": 1},  # [s] per step: about a second per episode
        "episodes": 50,
        "max_steps": 80,
        "output": {"video": True, "view": "front_camera"},
    }
    experiment.write_text(yaml.safe_dump(raw))
    env = {**os.environ, "PYTHONPATH": f"{ROOT}{os.pathsep}{ROOT / 'tests'}"}
    process = subprocess.Popen(
        [sys.executable, "-m", "tinyrace", "run", str(experiment), "-o", str(tmp_path / "runs")],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        cwd=tmp_path,
    )
    try:
        for line in process.stderr:  # one line per finished episode (not a terminal)
            if line.startswith("episode 0 (1/50)"):
                break
        process.send_signal(signum)
        err = process.communicate(timeout=120)[1]
    finally:
        process.kill()
    assert process.returncode == code, err
    assert "Traceback" not in err and "interrupted" in err
    (run_dir,) = (tmp_path / "runs").iterdir()
    results = json.loads((run_dir / "results.json").read_text())
    finished = len(results["episodes"])
    assert results["interrupted"] is True and results["signal"] == signal.Signals(signum).name
    assert 1 <= finished < 50
    rows = list(csv.DictReader((run_dir / "episodes.csv").open()))
    assert [int(r["episode"]) for r in rows] == list(range(finished))
    assert all(int(r["steps"]) == 80 for r in rows)
    assert (run_dir / "report.html").is_file()
    partial = run_dir / f"episode_{finished:03d}.mp4"  # the episode that was stopped
    frames = imageio_ffmpeg.read_frames(str(partial))
    meta = next(frames)
    assert meta["codec"] == "h264" and 1 <= sum(1 for _ in frames) <= 81
